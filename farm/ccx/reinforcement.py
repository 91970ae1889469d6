"""Deck lines of the cord reinforcement: axial springs on the hexahedra's edges.

Why cords as axial members and how plies become their stiffness:
:mod:`farm.reinforcement`. The members are ``SPRINGA`` elements (a linear spring along
the current line of its two nodes, so geometrically nonlinear under NLGEOM: a truss of
stiffness ``E*A/L`` with no area or material of its own; ccx 2.20 expands ``T3D2``
trusses into 3D elements, which inverted at the coincident nodes in a prototype). They
lie on the edges of the inner surface grid: in a radial tyre the carcass and the belts
on it are the innermost structural layers, under the inner liner (Clark 1981, ch. 1).
(A prototype split each layer between the inner and the outer surface: 20 mm apart in
the tread, the two halves gave the crown a sandwich's bending stiffness and the tyre 4-5
times the force of the cordless one.) A member stands for the cords across its
tributary width: the layer's membrane stiffness (N/mm) times half the distance to the
neighbouring parallel edges. The springs end on twins of the cavity nodes, tied to
them by equations, so that the strain measured on the cavity stays the rubber's.
"""

from __future__ import annotations

import numpy as np

from farm.mesh.tyremesh import TyreMesh
from farm.specs import ModelSpec

FIRST_ID_OFFSET = 10_000
"""Spring and twin node ids start this far after the hexahedra's: the rigid road slab
(:func:`farm.ccx.deck.road_slab`) numbers its nodes and elements from ``n + 1``."""


def _tread_rows(spec: ModelSpec) -> np.ndarray:
    """Whether each meridional element row (-y bead to +y bead) is tread (thesis §3.2)."""
    m = spec.mesh
    side = [False] * (m.bead + m.sidewall)
    return np.array(side + [True] * m.tread + side)


def _edges(grid: np.ndarray, periodic: bool) -> tuple[np.ndarray, np.ndarray]:
    """Meridional edges (R-1, C, 2) and circumferential edges (R, C or C-1, 2) of a grid."""
    merid = np.stack([grid[:-1], grid[1:]], axis=-1)
    if periodic:
        return merid, np.stack([grid, np.roll(grid, -1, axis=1)], axis=-1)
    return merid, np.stack([grid[:, :-1], grid[:, 1:]], axis=-1)


def _length(mesh: TyreMesh, edges: np.ndarray) -> np.ndarray:
    xyz = mesh.nodes[edges - 1]
    return np.linalg.norm(xyz[..., 1, :] - xyz[..., 0, :], axis=-1)


def _at_nodes(per_edge: np.ndarray, axis: int, periodic: bool) -> np.ndarray:
    """Half the sum of the two edges meeting at each node along ``axis`` (one at an end).

    ``per_edge`` has n - 1 entries along ``axis`` for n nodes, or n when ``periodic``
    (edge k joins nodes k and k + 1 mod n).
    """
    half = 0.5 * np.moveaxis(per_edge, axis, 0)
    if periodic:
        out = half + np.roll(half, 1, axis=0)
    else:
        zero = np.zeros_like(half[:1])
        out = np.concatenate([half, zero]) + np.concatenate([zero, half])
    return np.moveaxis(out, 0, axis)


def surface_trusses(spec: ModelSpec, mesh: TyreMesh,
                    grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Truss edges (T, 2) of one surface grid and the axial stiffness E*A (N) of each.

    A meridional edge stands for the cords across its circumferential tributary width;
    a circumferential edge for those across its meridional width, the belts counting
    only over tread element rows (so they end at the tread's edge).
    """
    reinf = spec.reinforcement
    carcass_c, carcass_m = reinf.carcass.membrane_stiffness()
    belt_c, belt_m = reinf.belt.membrane_stiffness()
    tread = _tread_rows(spec)
    merid, circ = _edges(grid, mesh.periodic)
    len_m, len_c = _length(mesh, merid), _length(mesh, circ)
    # meridional: stiffness per width of the element row x width at the edge's mid row
    width = _at_nodes(len_c, axis=1, periodic=mesh.periodic)  # (R, C)
    ea_m = (carcass_m + belt_m * tread)[:, None] * 0.5 * (width[:-1] + width[1:])
    # circumferential: each adjacent element row gives half its stiffness x length
    ea_c = _at_nodes((carcass_c + belt_c * tread)[:, None] * len_m, axis=0, periodic=False)
    ea_c = ea_c[:, : circ.shape[1]]
    return (np.concatenate([merid.reshape(-1, 2), circ.reshape(-1, 2)]),
            np.concatenate([ea_m.ravel(), ea_c.ravel()]))


def _twin_lines(mesh: TyreMesh, nodes: np.ndarray, first: int) -> list[str]:
    """Twin nodes ``first + k`` of ``nodes[k]`` tied to them by ``*EQUATION``s.

    ccx averages element strains extrapolated to a node over every element at the node,
    springs included (which count as zero): on the cavity nodes themselves the springs
    cut the measured strain E by 60 % on the coarse mesh. On twins they do not.
    """
    lines = ["*NODE, NSET=CORD_NODES"]
    lines += [f"{first + k}, " + ", ".join(f"{c:.12g}" for c in mesh.nodes[n - 1])
              for k, n in enumerate(nodes)]
    lines.append("*EQUATION")
    for k, n in enumerate(nodes):
        for dof in (1, 2, 3):
            lines += ["2", f"{first + k}, {dof}, 1., {n}, {dof}, -1."]
    return lines


def cord_lines(spec: ModelSpec, mesh: TyreMesh) -> list[str]:
    """``SPRINGA`` elements with their stiffness ``E*A/L``; none for a cordless model.

    The springs join twins of the cavity nodes (:func:`_twin_lines`). They are grouped
    by stiffness rounded to 4 significant digits (one ``*SPRING`` each: by axisymmetry
    about one per grid row and direction).
    """
    if spec.reinforcement is None:
        return []
    edges, ea = surface_trusses(spec, mesh, mesh.inner_grid)
    k = ea / _length(mesh, edges)
    keep = k > 0
    edges, k = edges[keep], np.array([float(f"{v:.4g}") for v in k[keep]])
    nodes, twin = np.unique(edges, return_inverse=True)
    twin = twin.reshape(edges.shape) + mesh.n_nodes + FIRST_ID_OFFSET
    lines = _twin_lines(mesh, nodes, mesh.n_nodes + FIRST_ID_OFFSET)
    first = mesh.n_elements + FIRST_ID_OFFSET
    for g, value in enumerate(np.unique(k)):
        ids = np.flatnonzero(k == value)
        lines.append(f"*ELEMENT, TYPE=SPRINGA, ELSET=CORD{g}")
        lines += [f"{first + e}, {twin[e, 0]}, {twin[e, 1]}" for e in ids]
        # ccx skips the blank line and reads a value with no decimal point as a
        # degree of freedom (SPRING1/2 syntax): always write the stiffness with one
        lines += [f"*SPRING, ELSET=CORD{g}", "", f"{value:.6e}"]
    return lines
