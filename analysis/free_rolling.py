"""Each rolling tree's free-rolling state, measured from its own states (issue 46).

A rolling tree's trunk rolls at a radius chosen before the roll (given, searched, or
estimated as R - 0.59 d: :func:`farm.solve.rolling.estimated_radius`), so its commanded
slip ratio ``kappa`` is measured from that radius, not from the tyre's true free-rolling
radius r_e. Where they differ the "free" trunk drives or brakes: on ``lean`` at 80 kPa
and 26 mm its Fx rose by 67 N every 15 mm for all 135 mm (docs/answer.md). A model asked
for the slip ratio would then learn a label off by a per-tree constant.

The tree measures its own offset. Along a roll at constant slip the longitudinal force
follows the first-order (string / relaxation-length) model of the transient tyre
(Pacejka, *Tyre and Vehicle Dynamics*, ch. 7)::

    dFx/ds = (C (kappa - kappa0) - Fx) / sigma

with C the slip stiffness, sigma the relaxation length and ``kappa0`` the commanded slip
at which the tyre rolls freely. Over a segment of ``ds`` mm starting at ``Fx0`` it gives
``Fx1 - Fx0 = (C (kappa - kappa0) - Fx0) q``, ``q = 1 - exp(-ds / sigma)``: linear in
(C, C kappa0) for each sigma. Every segment between stored states of the tree - the
trunk's from rest, each branch's from the trunk state it left - is one equation; sigma
is the one on a log grid whose least squares fit is best, and ``kappa0 = -D / C``. Only
segments in the linear range take part (horizontal force at both ends within
:data:`LINEAR_SHARE` of mu Fz: the brush model's force is near-linear in slip up to about
a third to a half of the friction limit), and at least two commanded slips must remain.

The rim turns by (1 + kappa) d / r, so the true slip of a state is
``(1 + kappa) / (1 + kappa0) - 1`` (:func:`free_slip_ratio`) and ``r_e = r / (1 + kappa0)``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr
from scipy.optimize import minimize_scalar

from analysis.data import totals
from analysis.errors import MissingVariableError
from analysis.splits import ROLL_FROM, TRAVEL, path_groups

__all__ = ["LINEAR_SHARE", "SIGMA_GRID_MM", "fit_offset", "free_rolling", "free_slip_ratio",
           "segments"]

#: the share of mu Fz up to which a segment's horizontal force counts as linear in slip
LINEAR_SHARE = 0.4
#: the relaxation lengths tried, mm: a trunk still winding up linearly after 135 mm
#: takes the largest (the rate alone then fixes kappa0: Fx0 q is negligible)
SIGMA_GRID_MM = np.geomspace(5.0, 1e6, 241)
_NEEDS = ("slip_ratio", "slip_angle", "friction", "rolling_radius", TRAVEL, ROLL_FROM)


def segments(ds: xr.Dataset) -> pd.DataFrame:
    """One row per segment between consecutive stored states of a roll: ``tree`` (the
    :func:`~analysis.splits.path_groups` label), ``kappa`` (commanded), ``ds`` (mm),
    ``fx0``/``fx1`` (N, at its ends), ``linear`` (both ends within :data:`LINEAR_SHARE`
    of mu Fz). A trunk's first segment starts from rest (Fx = 0 at travel 0); a branch's
    from the trunk's state at its ``roll_from`` (left out when that state is not stored)."""
    missing = [n for n in _NEEDS if n not in ds.variables]
    if missing:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no "
                                   f"{', '.join(map(repr, missing))}: free rolling is measured "
                                   "on a store of rolling trees")
    F = totals(ds)
    limit = LINEAR_SHARE * np.asarray(ds["friction"].values, float) * np.abs(F[:, 2])
    linear = np.hypot(F[:, 0], F[:, 1]) <= limit
    frame = pd.DataFrame({
        "tree": path_groups(ds), "kappa": np.asarray(ds["slip_ratio"].values, float),
        "alpha": np.asarray(ds["slip_angle"].values, float),
        "from": np.asarray(ds[ROLL_FROM].values, float),
        "travel": np.asarray(ds[TRAVEL].values, float), "fx": F[:, 0], "linear": linear})
    rows = []
    for tree, one in frame.groupby("tree", sort=True):
        trunk = one[one["from"] == 0].set_index("travel")  # the states branches leave
        rows += [_path_segments(int(tree), path, trunk)
                 for _, path in one.groupby(["from", "kappa", "alpha"], sort=True)]
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(
        columns=["tree", "kappa", "ds", "fx0", "fx1", "linear"])


def _path_segments(tree: int, path: pd.DataFrame, trunk: pd.DataFrame) -> pd.DataFrame:
    path = path.sort_values("travel")
    start = float(path["from"].iloc[0])
    if start == 0:
        s0, fx0, lin0 = 0.0, 0.0, True  # from rest: the loaded, standing tyre
    elif start in trunk.index:
        s0, fx0, lin0 = start, float(trunk.at[start, "fx"]), bool(trunk.at[start, "linear"])
    else:  # the trunk state it left is not stored: its first segment is unknown
        s0, fx0, lin0 = np.nan, np.nan, False
    travel, fx, lin = (path[c].to_numpy() for c in ("travel", "fx", "linear"))
    starts = np.concatenate([[s0], travel[:-1]])
    fx_starts = np.concatenate([[fx0], fx[:-1]])
    lin_starts = np.concatenate([[lin0], lin[:-1]])
    out = pd.DataFrame({"tree": tree, "kappa": float(path["kappa"].iloc[0]),
                        "ds": travel - starts, "fx0": fx_starts, "fx1": fx,
                        "linear": lin & lin_starts})
    return out[np.isfinite(out["ds"])]


def fit_offset(seg: pd.DataFrame) -> dict[str, float]:
    """The first-order model's fit to one tree's linear segments: ``kappa0``, ``C``
    (N per unit slip), ``sigma_mm`` (inf where the largest on the grid fits best: no
    curvature seen), ``rms_N`` (residual of Fx1) and ``segments`` used; NaN values when
    fewer than two distinct commanded slips remain (C cannot be told from kappa0)."""
    use = seg[seg["linear"]]
    out = {"kappa0": np.nan, "C": np.nan, "sigma_mm": np.nan, "rms_N": np.nan,
           "segments": float(len(use))}
    if np.unique(use["kappa"]).size < 2:
        return out
    k, ds_, f0, f1 = (use[c].to_numpy(float) for c in ("kappa", "ds", "fx0", "fx1"))

    def fit(log_sigma: float) -> tuple[float, np.ndarray]:
        q = -np.expm1(-ds_ / np.exp(log_sigma))
        A = np.column_stack([k * q, q])
        y = f1 - f0 + f0 * q
        coef = np.linalg.lstsq(A, y, rcond=None)[0]
        return float(np.sum((A @ coef - y) ** 2)), coef

    grid = np.log(SIGMA_GRID_MM)
    i = int(np.argmin([fit(g)[0] for g in grid]))  # then refined between its neighbours
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    best = minimize_scalar(lambda g: fit(g)[0], bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-6}).x
    sse, (C, D) = fit(best)
    sigma = float(np.exp(best))
    out.update(kappa0=float(-D / C), C=float(C), rms_N=float(np.sqrt(sse / len(use))),
               sigma_mm=float(np.inf if best >= grid[-1] - 1e-3 else sigma))
    return out


def free_rolling(ds: xr.Dataset) -> pd.DataFrame:
    """One row per rolling tree of ``ds``: its load case (pressure kPa, deflection mm,
    friction, tilt), the radius its rim turned with (``radius_mm``), the fit of
    :func:`fit_offset` and the free-rolling radius ``r_free_mm`` = radius / (1 + kappa0).
    """
    seg = segments(ds)
    groups = path_groups(ds)
    rows = []
    for tree in np.unique(groups):
        first = int(np.flatnonzero(groups == tree)[0])
        at = ds.isel(experiment=first)
        radius = float(at["rolling_radius"].values)
        fit = fit_offset(seg[seg["tree"] == tree])
        rows.append({"tree": int(tree), "pressure_kPa": 1000.0 * float(at["pressure"].values),
                     "deflection_mm": float(at["deflection"].values),
                     "friction": float(at["friction"].values),
                     "tilt_deg": float(at["tilt"].values) if "tilt" in at.variables else 0.0,
                     "states": int(np.sum(groups == tree)), "radius_mm": radius, **fit,
                     "r_free_mm": radius / (1.0 + fit["kappa0"])})
    return pd.DataFrame(rows)


def free_slip_ratio(ds: xr.Dataset, table: pd.DataFrame | None = None) -> np.ndarray:
    """(K,) each state's slip ratio measured from its tree's free rolling,
    ``(1 + kappa) / (1 + kappa0) - 1``; NaN for a tree whose offset is unmeasured.
    ``table``: :func:`free_rolling` of ``ds`` where the caller has it already."""
    table = (free_rolling(ds) if table is None else table).set_index("tree")
    kappa0 = table["kappa0"].reindex(path_groups(ds)).to_numpy(float)
    kappa = np.asarray(ds["slip_ratio"].values, float)
    return (1.0 + kappa) / (1.0 + kappa0) - 1.0
