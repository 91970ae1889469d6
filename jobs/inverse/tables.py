"""Tables 4.1-4.4 from finished loops, side by side with the thesis, and Figs. 4.2/4.3.

One row per (condition, method, optimiser), statistics over its repeats:

- ``forces`` (Tables 4.1/4.3): Fz [N], Mx, My [N m] mean and std, with the reference
  row first; moments about the contact centre from the final forward evaluation;
- ``rmse`` (Tables 4.2/4.4): mean over repeats of the RMSE of Ux, Uy, Uz [mm] and
  exx, eyy, exy [microstrain] against the noise-free reference;
- ``nodal`` (Figs. 4.2/4.3): mean, std and RMS of the nodal force errors x - x_true
  pooled over repeats, and the std relative to the largest reference nodal force;
- ``cost``: evaluations per solve, solver runs (unique evaluations solved), sequential
  rounds, wall and solver seconds.

Figures are drawn on a bare :class:`matplotlib.figure.Figure` (Agg), never pyplot.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from jobs.inverse import thesis
from jobs.inverse.loop import LoopResult
from jobs.inverse.problem import Problem

KEYS = ["condition", "method", "optimizer"]
DIRECTIONS = ("Ux", "Uy", "Uz", "exx", "eyy", "exy")


def _rows(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    rows = []
    for r in results:
        ok = bool(r.rmse)
        row = {"condition": r.spec.condition.name, "method": r.spec.method,
               "optimizer": r.spec.optimizer.name, "repeat": r.spec.repeat, "status": r.status,
               "Fz": r.final["total_force"][2] if ok else np.nan,
               "Mx": r.final["moment"][0] / 1e3 if ok else np.nan,
               "My": r.final["moment"][1] / 1e3 if ok else np.nan,
               "evaluations": len(r.f_history), "solved": r.stats.solved,
               "rounds": r.stats.rounds, "wall_s": r.wall_seconds,
               "solver_s": r.stats.solver_seconds, "objective": r.objective}
        row |= {d: r.rmse.get(d, np.nan) * (1e6 if d.startswith("e") else 1.0)
                for d in DIRECTIONS}
        rows.append(row)
    return pd.DataFrame(rows)


def per_solve(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    """One row per loop (the raw numbers behind every table)."""
    return _rows(results, problem)


def forces(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    """Tables 4.1/4.3 with the thesis' values beside ours."""
    frame = _rows(results, problem)
    stats = frame.groupby(KEYS, sort=False)[["Fz", "Mx", "My"]].agg(["mean", "std"])
    stats.columns = [f"{a}_{b}" for a, b in stats.columns]
    stats = stats.reset_index()
    stats.insert(3, "repeats", frame.groupby(KEYS, sort=False).size().to_numpy())
    ref = problem.reference
    head = pd.DataFrame([{"condition": "reference", "method": "", "optimizer": "",
                          "repeats": 1, "Fz_mean": ref["total_force"][2], "Fz_std": 0.0,
                          "Mx_mean": ref["moment"][0] / 1e3, "Mx_std": 0.0,
                          "My_mean": ref["moment"][1] / 1e3, "My_std": 0.0}])
    out = pd.concat([head, stats], ignore_index=True)
    for k, name in enumerate(("Fz", "Fz_std", "Mx", "Mx_std", "My", "My_std")):
        out[f"thesis_{name}"] = [
            (thesis.REFERENCE_FZ, 0, 0, 0, 0, 0)[k] if c == "reference" else
            thesis.FORCES.get((c, m), (None,) * 6)[k]
            for c, m in zip(out["condition"], out["method"], strict=True)]
    return out


def rmse(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    """Tables 4.2/4.4 with the thesis' values beside ours (mm and microstrain)."""
    frame = _rows(results, problem)
    out = frame.groupby(KEYS, sort=False)[list(DIRECTIONS)].mean().reset_index()
    for k, d in enumerate(DIRECTIONS):
        out[f"thesis_{d}"] = [thesis.RMSE.get((c, m), (None,) * 6)[k]
                              for c, m in zip(out["condition"], out["method"], strict=True)]
    return out


def nodal_errors(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    """Pooled nodal force errors per (condition, method, optimiser), N."""
    groups: dict[tuple, list[np.ndarray]] = {}
    for r in results:
        if r.rmse:
            key = (r.spec.condition.name, r.spec.method, r.spec.optimizer.name)
            groups.setdefault(key, []).append(r.x - problem.x_true)
    peak = float(np.max(np.abs(problem.x_true)))
    rows = []
    for (c, m, o), errs in groups.items():
        e = np.concatenate(errs)
        rows.append({"condition": c, "method": m, "optimizer": o, "mean": e.mean(),
                     "std": e.std(), "rms": np.sqrt(np.mean(e**2)),
                     "std_over_max_force": e.std() / peak,
                     "thesis_std": thesis.NODAL_ERROR_STD.get((c, m)),
                     "thesis_std_over_max_force":
                         thesis.NODAL_ERROR_STD.get((c, m), np.nan) / thesis.MAX_NODAL_FORCE})
    return pd.DataFrame(rows)


def cost(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    """Solver evaluations, runs, sequential rounds and time per solve (means)."""
    frame = _rows(results, problem)
    cols = ["evaluations", "solved", "rounds", "wall_s", "solver_s", "objective"]
    out = frame.groupby(KEYS, sort=False)[cols].mean().reset_index()
    out["solves"] = frame.groupby(KEYS, sort=False).size().to_numpy()
    out["statuses"] = frame.groupby(KEYS, sort=False)["status"].agg(
        lambda s: ", ".join(f"{k} {v}" for k, v in s.value_counts().items())).to_numpy()
    return out


def _pm(mean: float, std: float | None, digits: int = 5) -> str:
    if mean is None or (isinstance(mean, float) and np.isnan(mean)):
        return "-"
    if std is None or (isinstance(std, float) and np.isnan(std)) or std == 0:
        return f"{mean:.{digits}g}"
    return f"{mean:.{digits}g} ± {std:.2g}"


def views(results: Sequence[LoopResult], problem: Problem) -> dict[str, pd.DataFrame]:
    """Compact, formatted versions of the tables for a terminal: ours beside the thesis'."""
    f = forces(results, problem)
    v_forces = pd.DataFrame({
        "condition": f["condition"], "method": f["method"], "optimizer": f["optimizer"],
        "n": f["repeats"],
        **{f"{q} {u}": [_pm(m, s) for m, s in zip(f[f"{q}_mean"], f[f"{q}_std"], strict=True)]
           for q, u in (("Fz", "N"), ("Mx", "N m"), ("My", "N m"))},
        **{f"thesis {q}": [_pm(m, s) for m, s in zip(f[f"thesis_{q}"], f[f"thesis_{q}_std"],
                                                     strict=True)]
           for q in ("Fz", "Mx", "My")}})
    r = rmse(results, problem)
    v_rmse = r[KEYS].copy()
    for d in DIRECTIONS:
        v_rmse[f"{d} (thesis)"] = [f"{a:.3g} ({_pm(b, None, 3)})"
                                   for a, b in zip(r[d], r[f"thesis_{d}"], strict=True)]
    c = cost(results, problem)
    v_cost = c[[*KEYS, "solves", "evaluations", "solved", "rounds", "wall_s", "statuses"]]
    n = nodal_errors(results, problem)
    v_nodal = n[[*KEYS, "mean", "std", "std_over_max_force", "thesis_std",
                 "thesis_std_over_max_force"]] if not n.empty else n
    return {"forces": v_forces, "rmse": v_rmse, "nodal_errors": v_nodal, "cost": v_cost}


def histograms(results: Sequence[LoopResult], problem: Problem, folder: Path) -> list[Path]:
    """Figs. 4.2/4.3: histograms of the nodal force errors, one PNG per condition."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for cond in dict.fromkeys(r.spec.condition.name for r in results):
        mine = [r for r in results if r.spec.condition.name == cond and r.rmse]
        if not mine:
            continue
        fig = Figure(figsize=(7, 4), layout="constrained")
        FigureCanvasAgg(fig)
        ax = fig.subplots()
        labels = dict.fromkeys((r.spec.method, r.spec.optimizer.name) for r in mine)
        for method, opt in labels:
            e = np.concatenate([r.x - problem.x_true for r in mine
                                if (r.spec.method, r.spec.optimizer.name) == (method, opt)])
            ax.hist(e, bins=25, alpha=0.55,
                    label=f"{method}, {opt}: mean {e.mean():.2f} N, std {e.std():.2f} N")
        ax.set_xlabel("nodal force error x - x_true [N]")
        ax.set_ylabel("count (nodes x repeats)")
        ax.set_title(f"Nodal force errors: {cond} (thesis Figs. 4.2/4.3)")
        ax.legend(fontsize=8)
        path = folder / f"nodal_errors_{cond}.png"
        fig.savefig(path, dpi=120)
        paths.append(path)
    return paths
