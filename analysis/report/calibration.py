"""The figure of ``farm calibrate``: force-deflection of the start and the fitted model."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def force_deflection(curves: pd.DataFrame, points: Iterable[tuple[float, float]],
                     path: Path) -> Path:
    """Draw the curves and the reference points into ``path`` (PNG); return it.

    ``curves`` has columns ``model`` ("start" is drawn dashed), ``pressure_kpa``,
    ``deflection_mm`` and ``fz_n``; ``points`` are the (deflection mm, force N) pairs
    the fit aimed at, drawn as stars.
    """
    fig = Figure(figsize=(6.5, 4.5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    for (label, kpa), part in curves.groupby(["model", "pressure_kpa"], sort=False):
        ax.plot(part["deflection_mm"], part["fz_n"], "--" if label == "start" else "-",
                marker="o", ms=3, label=f"{label}, {kpa:g} kPa")
    pairs = [(float(d), float(f)) for d, f in points]
    ax.plot([d for d, _ in pairs], [f for _, f in pairs], "k*", ms=12, label="reference points")
    ax.set_xlabel("deflection [mm]")
    ax.set_ylabel("Fz [N]")
    ax.legend(fontsize=8)
    ax.set_title("Force-deflection: start vs calibrated model")
    fig.savefig(path, dpi=120)
    return path
