"""The report's "Findings": each chapter's headline numbers beside the thesis', read from
the stages' tables (nothing here is written by hand, so it cannot go stale).

One row per quantity: chapter, quantity, this run, thesis, difference in % of the thesis.
A chapter whose tables are missing (a stage not run, a table not computed) adds no rows.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from analysis.report import ch3, table_5_1
from analysis.report.stage import StageResult

COLUMNS = ["chapter", "quantity", "this run", "thesis", "difference %"]
#: the report's count of findings "close to the thesis"
CLOSE_PCT = 10.0
CH5_VARIANCE = "plsr/thesis_comparison"
CH5_TOTALS = "noise/totals"


def _row(chapter: int, quantity: str, ours, theirs) -> dict:
    ours, theirs = float(ours), float(theirs)
    diff = 100 * (ours - theirs) / theirs if np.isfinite(theirs) and theirs != 0 else np.nan
    return dict(zip(COLUMNS, (chapter, quantity, ours, theirs, diff), strict=True))


def chapter3(stage: StageResult) -> list[dict]:
    """Fz at the thesis' reference points; the full model's nodal mean and std (§3.3.2)."""
    rows = []
    points = stage.tables.get(ch3.REFERENCE_POINTS, pd.DataFrame())
    for _, p in points.iterrows():
        rows.append(_row(3, f"Fz N, {p['case']}", p["measured Fz N"], p["thesis Fz N"]))
    nodal = stage.tables.get(ch3.FULL_NODAL, pd.DataFrame())
    for _, q in nodal.iterrows():
        rows.append(_row(3, f"{q['quantity']}, full 80 kPa, 30 mm", q["measured"], q["thesis"]))
    return rows


def chapter4(stage: StageResult) -> list[dict]:
    """The std of the nodal force errors per condition and method, where the thesis gives
    one (the table whose columns hold ``std`` and ``thesis_std``)."""
    rows = []
    for frame in stage.tables.values():
        if not {"condition", "method", "std", "thesis_std"} <= set(frame.columns):
            continue
        theirs = pd.to_numeric(frame["thesis_std"], errors="coerce")  # "-" where none
        for (_, e), t in zip(frame.iterrows(), theirs, strict=True):
            if np.isfinite(t):
                rows.append(_row(4, f"std of the nodal force errors N, {e['condition']}, "
                                    f"{e['method']}", e["std"], t))
    return rows


def chapter5(stage: StageResult) -> list[dict]:
    """Cumulative % of output variance at the last mode the thesis gives; Table 5.1's
    noisy Fz and its ± per input set."""
    rows = []
    variance = stage.tables.get(CH5_VARIANCE, pd.DataFrame())
    if len(variance):
        last = variance[variance["mode"] == variance["mode"].max()]
        for _, v in last.iterrows():
            what = "PCR" if v["method"] == "pcr" else f"PLSR from {v['inputs']}"
            rows.append(_row(5, f"{what}: cumulative % of output variance, modes 1-"
                                f"{v['mode']}", v["measured_cum_pct"], v["thesis_cum_pct"]))
    if CH5_TOTALS in stage.tables:
        table = table_5_1.beside_thesis(stage.tables[CH5_TOTALS])
        for _, r in table[table["± Fz N"].notna()].iterrows():
            rows.append(_row(5, f"Fz N, {r['case']}", r["Fz N"], r["thesis Fz N"]))
            rows.append(_row(5, f"± Fz N, {r['case']}", r["± Fz N"], r["thesis ± Fz N"]))
    return rows


def findings(stages: list[StageResult]) -> pd.DataFrame:
    """Every chapter's headline numbers beside the thesis', chapters in thesis order."""
    by_name = {s.name: s for s in stages}
    rows = []
    for name, chapter in (("validation", chapter3), ("inverse", chapter4),
                          ("dataset", chapter5)):
        if name in by_name:
            rows += chapter(by_name[name])
    return pd.DataFrame(rows, columns=COLUMNS)


def summary(table: pd.DataFrame) -> str:
    """One sentence: how many findings lie within ``CLOSE_PCT`` of the thesis."""
    diff = table["difference %"].abs()
    close = int((diff <= CLOSE_PCT).sum())
    return (f"{close} of {int(diff.notna().sum())} quantities lie within ±{CLOSE_PCT:g} % of "
            "the thesis' value; difference % = 100 x (this run - thesis) / thesis. Per-node "
            "quantities scale with the mesh's node spacing and compare only on a mesh of the "
            "thesis' spacing.")
