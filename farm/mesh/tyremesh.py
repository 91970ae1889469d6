"""The tyre mesh as plain numpy arrays: what the deck writer and the measurements need.

Node ``k`` has id ``k + 1`` (CalculiX ids are 1-based); element ``e`` has id ``e + 1``.
Element connectivity follows CalculiX's C3D8 order with a positive Jacobian.
The inner and outer surfaces are also kept as structured grids (meridional row ``i``
from the -y bead to the +y bead, circumferential column ``j`` in increasing angle
``phi`` towards +x), which is what surface strains and unrolled heat-maps need.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from farm.atomic import replacing

REGIONS = ("tread", "sidewall", "bead")
"""Material regions; ``element_region`` holds indices into this tuple."""

HEX_FACES = np.array(
    [[0, 1, 2, 3], [4, 7, 6, 5], [0, 4, 5, 1], [1, 5, 6, 2], [2, 6, 7, 3], [3, 7, 4, 0]]
)
"""Local nodes of CalculiX C3D8 faces S1..S6 (row ``k`` is face ``k + 1``), in
CalculiX's order (their right-hand normal points into the element)."""


@dataclass(frozen=True, eq=False)
class TyreMesh:
    """A meshed tyre model.

    Attributes
    ----------
    mesh_key : str
        Content hash of the spec parts the mesh depends on.
    kind : str
        ``"reduced"`` or ``"full"``.
    sector_angle : float
        Revolved angle in degrees (360 for the full tyre).
    nodes : ndarray, shape (n_nodes, 3)
        Reference coordinates, mm, wheel centre at the origin, TYDEX C axes.
    elements : ndarray, shape (n_elements, 8)
        Node ids of each C3D8(I) element.
    element_region : ndarray, shape (n_elements,)
        Index into :data:`REGIONS`.
    node_sets : mapping of str to ndarray
        Sorted node ids per named set (from gmsh physical groups): ``INNER``, ``OUTER``,
        ``TREAD_OUTER``, ``BEAD_SEAT`` (the clamped bead faces) and, for a sector,
        ``CUT_START``/``CUT_END``.
    inner_face, outer_face : ndarray, shape (n_elements,)
        CalculiX face number (1..6) of each element on the cavity / outside surface.
    inner_grid, outer_grid : ndarray, shape (n_rows, n_columns)
        Node ids of the inner / outer surface on the structured grid.
    angles : ndarray, shape (n_columns,)
        Circumferential angle ``phi`` (rad) of each grid column; phi = 0 under the
        wheel centre, positive towards +x.
    tread_rows : tuple of int
        ``(first, stop)`` rows of the outer grid that belong to the tread.
    """

    mesh_key: str
    kind: str
    sector_angle: float
    nodes: np.ndarray
    elements: np.ndarray
    element_region: np.ndarray
    node_sets: Mapping[str, np.ndarray]
    inner_face: np.ndarray
    outer_face: np.ndarray
    inner_grid: np.ndarray
    outer_grid: np.ndarray
    angles: np.ndarray
    tread_rows: tuple[int, int]

    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @property
    def n_elements(self) -> int:
        return len(self.elements)

    @property
    def periodic(self) -> bool:
        """True for the full tyre, whose grid columns wrap around."""
        return self.sector_angle >= 360.0

    @property
    def inner_nodes(self) -> np.ndarray:
        """Inner-surface node ids, grid order (row-major), shape (n_inner,)."""
        return self.inner_grid.ravel()

    @property
    def tread_nodes(self) -> np.ndarray:
        """Outer tread node ids, grid order (row-major), shape (n_tread,)."""
        first, stop = self.tread_rows
        return self.outer_grid[first:stop].ravel()

    def xyz(self, ids: np.ndarray) -> np.ndarray:
        """Reference coordinates of node ``ids``, shape (len(ids), 3)."""
        return self.nodes[np.asarray(ids) - 1]

    def region_elements(self, region: str) -> np.ndarray:
        """Element ids of one material region."""
        return np.flatnonzero(self.element_region == REGIONS.index(region)) + 1

    @property
    def bottom_z(self) -> float:
        """Lowest z of the outer tread, i.e. where the road first touches (unloaded)."""
        return float(self.xyz(self.tread_nodes)[:, 2].min())

    def save(self, path: str | Path) -> None:
        arrays = {
            "nodes": self.nodes,
            "elements": self.elements,
            "element_region": self.element_region,
            "inner_face": self.inner_face,
            "outer_face": self.outer_face,
            "inner_grid": self.inner_grid,
            "outer_grid": self.outer_grid,
            "angles": self.angles,
            "meta": np.array([self.mesh_key, self.kind, repr(self.sector_angle),
                              repr(self.tread_rows)]),
        }
        arrays.update({f"set_{k}": v for k, v in self.node_sets.items()})
        # atomic: concurrent workers never read a half-written file
        with replacing(path, suffix=".npz") as tmp:
            # allow_pickle is numpy's default, named so that the type checker knows that
            # no array of **arrays takes its place
            np.savez_compressed(tmp, allow_pickle=True, **arrays)

    @classmethod
    def load(cls, path: str | Path) -> TyreMesh:
        with np.load(path) as z:
            key, kind, angle, rows = (str(v) for v in z["meta"])
            sets = {k[4:]: z[k] for k in z.files if k.startswith("set_")}
            first, stop = (int(v) for v in rows.strip("()").split(","))
            return cls(
                mesh_key=key, kind=kind, sector_angle=float(angle),
                nodes=z["nodes"], elements=z["elements"], element_region=z["element_region"],
                node_sets=sets, inner_face=z["inner_face"], outer_face=z["outer_face"],
                inner_grid=z["inner_grid"], outer_grid=z["outer_grid"], angles=z["angles"],
                tread_rows=(first, stop),
            )


def hex_jacobians(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Jacobian determinants at the 8 corners of each hexahedron, shape (n_elements, 8).

    At corner ``a`` the Jacobian is spanned by the edges to its three neighbours, taken
    in the order that is right-handed for a correctly numbered C3D8 element.
    """
    x = nodes[elements - 1]  # (E, 8, 3)
    neighbours = np.array(
        [[1, 3, 4], [2, 0, 5], [3, 1, 6], [0, 2, 7], [7, 5, 0], [4, 6, 1], [5, 7, 2], [6, 4, 3]]
    )
    dets = np.empty(x.shape[:2])
    for a, (i, j, k) in enumerate(neighbours):
        e1, e2, e3 = x[:, i] - x[:, a], x[:, j] - x[:, a], x[:, k] - x[:, a]
        dets[:, a] = np.einsum("ij,ij->i", e1, np.cross(e2, e3))
    return dets


def face_with_nodes(elements: np.ndarray, node_set: np.ndarray) -> np.ndarray:
    """For each element, the CalculiX face number whose 4 nodes are all in ``node_set``.

    Returns 0 where no face qualifies; raises ``ValueError`` where several do.
    """
    inside = np.isin(elements, node_set)  # (E, 8)
    full: np.ndarray = np.all(inside[:, HEX_FACES], axis=2)  # (E, 6); never a scalar
    if np.any(full.sum(axis=1) > 1):
        raise ValueError("an element has more than one face on the same surface")
    return np.where(full.any(axis=1), full.argmax(axis=1) + 1, 0).astype(np.int8)
