"""`farm analyse free-rolling`: each rolling tree's free-rolling offset and radius,
measured from its own states (issue 46; :mod:`analysis.free_rolling`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from analysis.free_rolling import LINEAR_SHARE, free_rolling
from analysis.render import markdown
from analysis.studies.common import Report

_METHOD = (
    "Each tree's longitudinal force along its rolls is fitted with the first-order "
    "transient model dFx/ds = (C (kappa - kappa0) - Fx) / sigma over every segment between "
    "stored states in the linear range (horizontal force within "
    f"{LINEAR_SHARE:g} mu Fz at both ends): the trunk's from rest, each branch's from the "
    "trunk state it left. kappa0 is the commanded slip at which the tyre rolls freely, "
    "r_free = radius / (1 + kappa0) its free-rolling radius, and a state's slip from free "
    "rolling (the `free_slip_ratio` target) is (1 + kappa) / (1 + kappa0) - 1. sigma = inf: "
    "Fx still rising linearly at the trunk's end (only the rate is seen). NaN: fewer than "
    "two commanded slips in the linear range (a trunk alone).")


def run(ds: xr.Dataset, out: Path) -> Report:
    """Write ``free_rolling.csv`` (one row per tree) and ``summary.md``."""
    table = free_rolling(ds)
    report = Report(Path(out))
    report.csv("free_rolling", table)
    kappa0 = table["kappa0"].to_numpy(float)
    measured = np.isfinite(kappa0)
    lines = [f"{int(measured.sum())} of {len(table)} trees measured."]
    if measured.any():
        lines.append(f"kappa0 from {np.min(kappa0[measured]):+.4f} to "
                     f"{np.max(kappa0[measured]):+.4f}; the free-rolling radius lies "
                     f"{np.min(table['r_free_mm'] - table['radius_mm']):+.2f} to "
                     f"{np.max(table['r_free_mm'] - table['radius_mm']):+.2f} mm from the "
                     "radius rolled.")
        span = float(np.ptp(np.asarray(ds["slip_ratio"].values, float)))
        if span > 0:
            worst = 100.0 * float(np.max(np.abs(kappa0[measured]))) / span
            lines.append(f"The largest offset is {worst:.1f} % of the commanded slip ratio's "
                         "range: what the `slip_ratio` labels are off by where "
                         "`free_slip_ratio` is not used.")
    path = markdown.write(report.out / "summary.md", "Free rolling of each rolling tree",
                          [("Method", _METHOD), ("Result", " ".join(lines)),
                           ("Trees", table)])
    report.files.append(path)
    return report
