"""Contact-patch metrics and inflation growth: what a tyre engineer checks first.

Issue 24: the farm reported the road force and a count of loaded nodes; whether the
patch was resolved, how large it was and what pressure it carried, and how far the
tyre grew when inflated (thesis §3.3.2: the real TM700 bulges at most 4 mm at 200 kPa,
the thesis' cordless model 8 mm, 16 mm or more with a uniform material) were not
outputs. Everything here is derived from the mesh and a solved state: no solver run.

Nodal pressure is a node's road-normal force over its tributary area: a quarter of each
outer-surface quadrilateral the node is a corner of, in the reference (unloaded,
uninflated) configuration. On a coarse mesh this smears the pressure over a node's
whole area, which is exactly why the metrics are reported side by side per refinement
level (the convergence study, docs/mesh-convergence.md).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from farm.mesh.tyremesh import TyreMesh
from farm.solve.states import SolvedState

LOADED_N = 1e-6
"""A tread node carries road force when its force exceeds this (N): ccx writes exact
zeros for open nodes, and the exponential contact law's far tail is below 1e-6 N."""


@dataclass(frozen=True)
class PatchMetrics:
    """The contact patch of one solved state (units: mm, mm^2, MPa, N).

    ``length`` and ``width`` are the extents of the loaded nodes' deformed positions along
    x and y (node to node: a one-column patch has length 0); ``area`` the tributary
    area of the loaded nodes; ``peak_pressure`` the largest nodal pressure, ``mean_pressure``
    the normal force over ``area``; ``nodal_mean``/``nodal_std`` the mean and standard
    deviation of the loaded nodes' normal forces (thesis §3.3.2 gives 263.3 / 227.4 N).
    """

    nodes: int
    columns: int
    area: float
    length: float
    width: float
    peak_pressure: float
    mean_pressure: float
    nodal_mean: float
    nodal_std: float

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


def grid_areas(mesh: TyreMesh, grid: np.ndarray) -> np.ndarray:
    """Tributary area (mm^2) of each node of a surface ``grid`` (the mesh's inner or
    outer grid), same shape: a quarter of every quadrilateral the node is a corner of,
    each quad's area from its two diagonals (exact for a planar quadrilateral)."""
    if mesh.periodic:
        grid = np.concatenate([grid, grid[:, :1]], axis=1)  # close the seam
    x = mesh.xyz(grid)
    d1 = x[1:, 1:] - x[:-1, :-1]
    d2 = x[1:, :-1] - x[:-1, 1:]
    quad = 0.5 * np.linalg.norm(np.cross(d1, d2), axis=-1)  # (rows - 1, cols - 1)
    area = np.zeros(grid.shape)
    for di in (0, 1):
        for dj in (0, 1):
            area[di:di + quad.shape[0], dj:dj + quad.shape[1]] += 0.25 * quad
    if mesh.periodic:
        area[:, 0] += area[:, -1]
        area = area[:, :-1]
    return area


def tread_areas(mesh: TyreMesh) -> np.ndarray:
    """Tributary area (mm^2) of each outer tread node, tread-node (grid) order."""
    first, stop = mesh.tread_rows
    return grid_areas(mesh, mesh.outer_grid)[first:stop].ravel()


def window_rms(mesh: TyreMesh, field: np.ndarray, half_angle: float) -> float:
    """Area-weighted RMS of an inner-surface field over ``|phi| <= half_angle`` degrees.

    ``field`` is (n_inner, k) in inner-node (grid) order, e.g. a displacement or a strain;
    the RMS is of its Euclidean norm per node, so meshes of different density compare.
    """
    areas = grid_areas(mesh, mesh.inner_grid)
    inside = np.abs(np.degrees(mesh.angles)) <= half_angle + 1e-9
    w = areas[:, inside].ravel()
    values = np.asarray(field).reshape(*mesh.inner_grid.shape, -1)[:, inside]
    squared = np.sum(values.reshape(len(w), -1) ** 2, axis=1)
    return float(np.sqrt(np.sum(w * squared) / w.sum()))


def patch_metrics(mesh: TyreMesh, state: SolvedState,
                  areas: np.ndarray | None = None) -> PatchMetrics:
    """Metrics of the patch of ``state``, normal forces along its road's normal (the
    state's tilt; +z for a level road); ``areas`` may pass :func:`tread_areas` computed
    once."""
    areas = tread_areas(mesh) if areas is None else areas
    n = np.array(state.motion.normal if state.motion is not None else (0.0, 0.0, 1.0))
    force = state.tread_force
    loaded = np.linalg.norm(force, axis=1) > LOADED_N
    if not loaded.any():
        return PatchMetrics(0, 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    fn = force[loaded] @ n
    pos = state.positions(mesh, mesh.tread_nodes[loaded])
    columns = np.nonzero(loaded.reshape(-1, mesh.outer_grid.shape[1]).any(axis=0))[0]
    area = float(areas[loaded].sum())
    return PatchMetrics(
        nodes=int(loaded.sum()), columns=len(columns), area=area,
        length=float(np.ptp(pos[:, 0])), width=float(np.ptp(pos[:, 1])),
        peak_pressure=float((fn / areas[loaded]).max()), mean_pressure=float(fn.sum() / area),
        nodal_mean=float(fn.mean()), nodal_std=float(fn.std()),
    )


def inflation_growth(mesh: TyreMesh, reference: SolvedState) -> float:
    """Radial growth (mm) of the tread under inflation, what the thesis calls bulging
    (§3.3.2): the outward radial displacement of the outer tread nodes in the inflated,
    unloaded ``reference`` state, averaged round the tyre per meridional row, largest
    row (the crown centre, or the shoulders of a tread that bulges there)."""
    first, stop = mesh.tread_rows
    rows = mesh.outer_grid[first:stop]
    x = mesh.xyz(rows)
    u = reference.displacement[rows - 1]
    radial = np.stack([x[..., 0], np.zeros(x.shape[:-1]), x[..., 2]], axis=-1)
    radial /= np.linalg.norm(radial, axis=-1, keepdims=True)
    return float(np.sum(u * radial, axis=-1).mean(axis=1).max())
