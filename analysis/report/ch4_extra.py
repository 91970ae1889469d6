"""Issue 16's chapter-4 tables beyond the thesis: initial guesses and regularisation.

Both read inverse-solves groups as :func:`storage.solves.open_solves` gives them (the
store holds all they need), like :mod:`analysis.report.ch4`:

- :func:`guesses`: per condition (one initial guess each: the thesis' 90 %, 90 % +
  N(0, 4 N), uniform + N(0, 4 N) of §4.3-4.5, the thickness-offset guess of §5.2/§6.2,
  the statistical "tyre distribution" of §6.2) and method: evaluations and sequential
  rounds to converge, the nodal error of the guess itself and of the solution (std
  and RMS of x - x_true, N), the total force;
- :func:`regularisation`: one group per regularisation setting (none, Tikhonov,
  smoothness, a PCA mask...), per noisy condition and method: nodal error std and
  total-force error, with the weight each solve chose (the discrepancy principle
  records it in the solve's message, ``jobs.inverse.loop.WEIGHT_TAG``), beside the
  thesis' nodal error std (Figs. 4.2/4.3) and Fz (Tables 4.1/4.3).
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np
import pandas as pd
import xarray as xr

from analysis.report import ch4_thesis as thesis
from analysis.report.ch4 import KEYS, check_solves, solved_ok, text_values

#: How a solve's message carries the weight the discrepancy principle chose.
WEIGHT = re.compile(r"discrepancy weight ([-+0-9.eE]+|nan|inf)")


def _weights(ds: xr.Dataset) -> np.ndarray:
    out = []
    for message in text_values(ds, "message"):
        m = WEIGHT.search(message)
        out.append(float(m.group(1)) if m else np.nan)
    return np.array(out)


def _per_solve(ds: xr.Dataset) -> pd.DataFrame:
    check_solves(ds)
    x_true = ds["x_true"].values
    e0 = ds["x0"].values - x_true
    e = ds["x_final"].values - x_true
    ok = solved_ok(ds)
    fz_ref = float(ds["reference_total_force"].values[2])
    return pd.DataFrame({
        **{k: text_values(ds, k) for k in KEYS}, "ok": ok,
        "evaluations": ds["evaluations"].values.astype(np.int64),
        "rounds": ds["rounds"].values.astype(np.int64),
        "solved": ds["solved"].values.astype(np.int64),
        "x0_err": list(e0), "err": list(e),
        "Fz": np.where(ok, ds["total_force"].values[:, 2], np.nan),
        "Fz_err_pct": np.where(ok, 100 * (ds["total_force"].values[:, 2] / fz_ref - 1), np.nan),
        "weight": _weights(ds), "status": text_values(ds, "status")})


def _pooled(errors) -> tuple[float, float]:
    e = np.concatenate(list(errors)) if len(errors) else np.array([np.nan])
    return float(e.std()), float(np.sqrt(np.mean(e**2)))


def guesses(ds: xr.Dataset) -> pd.DataFrame:
    """Evaluations to converge and nodal errors per initial guess (condition) and method."""
    frame = _per_solve(ds)
    rows = []
    for key, g in frame.groupby(KEYS, sort=False):
        done = g[g["ok"]]
        std0, rms0 = _pooled(g["x0_err"])
        std, rms = _pooled(done["err"])
        rows.append({**dict(zip(KEYS, key, strict=True)), "solves": len(g),
                     "evaluations": g["evaluations"].mean(), "rounds": g["rounds"].mean(),
                     "guess_std": std0, "guess_rms": rms0, "nodal_std": std, "nodal_rms": rms,
                     "Fz": done["Fz"].mean(), "Fz_err_pct": done["Fz_err_pct"].mean(),
                     "statuses": ", ".join(f"{k} {v}" for k, v in
                                           g["status"].value_counts().items())})
    return pd.DataFrame(rows)


def same_solves(ds: xr.Dataset, others: Mapping[str, xr.Dataset]) -> xr.Dataset:
    """The solves of ``ds`` whose (condition, method, repeat) the ``others`` solved too.

    The unregularised row of a setting must pool the same noise draws as the regularised
    ones beside it (the quick reproduction regularises one repeat of two, say)."""
    def triples(d: xr.Dataset) -> list[tuple]:
        return list(zip(text_values(d, "condition"), text_values(d, "method"),
                        d["repeat"].values.tolist(), strict=True))

    wanted = set().union(*(triples(d) for d in others.values()))
    keep = np.array([t in wanted for t in triples(ds)], dtype=bool)
    return ds.isel(solve=np.flatnonzero(keep))


def regularisation(groups: Mapping[str, xr.Dataset]) -> pd.DataFrame:
    """Nodal error std and total-force error per setting (label), condition and method,
    beside the thesis' values (which had no regularisation: Nelder-Mead, §4.4-4.5)."""
    rows = []
    for label, ds in groups.items():
        frame = _per_solve(ds)
        for (c, m, o), g in frame.groupby(KEYS, sort=False):
            done = g[g["ok"]]
            std, rms = _pooled(done["err"])
            w = g["weight"].to_numpy()
            rows.append({"setting": label, "condition": c, "method": m, "optimizer": o,
                         "solves": len(g), "weight": float(np.nanmedian(w))
                         if np.isfinite(w).any() else np.nan,
                         "nodal_std": std, "nodal_rms": rms,
                         "Fz": done["Fz"].mean(), "Fz_err_pct": done["Fz_err_pct"].mean(),
                         "evaluations": g["evaluations"].mean(),
                         "thesis_nodal_std": thesis.NODAL_ERROR_STD.get((c, m), np.nan),
                         "thesis_Fz": thesis.FORCES.get((c, m), (np.nan,))[0]})
    return pd.DataFrame(rows)
