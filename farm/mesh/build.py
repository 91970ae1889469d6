"""Build the structured hexahedral tyre mesh with gmsh (thesis §3.2).

The meridional section (:mod:`farm.geometry`) becomes five transfinite quadrilateral
patches, bead-sidewall-tread-sidewall-bead, with ONE element through the wall; the
patches are revolved about the spin axis (y) into hexahedra: two half-sectors for the
reduced model (so a node row lies under the wheel centre), four quarters for the full
tyre. Named physical groups become the CalculiX sets; the arrays are then checked
(positive Jacobians, one cavity face per element) before a :class:`TyreMesh` leaves.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from farm.errors import MeshError
from farm.geometry import REGIONS as SECTION_REGIONS
from farm.geometry import Section, build_section
from farm.mesh.layers import split_wall
from farm.mesh.session import gmsh_session
from farm.mesh.signals import signal_dispositions_kept
from farm.mesh.tyremesh import REGIONS, TyreMesh, face_with_nodes, hex_jacobians
from farm.mesh.version import mesh_key
from farm.spacing import column_angles, half_steps
from farm.specs import ModelSpec

SAMPLES_PER_ELEMENT = 4


def build_mesh(spec: ModelSpec) -> TyreMesh:
    """Mesh ``spec`` with gmsh and return the checked arrays: one element through the
    wall, then split into ``spec.mesh.through`` (:mod:`farm.mesh.layers`). gmsh runs
    with the process's signal dispositions kept (:mod:`farm.mesh.signals`)."""
    with signal_dispositions_kept():
        mesh = _one_element_mesh(spec)
    return split_wall(mesh, spec.mesh.through)


def _one_element_mesh(spec: ModelSpec) -> TyreMesh:
    section = build_section(spec.geometry, spec.mesh, SAMPLES_PER_ELEMENT)
    with gmsh_session(f"tyre-{spec.kind}") as gmsh:
        patches = _section_patches(gmsh.model.geo, section, spec)
        pieces = _revolve(gmsh.model.geo, patches, spec)
        gmsh.model.geo.synchronize()
        groups = _physical_groups(gmsh.model, patches, pieces, spec)
        gmsh.model.mesh.generate(3)
        if spec.is_full:
            gmsh.model.mesh.removeDuplicateNodes()  # close the seam at the top
        raw = _extract(gmsh.model, groups)
    return _assemble(raw, section, spec)


def _section_patches(geo, section: Section, spec: ModelSpec) -> list[dict]:
    """One transfinite quad patch per region in the plane phi = 0 (x = 0, z = -r).

    Each element edge along the contours is its own spline through the section samples,
    so nodes sit exactly on the samples and every element is aligned with the wall
    normal (a single spline per region would spread the inner nodes by inner arc length).
    """
    outer = [geo.addPoint(0.0, y, -r) for y, r in section.outer]
    inner = [geo.addPoint(0.0, y, -r) for y, r in section.inner]
    k = SAMPLES_PER_ELEMENT
    cross: dict[int, int] = {}

    def crossing(i: int) -> int:  # the straight line through the wall at sample i
        if i not in cross:
            cross[i] = geo.addLine(outer[i], inner[i])
            geo.mesh.setTransfiniteCurve(cross[i], 2)
        return cross[i]

    def edges(points: list[int], sl: slice) -> list[int]:
        tags = [geo.addSpline(points[i:i + k + 1]) for i in range(sl.start, sl.stop - 1, k)]
        for t in tags:
            geo.mesh.setTransfiniteCurve(t, 2)
        return tags

    patches = []
    for region, sl in zip(SECTION_REGIONS, section.region_slices, strict=True):
        c_out, c_in = edges(outer, sl), edges(inner, sl)
        first, last = sl.start, sl.stop - 1
        loop = geo.addCurveLoop(
            [*c_out, crossing(last), *(-c for c in reversed(c_in)), -crossing(first)]
        )
        surface = geo.addPlaneSurface([loop])
        geo.mesh.setTransfiniteSurface(
            surface, cornerTags=[outer[first], outer[last], inner[last], inner[first]]
        )
        geo.mesh.setRecombine(2, surface)
        patches.append({"region": region, "surface": surface, "n": len(c_out)})
    return patches


def _split(out: list, patches: list[dict]) -> list[dict]:
    """Split one revolve output into its parts per source patch.

    gmsh returns, per source surface, the top surface, the volume, then one lateral
    surface per boundary curve in curve-loop order: outer edges, end crossing, inner
    edges (reversed), start crossing.
    """
    parts, at = [], 0
    for p in patches:
        n = p["n"]
        chunk = out[at: at + 2 * n + 4]
        parts.append({"top": chunk[0], "volume": chunk[1][1],
                      "outer": [t for _, t in chunk[2: 2 + n]], "end": chunk[2 + n][1],
                      "inner": [t for _, t in chunk[3 + n: 3 + 2 * n]], "start": chunk[-1][1]})
        at += 2 * n + 4
    if at != len(out):
        raise MeshError(f"unexpected gmsh revolve output of {len(out)} entities (expected {at})")
    return parts


def _revolve(geo, patches: list[dict], spec: ModelSpec) -> list[list[dict]]:
    """Revolve the section about +y; return the split output of every revolve call.

    A positive gmsh angle turns the bottom point towards -x; sectors are revolved both
    ways from phi = 0 so the section itself stays a node row under the wheel centre.
    """
    pieces = []
    for sign in (1, -1):
        sources = [(2, p["surface"]) for p in patches]
        for angle, layers, heights in _chunks(spec):
            out = geo.revolve(sources, 0, 0, 0, 0, 1, 0, sign * angle, layers, heights,
                              recombine=True)
            parts = _split(out, patches)
            pieces.append(parts)
            sources = [part["top"] for part in parts]
    return pieces


def _chunks(spec: ModelSpec) -> list[tuple[float, list[int], list[float]]]:
    """The revolve calls of one side: (angle in radians, gmsh layers, gmsh heights).

    A gmsh revolve must turn less than pi, so the full tyre's half is two chunks. A
    uniform mesh: equal chunks of equal layers (the full tyre in quarters). A windowed
    mesh (:mod:`farm.spacing`): the window's equal elements, then the graded rest as one
    layer per element at its cumulative height.
    """
    n_circ = spec.mesh.circumferential
    if not spec.mesh.windowed:
        chunks, layers = (2, n_circ // 4) if spec.is_full else (1, n_circ // 2)
        return [(math.radians(spec.sector_angle) / (2 * chunks), [layers], [])] * chunks
    m = spec.mesh
    steps = half_steps(spec.sector_angle / 2, n_circ // 2, m.window, m.window_elements)
    rest = steps[m.window_elements:]
    heights = (np.cumsum(rest) / rest.sum()).tolist()
    heights[-1] = 1.0
    return [(math.radians(m.window), [m.window_elements], []),
            (math.radians(float(rest.sum())), [1] * len(rest), heights)]


def _physical_groups(model, patches, pieces, spec: ModelSpec) -> dict[str, tuple[int, int]]:
    """Named groups: element sets per region, node sets per surface."""
    vols: dict[str, list[int]] = {r: [] for r in REGIONS}  # gmsh entity tags
    surf: dict[str, list[int]] = {"INNER": [], "OUTER": [], "TREAD_OUTER": [], "BEAD_SEAT": []}
    last = len(patches) - 1
    for parts in pieces:
        for k, (patch, part) in enumerate(zip(patches, parts, strict=True)):
            vols[patch["region"]].append(part["volume"])
            surf["INNER"] += part["inner"]
            surf["OUTER"] += part["outer"]
            if patch["region"] == "tread":
                surf["TREAD_OUTER"] += part["outer"]
            if k == 0:
                surf["BEAD_SEAT"].append(part["start"])
            if k == last:
                surf["BEAD_SEAT"].append(part["end"])
    if not spec.is_full:  # the last chunk on each side ends at a cut face
        half = len(pieces) // 2
        surf["CUT_START"] = [part["top"][1] for part in pieces[half - 1]]
        surf["CUT_END"] = [part["top"][1] for part in pieces[-1]]
    groups = {}
    for region, tags in vols.items():
        groups[region.upper()] = (3, model.addPhysicalGroup(3, tags, name=region.upper()))
    for name, tags in surf.items():
        groups[name] = (2, model.addPhysicalGroup(2, sorted(set(tags)), name=name))
    return groups


def _extract(model, groups: dict[str, tuple[int, int]]) -> dict:
    """Nodes, hexahedra and the members of each physical group, in gmsh's numbering."""
    tags, coords, _ = model.mesh.getNodes()
    raw: dict[str, Any] = {"node_tags": np.asarray(tags, dtype=np.int64),
           "coords": np.asarray(coords).reshape(-1, 3), "elements": {}, "sets": {}}
    for name, (dim, tag) in groups.items():
        if dim == 3:
            conn = []
            for entity in model.getEntitiesForPhysicalGroup(dim, tag):
                types, _, node_tags = model.mesh.getElements(dim, entity)
                if list(types) != [5]:  # 5 = 8-node hexahedron
                    raise MeshError(
                        f"gmsh made element types {list(types)} in {name}, not hexahedra")
                conn.append(np.asarray(node_tags[0], dtype=np.int64).reshape(-1, 8))
            raw["elements"][name.lower()] = np.vstack(conn)
        else:
            nodes, _ = model.mesh.getNodesForPhysicalGroup(dim, tag)
            raw["sets"][name] = np.asarray(nodes, dtype=np.int64)
    return raw


def _assemble(raw: dict, section: Section, spec: ModelSpec) -> TyreMesh:
    """Renumber to 1-based ids, orient elements, find faces and grids, check invariants."""
    # Spline control points inside the section are geometry points that gmsh also
    # meshes; keep only the nodes some hexahedron uses.
    conn = np.vstack([raw["elements"][r] for r in REGIONS])
    used = np.unique(conn)
    order = np.argsort(raw["node_tags"])
    nodes = raw["coords"][order][np.searchsorted(raw["node_tags"][order], used)]
    lookup = np.zeros(raw["node_tags"].max() + 1, dtype=np.int64)
    lookup[used] = np.arange(1, len(used) + 1)

    elements = lookup[conn]
    region = np.concatenate(
        [np.full(len(raw["elements"][r]), i, dtype=np.int8) for i, r in enumerate(REGIONS)]
    )
    if np.any(elements == 0):
        raise MeshError("an element refers to a node gmsh did not return")
    jac = hex_jacobians(nodes, elements)
    flip = jac.mean(axis=1) < 0
    elements[flip] = elements[flip][:, [4, 5, 6, 7, 0, 1, 2, 3]]
    sets = {k: np.unique(lookup[v[np.isin(v, used)]]) for k, v in raw["sets"].items()}

    inner_face = face_with_nodes(elements, sets["INNER"])
    outer_face = face_with_nodes(elements, sets["OUTER"])
    angles, inner_grid = _surface_grid(nodes, sets["INNER"], section.inner, spec)
    _, outer_grid = _surface_grid(nodes, sets["OUTER"], section.outer, spec)
    first = spec.mesh.bead + spec.mesh.sidewall
    mesh = TyreMesh(
        mesh_key=mesh_key(spec), kind=spec.kind, sector_angle=float(spec.sector_angle),
        nodes=nodes, elements=elements, element_region=region, node_sets=sets,
        inner_face=inner_face, outer_face=outer_face, inner_grid=inner_grid,
        outer_grid=outer_grid, angles=angles, tread_rows=(first, first + spec.mesh.tread + 1),
    )
    check_mesh(mesh)
    return mesh


def _surface_grid(nodes, ids, contour, spec: ModelSpec) -> tuple[np.ndarray, np.ndarray]:
    """Place surface nodes on the (meridional row, circumferential column) grid."""
    rows = contour[::SAMPLES_PER_ELEMENT]  # (y, r) of each meridional node row
    xyz = nodes[ids - 1]
    yr = np.column_stack([xyz[:, 1], np.hypot(xyz[:, 0], xyz[:, 2])])
    dist = np.linalg.norm(yr[:, None, :] - rows[None, :, :], axis=2)
    i = dist.argmin(axis=1)
    if np.any(dist[np.arange(len(i)), i] > 1e-6 * spec.geometry.outer_radius):
        raise MeshError("a surface node does not lie on the section's node rows")

    m = spec.mesh
    angles = column_angles(spec.sector_angle, m.circumferential, spec.is_full, m.window,
                           m.window_elements)
    phi = np.arctan2(xyz[:, 0], -xyz[:, 2])
    if spec.is_full:  # the seam's nodes at +pi are column 0's, at -pi
        phi = np.where(phi > angles[-1] + 0.5 * (np.pi - angles[-1]), phi - 2 * np.pi, phi)
    j = np.abs(phi[:, None] - angles[None, :]).argmin(axis=1)
    if np.any(np.abs(phi - angles[j]) > 1e-6):
        raise MeshError("a surface node does not lie on the mesh's node columns")
    grid = np.zeros((len(rows), len(angles)), dtype=np.int64)
    grid[i, j] = ids
    if np.any(grid == 0) or len(ids) != grid.size:
        raise MeshError(f"surface nodes do not fill a {grid.shape} structured grid")
    return angles, grid


def check_mesh(mesh: TyreMesh) -> None:
    """Invariants every solver run relies on; raises :class:`MeshError`."""
    jac = hex_jacobians(mesh.nodes, mesh.elements)
    if np.any(jac <= 0):
        bad = int(np.flatnonzero((jac <= 0).any(axis=1))[0]) + 1
        raise MeshError(f"element {bad} has a non-positive Jacobian at a corner")
    for name, faces in (("cavity", mesh.inner_face), ("outer", mesh.outer_face)):
        if np.any(faces == 0):
            bad = int(np.flatnonzero(faces == 0)[0]) + 1
            raise MeshError(f"element {bad} has no {name} face: the wall must be one element thick")
    used = np.unique(mesh.elements)
    if len(used) != mesh.n_nodes:
        raise MeshError(f"{mesh.n_nodes - len(used)} nodes belong to no element")
