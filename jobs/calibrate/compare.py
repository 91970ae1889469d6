"""Hold a full model to every thesis statement (:mod:`jobs.calibrate.statements`).

Two load paths, one per pressure (80 and 200 kPa, 5-40 mm), run as tasks on a Dask
cluster; every statement is then evaluated from their force curves, inflated reference
states and contact patches. Nothing is fitted here: this is the table a calibration is
judged by, for any preset, under both readings of the thesis.
"""

from __future__ import annotations

import math
from typing import Any

from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.specs import LoadPath, ModelSpec, SolverSettings
from jobs.calibrate.statements import CURVE_MM, STATEMENTS, Statement, mean_stiffness
from jobs.guard import Failed, guarded

PRESSURES = (0.08, 0.2)


def solve_curve(model: ModelSpec, pressure: float, settings: SolverSettings | None = None
                ) -> dict[str, Any]:
    """One pressure's curve (runs on a worker): Fz and the patch's nodal force mean and
    std per deflection, and the inflation growth; a failed solve (after the farm's one
    retry with smaller increments, :func:`jobs.guard.guarded`) is its reason."""
    result = guarded(lambda s: run_load_path(model, LoadPath(CURVE_MM, pressure), s),
                     settings or SolverSettings())
    if isinstance(result, Failed):
        return {"pressure": pressure, "failed": result.reason}
    mesh = mesh_for(model)
    patches = result.patches(mesh)
    return {"pressure": pressure, "deflection": list(CURVE_MM),
            "Fz": [float(m.total_force[2]) for m in result.measurements],
            "nodal_mean": [p.nodal_mean for p in patches],
            "nodal_std": [p.nodal_std for p in patches],
            "contact_nodes": [p.nodes for p in patches],
            "growth": result.growth(mesh),
            "solve_s": result.solve_seconds}


def solve_curves(model: ModelSpec, client: Any, settings: SolverSettings | None = None
                 ) -> dict[float, dict[str, Any]]:
    futures = [client.submit(solve_curve, model, p, settings, pure=False) for p in PRESSURES]
    return {c["pressure"]: c for c in client.gather(futures)}


def ours(statement: Statement, curves: dict[float, dict[str, Any]]) -> float:
    """The model's value of ``statement`` from the solved curves (NaN where a curve it
    needs failed)."""
    needs = PRESSURES if statement.pressure is None else (statement.pressure,)
    if any("failed" in curves[p] for p in needs):
        return math.nan
    if statement.quantity == "stiffness ratio":
        k = {p: mean_stiffness(c["deflection"], c["Fz"]) for p, c in curves.items()}
        return k[PRESSURES[1]] / k[PRESSURES[0]]
    assert statement.pressure is not None  # only the stiffness ratio spans pressures
    curve = curves[statement.pressure]
    if statement.quantity == "growth":
        return float(curve["growth"])
    column = {"Fz": "Fz", "nodal mean": "nodal_mean", "nodal std": "nodal_std"}
    at = curve["deflection"].index(statement.deflection)
    return float(curve[column[statement.quantity]][at])


def evaluate(curves: dict[float, dict[str, Any]]) -> list[dict[str, Any]]:
    """Every statement beside the model's value, its error and whether the goal holds."""
    rows = []
    for s in STATEMENTS:
        value = ours(s, curves)
        error = 100.0 * (value - s.value) / s.value
        ok = value <= s.value if s.bound == "at most" else abs(error) <= s.tolerance_pct
        ok = ok and not math.isnan(value)
        rows.append({"statement": s.key, "describes": s.describes,
                     "reading": s.reading or "both", "target": s.value, "bound": s.bound,
                     "ours": value, "error_pct": error, "goal_met": bool(ok),
                     "source": s.source, "derivation": s.derivation})
    return rows


def summary(rows: list[dict[str, Any]], reading: str) -> str:
    """'k of n' goals met under one reading, counting the untagged statements too."""
    mine = [r for r in rows if r["reading"] in ("both", reading)]
    met = sum(r["goal_met"] for r in mine)
    return f"{reading} reading: {met} of {len(mine)} goals met"


def markdown(rows: list[dict[str, Any]]) -> str:
    head = "| statement | describes | reading | thesis | ours | error % | goal |"
    lines = [head, "|---|---|---|---|---|---|---|"]
    for r in rows:
        target = ("≤ " if r["bound"] == "at most" else "") + f"{r['target']:.4g}"
        goal = ("met" if r["goal_met"] else "failed solve" if math.isnan(r["ours"])
                else "not met") + ("" if r["bound"] == "at most" else " (±10 %)")
        err = "-" if math.isnan(r["error_pct"]) else f"{r['error_pct']:+.1f}"
        value = "-" if math.isnan(r["ours"]) else f"{r['ours']:.4g}"
        lines.append(f"| {r['statement']} | {r['describes']} | {r['reading']} | {target} | "
                     f"{value} | {err} | {goal} |")
    return "\n".join(lines) + "\n"


def curves_table(curves: dict[float, dict[str, Any]]) -> str:
    """Fz per deflection and pressure, and each curve's growth, as Markdown."""
    failed = [f"{p * 1000:g} kPa: {c['failed']}" for p, c in curves.items() if "failed" in c]
    curves = {p: c for p, c in curves.items() if "failed" not in c}
    note = "".join(f"\nFailed solve, {text}\n" for text in failed)
    if not curves:
        return note
    lines = ["| deflection mm | " + " | ".join(f"Fz N, {p * 1000:g} kPa" for p in curves)
             + " |", "|---|" + "---|" * len(curves)]
    for k, d in enumerate(CURVE_MM):
        lines.append(f"| {d:g} | " + " | ".join(f"{c['Fz'][k]:.1f}" for c in curves.values())
                     + " |")
    growth = ", ".join(f"{p * 1000:g} kPa {c['growth']:.2f} mm" for p, c in curves.items())
    stiff = ", ".join(f"{p * 1000:g} kPa {mean_stiffness(c['deflection'], c['Fz']):.1f} N/mm"
                      for p, c in curves.items())
    return ("\n".join(lines) + f"\n\nInflation growth: {growth}. Mean stiffness: {stiff}.\n"
            + note)

