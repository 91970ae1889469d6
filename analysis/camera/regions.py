"""Where each force lives on the inner surface: a global sensitivity of the targets to
each region's field (issue 46, "where to look").

Sensor-placement studies for intelligent tyres choose where to measure by how strongly
each place's signal varies with the forces over the whole operating range, not at one
load case. Here the inner surface, in the camera frame fixed to the contact centre
(docs/rolling.md), is cut into a grid of regions - bands of meridional arc length ``s``
from bead to bead, sectors of angle ``theta`` about the contact centre - and for each
region and target the index is the *held-out* share of the target's variance over the
study's design that the region's displacement field explains:

    R2 = 1 - sum (y - y_hat)^2 / sum (y - mean y)^2,

``y_hat`` predicted from that region alone by PLSR (its component count chosen by an
inner grouped CV, :class:`analysis.camera.learners.PLSCV`) in grouped K-fold CV (a
rolling tree's states never on both sides, :mod:`analysis.splits`), repeated over
shuffled folds. When the regression is the conditional mean, R2 estimates the
first-order, variance-based index Var(E[y | field of the region]) / Var(y) (Sobol
2001; Saltelli et al. 2008, ch. 1), the region's field taken as one input: a region
that carries a target scores near 1, one that does not near 0 (below 0: worse than the
mean). Optional noise (``noise_mm``, iid per coordinate) is drawn for training and
test rows alike, as a camera's would be.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from analysis.camera.learners import PLSCV
from analysis.camera.sensor.surface import InnerSurface
from analysis.errors import ParameterError

__all__ = ["Region", "grouped_folds", "held_out_r2", "region_grid", "region_r2"]


@dataclass(frozen=True)
class Region:
    """One cell of the grid: its nodes (store ``inner_node`` order) and its bounds."""

    s_band: int
    sector: int
    s_mm: tuple[float, float]
    theta_deg: tuple[float, float]
    nodes: np.ndarray


def region_grid(surface: InnerSurface, bands: int, sectors: int,
                span_deg: float) -> list[Region]:
    """``bands`` x ``sectors`` regions: equal bands of ``s`` (bead to bead) and equal
    sectors of the columns whose angle lies within ``span_deg`` of the contact centre.
    Each region holds at least one grid row and column, or the grid is refused."""
    if not (bands >= 1 and sectors >= 1 and 0.0 < span_deg <= 180.0):
        raise ParameterError(f"regions: bands and sectors >= 1 and a span in (0, 180] "
                             f"degrees, got {bands}, {sectors}, {span_deg}")
    deg = np.degrees(surface.theta)  # in (-180, 180]: a periodic grid's seam anywhere
    cols = np.flatnonzero(np.abs(deg) <= span_deg + 1e-9)
    s_edges = np.linspace(surface.s[0], surface.s[-1], bands + 1)
    t_edges = np.linspace(-span_deg, span_deg, sectors + 1)
    out = []
    for i in range(bands):
        rows = _within(surface.s, s_edges, i)
        for j in range(sectors):
            c = cols[_within(np.clip(deg[cols], -span_deg, span_deg), t_edges, j)]
            if rows.size == 0 or c.size == 0:
                raise ParameterError(
                    f"regions: {bands} x {sectors} over +-{span_deg:g} degrees leaves a region "
                    f"with no node (the grid has {surface.shape[0]} rows, {cols.size} columns "
                    "there): ask for fewer bands or sectors, or a smaller span")
            out.append(Region(i, j, (float(s_edges[i]), float(s_edges[i + 1])),
                              (float(t_edges[j]), float(t_edges[j + 1])),
                              surface.node_index[np.ix_(rows, c)].ravel()))
    return out


def _within(values: np.ndarray, edges: np.ndarray, i: int) -> np.ndarray:
    """Positions of ``values`` in bin ``i`` of ``edges`` (the last bin closed)."""
    upper = values <= edges[i + 1] if i == len(edges) - 2 else values < edges[i + 1]
    return np.flatnonzero((values >= edges[i]) & upper)


def grouped_folds(groups: np.ndarray, n_folds: int,
                  rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n_folds`` (train, test) folds of whole groups, the groups shuffled by ``rng``
    (scikit-learn's GroupKFold does not shuffle, and repeats need different folds)."""
    labels = np.unique(groups)
    if labels.size < 3:  # each fold's training part needs 2 for its own inner CV
        raise ParameterError(f"regions: grouped CV needs at least 3 load paths (rolling "
                             f"trees), the selection has {labels.size}: run more of the study")
    if not 2 <= n_folds <= labels.size:
        raise ParameterError(f"regions: {n_folds} folds need 2 to {labels.size} groups "
                             f"(the store's load paths), got {n_folds}")
    parts = np.array_split(rng.permutation(labels), n_folds)
    return [(np.flatnonzero(~np.isin(groups, p)), np.flatnonzero(np.isin(groups, p)))
            for p in parts]


def held_out_r2(X: np.ndarray, y: np.ndarray, groups: np.ndarray, folds, *,
                max_components: int) -> float:
    """R2 of ``y`` (K,) predicted from ``X`` (K, n) over ``folds``, each test row
    predicted once by a PLSR fitted on its fold's training rows (an inner grouped CV
    of 3 folds, or fewer where the training groups are fewer, picks the count). NaN for
    a ``y`` that does not vary: it has no variance to explain."""
    total = np.sum((y - y.mean()) ** 2)
    if not total > 0:
        return float("nan")
    pred = np.empty_like(y)
    for train, test in folds:
        if np.ptp(y[train]) == 0:  # nothing to learn here (a camber all folds but one lack)
            pred[test] = y[train].mean()
            continue
        inner = min(3, np.unique(groups[train]).size)
        fit = PLSCV(max_components=max_components, folds=inner)
        pred[test] = fit.fit(X[train], y[train, None], groups=groups[train]).predict(
            X[test])[:, 0]
    return float(1.0 - np.sum((y - pred) ** 2) / total)


def region_r2(field: np.ndarray, Y: np.ndarray, names, groups: np.ndarray,
              regions: list[Region], *, folds: int = 5, repeats: int = 3,
              max_components: int = 5, noise_mm: float = 0.0, seed: int = 0) -> pd.DataFrame:
    """The index of every region for every target, one row per (region, target, repeat).

    Parameters
    ----------
    field : ndarray, shape (K, N, 3)
        Inner-surface displacements (mm), store node order, camera frame.
    Y : ndarray, shape (K, T)
        Targets; ``names`` their T names.
    groups : ndarray, shape (K,)
        Load-path labels (:func:`analysis.splits.path_groups`).
    regions : list of Region
    folds, repeats, max_components, noise_mm, seed
        Grouped CV folds, shuffled repeats, PLSR's largest count, the iid noise's
        standard deviation (mm; drawn once a repeat for every row), the seed.

    Returns
    -------
    DataFrame with columns s_band, sector, s_from_mm, s_to_mm, theta_from_deg,
    theta_to_deg, nodes, target, repeat, r2.
    """
    rng = np.random.default_rng(seed)
    rows = []
    for r in range(repeats):
        split = grouped_folds(groups, folds, rng)
        seen = field + rng.normal(0.0, noise_mm, field.shape) if noise_mm > 0 else field
        for reg in regions:
            X = seen[:, reg.nodes, :].reshape(field.shape[0], -1)
            for t, name in enumerate(names):
                rows.append((reg.s_band, reg.sector, *reg.s_mm, *reg.theta_deg,
                             reg.nodes.size, name, r,
                             held_out_r2(X, Y[:, t], groups, split,
                                         max_components=max_components)))
    return pd.DataFrame(rows, columns=["s_band", "sector", "s_from_mm", "s_to_mm",
                                       "theta_from_deg", "theta_to_deg", "nodes", "target",
                                       "repeat", "r2"])
