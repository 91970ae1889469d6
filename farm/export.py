"""ParaView files (VTU, via meshio) of virtual experiments.

Two sources, two levels of detail:

* a solved load path (``farm run --vtu DIR``) knows every node's displacement: one VTU
  per deflection of the whole tyre (hexahedra), with U, the measured inner-surface
  strains and the road forces on the tread as point data;
* a store (``farm export``) keeps what the camera measures: the inner surface (quads)
  with U, strain and surface strain, and the outer tread (quads) with the road forces.
  Points are at reference coordinates; warp by ``U`` in ParaView to see the deformation.
"""

from __future__ import annotations

from pathlib import Path

import meshio
import numpy as np

from farm.experiment import PathResult
from farm.mesh.tyremesh import TyreMesh

STRAIN_NAMES = ("xx", "yy", "xy")


def _quads(grid: np.ndarray, periodic: bool) -> np.ndarray:
    """Quad cells (as indices into ``grid.ravel()``) of a structured surface grid."""
    rows, cols = grid.shape
    idx = np.arange(grid.size).reshape(rows, cols)
    right = np.roll(idx, -1, axis=1) if periodic else idx[:, 1:]
    left = idx if periodic else idx[:, :-1]
    return np.stack([left[:-1], right[:-1], right[1:], left[1:]], axis=-1).reshape(-1, 4)


def _per_node(mesh: TyreMesh, ids: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Scatter per-node values (len(ids), k) onto every mesh node (NaN elsewhere)."""
    out = np.full((mesh.n_nodes, values.shape[1]), np.nan)
    out[ids - 1] = values
    return out


def path_vtus(result: PathResult, mesh: TyreMesh, folder: str | Path) -> list[Path]:
    """One VTU of the whole deformed tyre per deflection of a solved path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    states = _states(result)
    for m, u in zip(result.measurements, states, strict=True):
        point_data = {"U": u, "reaction_force": _per_node(mesh, mesh.tread_nodes,
                                                          m.reaction_force)}
        for name in ("strain", "surface_strain"):
            local = _per_node(mesh, mesh.inner_nodes, getattr(m, name))
            point_data.update({f"{name}_{c}": local[:, k] for k, c in enumerate(STRAIN_NAMES)})
        path = folder / f"{result.model.kind}_{1000 * m.pressure:g}kPa_{m.deflection:g}mm.vtu"
        meshio.write(path, meshio.Mesh(mesh.nodes, [("hexahedron", mesh.elements - 1)],
                                       point_data=point_data,
                                       cell_data={"region": [mesh.element_region.astype(int)]}))
        written.append(path)
    return written


def _states(result: PathResult) -> list[np.ndarray]:
    """Full-field displacement of each state, from the reference state (NaN-free)."""
    ref = np.nan_to_num(result.reference.displacement)
    return [np.nan_to_num(s.displacement) - ref for s in result.states]


def surface_vtus(mesh: TyreMesh, arrays: dict[str, np.ndarray], stem: str | Path) -> list[Path]:
    """Inner-surface and tread VTUs of one stored experiment.

    ``arrays`` holds the store's per-experiment arrays: ``displacement``, ``strain``,
    ``surface_strain`` (inner nodes, grid order) and ``reaction_force`` (tread nodes).
    """
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    inner = {"U": arrays["displacement"]}
    for name in ("strain", "surface_strain"):
        inner.update({f"{name}_{c}": arrays[name][:, k] for k, c in enumerate(STRAIN_NAMES)})
    first, stop = mesh.tread_rows
    tread_grid = mesh.outer_grid[first:stop]
    out = []
    for suffix, grid, data in (("inner", mesh.inner_grid, inner),
                               ("tread", tread_grid, {"reaction_force": arrays["reaction_force"]})):
        path = stem.with_name(f"{stem.name}_{suffix}.vtu")
        meshio.write(path, meshio.Mesh(mesh.xyz(grid.ravel()),
                                       [("quad", _quads(grid, mesh.periodic))], point_data=data))
        out.append(path)
    return out
