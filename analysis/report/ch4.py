"""Tables 4.1-4.4 and Figs. 4.2/4.3 from an inverse-solves group, beside the thesis.

Every function takes the group as :func:`storage.solves.open_solves` gives it (or as
:func:`storage.solves.solves_dataset` builds it in memory): the store holds all they
need. One row per (condition, method, optimiser), in the order of the group's solves,
statistics over its repeats:

- ``forces`` (Tables 4.1/4.3): Fz [N], Mx, My [N m] mean and std (pandas' sample std),
  the reference experiment's row first; moments about the contact centre from each
  solve's final forward evaluation;
- ``rmse`` (Tables 4.2/4.4): mean over repeats of the RMSE of Ux, Uy, Uz [mm] and
  exx, eyy, exy [microstrain] against the noise-free reference;
- ``nodal_errors`` (Figs. 4.2/4.3): mean, std and RMS of the nodal force errors
  x - x_true pooled over repeats, and the std relative to the largest reference nodal
  force;
- ``cost``: evaluations per solve, solver runs (unique evaluations solved), sequential
  rounds, wall and solver seconds.

A solve whose final forward evaluation failed (NaN ``rmse``) counts in ``cost`` but
has NaN forces and RMSE, and no nodal errors. Figures are drawn on a bare
:class:`matplotlib.figure.Figure` (Agg), never pyplot.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from analysis.errors import MissingVariableError
from analysis.report import ch4_thesis as thesis
from analysis.report.readable import MISSING
from storage.solves import DIRECTIONS, KIND, VARIABLES

KEYS = ["condition", "method", "optimizer"]
#: The tables written as CSV, by name.
TABLES = ("forces", "rmse", "nodal_errors", "cost", "per_solve")
N_MM_PER_N_M = 1e3  # the store's moments are N mm; the thesis prints N m


def check_solves(ds: xr.Dataset) -> None:
    missing = [name for name in VARIABLES if name not in ds]
    if ds.attrs.get("kind") != KIND or missing:
        raise MissingVariableError(
            f"not an inverse-solves group (kind={ds.attrs.get('kind')!r}"
            + (f", no {missing[0]!r}" if missing else "")
            + "): open the study's group with storage.solves.open_solves")


def text_values(ds: xr.Dataset, name: str) -> list[str]:
    return [str(v) for v in ds[name].values]


def solved_ok(ds: xr.Dataset) -> np.ndarray:
    """Solves whose final forward evaluation succeeded (its RMSE was recorded)."""
    return ~np.isnan(ds["rmse"].values).all(axis=1)


def per_solve(ds: xr.Dataset) -> pd.DataFrame:
    """One row per solve (the raw numbers behind every table)."""
    check_solves(ds)
    force, moment = ds["total_force"].values, ds["moment"].values
    frame = pd.DataFrame({
        "condition": text_values(ds, "condition"), "method": text_values(ds, "method"),
        "optimizer": text_values(ds, "optimizer"), "repeat": ds["repeat"].values.astype(np.int64),
        "status": text_values(ds, "status"), "Fz": force[:, 2],
        "Mx": moment[:, 0] / N_MM_PER_N_M, "My": moment[:, 1] / N_MM_PER_N_M,
        **{name: ds[name].values.astype(np.int64)
           for name in ("evaluations", "solved", "rounds")},
        "wall_s": ds["wall_seconds"].values, "solver_s": ds["solver_seconds"].values,
        "objective": ds["objective"].values})
    rmse = ds["rmse"].sel(direction=list(DIRECTIONS)).values
    for k, d in enumerate(DIRECTIONS):
        frame[d] = rmse[:, k] * (1e6 if d.startswith("e") else 1.0)
    return frame


def forces(ds: xr.Dataset) -> pd.DataFrame:
    """Tables 4.1/4.3 with the thesis' values beside ours."""
    frame = per_solve(ds)
    stats = frame.groupby(KEYS, sort=False)[["Fz", "Mx", "My"]].agg(["mean", "std"])
    stats.columns = [f"{a}_{b}" for a, b in stats.columns]
    stats = stats.reset_index()
    stats.insert(3, "repeats", frame.groupby(KEYS, sort=False).size().to_numpy())
    ref_force, ref_moment = ds["reference_total_force"].values, ds["reference_moment"].values
    head = pd.DataFrame([{"condition": "reference", "method": "", "optimizer": "",
                          "repeats": 1, "Fz_mean": ref_force[2], "Fz_std": 0.0,
                          "Mx_mean": ref_moment[0] / N_MM_PER_N_M, "Mx_std": 0.0,
                          "My_mean": ref_moment[1] / N_MM_PER_N_M, "My_std": 0.0}])
    out = pd.concat([head, stats], ignore_index=True)
    for k, name in enumerate(("Fz", "Fz_std", "Mx", "Mx_std", "My", "My_std")):
        out[f"thesis_{name}"] = [
            (thesis.REFERENCE_FZ, 0, 0, 0, 0, 0)[k] if c == "reference" else
            thesis.FORCES.get((c, m), (None,) * 6)[k]
            for c, m in zip(out["condition"], out["method"], strict=True)]
    return out


def rmse(ds: xr.Dataset) -> pd.DataFrame:
    """Tables 4.2/4.4 with the thesis' values beside ours (mm and microstrain)."""
    frame = per_solve(ds)
    out = frame.groupby(KEYS, sort=False)[list(DIRECTIONS)].mean().reset_index()
    for k, d in enumerate(DIRECTIONS):
        out[f"thesis_{d}"] = [thesis.RMSE.get((c, m), (None,) * 6)[k]
                              for c, m in zip(out["condition"], out["method"], strict=True)]
    return out


def _errors(ds: xr.Dataset) -> dict[tuple[str, str, str], np.ndarray]:
    """Nodal force errors x - x_true of the solves that finished, pooled per key, N."""
    check_solves(ds)
    keys = zip(*(text_values(ds, k) for k in KEYS), strict=True)
    error = ds["x_final"].values - ds["x_true"].values
    groups: dict[tuple[str, str, str], list[np.ndarray]] = {}
    for key, e, ok in zip(keys, error, solved_ok(ds), strict=True):
        if ok:
            groups.setdefault(key, []).append(e)
    return {key: np.concatenate(errs) for key, errs in groups.items()}


def nodal_errors(ds: xr.Dataset) -> pd.DataFrame:
    """Pooled nodal force errors per (condition, method, optimiser), N."""
    peak = float(np.max(np.abs(ds["x_true"].values)))
    rows = []
    for (c, m, o), e in _errors(ds).items():
        rows.append({"condition": c, "method": m, "optimizer": o, "mean": e.mean(),
                     "std": e.std(), "rms": np.sqrt(np.mean(e**2)),
                     "std_over_max_force": e.std() / peak,
                     "thesis_std": thesis.NODAL_ERROR_STD.get((c, m)),
                     "thesis_std_over_max_force":
                         thesis.NODAL_ERROR_STD.get((c, m), np.nan) / thesis.MAX_NODAL_FORCE})
    return pd.DataFrame(rows)


def cost(ds: xr.Dataset) -> pd.DataFrame:
    """Solver evaluations, runs, sequential rounds and time per solve (means)."""
    frame = per_solve(ds)
    cols = ["evaluations", "solved", "rounds", "wall_s", "solver_s", "objective"]
    out = frame.groupby(KEYS, sort=False)[cols].mean().reset_index()
    out["solves"] = frame.groupby(KEYS, sort=False).size().to_numpy()
    out["statuses"] = frame.groupby(KEYS, sort=False)["status"].agg(
        lambda s: ", ".join(f"{k} {v}" for k, v in s.value_counts().items())).to_numpy()
    return out


def tables(ds: xr.Dataset) -> dict[str, pd.DataFrame]:
    """Every table of :data:`TABLES`, by name (what ``farm invert`` writes as CSV)."""
    return {name: globals()[name](ds) for name in TABLES}


def _pm(mean: float, std: float | None, digits: int = 5) -> str:
    if mean is None or (isinstance(mean, float) and np.isnan(mean)):
        return MISSING
    if std is None or (isinstance(std, float) and np.isnan(std)) or std == 0:
        return f"{mean:.{digits}g}"
    return f"{mean:.{digits}g} ± {std:.2g}"


def views(ds: xr.Dataset) -> dict[str, pd.DataFrame]:
    """Compact, formatted versions of the tables for a terminal: ours beside the thesis'."""
    f = forces(ds)
    v_forces = pd.DataFrame({
        "condition": f["condition"], "method": f["method"], "optimizer": f["optimizer"],
        "n": f["repeats"],
        **{f"{q} {u}": [_pm(m, s) for m, s in zip(f[f"{q}_mean"], f[f"{q}_std"], strict=True)]
           for q, u in (("Fz", "N"), ("Mx", "N m"), ("My", "N m"))},
        **{f"thesis {q}": [_pm(m, s) for m, s in zip(f[f"thesis_{q}"], f[f"thesis_{q}_std"],
                                                     strict=True)]
           for q in ("Fz", "Mx", "My")}})
    r = rmse(ds)
    v_rmse = r[KEYS].copy()
    for d in DIRECTIONS:
        v_rmse[f"{d} (thesis)"] = [f"{a:.3g} ({_pm(b, None, 3)})"
                                   for a, b in zip(r[d], r[f"thesis_{d}"], strict=True)]
    c = cost(ds)
    v_cost = c[[*KEYS, "solves", "evaluations", "solved", "rounds", "wall_s", "statuses"]]
    n = nodal_errors(ds)
    v_nodal = n[[*KEYS, "mean", "std", "std_over_max_force", "thesis_std",
                 "thesis_std_over_max_force"]] if not n.empty else n
    return {"forces": v_forces, "rmse": v_rmse, "nodal_errors": v_nodal, "cost": v_cost}


def histograms(ds: xr.Dataset, folder: Path) -> list[Path]:
    """Figs. 4.2/4.3: histograms of the nodal force errors, one PNG per condition."""
    errors = _errors(ds)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for cond in dict.fromkeys(text_values(ds, "condition")):
        mine = {(m, o): e for (c, m, o), e in errors.items() if c == cond}
        if not mine:
            continue
        fig = Figure(figsize=(7, 4), layout="constrained")
        FigureCanvasAgg(fig)
        ax = fig.subplots()
        for (method, opt), e in mine.items():
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
