"""CalculiX input decks for the tyre models (thesis §3.2).

A deck is assembled from small sections: the tyre mesh with its named sets (from the
gmsh physical groups), the Neo-Hookean materials, an optional rigid road slab with
node-to-surface contact, and one NLGEOM static step. Loads ramp with amplitudes inside
ONE step: inflation over step time [0, 1], then the road over [1, 2]. (Inflating and
loading as two ``*STEP``s was fragile in a prototype: a 9-40 mm first correction and
cutbacks at the start of the second step - ccx's linear first iteration when a boundary
moves in a step's first increment, :func:`road_step_lines`; a later step that holds its
loads for its first increment converges, :class:`Split`.) ``*TIME POINTS`` make one run
produce results at every deflection of a load path.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from farm.ccx.reinforcement import cord_lines  # noqa: F401  (decks add it after materials)
from farm.mesh.tyremesh import REGIONS, TyreMesh
from farm.specs import ContactLaw, Materials, ModelSpec, SolverSettings

ELEMENT_TYPE = "C3D8I"  # incompatible modes: plain C3D8 locks at nu = 0.499 (§3.2)


def fnum(v: float) -> str:
    """A number as the decks write it: 12 significant digits, no trailing zeros."""
    return f"{float(v):.12g}"


def _id_lines(ids: Iterable[int], per_line: int = 16) -> list[str]:
    texts = [str(int(i)) for i in ids]
    return [", ".join(texts[k:k + per_line]) for k in range(0, len(texts), per_line)]


def mesh_lines(mesh: TyreMesh) -> list[str]:
    """Nodes, elements per region (element sets TREAD/SIDEWALL/BEAD) and node sets."""
    lines = ["*NODE, NSET=TYRE"]
    lines += [f"{k + 1}, {fnum(x)}, {fnum(y)}, {fnum(z)}" for k, (x, y, z) in enumerate(mesh.nodes)]
    for r, region in enumerate(REGIONS):
        ids = np.flatnonzero(mesh.element_region == r)
        lines.append(f"*ELEMENT, TYPE={ELEMENT_TYPE}, ELSET={region.upper()}")
        lines += [f"{e + 1}, " + ", ".join(map(str, mesh.elements[e])) for e in ids]
    for name, ids in mesh.node_sets.items():
        lines.append(f"*NSET, NSET={name}")
        lines += _id_lines(ids)
    return lines


def material_lines(materials: Materials) -> list[str]:
    """``*HYPERELASTIC, NEO HOOKE`` with C10 = G/2 and D1 = 2/K per region (Table 3.1)."""
    lines = []
    for region, m in materials.by_region().items():
        name = region.upper()
        lines += [f"*MATERIAL, NAME=M_{name}", "*HYPERELASTIC, NEO HOOKE",
                  f"{fnum(m.c10)}, {fnum(m.d1)}",
                  f"*SOLID SECTION, ELSET={name}, MATERIAL=M_{name}"]
    return lines


def support_lines(spec: ModelSpec) -> list[str]:
    """Clamped beads on the rim seat, and a sector's cut faces when they are fixed (§3.2)."""
    lines = ["*BOUNDARY", "BEAD_SEAT, 1, 3, 0"]
    if not spec.is_full and spec.cut_faces == "fixed":
        lines += ["CUT_START, 1, 3, 0", "CUT_END, 1, 3, 0"]
    return lines


def cavity_pressure_lines(mesh: TyreMesh, pressure: float, amplitude: str | None) -> list[str]:
    """Inflation pressure (MPa) on every cavity face (face 0: an element of a layered
    wall that does not touch the cavity, :mod:`farm.mesh.layers`)."""
    head = "*DLOAD" + (f", AMPLITUDE={amplitude}" if amplitude else "")
    return [head] + [f"{e + 1}, P{f}, {fnum(pressure)}"
                     for e, f in enumerate(mesh.inner_face) if f > 0]


@dataclass(frozen=True)
class Road:
    """A rigid road slab under the tyre: its node and element ids and top-plane height."""

    first_node: int
    first_element: int
    z_top: float
    lines: tuple[str, ...]
    # reference coordinates of the road nodes (ids first_node, first_node + 1, ...)
    xyz: np.ndarray = field(compare=False, repr=False)

    @property
    def node_set(self) -> str:
        return "ROAD"


def road_slab(mesh: TyreMesh, z_top: float, half_length: float, half_width: float,
              divisions: tuple[int, int] = (8, 4), thickness: float = 10.0) -> Road:
    """Rigid road: C3D8 slab whose top face (S2) is the contact master surface.

    Every road node gets a prescribed displacement, so the slab is rigid and the sum of
    its reaction forces is the road's reaction on the tyre.
    """
    nx, ny = divisions
    xs = np.linspace(-half_length, half_length, nx + 1)
    ys = np.linspace(-half_width, half_width, ny + 1)
    n0, e0 = mesh.n_nodes + 1, mesh.n_elements + 1
    lines = ["*NODE, NSET=ROAD"]
    ids = np.arange(n0, n0 + 2 * xs.size * ys.size).reshape(2, xs.size, ys.size)
    for layer, z in enumerate((z_top - thickness, z_top)):
        for i, x in enumerate(xs):
            for j, y in enumerate(ys):
                lines.append(f"{ids[layer, i, j]}, {fnum(x)}, {fnum(y)}, {fnum(z)}")
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=ROAD")
    faces = []
    e = e0
    for i in range(nx):
        for j in range(ny):
            quad = [ids[0, i, j], ids[0, i + 1, j], ids[0, i + 1, j + 1], ids[0, i, j + 1]]
            top = [ids[1, i, j], ids[1, i + 1, j], ids[1, i + 1, j + 1], ids[1, i, j + 1]]
            lines.append(f"{e}, " + ", ".join(map(str, quad + top)))
            faces.append(f"{e}, S2")
            e += 1
    lines += ["*SURFACE, NAME=ROAD_TOP, TYPE=ELEMENT", *faces,
              "*MATERIAL, NAME=M_ROAD", "*ELASTIC", "210000, 0.3",
              "*SOLID SECTION, ELSET=ROAD, MATERIAL=M_ROAD"]
    xyz = np.array([[x, y, z] for z in (z_top - thickness, z_top) for x in xs for y in ys])
    return Road(n0, e0, z_top, tuple(lines), xyz)


def contact_lines(mesh: TyreMesh, law: ContactLaw,
                  friction: tuple[float, float] | None = None) -> list[str]:
    """Node-to-surface contact of the outer tread with the road top.

    The slave surface is element-face based so that ccx knows each slave node's area
    and reports contact pressure (CSTR) rather than a force. ``friction`` = (mu,
    stick slope in N/mm^3) adds Coulomb friction (``*FRICTION``; ccx refuses mu = 0,
    so a frictionless contact has no such card: None or mu = 0 give the same deck).
    """
    tread = REGIONS.index("tread")
    faces = [f"{e + 1}, S{mesh.outer_face[e]}"  # outer_face 0: not the outside layer
             for e in np.flatnonzero((mesh.element_region == tread) & (mesh.outer_face > 0))]
    lines = ["*SURFACE, NAME=TREAD_SURF, TYPE=ELEMENT", *faces,
             "*SURFACE INTERACTION, NAME=ROAD_CONTACT",
             "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=EXPONENTIAL",
             f"{fnum(law.clearance)}, {fnum(law.pressure)}"]
    if friction is not None and friction[0] > 0:
        lines += ["*FRICTION", f"{fnum(friction[0])}, {fnum(friction[1])}"]
    return [*lines, "*CONTACT PAIR, INTERACTION=ROAD_CONTACT, TYPE=NODE TO SURFACE",
            "TREAD_SURF, ROAD_TOP"]


def stick_slope(law: ContactLaw) -> float:
    """Default stick slope lambda (N/mm^3) of ``*FRICTION``: the normal law's stiffness.

    ccx's node-to-surface friction is a tangential penalty: while a node sticks its shear
    stress is lambda times its elastic slip (ccx ``springforc_n2f``: spring constant
    lambda x slave area). The exponential law p = p0 exp(-beta c), beta = ln(100)/c0,
    has the normal stiffness dp/dc = -beta p, at most beta p0 (4.6 N/mm^3 for the
    default c0 = 0.5 mm, p0 = 0.5 MPa). Lambda = beta p0 makes the tangential penalty
    as stiff as the normal one at contact: the elastic slip before sliding, mu p /
    lambda, stays below 0.09 mm (mu = 1, p = 0.4 MPa) - within the 0.03-0.25 mm the
    tread floats above the road - and lambda is about 4 times the tread's own shear
    stiffness per area (G/h = 21 MPa / 20 mm), so sticking is sticking. Measured on the
    coarse full model at mu = 0.3, 20 mm, 5 mm lateral shift (partial slip): lambda =
    1, 3, 4.6, 10 N/mm^3 gave Fy = 622, 626, 627, 628 N, so the choice moves the force
    by 0.2 % against a 2x stiffer penalty; stiffer penalties cost increments (29 for
    lambda = 1, 42-44 for 3 and 10). The CalculiX manual's rule of thumb (lambda ~
    1/100 of the normal spring constant) is for its stiff linear laws; here it would
    let every node creep by millimetres before sliding.

    A law with its own ``stick_slope`` (a preset's, e.g. ``reinforced-calibrated``'s,
    whose 11 MPa tread is about 5 times softer in shear than Table 3.1's, and whose
    slides did not converge with this one) gives that instead.
    """
    if law.stick_slope is not None:
        return law.stick_slope
    return math.log(100.0) / law.clearance * law.pressure


@dataclass(frozen=True)
class Lead:
    """A roll's lead (:func:`lead_points`): the road's further offset, mm, along its tilted
    lateral axis (``y``, ``Roll.lead``) and along x (``x``, ``Roll.lead_x``), both eased in
    over ``time`` of step time from the shift's start (:func:`farm.solve.rolling.lead_time`)."""

    y: float = 0.0
    x: float = 0.0
    time: float = 0.0


def road_motion_lines(road: Road, travel: float, shift: tuple[float, float], tilt: float,
                      t0: float, tilt_time: float, rise: str = "vertical",
                      split: Split | None = None, move_time: float = 1.0,
                      lead: Lead = Lead()) -> tuple[list[str], list[str]]:
    """Road boundary conditions of a combined load: tilt, rise, then shift.

    Every road node is prescribed (the slab stays rigid and its reactions sum to the
    road's force on the tyre). Over step time [t0, t0 + tilt_time] the road, still
    clear of the tyre, rotates by ``tilt`` degrees about the x axis through (0, 0,
    ``road.z_top``); over [t0 + tilt_time, t0 + 1] it rises by ``travel`` (:func:`_rise`); over
    [t0 + 1, t0 + 2] it slides in its own plane by ``shift`` (mm along x and along its
    tilted lateral axis (0, cos tilt, sin tilt)). A node's dof has one
    amplitude in ccx (a second ``*BOUNDARY`` replaces the first), so dofs 2 and 3 get
    absolute amplitudes per group of nodes with the same rotation (a row of the slab);
    dof 1 moves only in the last ramp. The rotation is exact at the end of its ramp
    (linear ramps of the end displacements keep the top plane flat, an affine map).

    ``split``: the deck is cut into two steps (:class:`Split`), every amplitude in total
    time with the hold inserted. ``move_time``: the shift's ramp lasts this long instead
    of one unit (a long roll, :func:`farm.solve.rolling.roll_time`). ``lead``: further
    offsets along the tilted lateral axis and along x, eased in over the start of the
    shift's ramp (:class:`Lead`). Without one along x dof 1 keeps its relative amplitude
    (decks as before leads); with it the amplitude holds the x values in mm.

    Returns the amplitude lines (model definition) and the boundary lines (the step).
    """
    ids = np.arange(road.first_node, road.first_node + len(road.xyz))
    angle = math.radians(tilt)
    rot = _tilt_displacement(road, tilt)
    groups, index = np.unique(rot, axis=0, return_inverse=True)
    index = np.ravel(index)
    end = t0 + 1 + move_time
    lines, bcs = _road_x_lines(shift[0], t0, end, split, lead)
    t1 = t0 + tilt_time
    sy, sz = shift[1] * math.cos(angle), shift[1] * math.sin(angle)  # in the road plane
    ry, rz = _rise(travel, tilt, rise)
    ly, lz = lead.y * math.cos(angle), lead.y * math.sin(angle)
    for k, (uy, uz) in enumerate(groups):
        for dof, points in ((2, [(t1, uy), *lead_points(t0 + 1, end, uy + ry, sy, ly, lead.time)]),
                            (3, [(t1, uz), *lead_points(t0 + 1, end, uz + rz, sz, lz, lead.time)])):
            name = f"ROAD_{k + 1}_{dof}"
            lines += amplitude_lines(name, [(0.0, 0.0), (t0, 0.0), *points], split)
            bcs.append(f"*BOUNDARY, AMPLITUDE={name}")
            bcs += [f"{i}, {dof}, {dof}, 1" for i in ids[index == k]]
    return lines, bcs


def _road_x_lines(shift: float, t0: float, end: float, split: Split | None,
                  lead: Lead) -> tuple[list[str], list[str]]:
    """Amplitude and boundary lines of every road node's dof 1 (x) over the shift's ramp
    [t0 + 1, ``end``]: ``shift`` mm, plus the lead along x eased in by
    :func:`lead_points`."""
    if not lead.x:  # a relative ramp scaled by the shift: decks as before leads
        lines = amplitude_lines("ROAD_MOVE", [(0.0, 0.0), (t0 + 1, 0.0), (end, 1.0)], split)
        return lines, ["*BOUNDARY, AMPLITUDE=ROAD_MOVE", f"ROAD, 1, 1, {fnum(shift)}"]
    points = lead_points(t0 + 1, end, 0.0, shift, lead.x, lead.time)
    lines = amplitude_lines("ROAD_MOVE", [(0.0, 0.0), *points], split)
    return lines, ["*BOUNDARY, AMPLITUDE=ROAD_MOVE", "ROAD, 1, 1, 1"]


#: Points of a lead's ease-in (:func:`lead_points`)
LEAD_POINTS = 12


def lead_points(start: float, end: float, base: float, shift: float, lead: float,
                lead_time: float) -> list[tuple[float, float]]:
    """(time, value) of one road dof over the shift's ramp [``start``, ``end``]: linear
    from ``base`` to ``base + shift``, plus ``lead`` eased in over [start, start +
    ``lead_time``] by a smoothstep (3u^2 - 2u^3) and held after.

    Why eased: the lead is a burst of lateral slip on top of the roll's; it must end with
    the lateral speed of the roll itself. A lead taken in one 6.4 mm ramp (a kink in the
    road's lateral speed) stopped the roll where it ended, eased over 96 mm it rolled
    through (docs/rolling.md, "A steady roll")."""
    if not lead or lead_time <= 0.0:
        return [(start, base), (end, base + shift)]
    rate = shift / (end - start)
    eased = [(start + u * lead_time, base + u * lead_time * rate + lead * (3 - 2 * u) * u * u)
             for u in np.linspace(0.0, 1.0, LEAD_POINTS + 1)]
    return [*eased, (end, base + shift + lead)]


def _rise(travel: float, tilt: float, rise: str) -> tuple[float, float]:
    """(uy, uz) of every road node for a rise of ``travel`` mm under the wheel centre.

    ``"vertical"``: along the wheel's z axis. A tilted road then also moves in its own
    plane by travel sin(tilt), so the tread slides sideways on it while the patch forms.
    ``"normal"``: along the tilted road's normal by travel cos(tilt), as a camber rig
    loads an inclined wheel against a level road; the road's plane ends where the
    vertical rise puts it (a plane moved within itself is the same plane), so deflections
    keep their meaning, and only the friction history differs
    (:attr:`farm.specs.RoadMotion.rise`).
    """
    if rise == "normal":
        a = math.radians(tilt)
        return (-travel * math.cos(a) * math.sin(a), travel * math.cos(a) ** 2)
    return (0.0, travel)


def _tilt_displacement(road: Road, tilt: float) -> np.ndarray:
    """(uy, uz) of each road node when the road has turned by ``tilt`` degrees about
    the x axis through (0, 0, ``road.z_top``), (n_road, 2); rounded to deck-stable
    values (one amplitude pair per row of the slab)."""
    angle = math.radians(tilt)
    y, z = road.xyz[:, 1], road.xyz[:, 2] - road.z_top
    rot = np.stack([y * (math.cos(angle) - 1.0) - z * math.sin(angle),
                    y * math.sin(angle) + z * (math.cos(angle) - 1.0)], axis=1)
    return np.round(rot, 9) + 0.0


def road_position_lines(road: Road, travel: float, shift: tuple[float, float],
                        tilt: float, rise: str = "vertical") -> list[str]:
    """``*BOUNDARY`` (no amplitude) placing every road node where
    :func:`road_motion_lines` takes it: turned by ``tilt``, risen by ``travel`` and slid
    by ``shift`` in its own plane (:func:`_road_values`).

    In a later step these values ramp from where the road is from the first increment
    on, which makes ccx's first iteration linear: the trees use :func:`road_step_lines`
    (the same place, reached after a hold); the tests use this to reproduce the decks
    of before.
    """
    ids = np.arange(road.first_node, road.first_node + len(road.xyz))
    values = _road_values(road, travel, shift, tilt, rise)
    return ["*BOUNDARY", *(f"{i}, {dof + 1}, {dof + 1}, {fnum(values[k, dof])}"
                           for k, i in enumerate(ids) for dof in range(3))]


#: Step time (of a unit step) over which a new step holds the road where the last one
#: left it before moving it (:func:`road_step_lines`), and the new step's first increment.
STEP_DWELL = 0.1


def _road_values(road: Road, travel: float, shift: tuple[float, float], tilt: float,
                 rise: str) -> np.ndarray:
    """(ux, uy, uz) of every road node placed as :func:`road_position_lines` places it."""
    angle = math.radians(tilt)
    rot = _tilt_displacement(road, tilt)
    ry, rz = _rise(travel, tilt, rise)
    sy, sz = shift[1] * math.cos(angle), shift[1] * math.sin(angle)
    return np.column_stack([np.full(len(rot), float(shift[0])),
                            rot[:, 0] + ry + sy, rot[:, 1] + rz + sz])


def road_step_lines(road: Road, before: tuple[float, tuple[float, float]],
                    after: tuple[float, tuple[float, float]], tilt: float, rise: str,
                    name: str, dwell: float = STEP_DWELL) -> list[str]:
    """Step cards moving the road from ``before`` to ``after`` ((travel, shift) as in
    :func:`road_position_lines`): held still for the step time [0, ``dwell``], then
    linearly to the new place at step time 1.

    Why the hold: ccx 2.20 starts every step with its internal force vector at zero
    (``nonlingeo.c`` allocates it per step; only a dynamic step recomputes it before the
    first increment), and when a prescribed displacement changes by more than 1e-5 in a
    step's first increment its first iteration is "purely linear" and adds that
    increment's linear forces to this vector (``ilin``; ``resultsmech.f``: "if the forced
    displacements were changed at the start of a nonlinear step"). In a later step the
    first iteration so sees the whole preload - the inflation, the road's reaction - as
    out of balance, and Newton starts from a tyre pushed by all of it once more: the
    divergence of new steps "whatever the increment" (docs/combined-loads.md). With the
    road still in the first increment (of at most ``dwell``), ccx takes an ordinary
    iteration from the true internal forces instead.

    ccx scales an amplitude's boundary value (``xboun * amplitude``), so the hold is an
    amplitude per group of node dofs with the same old-to-new ratio (a row of the slab);
    a dof that does not move keeps its value, and one whose new value is zero (no ratio
    reaches the old one) ramps plainly. Amplitude names start with ``name`` and must be
    new to the run (ccx keeps a run's amplitudes across steps and restarts).
    """
    if not 0 < dwell < 1:
        raise ValueError(f"dwell must lie in (0, 1), got {dwell!r}")
    ids = np.arange(road.first_node, road.first_node + len(road.xyz))
    old = _road_values(road, before[0], before[1], tilt, rise)
    new = _road_values(road, after[0], after[1], tilt, rise)
    plain = ["*BOUNDARY"]
    held: dict[tuple[int, str], list[int]] = {}
    for (node, dof), u1 in np.ndenumerate(new):
        u0 = old[node, dof]
        if abs(u1 - u0) <= 1e-12 or abs(u1) <= 1e-9:
            plain.append(f"{ids[node]}, {dof + 1}, {dof + 1}, {fnum(u1)}")
        else:
            held.setdefault((dof + 1, fnum(u0 / u1)), []).append(node)
    lines: list[str] = []
    bcs: list[str] = []
    for k, ((dof, ratio), nodes) in enumerate(sorted(held.items())):
        amp = f"{name}_{k + 1}"
        lines += [f"*AMPLITUDE, NAME={amp}",
                  *_amplitude([(0.0, float(ratio)), (dwell, float(ratio)), (1.0, 1.0)])]
        bcs.append(f"*BOUNDARY, AMPLITUDE={amp}")
        bcs += [f"{ids[n]}, {dof}, {dof}, {fnum(new[n, dof - 1])}" for n in nodes]
    return [*lines, *(plain if len(plain) > 1 else []), *bcs]


#: Step time of the hold that begins the second step of a :class:`Split` deck, and that
#: step's first increment: 0.01 of the rise's ramp, 0.2-0.3 mm of road travel on the
#: combined paths measured (docs/combined-loads.md, "First touch").
SPLIT_HOLD = 0.01


@dataclass(frozen=True)
class Split:
    """A one-step deck's time layout cut at time ``at`` (and at each time of ``more``,
    after it) into steps: each step after a cut holds every load still for its first
    increment, of ``hold``; every time after a cut moves on by ``hold``.

    Why (:attr:`farm.specs.SolverSettings.split_rise`): ccx's automatic increments grow
    through the easy inflation; the rise then starts with increments of half its ramp,
    and the stick/slip state of the first tread nodes to touch a tilted frictional road
    flips from iteration to iteration while they are cut back (docs/combined-loads.md).
    A new step starts its increments small again. The hold keeps the step's first
    iteration an ordinary one (:func:`road_step_lines` says why a moving first increment
    is not). Amplitudes and time points of a split deck are in total time, so that
    loads ramp across the cut as they did in one step. ``more``: a roll's restart points
    (:attr:`farm.specs.SolverSettings.restart_every_mm`; ccx writes its restart state at
    a step's end).
    """

    at: float
    hold: float = SPLIT_HOLD
    more: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if any(b <= a for a, b in itertools.pairwise(self.cuts)):
            raise ValueError(f"a split's cuts must increase, got {list(self.cuts)}")

    @property
    def cuts(self) -> tuple[float, ...]:
        """Every cut, in the one-step layout's time, in order."""
        return (self.at, *self.more)

    def time(self, t: float) -> float:
        """The total time of the one-step layout's time ``t``."""
        return t + self.hold * sum(t > c for c in self.cuts)

    def layout(self, total: float) -> float:
        """The one-step layout's time of total time ``total`` (a hold maps to its cut)."""
        for k, c in enumerate(self.cuts):
            if total <= c + k * self.hold:
                return total - k * self.hold
            if total <= c + (k + 1) * self.hold:
                return c
        return total - len(self.cuts) * self.hold

    def step_end(self, step: int) -> float:
        """The total time at which step ``step`` (1: the first) ends: its cut's hold
        begins there; the last step ends with the layout."""
        return self.time(self.cuts[step - 1])

    def points(self, points: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
        """Amplitude ``points`` (time, value) of the one-step layout, held over each cut
        (after the last point an amplitude keeps its last value, in ccx as here)."""
        out = list(points)
        for c in reversed(self.cuts):  # the last cut first: earlier cuts move its hold on
            ts, vs = zip(*out, strict=True)
            v = float(np.interp(c, ts, vs))
            out = ([p for p in out if p[0] <= c] + [(c, v), (c + self.hold, v)]
                   + [(t + self.hold, u) for t, u in out if t > c])
        return out


def amplitude_lines(name: str, points: Sequence[tuple[float, float]],
                    split: Split | None = None) -> list[str]:
    """``*AMPLITUDE`` of (time, value) ``points`` in step time, or in total time with
    the hold of ``split`` inserted."""
    if split is None:
        return [f"*AMPLITUDE, NAME={name}", *_amplitude(list(points))]
    return [f"*AMPLITUDE, NAME={name}, TIME=TOTAL TIME", *_amplitude(split.points(points))]


def inflate_amplitude_lines(split: Split | None = None) -> list[str]:
    """``INFLATE``: the cavity pressure ramped over step time [0, 1], then held."""
    return amplitude_lines("INFLATE", [(0.0, 0.0), (1.0, 1.0), (2.0, 1.0)], split)


def _amplitude(points: list[tuple[float, float]]) -> list[str]:
    """Amplitude data lines: at most four (time, value) pairs a line (ccx reads no more
    from one line: a fifth pair is silently dropped), each time once (the first of
    equal times; equal times carry equal values)."""
    kept = [pt for i, pt in enumerate(points) if i == 0 or pt[0] > points[i - 1][0]]
    pairs = [f"{fnum(t)}, {fnum(v)}" for t, v in kept]
    return [", ".join(pairs[k:k + 4]) for k in range(0, len(pairs), 4)]


def static_step_lines(period: float, settings: SolverSettings,
                      first: float | None = None) -> list[str]:
    """NLGEOM static step with automatic incrementation over ``period``.

    Increment sizes are fractions of one load ramp, which lasts one unit of step time;
    ``first`` caps the first increment (a step after another: at most its
    :data:`STEP_DWELL`, :func:`road_step_lines`).
    """
    start = settings.initial_increment if first is None else min(first,
                                                                 settings.initial_increment)
    return [f"*STEP, NLGEOM, INC={settings.max_increments}", "*STATIC",
            f"{fnum(start)}, {fnum(period)}, "
            f"{fnum(min(start, settings.min_increment))}, {fnum(settings.max_increment)}"]


#: Cutbacks ccx may take within one increment of a frictional path (its default is 5).
#: The first increment of a road slide under a sticking patch at high mu needs the
#: increment cut to ~1e-3 of the ramp before it converges, after which it grows back
#: at 2 iterations an increment: measured on the coarse full model at 80 kPa, 21.5 mm,
#: mu 0.87, 3.95 mm slide, 5 cutbacks stop with "too many cutbacks", 10 get through
#: (docs/combined-loads.md, "Convergence at high friction"). A converged increment is
#: the same whatever it took to get there, so this changes no result.
FRICTION_CUTBACKS = 10


def friction_controls_lines(grow_after: int = 4) -> list[str]:
    """Step option: ccx's default time incrementation controls (I0, IR, IP, IC, IL, IG,
    IS, IA = 4, 8, 9, 16, 10, 4, -, 5) with IA raised to :data:`FRICTION_CUTBACKS` and IG
    set to ``grow_after`` (:attr:`farm.specs.SolverSettings.grow_after`)."""
    return ["*CONTROLS, PARAMETERS=TIME INCREMENTATION",
            f"4, 8, 9, 16, 10, {grow_after}, , {FRICTION_CUTBACKS}"]


#: ccx's field convergence controls R_n and C_n (residual force over the average force,
#: correction over the increment's displacement change; defaults 0.005 and 0.01) for
#: solves that continue from a saved state (:mod:`farm.solve.continuation`). At the
#: defaults a converged state still carries errors up to ~1.5e-3 mm in U and ~3e-6 in
#: strain on the reduced model at 30 mm, and which ones depends on where Newton started;
#: at 1e-5 a state is the same to the .frd's six printed digits whether it was ramped
#: from rest or continued from a neighbour (measured: 1-2 more iterations; tested in
#: tests/farm/test_continuation.py), so a result does not depend on its path.
TIGHT_FIELD_CONTROLS = (1e-5, 1e-5)


def tight_controls_lines() -> list[str]:
    """Step option: :data:`TIGHT_FIELD_CONTROLS` as R_n, C_n; ccx's defaults for the rest."""
    return ["*CONTROLS, PARAMETERS=FIELD", ", ".join(fnum(v) for v in TIGHT_FIELD_CONTROLS)]


def restart_lines(read: bool, write: bool) -> list[str]:
    """``*RESTART``: READ continues from ``<job>.rin`` (the model definition and the
    state at the end of its last step come from it); WRITE leaves the state at the end
    of every step in ``<job>.rout``, one self-contained block a step appended to the
    file (ccx's ``OVERLAY`` would keep the last only; :func:`farm.solve.tree.split_restart`
    cuts the blocks apart)."""
    return ((["*RESTART, READ"] if read else [])
            + (["*RESTART, WRITE, FREQUENCY=1"] if write else []))


def continuation_step_lines(settings: SolverSettings) -> list[str]:
    """NLGEOM static step for a small change of the loads from the previous state.

    The change is tried in one increment (4x the first increment of a ramp, at most the
    whole step: 1 with the default settings, 1/4 with the guard's smaller increments),
    ccx cutting it back as it needs; loads move linearly from their previous values.
    """
    first = min(1.0, 4 * settings.initial_increment)
    return [f"*STEP, NLGEOM, INC={settings.max_increments}", "*STATIC",
            f"{fnum(first)}, 1, {fnum(settings.min_increment)}, {fnum(first)}"]


def time_points_lines(time_points: Sequence[float], split: Split | None = None) -> list[str]:
    """The output times (model definition, referenced as ``OUT`` by the step's output);
    with a ``split``, total times past its hold."""
    if split is None:
        return ["*TIME POINTS, NAME=OUT", *(fnum(t) for t in time_points)]
    return ["*TIME POINTS, NAME=OUT, TIME=TOTAL TIME",
            *(fnum(split.time(t)) for t in time_points)]


def written_sets(mesh: TyreMesh) -> tuple[str, ...]:
    """The tyre's node sets whose U and RF a step writes: both surfaces hold every node
    of a one-element wall; a layered wall's interior nodes (:mod:`farm.mesh.layers`)
    carry support reactions and the full-field displacement too, so all of ``TYRE``."""
    if np.all(mesh.inner_face > 0):  # one element through the wall: decks as before
        return ("INNER", "OUTER")
    return ("TYRE",)


def measured_set_lines(node_sets: Sequence[str]) -> list[str]:
    """Node set ``MEASURED``: the union of the sets whose results are written."""
    return ["*NSET, NSET=MEASURED", *(f"{s}," for s in node_sets)]


def output_lines(time_points: bool, contact: bool, points: str = "OUT") -> list[str]:
    """Step output: U and RF of ``MEASURED`` nodes, strain at the cavity, contact.

    Output is limited to the nodes the measurements need (the .frd stays small and
    quick to parse); ``*EL FILE`` E gives ccx's integration-point strains extrapolated
    to and averaged at the nodes (thesis §4.2). ``points`` names the ``*TIME POINTS``.
    """
    tp = f", TIME POINTS={points}" if time_points else ""
    lines = [f"*NODE FILE, NSET=MEASURED{tp}", "U, RF", f"*EL FILE, NSET=INNER{tp}", "E"]
    if contact:
        lines += [f"*CONTACT FILE{tp}", "CDIS, CSTR",
                  f"*NODE PRINT, NSET=ROAD, TOTALS=ONLY{tp}", "RF"]
    return lines


def assemble(*sections: Iterable[str]) -> str:
    """Join deck sections into the deck text."""
    out = ["*HEADING", "tyre-farm virtual experiment (TM700 280/70R16)"]
    for section in sections:
        out += list(section)
    return "\n".join(out) + "\n"
