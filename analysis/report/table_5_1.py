"""Table 5.1 as the report shows it: each case's totals, this run beside the thesis.

The noise study's ``totals`` table has 19 columns (every total's mean, its nodal-average
std and the std of the total, Monte Carlo and analytic); the thesis prints 5. The report
shows one table of what the two share - the mean totals and the ± of Fz - row by row; the
rest stays in the CSV (``tables/dataset__noise_totals.csv``).

Rows are the thesis' cases, trained on noise-free data (``training == "clean"``). The
study also refits the models on noisy training inputs (``training == "noisy"``, issue 25);
that ± sits in one more column beside the clean one, on the same row.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from analysis import data
from analysis.report import thesis

UNITS = {"Fz": "N", "Mx": "N m", "My": "N m"}
CAPTION = "Totals predicted by PLSR with and without noise, beside the thesis (Table 5.1)"
NOISY_TRAINING = "± Fz N, noisy training"
NOTE = ("Noise at the thesis' level (§5.6). ± is the nodal-average standard deviation of Fz, "
        "the thesis' measure; the moments' spreads, the standard deviation of each total and "
        "the analytic values are in tables/dataset__noise_totals.csv. Like the thesis, the "
        "models train on noise-free FE data and only the reference inputs are noisy; "
        f"'{NOISY_TRAINING}' is the ± of the same models refitted on noisy training inputs, "
        "as a model trained on measurements sees them (rows 'training: noisy' of the CSV).")


def _thesis_rows() -> dict[tuple[str, bool], tuple]:
    """(input set, noisy) -> the thesis' (Fz, Mx, My, ±) of that case."""
    rows = {}
    for case, *values in thesis.TABLE_5_1:
        inputs = "" if case == "reference" else case.split(" + ")[0]
        rows[(inputs, " + " in case)] = tuple(values)
    return rows


def noise_level(inputs: str, sigma: float) -> str:
    """A noise level with its unit: ``1 mm``, ``0.04 % strain``."""
    family = data.family(data.expand_inputs(inputs.split("+"))[0])
    if family == "displacement":
        return f"{sigma:g} mm"
    return f"{100 * sigma:g} % strain (σ = {sigma:g})"


def _case(row) -> str:
    if row["case"] == "reference":
        return "reference (virtual experiment)"
    if row["sigma"] == 0:
        return f"PLSR from {row['inputs']}, noise-free"
    return f"PLSR from {row['inputs']} + noise σ = {noise_level(row['inputs'], row['sigma'])}"


def beside_thesis(totals: pd.DataFrame) -> pd.DataFrame:
    """One row per clean-training case of the noise study's ``totals``: mean Fz, Mx, My and
    the ± of Fz, each beside the thesis' value (NaN where the thesis has no such case or no
    ±), then the ± of Fz with noisy training (NaN for noise-free rows, or a ``totals``
    without a ``training`` column, which is all clean)."""
    theirs = _thesis_rows()
    training = totals["training"] if "training" in totals else pd.Series("clean", totals.index)
    noisy_std = {(r["inputs"], r["sigma"]): r["Fz_nodal_avg_std"]
                 for _, r in totals[training == "noisy"].iterrows()}
    rows = []
    for _, row in totals[training != "noisy"].iterrows():
        noisy = bool(row["sigma"] > 0)
        key = ("" if row["case"] == "reference" else row["inputs"], noisy)
        t = theirs.get(key, (np.nan,) * 4)
        out: dict[str, str | float] = {"case": _case(row)}
        for k, total in enumerate(UNITS):
            out[f"{total} {UNITS[total]}"] = row[total]
            out[f"thesis {total} {UNITS[total]}"] = t[k]
        out["± Fz N"] = row["Fz_nodal_avg_std"] if noisy else np.nan
        out["thesis ± Fz N"] = np.nan if t[3] is None else t[3]
        out[NOISY_TRAINING] = noisy_std.get((row["inputs"], row["sigma"]), np.nan)
        rows.append(out)
    return pd.DataFrame(rows)

