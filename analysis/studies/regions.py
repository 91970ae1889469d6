"""`farm analyse regions`: where each target lives on the inner surface - the held-out
share of its variance that each region's field explains (issue 46, "where to look";
:mod:`analysis.camera.regions`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from analysis.camera import features
from analysis.camera.regions import region_grid, region_r2
from analysis.camera.sensor.surface import InnerSurface
from analysis.render import markdown, plots
from analysis.splits import path_groups
from analysis.studies.common import Report

_METHOD = (
    "The inner surface in the camera frame (fixed to the contact centre) is cut into "
    "bands of meridional arc length s (bead to bead; 0 at the crown, + towards +y) and "
    "sectors of angle theta about the contact centre (+ ahead of it, towards +x). For each "
    "region and target the index is the held-out R2 of the target predicted from that "
    "region's displacement field alone: PLSR, its component count chosen by an inner "
    "grouped CV, in grouped K-fold CV (a rolling tree's states never on both sides), "
    "repeated over shuffled folds. It estimates the share of the target's variance over "
    "the design that the region's field explains (the region's first-order, "
    "variance-based index where the regression is the conditional mean): near 1 the region "
    "carries the target, near 0 it does not, below 0 it predicts worse than the mean.")


def run(ds: xr.Dataset, out: Path, *, targets=None, bands: int = 6, sectors: int = 8,
        span_deg: float = 60.0, folds: int = 5, repeats: int = 3, noise_mm: float = 0.0,
        max_components: int = 5, seed: int = 0) -> Report:
    """Write ``regions.csv`` (mean and spread of each region's index per target),
    ``regions_repeats.csv``, ``regions.png`` and ``summary.md``."""
    names = tuple(targets) if targets else features.varying_targets(ds)
    regions = region_grid(InnerSurface.from_dataset(ds), bands, sectors, span_deg)
    raw = region_r2(features.displacements(ds), features.targets(ds, names), names,
                    path_groups(ds), regions, folds=folds, repeats=repeats,
                    max_components=max_components, noise_mm=noise_mm, seed=seed)
    report = Report(Path(out))
    report.csv("regions_repeats", raw)
    table = summarise(raw)
    report.csv("regions", table)
    figure = _maps(table, names, report.out / "regions.png")
    report.files.append(figure)
    setup = (f"{ds.sizes['experiment']} experiments in {np.unique(path_groups(ds)).size} "
             f"load paths; {bands} bands x {sectors} sectors over +-{span_deg:g} degrees; "
             f"{folds} grouped folds, {repeats} repeats; noise {noise_mm:g} mm (iid, "
             "training and test alike); PLSR up to "
             f"{max_components} components.")
    path = markdown.write(report.out / "summary.md", "Where each target lives",
                          [("Method", _METHOD), ("Setup", setup),
                           ("Where to look", best(table)),
                           ("Map", markdown.figure(figure, report.out, "held-out R2 maps"))])
    report.files.append(path)
    return report


def summarise(raw: pd.DataFrame) -> pd.DataFrame:
    """One row per (region, target): R2's mean, standard deviation, min and max over
    the repeats."""
    keys = ["target", "s_band", "sector", "s_from_mm", "s_to_mm", "theta_from_deg",
            "theta_to_deg", "nodes"]
    g = raw.groupby(keys, sort=False)["r2"]
    return g.agg(r2_mean="mean", r2_std="std", r2_min="min", r2_max="max").reset_index()


def best(table: pd.DataFrame) -> pd.DataFrame:
    """Per target, the region with the highest mean index, and how many regions come
    within one standard deviation of it (several: the target is spread out)."""
    rows = []
    for name, part in table.groupby("target", sort=False):
        top = part.loc[part["r2_mean"].idxmax()]
        near = int((part["r2_mean"] >= top["r2_mean"] - np.nan_to_num(top["r2_std"])).sum())
        rows.append((name, f"{top['s_from_mm']:.0f} to {top['s_to_mm']:.0f}",
                     f"{top['theta_from_deg']:+.0f} to {top['theta_to_deg']:+.0f}",
                     top["r2_mean"], top["r2_std"], near, part["r2_mean"].median()))
    return pd.DataFrame(rows, columns=["target", "s (mm)", "theta (deg)", "R2 mean", "R2 std",
                                       "regions within 1 std", "median region's R2"])


def _maps(table: pd.DataFrame, names, path: Path) -> Path:
    """One heat-map of the mean index per target, theta across, s up."""
    fig, axes = plots.new_figure(1, len(names), 2.6 * len(names) + 0.8, 3.2)
    image = None
    for ax, name in zip(axes[0], names, strict=True):
        part = table[table["target"] == name]
        grid = np.full((part["s_band"].max() + 1, part["sector"].max() + 1), np.nan)
        grid[part["s_band"], part["sector"]] = part["r2_mean"]
        extent = (part["theta_from_deg"].min(), part["theta_to_deg"].max(),
                  part["s_from_mm"].min(), part["s_to_mm"].max())
        image = ax.imshow(grid, origin="lower", aspect="auto", extent=extent, cmap="viridis",
                          vmin=0.0, vmax=1.0)
        ax.set_title(name)
        ax.set_xlabel("theta [deg]")
    axes[0][0].set_ylabel("s [mm]")
    fig.colorbar(image, ax=axes[0].tolist(), label="held-out R2")
    return plots.save_figure(fig, path)
