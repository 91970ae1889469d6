"""Compare the convergence study's levels: changes, Richardson estimates, the verdict.

For a quantity ``f`` on three levels refined by a constant ratio ``r`` (coarse to fine
``f1, f2, f3``), the observed order is ``p = ln((f1 - f2) / (f2 - f3)) / ln r`` and the
finest level's remaining error is estimated as ``(f3 - f2) / (r**p - 1)`` (Richardson
extrapolation; Roache 1998, the grid convergence index without its safety factor).
When the two changes differ in sign the convergence is oscillatory and no order is
estimated. Issue 24's criterion for a study default: the next refinement changes the
totals (Fx, Fy, Fz) by less than 2 % and the camera window's field RMS by less than 5 %.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

TOTALS_PCT = 2.0
FIELDS_PCT = 5.0
FORCE_FLOOR_N = 50.0
"""A total force below this (N) on the finest level is not judged in per cent: the
vertical cases' Fx and Fy are round-off about zero."""

# (label, key, kind): kind "total" is judged against TOTALS_PCT, "field" against FIELDS_PCT
QUANTITIES = (
    ("Fz N", "Fz", "total"), ("Fy N", "Fy", "total"), ("Fx N", "Fx", "total"),
    ("Mz N m", "Mz", None), ("contact nodes", "patch.nodes", None),
    ("contact area mm²", "patch.area", None), ("contact length mm", "patch.length", None),
    ("contact width mm", "patch.width", None),
    # the largest nodal pressure: not a converging quantity (issue 44; +51 % from patch
    # to the next level at 40 mm while Fz moved 0.5 %), reported, never judged
    ("peak nodal pressure MPa (mesh-dependent)", "patch.peak_pressure", None),
    ("mean pressure MPa", "patch.mean_pressure", None),
    # per node: scales with the node spacing by definition (compare the thesis' 263.3 N
    # only on its own mesh); reported, not judged
    ("nodal force mean N", "patch.nodal_mean", None),
    ("nodal force std N", "patch.nodal_std", None),
    ("window RMS of U mm", "U_rms", "field"), ("window RMS of CST strain", "strain_rms", "field"),
    ("window RMS of solver strain", "solver_strain_rms", "field"),
)


def value(state: dict[str, Any], key: str) -> float:
    out: Any = state
    for part in key.split("."):
        out = out[part]
    return float(out)


def richardson(f1: float, f2: float, f3: float, ratio: float) -> tuple[float, float]:
    """``(order p, estimated error of f3)``; NaN, NaN when not monotone or converged."""
    d12, d23 = f1 - f2, f2 - f3
    if d23 == 0 or d12 == 0 or (d12 > 0) != (d23 > 0) or abs(d12) <= abs(d23):
        return math.nan, math.nan
    p = math.log(d12 / d23) / math.log(ratio)
    return p, (f3 - f2) / (ratio ** p - 1.0)


def change_pct(coarse: float, fine: float) -> float:
    """Relative change of refining, % of the finer value (0 when both are 0)."""
    if fine == coarse:
        return 0.0
    return 100.0 * abs(fine - coarse) / abs(fine) if fine else math.inf


def rows(records: Sequence[dict[str, Any]], levels: Sequence[str], ratio: float = 2.0
         ) -> list[dict[str, Any]]:
    """One row per (case, state, quantity): the value on each level, the last change,
    the Richardson order and error estimate over the last three levels, and the verdict.

    ``levels`` are the extrapolated sequence, coarse to fine; other levels' values are
    reported as columns too but judged by nothing.
    """
    by = {(r["level"], r["case"]): r for r in records}
    cases = list(dict.fromkeys(r["case"] for r in records))
    all_levels = list(dict.fromkeys(r["level"] for r in records))
    out = []
    for case in cases:
        ref = next((by[(lv, case)] for lv in reversed(levels)
                    if by.get((lv, case), {}).get("status") == "done"), None)
        if ref is None:
            continue
        for k, state in enumerate(ref["states"]):
            for label, key, kind in QUANTITIES:
                vals = {}
                for lv in all_levels:
                    rec = by.get((lv, case), {})
                    if rec.get("status") == "done" and k < len(rec["states"]):
                        vals[lv] = value(rec["states"][k], key)
                seq = [vals.get(lv, math.nan) for lv in levels]
                out.append(_row(case, state["state"], label, kind, vals, seq, ratio))
    return out


def _row(case: str, state: str, label: str, kind: str | None, vals: dict[str, float],
         seq: list[float], ratio: float) -> dict[str, Any]:
    last = change_pct(seq[-2], seq[-1]) if len(seq) >= 2 else math.nan
    p, err = (richardson(seq[-3], seq[-2], seq[-1], ratio) if len(seq) >= 3
              else (math.nan, math.nan))
    err_pct = 100.0 * abs(err) / abs(seq[-1]) if seq[-1] and not math.isnan(err) else math.nan
    limit = {"total": TOTALS_PCT, "field": FIELDS_PCT}.get(kind or "")
    if kind == "total" and not abs(seq[-1]) >= FORCE_FLOOR_N:
        limit = None  # a frictionless case's Fx, Fy: round-off about 0, no per cent
    return {"case": case, "state": state, "quantity": label, "values": vals,
            "last_change_pct": last, "order": p, "error_pct": err_pct,
            "limit_pct": limit, "converged": None if limit is None else bool(last < limit)}


def verdict(table: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Whether the finest step meets issue 24's limits on every judged row."""
    judged = [r for r in table if r["limit_pct"] is not None]
    failing = [r for r in judged if not r["converged"]]
    return {"judged": len(judged), "failing": failing, "converged": not failing}


def _fmt(x: float | None) -> str:
    if x is None or math.isnan(x):
        return "-"
    if math.isinf(x):
        return "inf"
    return f"{x:.1f}" if abs(x) >= 100 else f"{x:.4g}" if abs(x) >= 1 else f"{x:.3g}"


def markdown(table: Sequence[dict[str, Any]], records: Sequence[dict[str, Any]],
             levels: Sequence[str]) -> str:
    """The convergence table and the cost table as Markdown."""
    all_levels = list(dict.fromkeys(r["level"] for r in records))
    head = ["case", "state", "quantity", *all_levels, "last step %", "order p",
            "est. error %", "limit %"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in table:
        cells = [r["case"], r["state"], r["quantity"],
                 *[_fmt(r["values"].get(lv, math.nan)) for lv in all_levels],
                 _fmt(r["last_change_pct"]), _fmt(r["order"]), _fmt(r["error_pct"]),
                 "-" if r["limit_pct"] is None else
                 f"{r['limit_pct']:g} {'ok' if r['converged'] else 'NOT MET'}"]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "| level | case | status | nodes | ccx runs | solve s | inflation growth mm |",
              "|---|---|---|---|---|---|---|"]
    for r in records:
        if r["status"] == "done":
            lines.append(f"| {r['level']} | {r['case']} | done | {r['nodes']} | "
                         f"{r['ccx_runs']} | {r['solve_s']:.1f} | {r['growth']:.2f} |")
        else:
            lines.append(f"| {r['level']} | {r['case']} | failed: {r['reason'][:120]} | "
                         "- | - | - | - |")
    return "\n".join(lines) + "\n"


def direction_markdown(records: Sequence[dict[str, Any]], sequences: dict[str, list[str]]
                       ) -> tuple[str, str, dict[str, list[dict[str, Any]]]]:
    """``(Markdown, one-line verdict, rows per sequence)`` of a study's records.

    ``sequences`` maps a name to its extrapolated levels, coarse to fine: one,
    ``levels``, for the study of :data:`jobs.convergence.levels.LEVELS` (its table as
    before), or one per refined direction, each then a section of its own over the
    records of its levels only.
    """
    tables, parts, passed, judged = {}, [], 0, 0
    for name, seq in sequences.items():
        # the study of LEVELS also reports levels outside its sequence (uniform-40)
        own = records if name == "levels" else [r for r in records if r["level"] in seq]
        table = tables[name] = rows(own, seq)  # every sequence the farm builds doubles
        decided = verdict(table)
        judged += decided["judged"]
        passed += decided["judged"] - len(decided["failing"])
        head = ("" if name == "levels" else
                f"## {name}: {' -> '.join(seq)}\n\n{_verdict_line(decided)}\n\n")
        parts.append(head + markdown(table, own, seq))
    summary = (f"finest step: {passed} of {judged} judged rows within issue 24's limits "
               "(totals 2 %, window fields 5 %)")
    if list(sequences) == ["levels"]:
        return summary + "\n\n" + parts[0], summary, tables
    return summary + "\n\n" + "\n".join(parts), summary, tables


def _verdict_line(decided: dict[str, Any]) -> str:
    failing = ", ".join(sorted({f"{r['case']} {r['quantity']} {r['last_change_pct']:.2f} %"
                                for r in decided["failing"]}))
    return (f"{decided['judged'] - len(decided['failing'])} of {decided['judged']} judged "
            "rows within the limits" + (f"; not met: {failing}" if failing else ""))
