"""Figures of chapter 5 as PNG files.

Figures are built on :class:`matplotlib.figure.Figure` with the Agg canvas, never through
pyplot's global state, so reports render headless (workers, CI) and do not change the
backend of a caller's session. Surface maps are drawn on the unrolled structured grid
(``*_row``: meridian, ``*_col``: circumference), as the thesis' heat-maps are.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from analysis import data

DPI = 120


def new_figure(nrows: int, ncols: int, width: float, height: float, **kw):
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False, **kw)
    return fig, axes


def save_figure(fig: Figure, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    return path


def grid_image(values: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Scatter node values onto a (rows, cols) image; NaN where no node sits."""
    img = np.full((int(rows.max()) + 1, int(cols.max()) + 1), np.nan)
    img[rows, cols] = values
    return img


def _surface(ax, values, nodes: pd.DataFrame, vmax: float, cmap="RdBu_r"):
    """Map on the unrolled grid, or on (x, y) when the store has no grid positions."""
    if (nodes["row"] >= 0).all():
        img = grid_image(values, nodes["row"].to_numpy(), nodes["col"].to_numpy())
        im = ax.imshow(img, origin="lower", aspect="auto", cmap=cmap, vmin=-vmax, vmax=vmax)
        ax.set_xlabel("column (circumference, +x)")
        ax.set_ylabel("row (meridian, +y)")
    else:
        im = ax.scatter(nodes["x"], nodes["y"], c=values, cmap=cmap, vmin=-vmax, vmax=vmax, s=8)
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("y [mm]")
    return im


def singular_values(table: pd.DataFrame, path: Path, title: str) -> Path:
    """Figs. 5.1/5.3: all singular values on a log scale (top), first three linear."""
    fig, axes = new_figure(2, 1, 7, 6)
    top, bottom = axes[0, 0], axes[1, 0]
    directions = list(dict.fromkeys(table["direction"]))
    width = 0.8 / max(len(directions), 1)
    for i, (d, part) in enumerate(table.groupby("direction", sort=False)):
        positive = part[part["singular_value"] > 0]
        top.semilogy(positive["mode"], positive["singular_value"], "o-", label=d)
        first = part[part["mode"] <= 3]
        bottom.bar(
            first["mode"] + (i - (len(directions) - 1) / 2) * width,
            first["singular_value"],
            width,
            label=d,
        )
    top.set(title=title, xlabel="mode", ylabel="singular value (log)")
    bottom.set(xlabel="mode", ylabel="singular value", xticks=[1, 2, 3])
    top.legend()
    return save_figure(fig, path)


def eigen_maps(
    vectors: Mapping[str, np.ndarray],
    importance: Mapping[str, float],
    nodes: pd.DataFrame,
    path: Path,
    title: str,
) -> Path:
    """Figs. 5.2/5.4: first column of W per direction, own scale (left) and normalised
    by the direction's importance σ₁/σ₁,max on a common scale (right)."""
    fig, axes = new_figure(len(vectors), 2, 10, 2.6 * len(vectors))
    for i, (d, w) in enumerate(vectors.items()):
        own = float(np.nanmax(np.abs(w))) or 1.0
        im = _surface(axes[i, 0], w, nodes, own)
        fig.colorbar(im, ax=axes[i, 0])
        axes[i, 0].set_title(f"{d}: W[:, 1]")
        scaled = w / own * importance[d]
        im = _surface(axes[i, 1], scaled, nodes, 1.0)
        fig.colorbar(im, ax=axes[i, 1])
        axes[i, 1].set_title(f"{d}: normalised (importance {importance[d]:.2f})")
    fig.suptitle(title)
    return save_figure(fig, path)


def predictions(
    tread: pd.DataFrame,
    reference: np.ndarray,
    preds: Mapping[int, np.ndarray],
    path: Path,
    title: str,
) -> Path:
    """Figs. 5.5/5.6/5.8/5.9: predicted vs reference tread forces for 1..n modes.

    Left: every node, predicted against reference. Right: the longitudinal profile
    along the tread's centre row.
    """
    fig, axes = new_figure(1, 2, 11, 4.5)
    scatter, profile = axes[0, 0], axes[0, 1]
    lim = [float(min(reference.min(), 0)), float(reference.max()) * 1.05 or 1.0]
    scatter.plot(lim, lim, "k--", lw=1, label="y = x")
    centre = _peak_row(tread, reference)
    order = np.argsort(tread["x"].to_numpy()[centre])
    xs = tread["x"].to_numpy()[centre][order]
    profile.plot(xs, reference[centre][order], "k-", lw=2, label="reference")
    for n, p in preds.items():
        scatter.plot(reference, p, ".", ms=4, label=f"{n} mode{'s' if n > 1 else ''}")
        profile.plot(xs, p[centre][order], "--", label=f"{n}")
    scatter.set(xlabel="reference force [N]", ylabel="predicted force [N]", title=title)
    profile.set(xlabel="x [mm]", ylabel="force [N]", title="centre row of the tread")
    scatter.legend(fontsize=8)
    profile.legend(fontsize=8, title="modes")
    return save_figure(fig, path)


def _peak_row(tread: pd.DataFrame, reference: np.ndarray) -> np.ndarray:
    """Mask of the tread row (or, without grid positions, the y line) through the peak."""
    peak = int(np.argmax(reference))
    if (tread["row"] >= 0).all():
        return tread["row"].to_numpy() == tread["row"].iloc[peak]
    y = tread["y"].to_numpy()
    return np.isclose(y, y[peak], rtol=0, atol=1e-6 * (np.ptp(y) + 1))


def variance_bars(table: pd.DataFrame, path: Path, title: str) -> Path:
    """Figs. 5.7/5.10: % of variance explained per mode, bars grouped by label."""
    fig, axes = new_figure(1, 1, 7, 4)
    ax = axes[0, 0]
    labels = list(dict.fromkeys(table["label"]))
    width = 0.8 / max(len(labels), 1)
    for i, (label, part) in enumerate(table.groupby("label", sort=False)):
        ax.bar(part["mode"] + (i - (len(labels) - 1) / 2) * width, part["pct"], width, label=label)
    ax.set(xlabel="mode", ylabel="variance explained [%]", title=title)
    ax.legend(fontsize=8)
    return save_figure(fig, path)


def node_maps(
    tread: pd.DataFrame, panels: Mapping[str, np.ndarray], path: Path, title: str
) -> Path:
    """Fig. 5.11: maps over the tread (mean error, standard deviation)."""
    fig, axes = new_figure(1, len(panels), 5.5 * len(panels), 4)
    for ax, (name, values) in zip(axes[0], panels.items(), strict=True):
        diverging = np.nanmin(values) < 0
        vmax = float(np.nanmax(np.abs(values))) or 1.0
        im = _surface(ax, values, tread, vmax, cmap="RdBu_r" if diverging else "viridis")
        if not diverging:
            im.set_clim(0, vmax)
        fig.colorbar(im, ax=ax, label="N")
        ax.set_title(name)
    fig.suptitle(title)
    return save_figure(fig, path)


def noise_sweep(sweep: pd.DataFrame, path: Path) -> Path:
    """Fig. 5.12: nodal-average std (blue) and mean total force (orange) per noise level,
    over σ in its unit (mm, or µstrain for strains) and, on top, in multiples of the
    thesis' level."""
    groups = list(sweep.groupby("inputs", sort=False))
    fig, axes = new_figure(len(groups), 1, 7, 3.5 * len(groups))
    for ax, (inputs, part) in zip(axes[:, 0], groups, strict=True):
        scale, unit = noise_unit(inputs)
        sigma = part["sigma"].to_numpy() * scale
        ax.plot(sigma, part["Fz_nodal_avg_std"], "o-", color="tab:blue", label="Monte Carlo")
        ax.plot(sigma, part["Fz_nodal_avg_std_analytic"], "k:", label="analytic")
        ax.set(xlabel=f"noise σ on the {inputs} inputs [{unit}]",
               ylabel="nodal average std of Fz [N]", title=inputs)
        ax.legend(loc="upper left", fontsize=8)
        per = _per_multiple(part, scale)
        if per:
            top = ax.secondary_xaxis("top", functions=(lambda s, p=per: s / p,
                                                       lambda m, p=per: m * p))
            top.set_xlabel("noise (× thesis σ)")
        twin = ax.twinx()
        twin.errorbar(sigma, part["Fz_mean"], yerr=part["Fz_total_std"], color="tab:orange",
                      fmt="s-", ms=3, capsize=2)
        twin.set_ylabel("mean total Fz ± std of the total [N]", color="tab:orange")
    return save_figure(fig, path)


def noise_unit(inputs: str) -> tuple[float, str]:
    """(factor, unit) that print an input set's noise σ: mm as stored, strains in µstrain."""
    family = data.family(data.expand_inputs(inputs.split("+"))[0])
    return (1.0, "mm") if family == "displacement" else (1e6, "µstrain")


def _per_multiple(part: pd.DataFrame, scale: float) -> float | None:
    """σ (in the axis' unit) of one multiple of the thesis' level, None if not known."""
    ok = part["multiplier"].to_numpy() > 0
    if not ok.any():
        return None
    return float(part["sigma"].to_numpy()[ok][0] * scale / part["multiplier"].to_numpy()[ok][0])


def lines(path: Path, series: Mapping[str, tuple[np.ndarray, np.ndarray]], *, xlabel: str,
          ylabel: str, title: str, logx: bool = False) -> Path:
    """One marked line per ``label -> (x, y)`` on one axis (the sensor study's error
    curves)."""
    fig, axes = new_figure(1, 1, 7, 4.5)
    ax = axes[0, 0]
    for label, (x, y) in series.items():
        ax.plot(x, y, "o-", ms=3, label=label)
    if logx:
        ax.set_xscale("log")
    ax.set(xlabel=xlabel, ylabel=ylabel, title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncols=2)
    return save_figure(fig, path)
