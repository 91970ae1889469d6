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

Issue 24's options (:class:`farm.reinforcement.Reinforcement`, docs/reinforcement.md):
``belt_layout = "cords"`` replaces the belts' edge members by members along each ply's
cords (:mod:`farm.ccx.belt_cords`), and ``tension_only`` writes every member as a
``*SPRING, NONLINEAR`` that is (almost) slack in compression (:func:`spring_lines`).
"""

from __future__ import annotations

import numpy as np

from farm.ccx.belt_cords import BeltChords, belt_chords
from farm.mesh.tyremesh import TyreMesh
from farm.specs import ModelSpec

FIRST_ID_OFFSET = 10_000
"""Spring and twin node ids start this far after the hexahedra's: the rigid road slab
(:func:`farm.ccx.deck.road_slab`) numbers its nodes and elements from ``n + 1``."""

COMPRESSION_RATIO = 1e-3
"""Compression stiffness of a tension-only cord over its tension stiffness. ccx's manual
(``*SPRING``) warns that a zero tangent may make the stiffness matrix singular. Here
every member end is tied to the rubber by equations, and zero did converge on the coarse
mesh (21 increments against 18 with 1e-3 at 30 mm / 80 kPa, Fz 0.35 % lower); 1e-3 keeps
that warning moot at no measurable cost: a slack steel member keeps a few N/mm, well
below the rubber around it (docs/reinforcement.md)."""


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


def surface_trusses(spec: ModelSpec, mesh: TyreMesh, grid: np.ndarray,
                    belt: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Truss edges (T, 2) of one surface grid and the axial stiffness E*A (N) of each.

    A meridional edge stands for the cords across its circumferential tributary width;
    a circumferential edge for those across its meridional width, the belts counting
    only over tread element rows (so they end at the tread's edge), and not at all
    with ``belt=False`` (the carcass alone, under belts of their own layout).
    """
    reinf = spec.reinforcement
    assert reinf is not None, "cord_lines builds trusses for reinforced models only"
    carcass_c, carcass_m = reinf.carcass.membrane_stiffness()
    belt_c, belt_m = reinf.belt.membrane_stiffness() if belt else (0.0, 0.0)
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


def spring_lines(first: int, pairs: np.ndarray, k: np.ndarray, length: np.ndarray,
                 tension_only: bool) -> list[str]:
    """``SPRINGA`` elements ``first, first + 1, ...`` joining ``pairs`` (n, 2) of node ids,
    of stiffness ``k`` (N/mm; rounded to 4 significant digits and grouped by value, one
    ``*SPRING`` each: by axisymmetry about one per grid row and direction).

    ``tension_only``: ``*SPRING, NONLINEAR`` through (force, elongation) points
    ``(-r k e_c, -e_c)``, ``(0, 0)``, ``(k e_t, e_t)`` with ``r`` =
    :data:`COMPRESSION_RATIO`, ``e_c`` half the group's shortest member (ccx refuses an
    elongation below minus the length) and ``e_t`` its longest (100 % strain: ccx holds
    the force constant beyond the last point, a zero tangent no cord should reach).
    """
    k = np.array([float(f"{v:.4g}") for v in k])
    lines = []
    for g, value in enumerate(np.unique(k)):
        ids = np.flatnonzero(k == value)
        lines.append(f"*ELEMENT, TYPE=SPRINGA, ELSET=CORD{g}")
        lines += [f"{first + e}, {pairs[e, 0]}, {pairs[e, 1]}" for e in ids]
        # ccx skips the blank line and reads a value with no decimal point as a
        # degree of freedom (SPRING1/2 syntax): always write the stiffness with one
        if not tension_only:
            lines += [f"*SPRING, ELSET=CORD{g}", "", f"{value:.6e}"]
            continue
        shortest, longest = 0.5 * length[ids].min(), length[ids].max()
        lines += [f"*SPRING, ELSET=CORD{g}, NONLINEAR", "",
                  f"{-COMPRESSION_RATIO * value * shortest:.6e}, {-shortest:.6e}",
                  "0.000000e+00, 0.000000e+00", f"{value * longest:.6e}, {longest:.6e}"]
    return lines


def cord_lines(spec: ModelSpec, mesh: TyreMesh) -> list[str]:
    """``SPRINGA`` elements with their stiffness ``E*A/L``; none for a cordless model.

    Members on the cavity face join twins of its nodes (:func:`_twin_lines`); belts of
    the ``cords`` layout are :mod:`farm.ccx.belt_cords`' members, whose far ends are
    nodes of their own tied to the row they end on.
    """
    if spec.reinforcement is None:
        return []
    reinf = spec.reinforcement
    edges, ea = surface_trusses(spec, mesh, mesh.inner_grid, belt=reinf.belt_layout == "edges")
    length = _length(mesh, edges)
    keep = ea > 0
    edges, k, length = edges[keep], ea[keep] / length[keep], length[keep]
    chords = belt_chords(spec, mesh) if reinf.belt_layout == "cords" else None
    twinned = edges.ravel()
    if chords is not None and chords.surface.on_nodes:  # cavity nodes only
        starts = chords.start_nodes()
        twinned = np.concatenate([twinned, starts[np.isin(starts, mesh.inner_grid)]])
    nodes = np.unique(twinned)
    first_twin = mesh.n_nodes + FIRST_ID_OFFSET
    twin = dict(zip(nodes.tolist(), range(first_twin, first_twin + len(nodes)), strict=True))
    lines = _twin_lines(mesh, nodes, first_twin)
    pairs = np.vectorize(twin.__getitem__, otypes=[np.int64])(edges)
    if chords is not None:
        chord_pairs, end_lines = _chord_ends(mesh, chords, twin, first_twin + len(nodes))
        lines += end_lines
        pairs = np.concatenate([pairs, chord_pairs])
        k = np.concatenate([k, chords.ea / chords.length])
        length = np.concatenate([length, chords.length])
    return lines + spring_lines(mesh.n_elements + FIRST_ID_OFFSET, pairs, k, length,
                                reinf.tension_only)


def _chord_ends(mesh: TyreMesh, chords: BeltChords, twin: dict[int, int],
                first: int) -> tuple[np.ndarray, list[str]]:
    """Node pairs (n, 2) of the belt members and the lines of their ends.

    A member starts at its node (its twin where it has one: the cavity face), or, with
    the belts between node layers, at a node of its own per surface point (``BELT_POINTS``,
    tied to the two nodes of its through-wall line). Its far end is a node ``BELT_ENDS``
    on the next row, tied by an ``*EQUATION`` per dof to the nodes the two row points
    hang on (a term whose weight vanishes is left out: ccx needs nonzero coefficients).
    """
    surface, lines = chords.surface, []
    if surface.on_nodes:
        starts = np.array([twin.get(int(s), int(s)) for s in chords.start_nodes()],
                          dtype=np.int64)
    else:
        points = np.unique(chords.start)
        nodes, coef = surface.terms(points)
        ids = first + np.arange(len(points))
        lines += _tied_nodes("BELT_POINTS", ids, surface.xyz.reshape(-1, 3)[points],
                             nodes, coef)
        starts = ids[np.searchsorted(points, chords.start)]
        first += len(points)
    ids = first + np.arange(len(chords.start))
    w = chords.weight[:, None]
    (na, ca), (nb, cb) = surface.terms(chords.ends[:, 0]), surface.terms(chords.ends[:, 1])
    nodes, coef = np.concatenate([na, nb], axis=1), np.concatenate([(1 - w) * ca, w * cb],
                                                                   axis=1)
    xyz = np.einsum("nk,nkj->nj", coef, mesh.xyz(nodes))
    lines += _tied_nodes("BELT_ENDS", ids, xyz, nodes, coef)
    return np.stack([starts, ids], axis=1), lines


def _tied_nodes(name: str, ids: np.ndarray, xyz: np.ndarray, nodes: np.ndarray,
                coef: np.ndarray) -> list[str]:
    """Nodes ``ids`` at ``xyz`` in set ``name``, each dof an ``*EQUATION`` making it
    ``sum(coef * nodes)`` (repeated nodes merged in order, terms under 1e-9 left out)."""
    lines = [f"*NODE, NSET={name}"]
    lines += [f"{n}, " + ", ".join(f"{c:.12g}" for c in p) for n, p in zip(ids, xyz, strict=True)]
    lines.append("*EQUATION")
    for n, row, weights in zip(ids, nodes, coef, strict=True):
        merged: dict[int, float] = {}
        for node, c in zip(row.tolist(), weights.tolist(), strict=True):
            merged[node] = merged.get(node, 0.0) + c
        terms = [(node, c) for node, c in merged.items() if c > 1e-9]
        for dof in (1, 2, 3):
            lines += [str(1 + len(terms)), f"{n}, {dof}, 1., " + ", ".join(
                f"{node}, {dof}, {-c:.12g}" for node, c in terms)]
    return lines
