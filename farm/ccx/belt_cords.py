"""Belt members along the cords (``reinforcement.belt_layout = "cords"``, issue 24).

Why: members on the edges of the surface grid give the +-theta belt pair no in-plane
shear stiffness (:mod:`farm.netting`). Here each ply gets its own members across every
tread element row of the belt surface: from each node of one of the row's two node rows
to the point of the other where the line from that node meets it at the ply's angle
``theta`` to the circumferential direction. That point generally lies between two
nodes: it is a node of its own, tied by ``*EQUATION`` to the linear interpolation of
the two (a hexahedron's edge is straight and moves linearly between its nodes, so the
member's end moves with the rubber as an embedded cord would: the "rebar" idea,
Helnwein et al. 1993). Snapping the end to the node whose angle is nearest theta
instead puts the members 2-3 degrees off theta in the ``patch`` mesh's window and much
more outside it, and its A22 tens of % off (docs/reinforcement.md): whole column
offsets are too coarse for a 20 degree cord.

Stiffness: a member stands for a quarter of the pair's cords over a tributary area
``A`` (the spacing of the two node rows times the circumferential width at its start
node): ``E*A = (S / 4) A / L`` with ``S`` the pair's cord stiffness per width, i.e.
netting theory at the member's own angle, which equals theta up to the bisection
tolerance and the curvature of the surface. A quarter, because each ply is two
families (:data:`FAMILIES`), for the mesh's mirror symmetries. The network then has
the pair's A11, A22 and A66 (tests/farm/test_reinforcement_cords.py).

Depth: the belts lie on a surface of points at a fixed fraction of the wall from the
cavity face (:meth:`farm.reinforcement.Reinforcement.depth_on`; half the wall, 10 mm out
in the 20 mm tread, on a layered wall by default). A point on a node layer is that
node; between layers (``reinforcement.belt_depth`` on a one-element wall, issue 44) it
is a node of its own, tied by ``*EQUATION`` to the two nodes of its through-wall line
either side (the edge is straight and moves linearly, as along a row). The depth is the
same for every number of layers, so that refining through the wall refines the mesh,
not the model (issue 44: with the belts on the *first* interior layer, 4 layers put them
5 mm deep where 2 put them 10 mm, and Fz moved -7.0 % then +2.3 %). Cavity-face belts
(a one-element wall by default) join the twins of :mod:`farm.ccx.reinforcement`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from farm.errors import MeshError
from farm.mesh.tyremesh import TyreMesh
from farm.specs import ModelSpec

BISECTIONS = 60  # halves the column interval 60 times: far below 1e-9 of a column


@dataclass(frozen=True)
class BeltSurface:
    """Points (rows, columns) of the surface the belts lie on, each on a through-wall
    line: ``(1 - weight) * nodes[..., 0] + weight * nodes[..., 1]`` (``weight`` 0: on
    the node ``nodes[..., 0]``, which both columns then hold).

    ``xyz`` (R, C, 3) the points; ``nodes`` (R, C, 2) node ids; ``weight`` (R, C).
    """

    xyz: np.ndarray
    nodes: np.ndarray
    weight: np.ndarray

    @property
    def on_nodes(self) -> bool:
        return not self.weight.any()

    def terms(self, flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Node ids (n, 2) and their coefficients (n, 2) of the points ``flat``
        (indices into the raveled grid)."""
        nodes = self.nodes.reshape(-1, 2)[flat]
        w = self.weight.ravel()[flat]
        return nodes, np.stack([1.0 - w, w], axis=1)


@dataclass(frozen=True)
class BeltChords:
    """The members of both belt plies (:data:`FAMILIES`), one per row of each array.

    ``start``: the member's first end, a point of ``surface`` (index into its raveled
    grid); ``ends`` (n, 2) and ``weight`` (n,): its second end is ``(1 - weight) *
    ends[:, 0] + weight * ends[:, 1]``, two points of ``surface``; ``ea`` its axial
    stiffness E*A (N); ``length`` (mm); ``vectors`` (n, 2) its vector in the local
    (circumferential, meridional) frame; ``area`` (n,) its tributary area (mm^2) and
    ``strip`` (n,) the element row it crosses.
    """

    surface: BeltSurface
    start: np.ndarray
    ends: np.ndarray
    weight: np.ndarray
    ea: np.ndarray
    length: np.ndarray
    vectors: np.ndarray
    area: np.ndarray
    strip: np.ndarray

    def start_xyz(self) -> np.ndarray:
        """(n, 3) where each member starts."""
        return self.surface.xyz.reshape(-1, 3)[self.start]

    def end_xyz(self) -> np.ndarray:
        """(n, 3) where each member ends."""
        points, w = self.surface.xyz.reshape(-1, 3), self.weight[:, None]
        return (1 - w) * points[self.ends[:, 0]] + w * points[self.ends[:, 1]]

    def start_nodes(self) -> np.ndarray:
        """Node id of each member's start where the surface lies on nodes."""
        if not self.surface.on_nodes:
            raise MeshError("the belts lie between node layers: their starts are points")
        return self.surface.terms(self.start)[0][:, 0]


def belt_surface(spec: ModelSpec, mesh: TyreMesh) -> BeltSurface:
    """The belts' surface at :meth:`~farm.reinforcement.Reinforcement.depth_on` of the
    wall, on the through-wall lines of the cavity grid's nodes.

    Layer ``j`` of the line from cavity node ``a`` is ``a`` (``j = 0``), its outer
    node (``j = through``), else ``n1 + 1 + (j - 1) P + rank(a)`` (``n1`` nodes of the
    one-element mesh, ``P`` lines numbered in order of their cavity node:
    :func:`farm.mesh.layers.split_wall`). Checked against the geometry.
    """
    assert spec.reinforcement is not None, "belts lie in reinforced models only"
    through = spec.mesh.through
    depth = spec.reinforcement.depth_on(through)
    inner = mesh.inner_grid
    order = np.unique(inner)
    first = mesh.n_nodes - (through - 1) * len(order)

    def layer(j: int) -> np.ndarray:
        if j == 0:
            return inner
        if j == through:
            return mesh.outer_grid
        return first + 1 + (j - 1) * len(order) + np.searchsorted(order, inner)

    at = depth * through
    j = min(int(np.floor(at + 1e-9)), through - 1)
    weight = at - j
    if abs(weight) < 1e-9:  # on a node layer
        below = layer(j)
        nodes, weight = np.stack([below, below], axis=-1), 0.0
    else:
        nodes = np.stack([layer(j), layer(j + 1)], axis=-1)
    x_in, x_out = mesh.xyz(inner), mesh.xyz(mesh.outer_grid)
    expected = x_in + (x_out - x_in) * depth
    xyz = (1 - weight) * mesh.xyz(nodes[..., 0]) + weight * mesh.xyz(nodes[..., 1])
    if np.abs(xyz - expected).max() > 1e-6 * np.abs(x_in).max():
        raise MeshError("the node layers are not where the layered wall puts them "
                        "(farm.mesh.layers changed?): cannot place the belts")
    return BeltSurface(xyz=xyz, nodes=nodes, weight=np.full(inner.shape, weight))


def _tread_strips(spec: ModelSpec) -> np.ndarray:
    """Indices of the element rows (-y bead to +y bead) under the tread (thesis §3.2)."""
    m = spec.mesh
    first = m.bead + m.sidewall
    return np.arange(first, first + m.tread)


def _along_row(row: np.ndarray, u: np.ndarray, periodic: bool) -> tuple:
    """Points at continuous column ``u`` of a row of points (C, 3): the two columns
    each lies between and the weight of the second."""
    n = len(row)
    lo = np.floor(u).astype(np.int64)
    weight = u - lo
    if periodic:
        lo, hi = lo % n, (lo + 1) % n
    else:
        lo = np.clip(lo, 0, n - 2)
        weight = u - lo
        hi = lo + 1
    point = (1 - weight)[:, None] * row[lo] + weight[:, None] * row[hi]
    return point, lo, hi, weight


def _local(p0: np.ndarray, p1: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Vectors ``p1 - p0`` in the (circumferential, meridional) frame at their midpoint:
    circumferential component along (cos phi, 0, sin phi), the rest meridional, signed
    as its projection on ``up`` (the direction of increasing grid row)."""
    v = p1 - p0
    mid = 0.5 * (p0 + p1)
    phi = np.arctan2(mid[:, 0], -mid[:, 2])
    vc = v[:, 0] * np.cos(phi) + v[:, 2] * np.sin(phi)
    vm = np.sqrt(np.maximum(np.einsum("ij,ij->i", v, v) - vc * vc, 0.0))
    return np.stack([vc, np.copysign(vm, np.einsum("ij,ij->i", v, up))], axis=1)


def _widths(points: np.ndarray, periodic: bool) -> np.ndarray:
    """Circumferential tributary width at each node of a row (half of each side)."""
    if periodic:
        seg = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)
        return 0.5 * (seg + np.roll(seg, 1))
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    return 0.5 * (np.concatenate([seg, [0.0]]) + np.concatenate([[0.0], seg]))


def _family(p0: np.ndarray, row: np.ndarray, sign: int, angle: float,
            periodic: bool, up: np.ndarray) -> tuple:
    """Members from every point of a row ``p0`` (C, 3) to the next row ``row`` (C, 3),
    their ends ``sign`` (+1: increasing phi) round at ``angle`` to the circumferential
    (``up``: direction of increasing grid row at each point, for :func:`_local`).

    Bisection on the continuous column of the end: the member's angle to the
    circumferential direction falls from ~90 degrees (end straight across) as the end
    moves round. Returns start columns, end lo/hi columns, weights, ends, local vectors.
    """
    n = len(p0)
    cols = np.arange(n, dtype=float)
    if periodic:
        near, far = cols, cols + sign * n / 2
    else:  # a sector: members that would leave it are dropped below
        near, far = cols, np.full(n, (n - 1) * (sign > 0), dtype=float)
    target = np.tan(np.radians(angle))
    for _ in range(BISECTIONS):
        mid = 0.5 * (near + far)
        v = _local(p0, _along_row(row, mid, periodic)[0], up)
        steep = np.abs(v[:, 1]) > target * np.abs(v[:, 0])  # still steeper than theta
        near, far = np.where(steep, mid, near), np.where(steep, far, mid)
    end, lo, hi, weight = _along_row(row, 0.5 * (near + far), periodic)
    vectors = _local(p0, end, up)
    slope = np.degrees(np.arctan2(np.abs(vectors[:, 1]), np.abs(vectors[:, 0])))
    ok = np.abs(slope - angle) < 1e-3
    return np.flatnonzero(ok), lo[ok], hi[ok], weight[ok], end[ok], vectors[ok]


FAMILIES = ((0, 1), (1, -1), (0, -1), (1, 1))
"""(start row of the element row: 0 lower, 1 upper; end direction round). A member
starts at a node and ends between two: so that the network has the mesh's mirror
symmetries (y -> -y, phi -> -phi; else the lateral moment of a vertical push is not zero:
0.3 % of Fz x section width on the coarse mesh), each ply is two families with half the
stiffness each: +theta from the lower row towards +phi and from the upper row towards
-phi, -theta their mirror images."""


def belt_chords(spec: ModelSpec, mesh: TyreMesh) -> BeltChords:
    """Both plies' members over the tread rows of :func:`belt_surface`."""
    assert spec.reinforcement is not None, "cord_lines lays belts in reinforced models only"
    belt = spec.reinforcement.belt
    stiffness = belt.modulus * 1e3 * belt.area_per_width  # N/mm, GPa -> MPa
    surface = belt_surface(spec, mesh)
    xyz = surface.xyz
    flat = np.arange(xyz.shape[0] * xyz.shape[1]).reshape(xyz.shape[:2])
    parts = []
    for i in _tread_strips(spec):
        spacing = np.linalg.norm(xyz[i + 1] - xyz[i], axis=1)
        width = 0.5 * (_widths(xyz[i], mesh.periodic) + _widths(xyz[i + 1], mesh.periodic))
        for up, sign in FAMILIES:
            a, b = (i + 1, i) if up else (i, i + 1)
            cols, lo, hi, weight, end, vectors = _family(
                xyz[a], xyz[b], sign, belt.angle, mesh.periodic, xyz[i + 1] - xyz[i])
            area = spacing[cols] * width[cols]
            length = np.linalg.norm(end - xyz[a, cols], axis=1)
            # a quarter of the pair's cords per family: half a ply, half the area's cords
            parts.append((flat[a, cols], np.stack([flat[b, lo], flat[b, hi]], axis=1),
                          weight, 0.25 * stiffness * area / length, length, vectors,
                          area, np.full(len(cols), i)))
    return BeltChords(surface, *(np.concatenate(column) for column in zip(*parts, strict=True)))
