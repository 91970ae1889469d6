"""Several elements through the wall: split each hexahedron of the one-element mesh.

The thesis' mesh has one C3D8I element through the wall (§3.2); issue 15 asks for two
or more as a model-complexity option (thesis §6.2: a finer model). The finished
one-element mesh of :mod:`farm.mesh.build` is split here, and the splitter's version
(:data:`farm.mesh.version.LAYERS_VERSION`) joins the mesh key only when
``mesh.through > 1``.

Each element's cavity face and outside face are opposite faces joined by four straight
edges through the wall (the revolved crossing lines of the section). Splitting those
edges into ``through`` equal parts and joining the points gives ``through`` hexahedra
that are exactly the parent's trilinear map restricted to a slab of its through-wall
parent coordinate (a trilinear map is linear along each parent axis): the volume is
the parent's, and the Jacobian determinant at each point is the parent's there divided by
``through``, so positive where the parent's is.

What the layered mesh keeps: node ids ``1..n`` of the one-element mesh (the inner and
outer surface nodes, hence ``INNER``, ``OUTER``, ``TREAD_OUTER`` and both surface grids
unchanged); the new interior nodes follow. Elements are stored layer by layer from the
cavity outwards, so elements ``1..E`` are the cavity layer. ``BEAD_SEAT`` and ``CUT_*``
get the interior nodes of their through-wall edges. ``inner_face``/``outer_face`` are 0
for an element with no face on that surface (the convention of
:func:`farm.mesh.tyremesh.face_with_nodes`): cavity pressure goes on the first layer's
faces only, the contact slave surface on the last layer's.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from farm.errors import MeshError
from farm.mesh.tyremesh import HEX_FACES, TyreMesh, hex_jacobians

_EDGES = {frozenset(e) for e in [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7),
                                 (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]}


def _partners() -> tuple[np.ndarray, np.ndarray]:
    """For each face ``f`` (0-based): its opposite face, and for each of its 4 local nodes
    the local node at the other end of the hex edge that leaves the face."""
    opposite = np.zeros(6, dtype=np.int64)
    partner = np.zeros((6, 4), dtype=np.int64)
    for f, face in enumerate(HEX_FACES):
        rest = set(range(8)) - set(face)
        opposite[f] = next(g for g, other in enumerate(HEX_FACES) if set(other) == rest)
        for k, a in enumerate(face):
            partner[f, k] = next(b for b in rest if frozenset((a, b)) in _EDGES)
    return opposite, partner


_OPPOSITE, _PARTNER = _partners()


def split_wall(mesh: TyreMesh, through: int) -> TyreMesh:
    """The mesh with ``through`` elements through the wall instead of one.

    Parameters
    ----------
    mesh : TyreMesh
        A one-element-thick mesh (every element has a cavity and an outside face), as
        :func:`farm.mesh.build.build_mesh` makes it, with ``n`` nodes and ``E`` elements.
    through : int
        Elements through the wall, >= 1; 1 returns ``mesh`` itself.

    Returns
    -------
    TyreMesh
        ``n + (through - 1) * n_inner`` nodes (``n_inner`` through-wall lines, one per
        inner surface node) and ``through * E`` elements; same key, grids and surfaces.

    Raises
    ------
    MeshError
        If ``mesh`` is not one element thick or a split element is inverted.
    """
    if not (isinstance(through, int) and through >= 1):
        raise MeshError(f"through must be a positive integer, got {through!r}")
    if through == 1:
        return mesh
    if np.any(mesh.inner_face == 0) or np.any(mesh.outer_face == 0):
        raise MeshError("only a one-element-thick mesh can be split through the wall "
                        "(an element has no cavity or no outside face)")
    f_in = mesh.inner_face.astype(np.int64) - 1
    if np.any(_OPPOSITE[f_in] != mesh.outer_face - 1):
        bad = int(np.flatnonzero(_OPPOSITE[f_in] != mesh.outer_face - 1)[0]) + 1
        raise MeshError(f"element {bad}: its cavity and outside faces are not opposite")

    rows = np.arange(mesh.n_elements)[:, None]
    local_in = HEX_FACES[f_in]  # (E, 4) local nodes on the cavity face
    local_out = _PARTNER[f_in]  # (E, 4) their partners on the outside face
    ends = np.stack([mesh.elements[rows, local_in], mesh.elements[rows, local_out]], axis=-1)
    pairs, line = np.unique(ends.reshape(-1, 2), axis=0, return_inverse=True)
    line = line.reshape(-1, 4)  # (E, 4) through-wall line of each cavity-face corner
    if len(np.unique(pairs[:, 0])) != len(pairs):
        raise MeshError("a cavity node starts more than one through-wall line")

    # levels[p, m]: node id at m/through along line p, cavity (m = 0) to outside
    n, p = mesh.n_nodes, len(pairs)
    levels = np.empty((p, through + 1), dtype=np.int64)
    levels[:, 0], levels[:, -1] = pairs[:, 0], pairs[:, 1]
    levels[:, 1:-1] = n + 1 + np.arange(through - 1)[None, :] * p + np.arange(p)[:, None]
    x_in, x_out = mesh.xyz(pairs[:, 0]), mesh.xyz(pairs[:, 1])
    new = [x_in + (x_out - x_in) * (m / through) for m in range(1, through)]
    nodes = np.vstack([mesh.nodes, *new])

    layers = []
    for k in range(through):
        conn = np.empty_like(mesh.elements)
        conn[rows, local_in] = levels[line, k]
        conn[rows, local_out] = levels[line, k + 1]
        layers.append(conn)
    elements = np.vstack(layers)
    none = np.zeros_like(mesh.inner_face)
    inner_face = np.concatenate([mesh.inner_face, *[none] * (through - 1)])
    outer_face = np.concatenate([*[none] * (through - 1), mesh.outer_face])

    sets = {}
    for name, ids in mesh.node_sets.items():
        # a through-wall line lies in a surface set (bead seat, cut face) iff both its
        # ends do; INNER and OUTER hold one end of every line, so they get nothing
        both = np.isin(pairs[:, 0], ids) & np.isin(pairs[:, 1], ids)
        sets[name] = np.unique(np.concatenate([ids, levels[both, 1:-1].ravel()]))

    layered = dataclasses.replace(
        mesh, nodes=nodes, elements=elements,
        element_region=np.tile(mesh.element_region, through), node_sets=sets,
        inner_face=inner_face, outer_face=outer_face,
    )
    check_layered(layered, through)
    return layered


def check_layered(mesh: TyreMesh, through: int) -> None:
    """Invariants of a wall of ``through`` layers; raises :class:`MeshError`."""
    jac = hex_jacobians(mesh.nodes, mesh.elements)
    if np.any(jac <= 0):
        bad = int(np.flatnonzero((jac <= 0).any(axis=1))[0]) + 1
        raise MeshError(f"element {bad} has a non-positive Jacobian at a corner")
    per_layer = mesh.n_elements // through
    for name, faces, layer in (("cavity", mesh.inner_face, 0),
                               ("outside", mesh.outer_face, through - 1)):
        has = (faces > 0).reshape(through, per_layer)
        if not has[layer].all() or has.sum() != per_layer:
            raise MeshError(f"the {name} faces are not exactly those of layer {layer + 1}")
    if len(np.unique(mesh.elements)) != mesh.n_nodes:
        raise MeshError("a node belongs to no element")
