"""Quasi-static rolling (issue 30): the rim turns while the road travels under it.

CalculiX has no steady-state transport, so a rolling tyre is a large prescribed motion
in one ccx run (:func:`roll_deck`): inflate, turn the road to its tilt (camber), push it
up to the deflection with friction on - the one-run combined path of
:mod:`farm.solve.contact` - then, over one more unit of step time, translate the road
by ``distance`` mm along the travel direction while the rim turns about the spin axis
(+y, through the wheel centre at the origin): the bead seat, clamped for a standing
tyre, is clamped to a turning rim instead (:func:`rim_lines`).

Kinematics (SAE sign convention, wheel frame; the road moves, the wheel stays):

- the wheel travels at speed V along (cos a, sin a) relative to the road, a = the slip
  angle: the road moves by ``-distance * (cos a, sin a)`` in its own plane;
- the rim turns by ``phi = (1 + kappa) * distance * cos(a) / r_e`` about +y (a positive
  turn about +y carries the bottom of the tyre towards -x, with the road), so that the
  longitudinal slip ratio ``kappa = (omega r_e - V_x) / V_x`` is constant along the roll;
  ``r_e`` is the free-rolling (effective) radius, the one at which Fx vanishes for
  kappa = 0 (:func:`free_rolling_radius` finds it by a secant search on Fx).

Results are written at fractions of the roll; a state's forces are the road's reaction
on the tyre (Fx, Fy, Fz) and its moment about the contact centre (Mx, My, Mz), both from
the rigid road's nodal reactions, plus the tread forces and stick/slip states of the
combined loads (:func:`farm.solve.contact.combined_state`).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from farm.ccx import deck as D
from farm.ccx.frd import FrdFile
from farm.ccx.runner import CcxRun, ccx_version
from farm.errors import ResultsError, SolverError, SpecError
from farm.mesh.tyremesh import TyreMesh
from farm.solve import roll_restart
from farm.solve.contact import (
    TILT_TIME,
    combined_state,
    run_deck_keeping,
    slave_faces,
    tilted_gap,
    touch_height,
)
from farm.solve.entries import read_entry, write_entry
from farm.solve.states import SolvedState
from farm.spacing import column_angles
from farm.specs import LEAD_RAMP_MM, LoadPath, ModelSpec, RoadMotion, Roll, SolverSettings


@dataclass(frozen=True, eq=False)
class RolledState:
    """One state along a roll: road reaction (N) and moment about the contact centre
    (N mm), tread forces (n_tread, 3) and contact status (n_tread,), the tyre's
    displacement (n_nodes, 3), how far the road has travelled (mm) and the rim turned
    (rad).

    ``camera`` (n_nodes, 3), mm: what a camera fixed to the contact centre sees (T2Cam
    is stabilised and looks at the patch while the tyre turns, thesis §2.2): each
    material point's position minus where the inflated, unloaded tyre, turned by the
    same spin, would hold it. The rigid turn is removed, the deformation by the road
    stays; at spin 0 it is the displacement from the inflated state.

    ``solved`` is the state as the solver left it (material node order, strains in the
    reference axes), ``reference`` the inflated, unloaded tyre before the road touched:
    :func:`farm.measure.camera.camera_state` re-reads ``solved`` at the grid's fixed places.

    ``start`` (rad) is the turn the tyre was given before the roll (:func:`start_spin`:
    a windowed mesh starts with its window ahead of the road), so the material at each
    node's place of the stored mesh is the one ``start + spin`` carried there; the
    arrays are those of the stored mesh (``displacement`` includes the start's turn).
    """

    fraction: float
    travelled: float
    spin: float
    force: np.ndarray
    moment: np.ndarray
    tread_force: np.ndarray
    contact_status: np.ndarray
    displacement: np.ndarray
    camera: np.ndarray
    solved: SolvedState
    reference: SolvedState
    start: float = 0.0

    @property
    def turn(self) -> float:
        """The tyre's turn from the stored mesh, rad: ``start + spin``."""
        return self.start + self.spin


#: Straight pieces of each bead node's circular path over a roll: the chord of a piece
#: strays from the arc by r (1 - cos(dphi / 2)), 0.004 mm for the 203 mm bead seat
#: turning 0.25 rad in 20 pieces. At least this many; a longer roll gets pieces of at
#: most RIM_PIECE_RAD (0.04 mm from the arc, as a 320 mm roll's 20 pieces were).
RIM_PIECES = 20
RIM_PIECE_RAD = 0.04


def rim_lines(mesh: TyreMesh, spin: float, start: float,
              duration: float = 1.0, split: D.Split | None = None,
              ) -> tuple[list[str], list[str]]:
    """The bead seat turned by ``spin`` radians about +y over step time [start, start +
    ``duration``] and held before: (amplitude lines, boundary lines).

    Every bead seat node gets its displacement on the circle about the spin axis at
    RIM_PIECES + 1 times (one amplitude per node and dof, linear between): a rim clamped
    on a turning wheel. ccx's ``*RIGID BODY`` with the spin on its rotation node was
    tried first: its first rolling increment started with a residual of 3e7 N and never
    converged once the spin passed about 0.1 rad (coarse mesh, 200 kPa, 15 mm).
    """
    seat = np.asarray(mesh.node_sets["BEAD_SEAT"])
    xyz = mesh.nodes[seat - 1]
    pieces = max(RIM_PIECES, math.ceil(abs(spin) / RIM_PIECE_RAD))
    times = start + np.linspace(0.0, duration, pieces + 1)
    # (n_seat, pieces + 1, 3): each seat node's displacement at each time
    u = np.stack([turned(xyz, phi) - xyz for phi in np.linspace(0.0, spin, pieces + 1)],
                 axis=1)
    amplitudes, boundary = [], ["*BOUNDARY", *(f"{n}, 2, 2, 0" for n in seat)]
    for k, n in enumerate(seat):
        for dof in (1, 3):
            name = f"RIM_{n}_{dof}"
            amplitudes += D.amplitude_lines(
                name, [(0.0, 0.0), *zip(times, u[k, :, dof - 1], strict=True)], split)
            boundary += [f"*BOUNDARY, AMPLITUDE={name}", f"{n}, {dof}, {dof}, 1"]
    return amplitudes, boundary


def roll_deck(spec: ModelSpec, mesh: TyreMesh, deflection: float, pressure: float,
              roll: Roll, settings: SolverSettings, touch_z: float,
              fractions: Sequence[float], *, model: Sequence[str] = (),
              ahead: float = 0.0, every: float = 0.0) -> tuple[str, list[float], D.Road, float]:
    """The one-run deck of a roll; returns (deck, output times of the fractions, road,
    road start z).

    ``model`` lines go at the end of the model definition and ``ahead`` (mm) lengthens
    the road past the roll's end: a rolling trunk's restart output, its branches' time
    points and their travel (:mod:`farm.solve.rolling_tree`). ``every`` (mm): the roll
    cut into steps at every so many mm of travel, each step's end written as a restart
    point (:mod:`farm.solve.roll_restart`)."""
    gap = tilted_gap(spec, roll.tilt)
    travel = gap + deflection
    z_start = touch_z - gap
    radius = spec.geometry.outer_radius
    # the road must reach past the patch after it has travelled: longer ahead (+x)
    road = D.road_slab(mesh, z_start, half_length=0.8 * radius + roll.distance + ahead,
                       half_width=0.6 * spec.geometry.section_width, divisions=(16, 4))
    # camber as a rig gives it: the road pushed along its own normal (no side slide)
    duration = roll_time(roll)
    split = roll_split(roll, every)
    amplitudes, boundary = D.road_motion_lines(road, travel, roll.travel, roll.tilt, 1.0,
                                               TILT_TIME if roll.tilt else 0.0, "normal",
                                               split, move_time=duration,
                                               lead=D.Lead(y=roll.lead, x=roll.lead_x,
                                                           time=lead_time(roll)))
    amplitudes += D.inflate_amplitude_lines(split)
    rim_amplitudes, rim = rim_lines(mesh, roll.spin, 2.0, duration, split)
    times = _output_times(fractions, duration, split, every)
    lam = D.stick_slope(spec.contact)
    capped = _capped(settings, roll)
    controls = D.friction_controls_lines(settings.grow_after) if roll.friction > 0 else []
    outputs = D.output_lines(time_points=True, contact=True)
    rise_mu = RISE_FRICTION if roll.friction_from == "roll" else roll.friction
    deck = D.assemble(
        D.mesh_lines(mesh), D.material_lines(spec.materials), D.cord_lines(spec, mesh),
        road.lines,
        D.contact_lines(mesh, spec.contact, (rise_mu, lam) if roll.friction > 0 else None),
        amplitudes, rim_amplitudes, D.time_points_lines(sorted({1.0, 2.0, *times}), split),
        D.measured_set_lines((*D.written_sets(mesh), "ROAD")), model,
        D.restart_lines(read=False, write=True) if every > 0 else [],
        D.static_step_lines(2.0 + duration if split is None else split.at, capped),
        controls, rim, boundary, D.cavity_pressure_lines(mesh, pressure, "INFLATE"),
        outputs, ["*END STEP"],
        [] if split is None else _later_steps(roll, split, capped, lam,
                                              _later_controls(roll, settings, every) + outputs),
    )
    return deck, [split.time(t) for t in times] if split else times, road, z_start


def _output_times(fractions: Sequence[float], duration: float, split: D.Split | None,
                  every: float) -> list[float]:
    """The layout's times of a roll's states at ``fractions``; refused in one line where
    they do not increase within [0, 1] or where one falls on a restart point's cut."""
    if not fractions or any(not 0.0 <= f <= 1.0 for f in fractions) or any(
            b <= a for a, b in itertools.pairwise(fractions)):
        raise SpecError(f"roll fractions must increase within [0, 1] (0: the standing "
                        f"tyre before the roll), got {list(fractions)}")
    times = [2.0 + f * duration for f in fractions]
    restart_cuts = [c for c in split.cuts if c > 2.0] if split is not None else []
    if any(abs(t - c) < 1e-6 for t in times for c in restart_cuts):
        raise SpecError(f"a state of the roll falls on one of its restart points (every "
                        f"{every:g} mm, {CUT_AFTER_MM:g} mm on): give restart_every_mm "
                        f"another value")
    return times


def _later_steps(roll: Roll, split: D.Split, settings: SolverSettings, stick: float,
                 cards: list[str]) -> list[str]:
    """The steps after each cut of a split roll (:func:`roll_split`): each held for its
    first increment, with ``cards`` (controls and outputs); loads, boundaries and
    amplitudes carry over. The step that begins at the roll's start after a
    frictionless rise switches the roll's friction on (``*CHANGE FRICTION``)."""
    ends = [*split.cuts[1:], 2.0 + roll_time(roll)]
    lines: list[str] = []
    for cut, end in zip(split.cuts, ends, strict=True):
        lines += D.static_step_lines(end - cut + split.hold, settings, first=split.hold)
        if cut == 2.0 and roll.friction_from == "roll":
            lines += ["*CHANGE FRICTION, INTERACTION=ROAD_CONTACT", "*FRICTION",
                      f"{D.fnum(roll.friction)}, {D.fnum(stick)}"]
        lines += [*cards, "*END STEP"]
    return lines


#: mu of a frictionless rise (``friction_from = "roll"``): ccx refuses mu = 0 and changes
#: only a friction it has (``*CHANGE FRICTION``, as its test ``changefric.inp`` goes from
#: 1e-4 to 0.2); 1e-4 of the contact pressure is a shear of at most 1e-4 MPa.
RISE_FRICTION = 1e-4


def roll_split(roll: Roll, every: float = 0.0) -> D.Split | None:
    """Where a roll's deck is cut into steps: at the roll's start (step time 2), for a
    roll whose friction begins there (``roll.friction_from == "roll"``), and at every
    ``every`` mm of travel after it (0: nowhere; restart points,
    :mod:`farm.solve.roll_restart`); None where the roll is one step.

    Why the first (issue 45, docs/rolling.md "A frictionless rise"): on the 16-element
    polygon a node stands for some 7,800 mm2 of tread, and its tangential penalty swings
    its shear past its margin to slip in one Newton correction: rolls stopped in a
    frictional rise (a tilted road presses the shoulder nodes first) and at the roll's
    first increment (shoulder nodes left sticking at 95 % of mu by the rise). Rising
    without friction leaves no node sticking when the friction comes on, at rest, in the
    new step's hold. Why the others: ccx writes its restart state at a step's end only.
    """
    cuts = [2.0] if roll.friction_from == "roll" and roll.friction > 0 else []
    if every > 0:
        duration = roll_time(roll)
        cuts += [2.0 + (k * every + CUT_AFTER_MM) / roll.distance * duration
                 for k in range(1, math.ceil((roll.distance - CUT_AFTER_MM) / every - 1e-9))]
    if not cuts:
        return None
    return D.Split(cuts[0], STEP_HOLD if every > 0 else D.SPLIT_HOLD, tuple(cuts[1:]))


#: Road travel (mm) past each multiple of ``restart_every_mm`` at which the roll is cut.
#: A roll restarted at a step's end finds its next output time from the total time of
#: that end (ccx ``checktime``): an output time equal to it, as a state's at a round
#: travel would be, comes out a rounding error ahead and stops the restart ("a time
#: point precedes the minimum time tmin"); the states' times stay clear of the cuts.
CUT_AFTER_MM = 0.25

#: The hold that begins each step of a roll cut at restart points (:func:`roll_split`),
#: in step time, and ccx's IG in those steps: a rolling branch's
#: (:data:`farm.solve.rolling_tree.BRANCH_DWELL`, ``BRANCH_GROW_AFTER``). A roll's first
#: moving increment in a new step converges only once cut to about 1e-4 of its step, and
#: at ccx's default IG 4 its increments then stay small and stop at a tread node's entry
#: (docs/rolling.md, "Why a roll in a new step"). Measured on `patch` for branches; on
#: the coarse model, at the roll's own smallest increment, a 0.01 hold and IG 4 stopped
#: the two rolls tried at their first cut (every 20 or 30 mm), these at a later cut or
#: not at all (docs/rolling.md, "Restart points").
STEP_HOLD = 0.002
STEP_GROW_AFTER = 10

def _later_controls(roll: Roll, settings: SolverSettings, every: float) -> list[str]:
    """Controls of the steps after a roll's first: the roll's own, or a branch's IG
    where the roll is cut at restart points."""
    if roll.friction <= 0:
        return []
    grow = max(settings.grow_after, STEP_GROW_AFTER) if every > 0 else settings.grow_after
    return D.friction_controls_lines(grow)


#: The most road travel one increment may take, mm. Measured (coarse full model, 16 and
#: 64 elements round, 200 kPa, 15 mm, mu 0.6, free rolling over 100 mm): with ccx's
#: automatic increments the roll's first increment took 25 mm and never converged, not
#: even cut back to 1e-4 of it (the tread nodes' stick/slip state flipped between
#: iterations); capped at 5 mm it went through.
MAX_TRAVEL_MM = 5.0

#: The longest roll that lasts one unit of step time. The increment cap is a fraction
#: of step time for the whole run, the rise's included: a 1000 mm roll capped its rise at
#: 0.005 of the ramp, and the rise stopped at first touch ("increment below minimum";
#: 320 and 640 mm rolls went through). A longer roll lasts distance / ROLL_UNIT_MM units
#: instead, so its rise keeps the cap of a roll of this length (docs/rolling.md).
ROLL_UNIT_MM = 320.0


def roll_time(roll: Roll) -> float:
    """Step time the roll lasts (:data:`ROLL_UNIT_MM`): 1 up to that distance."""
    return max(1.0, roll.distance / ROLL_UNIT_MM)


def lead_time(roll: Roll) -> float:
    """Step time over which the roll's lead is eased in: its first
    :data:`~farm.specs.LEAD_RAMP_MM` of travel (0 without a lead).

    Why a lead (docs/rolling.md, "A steady roll"): a slip angle's lateral force relaxes
    over about 0.7 m of travel (a first-order lag whose length is sigma), more than a
    windowed mesh can roll with the patch in its window. In the stretched-string model
    (Pacejka, *Tyre and Vehicle Dynamics*, ch. 7) the carcass's lateral deflection at the
    patch's leading edge is sigma tan(alpha) in steady rolling; a roll whose road is
    offset by about that much at its start begins near there, and only the patch itself,
    which the roll renews within its length, has to settle. The lead that starts exactly
    at the steady force is the steady force over the carcass's lateral stiffness (on
    `lean` about 190 N/mm, 0.5-2 degrees; sigma tan(alpha) only while Fy is linear): two
    leads that bracket it give the steady value (``benchmarks/bench_steady_roll.py``).
    The longitudinal lead (``roll.lead_x``) does the same for Fx, whose relaxation on
    `lean` is about half a metre too: its flat lead is Fx over about 520 N/mm (positive
    with a driving slip; docs/rolling.md, "A longitudinal lead")."""
    if not (roll.lead or roll.lead_x):
        return 0.0
    return LEAD_RAMP_MM / roll.distance * roll_time(roll)


def travel_cap(settings: SolverSettings) -> float:
    """The most road travel (mm) one increment may take under ``settings``:
    :data:`MAX_TRAVEL_MM`, scaled down with a ``max_increment`` below the default.

    Why: the guard's retry (:func:`jobs.guard.smaller_increments`) divides
    ``max_increment`` by 4, but a roll's increments are capped by travel far below it
    (5 mm of a 150 mm roll is 0.033 of its step), so until 2026-11-29 a retried roll ran
    the same deck again and stopped where it had. With the cap scaled, the retry rolls in
    1.25 mm increments: on 32 elements round (mu 0.6, r 403.8 mm) a 135 mm trunk and a
    165 mm roll at 2 degrees that stopped "increment below minimum" at 5 mm went through
    at 1.25 mm (docs/rolling.md, "Rolling trees"). At the default settings nothing changes.
    """
    scale = min(1.0, settings.max_increment / SolverSettings().max_increment)
    return MAX_TRAVEL_MM * scale


#: A roll's smallest increment, in step time, at most (``min_increment`` is larger by
#: default: 1e-5 of a ramp). A roll's first moving increment - from rest, after a cut or
#: at a tread node's entry - and the rise onto a tilted road converge on the coarse model
#: only cut back below 1e-5 of the step (docs/rolling.md, "Why rolls of the coarse model
#: stop"), and stopped there "increment below minimum". Measured (coarse model, the 60
#: rolls of examples/rolling_design_coarse.toml, [solver] min_increment = 1e-7, 2026-12-01):
#: 9 lost where the default lost 29; a roll that goes through at 1e-5 is the same to
#: the bit at 1e-7 (ccx consults its least increment only to stop): 31 of the 32 done
#: both ways, the other one the guard had retried at smaller increments under 1e-5.
#: 1e-9 rescued none of the 9 more.
ROLL_MIN_INCREMENT = 1e-7


def capped_increments(settings: SolverSettings, cap: float) -> SolverSettings:
    """``settings`` for a rolling step whose increments may last ``cap`` of step time at
    most (:func:`travel_cap` of road travel), the smallest at most
    :data:`ROLL_MIN_INCREMENT`: a roll's and a rolling branch's."""
    cap = min(settings.max_increment, cap)
    return dataclasses.replace(settings, max_increment=cap,
                               initial_increment=min(settings.initial_increment, cap),
                               min_increment=min(settings.min_increment, cap,
                                                 ROLL_MIN_INCREMENT))


def _capped(settings: SolverSettings, roll: Roll) -> SolverSettings:
    """:func:`capped_increments` for a roll (an increment is a fraction of step time;
    the roll lasts :func:`roll_time`)."""
    return capped_increments(settings, travel_cap(settings) * roll_time(roll) / roll.distance)


def turned(xyz: np.ndarray, spin: float) -> np.ndarray:
    """Points (n, 3) turned by ``spin`` radians about +y through the origin (the wheel's
    spin axis; a positive turn carries the bottom of the tyre towards -x)."""
    c, s = math.cos(spin), math.sin(spin)
    x, y, z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    return np.stack([c * x + s * z, y, -s * x + c * z], axis=1)


def on_grid(values: np.ndarray, mesh: TyreMesh, spin: float,
            grid: np.ndarray | None = None) -> np.ndarray:
    """Per-node ``values`` (n_nodes, k) of a tyre turned by ``spin`` radians, read at the
    grid's positions fixed in the contact frame: (n_rows, n_columns, k).

    The grid's columns sit at angles phi (0 under the wheel centre, positive towards
    +x, :attr:`farm.mesh.tyremesh.TyreMesh.angles`); a turn by ``spin`` about +y takes the
    material at phi + spin to phi. So column j reads each row's values at phi_j + spin,
    linear between the columns and periodic round the tyre: what a camera fixed to the
    contact centre sees at the place of column j (T2Cam's view, thesis §2.2). At a whole
    number of column pitches of a uniform grid it is the columns shifted.
    """
    grid = mesh.inner_grid if grid is None else grid
    if not mesh.periodic:
        raise SpecError("a rolled tyre needs the full model (its grid wraps around)")
    phi = np.asarray(mesh.angles, dtype=float)
    order = np.argsort(phi)
    at = phi + spin
    rows = values[grid - 1]  # (n_rows, n_columns, k)
    out = np.empty_like(rows)
    for r in range(rows.shape[0]):
        for c in range(rows.shape[2]):
            out[r, :, c] = np.interp(at, phi[order], rows[r, order, c], period=2 * np.pi)
    return out


def turn_matrix(spin: float) -> np.ndarray:
    """The matrix of :func:`turned`: ``turned(p, spin) == p @ turn_matrix(spin).T``."""
    c, s = math.cos(spin), math.sin(spin)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def turned_strain(strain: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Strains (n, 6) in ccx's components xx, yy, zz, xy, yz, zx
    (:attr:`SolvedState.strain`) with their axes turned: R E R^T for each."""
    e = r @ strain[:, [[0, 3, 5], [3, 1, 4], [5, 4, 2]]] @ r.T
    return e[:, [0, 1, 2, 0, 1, 2], [0, 1, 2, 1, 2, 0]]


def start_spin(spec: ModelSpec, roll: Roll) -> float:
    """The turn (rad, about +y as :func:`turned`) given to the tyre before ``roll``.

    A windowed mesh (:mod:`farm.spacing`) is refined in the material, so a roll carries
    its window away from the road (issue 30). It starts turned back by the roll's own
    spin: the window is ahead of the road, rolls in, and ends centred under the contact,
    where a standing tyre has it, so the rolled state is read at the stored mesh's own
    nodes. A uniform mesh starts as meshed (0): its elements are alike all round.
    """
    return -roll.spin if spec.mesh.windowed else 0.0


def turned_mesh(mesh: TyreMesh, start: float) -> TyreMesh:
    """``mesh`` with its nodes turned by ``start`` (its sets, grids and angles as they
    were: they name material, not places)."""
    if start == 0.0:
        return mesh
    return dataclasses.replace(mesh, nodes=turned(mesh.nodes, start))


def _unturned(state: SolvedState, start: float, mesh: TyreMesh, *,
              whole: bool) -> SolvedState:
    """A state solved on ``turned_mesh(mesh, start)``, referred to ``mesh``.

    Strains are Lagrange strains of the material, so only their axes change: E' = Q^T E Q,
    Q the start's turn. ``whole``: the solution turned back as a whole (the inflated tyre,
    which no road touches: displacement Q^T u); otherwise the start's turn joins the
    displacement (the rolled tyre stays where the road has it) and the road's forces stay.
    """
    if start == 0.0:
        return state
    q = turn_matrix(start)
    strain = turned_strain(state.strain, q.T)
    if whole:
        return dataclasses.replace(state, displacement=state.displacement @ q,
                                   strain=strain, tread_force=state.tread_force @ q)
    moved = turned(mesh.nodes, start) - mesh.nodes
    return dataclasses.replace(state, displacement=state.displacement + moved, strain=strain)


def _rolled(state: SolvedState, reference: SolvedState, mesh: TyreMesh, roll: Roll,
            fraction: float, start: float = 0.0) -> RolledState:
    """A roll's state at ``fraction`` of ``roll`` (:func:`rolled_at`)."""
    return rolled_at(state, reference, mesh, roll.rolling_radius, fraction,
                     fraction * roll.distance, fraction * roll.spin, start)


def rolled_at(state: SolvedState, reference: SolvedState, mesh: TyreMesh, radius: float,
              fraction: float, travelled: float, spin: float,
              start: float = 0.0) -> RolledState:
    """A rolled state from the combined-load state at its time (the road's reaction and
    moment, tread forces, stick/slip) and the inflated tyre's, both referred to the
    stored ``mesh`` (:func:`_unturned`), ``travelled`` mm and ``spin`` rad from the
    roll's start; its ``solved`` state carries the radius the rim turned with."""
    state = dataclasses.replace(_unturned(state, start, mesh, whole=False),
                                rolling_radius=float(radius))
    reference = _unturned(reference, start, mesh, whole=True)
    assert state.road_moment is not None and state.contact_status is not None
    camera = state.displacement - (turned(mesh.nodes + reference.displacement,
                                          start + spin) - mesh.nodes)
    return RolledState(fraction, travelled, spin, state.road_reaction,
                       state.road_moment, state.tread_force, state.contact_status,
                       state.displacement, camera, state, reference, start)


def solve_roll(spec: ModelSpec, mesh: TyreMesh, deflection: float, pressure: float,
               roll: Roll, settings: SolverSettings, fractions: Sequence[float] = (1.0,),
               should_stop: Callable[[], bool] | None = None) -> list[RolledState]:
    """Roll the inflated, deflected tyre; one state per fraction of the roll."""
    return _roll_run(spec, mesh, deflection, pressure, roll, settings, fractions,
                     should_stop)[1]


def _roll_run(spec: ModelSpec, mesh: TyreMesh, deflection: float, pressure: float,
              roll: Roll, settings: SolverSettings, fractions: Sequence[float],
              should_stop: Callable[[], bool] | None) -> tuple[CcxRun, list[RolledState]]:
    """Solve the roll; its states at ``fractions``. A roll that stops raises its
    :class:`SolverError` holding the states it reached (``partial``, issue 45); with
    restart points (``settings.restart_every_mm``) its next run goes on from the last
    one it passed (:mod:`farm.solve.roll_restart`)."""
    if not spec.inflated or spec.road != "contact":
        raise SpecError("rolling needs the inflated full model with the contact road "
                        "(model kind 'full', road 'contact')")
    # the deflection is from the stored mesh's first touch: where the roll ends
    touch_z, _ = touch_height(spec, mesh, pressure, settings, should_stop)
    start = start_spin(spec, roll)
    solved = turned_mesh(mesh, start)
    every = settings.restart_every_mm
    deck, times, road, z_start = roll_deck(spec, solved, deflection, pressure, roll,
                                           settings, touch_z, fractions, every=every)
    point_key = roll_restart.key(deck) if every > 0 else None
    run, frd, error, point = _run_roll(deck, settings, should_stop, roll, point_key)
    # the contact centre: under the wheel centre, on the road plane at the deflection
    centre_z = z_start + tilted_gap(spec, roll.tilt) + deflection
    faces = slave_faces(mesh)
    motion = RoadMotion(friction=roll.friction, tilt=roll.tilt, rise="normal")
    still = RoadMotion(friction=roll.friction)

    def states(at: Sequence[tuple[float, float]]) -> list[RolledState]:
        base = frd if point is None else point.frd  # the roll from rest's own results
        if base is None:
            raise ResultsError("the roll's results could not be read")
        reference = combined_state(base, solved, faces, road, 1.0, 0.0, np.nan, still)
        out = []
        for t, f in at:
            source, seconds = _source(point, frd, run, t)
            state = combined_state(source, solved, faces, road, t, deflection, centre_z,
                                   motion, seconds)
            out.append(_rolled(state, reference, mesh, roll, f, start))
        return out

    if error is None:
        return run, states(list(zip(times, fractions, strict=True)))
    if error.reached is not None:
        error = error.located(_stage(layout_time(roll, error.reached, every), deflection,
                                     roll))
    if point is not None:
        error = error.noting(f"It rolled on from its restart point at "
                             f"{_travel_at(roll, point.time, every):.1f} mm of travel")
    # a resumed run reached the point at least, even if no increment of its own converged
    reached = max(error.reached or 0.0, 0.0 if point is None else point.time)
    kept = _reached(states, times, fractions, frd if point is None else point.frd, reached)
    raise error.with_partial(tuple(kept) or None)


def _run_roll(deck: str, settings: SolverSettings, should_stop: Callable[[], bool] | None,
              roll: Roll, point_key: dict | None
              ) -> tuple[CcxRun, FrdFile | None, SolverError | None,
                         roll_restart.RestartPoint | None]:
    """Run a roll's deck from rest, or from the restart point a stopped run of it kept
    (then the point too); a roll with restart points (``point_key``) that stops keeps
    its last, one that finishes from a point drops it."""
    if point_key is None:
        return (*run_deck_keeping(deck, settings, should_stop, "roll"), None)
    point = roll_restart.load(point_key)
    if point is None:
        split = roll_split(roll, settings.restart_every_mm)
        assert split is not None  # restart points cut the roll

        def keep_point(stopped: CcxRun) -> None:
            roll_restart.save(point_key, stopped, split)

        return (*run_deck_keeping(deck, settings, should_stop, "roll", on_stop=keep_point),
                None)
    run, frd, error = run_deck_keeping(roll_restart.resumed_deck(deck, point.step), settings,
                                       should_stop, "roll", inputs={"rin": point.block})
    if error is None:
        roll_restart.drop(point_key)
    return run, frd, error, point


def _source(point: roll_restart.RestartPoint | None, frd: FrdFile | None, run: CcxRun,
            t: float) -> tuple[FrdFile, float]:
    """The results holding a roll's time ``t`` and the seconds it took to get there: a
    resumed roll's states up to its restart point are the stopped run's."""
    if point is not None and t <= point.time + 1e-9:
        return point.frd, point.seconds_to(t)
    if frd is None:
        raise ResultsError(f"the roll's results at time {t:g} could not be read")
    return frd, (0.0 if point is None else point.seconds) + run.seconds_to(t)


def _travel_at(roll: Roll, total: float, every: float) -> float:
    """Road travel (mm) of the roll's deck at total time ``total``."""
    return max(0.0, layout_time(roll, total, every) - 2.0) / roll_time(roll) * roll.distance


def _reached(states: Callable[[Sequence[tuple[float, float]]], list[RolledState]],
             times: Sequence[float], fractions: Sequence[float], frd: object,
             reached: float) -> list[RolledState]:
    """The states a stopped roll converged at before it stopped (at total time
    ``reached``), in order; none where its ``.frd`` cannot be read or lacks them (the
    roll then keeps nothing)."""
    at = [(t, f) for t, f in zip(times, fractions, strict=True) if t <= reached + 1e-9]
    if frd is None or not at:
        return []
    try:
        return states(at)
    except ResultsError:
        return []


def with_stick_slope(spec: ModelSpec, motion: RoadMotion) -> ModelSpec:
    """``spec`` with ``motion.stick_slope`` (where set) as its contact law's.

    Why: a roll's deck takes the stick slope from the model's contact law (a :class:`Roll`
    carries none), while a motion given through the API may set its own, and its
    experiment id says so; until 2026-11-29 a roll ran with the law's value whatever the
    motion said."""
    if motion.stick_slope is None:
        return spec
    return dataclasses.replace(spec, contact=dataclasses.replace(
        spec.contact, stick_slope=motion.stick_slope))


def roll_path(spec: ModelSpec, mesh: TyreMesh, path: LoadPath, settings: SolverSettings,
                should_stop: Callable[[], bool] | None = None,
                ) -> tuple[list[RolledState], float, int, int]:
    """A rolling path (``path.motion.rolls``): its states at ``path.motion_fractions``
    of the roll (the roll's end alone by default; issue 45: every state a study keeps),
    and the solver seconds, ccx runs and increments it took. The roll always goes to its
    end: a state's values do not depend on which others are kept.

    A free rolling radius (``motion.rolling_radius`` None) is found first
    (:func:`cached_free_radius`: a few rolls of :func:`free_roll_mm` at kappa = 0, or
    none when another experiment found it); the seconds and runs count those rolls too.
    The experiment's own roll is always a run of its own, even where a search roll had
    the same distance and slip. A roll that stops raises its :class:`SolverError` with
    the states it reached (``partial``). The camera's view of the states is
    :func:`farm.measure.camera.rolling_solution`'s.
    """
    motion = path.motion
    if motion is None or not motion.rolls:
        raise SpecError("not a rolling path: give the motion a roll (mm of road travel)")
    if len(path.deflections) != 1:
        raise SpecError(f"a rolling path has one deflection, got {list(path.deflections)}")
    [deflection] = path.deflections
    spec = with_stick_slope(spec, motion)
    radius, tried = motion_radius(spec, mesh, motion, deflection, path.pressure, settings,
                                  should_stop)
    spent, runs = sum(t.seconds for t in tried), len(tried)
    increments = sum(t.increments for t in tried)
    try:
        run, states = _roll_run(spec, mesh, deflection, path.pressure,
                                motion.as_roll(radius), settings, path.motion_fractions,
                                should_stop)
    except SolverError as e:
        if isinstance(e.partial, tuple):  # the rolled states it reached
            e = e.with_partial(tuple(_after(s, spent) for s in e.partial))
        if not motion.searches_radius:
            raise e from None
        # what the search found is kept (and cached: a retry rolls at once)
        raise e.noting(f"The free-rolling radius found before the roll: {radius:.3f} mm "
                       f"({runs} rolls, {spent:.0f} s; 0 rolls: cached)") from e
    return ([_after(s, spent) for s in states], spent + run.seconds, runs + 1,
            increments + run.increments)


def _after(state: RolledState, seconds: float) -> RolledState:
    """``state`` with ``seconds`` (a free-radius search's) added to what reaching it
    cost: a state's ``solve_seconds`` is the solver time its experiment took."""
    solved = dataclasses.replace(state.solved,
                                 solve_seconds=seconds + state.solved.solve_seconds)
    return dataclasses.replace(state, solved=solved)


#: Road travel (mm) of the rolls that look for a free-rolling radius (roll_path): at
#: least one element pitch of the coarse meshes (158 mm at 16 round) past their roll-in.
FREE_ROLL_MM = 400.0

#: The same on a windowed mesh, whose element under the road at the roll's end is the
#: window's (2 degrees, 14 mm on ``patch``): the longest roll whose start stays within
#: the window (``patch``: 150 mm turn 21 of its +-32 degrees) and past Fx's roll-in (within
#: 1 % after 135 mm on 32 elements round, docs/rolling.md).
FREE_ROLL_WINDOWED_MM = 150.0


def free_roll_mm(spec: ModelSpec) -> float:
    """Road travel (mm) of a free-rolling radius search's rolls on ``spec``'s mesh."""
    return FREE_ROLL_WINDOWED_MM if spec.mesh.windowed else FREE_ROLL_MM


def search_roll(spec: ModelSpec, motion: RoadMotion) -> Roll:
    """The roll a free-rolling radius search of ``motion`` tries radii with: the motion's
    friction, slip angle and tilt over :func:`free_roll_mm` (its radius is the search's
    to set). Until 2026-11-29 the search rolled the experiment's own distance (the
    search length was passed where a radius stands in), so a 60 mm roll on a 16-round
    mesh searched with 60 mm rolls read at their end, not 400 mm rolls averaged over
    a pitch as this module says."""
    free = dataclasses.replace(motion, roll=free_roll_mm(spec), slip_ratio=0.0, roll_from=0.0,
                               rolling_radius=None)
    return free.as_roll(spec.geometry.outer_radius)


def cached_free_radius(spec: ModelSpec, mesh: TyreMesh, deflection: float, pressure: float,
                       roll: Roll, settings: SolverSettings,
                       should_stop: Callable[[], bool] | None = None,
                       ) -> tuple[float, list[RadiusTry]]:
    """:func:`free_rolling_radius`, cached per model, mesh, pressure, deflection, roll
    (its slip ratio and radius aside) and solver, as the inflation is
    (:mod:`farm.solve.entries`): a retried experiment, a resumed study or the slip ratios
    of one slip angle search once. Returns (r_e, the rolls tried; none when the cache
    answered)."""
    key = {"model": spec.to_dict(), "mesh": mesh.mesh_key, "pressure": pressure,
           "deflection": deflection, "solver": ccx_version(),
           "roll": {k: v for k, v in dataclasses.asdict(roll).items()
                    if k not in ("slip_ratio", "rolling_radius")  # entries from before:
                    and (k, v) not in (("friction_from", "touch"), ("lead", 0.0),
                                       ("lead_x", 0.0))}}
    if spec.mesh.windowed:  # searched with the window ahead (start_spin) since issue 30
        key["start"] = "window ahead"
    entry = read_entry("free-radius", key)
    if entry is not None and isinstance(entry.get("radius_mm"), float):
        return entry["radius_mm"], []
    radius, tried = free_rolling_radius(spec, mesh, deflection, pressure, roll, settings,
                                        should_stop=should_stop)
    write_entry("free-radius", key, {"radius_mm": radius})
    return radius, tried


def layout_time(roll: Roll, total: float, every: float = 0.0) -> float:
    """The one-step layout's time (inflation [0, 1], rise [1, 2], roll after) of the
    roll's deck's total time ``total`` (the holds of :func:`roll_split`'s cuts map to
    their cuts)."""
    split = roll_split(roll, every)
    return total if split is None else split.layout(total)


def _stage(time: float, deflection: float, roll: Roll) -> str:
    """Where along the roll's deck step ``time`` lies."""
    if time < 1.0:
        return f"in the inflation, {100 * time:.0f} % of the pressure"
    if time < 2.0:
        return f"in the rise to {deflection:g} mm, {100 * (time - 1.0):.0f} % of it"
    travelled = (time - 2.0) / roll_time(roll) * roll.distance
    return f"in the roll at {deflection:g} mm, after {travelled:.1f} mm"


def element_pitch(spec: ModelSpec, roll: Roll) -> float:
    """Road travel (mm) over which the rolling tyre advances by the element that is under
    the contact centre at the roll's end: r_e times its angle, r_e the roll's rolling
    radius. On a uniform mesh every element is 2 pi / n round; on a windowed one
    (:mod:`farm.spacing`) the element is the one the roll's turn has carried there (the
    material at angle ``start + spin`` ends under the centre, :func:`on_grid`): the
    window's, as the roll starts with it ahead (:func:`start_spin`)."""
    m = spec.mesh
    if not spec.is_full:  # a sector's elements do not go round: it cannot roll
        raise SpecError("rolling needs the full model (its elements go all round)")
    if not m.windowed:
        return 2.0 * math.pi * roll.rolling_radius / m.circumferential
    edges = column_angles(spec.sector_angle, m.circumferential, spec.is_full, m.window,
                          m.window_elements)
    edges = np.append(edges, edges[0] + 2.0 * math.pi)  # the full tyre's columns wrap
    at = (start_spin(spec, roll) + roll.spin - edges[0]) % (2.0 * math.pi) + edges[0]
    k = min(int(np.searchsorted(edges, at, side="right")) - 1, len(edges) - 2)
    return float(edges[k + 1] - edges[k]) * roll.rolling_radius


def last_pitch(spec: ModelSpec, roll: Roll, samples: int = 8) -> list[float]:
    """``samples`` fractions of ``roll`` spread evenly over its last element pitch,
    increasing, the last 1.0 (the roll's end)."""
    pitch = element_pitch(spec, roll)
    if samples < 1 or pitch >= roll.distance:
        raise ValueError(f"a roll of {roll.distance:g} mm is shorter than its element pitch "
                         f"({pitch:.1f} mm): roll further to average over a pitch")
    step = pitch / samples / roll.distance
    return [1.0 - step * k for k in range(samples - 1, -1, -1)]


@dataclass(frozen=True)
class RadiusTry:
    """One roll of :func:`free_rolling_radius`: its radius (mm), Fx and Fz (N) averaged
    over its last element pitch (at its end when the roll is shorter than a pitch), and
    what its ccx run cost."""

    radius: float
    fx: float
    fz: float
    seconds: float
    increments: int


def free_rolling_radius(spec: ModelSpec, mesh: TyreMesh, deflection: float, pressure: float,
                        roll: Roll, settings: SolverSettings, *, tolerance: float = 0.005,
                        max_rolls: int = 6,
                        should_stop: Callable[[], bool] | None = None,
                        ) -> tuple[float, list[RadiusTry]]:
    """The effective rolling radius r_e: where a roll at ``roll.slip_ratio`` = 0 ends
    with Fx = 0 (within ``tolerance`` of Fz). Secant steps on 1/r (the spin per mm of
    travel, in which Fx is nearly linear near free rolling), starting from
    R - deflection / 3 and R, R the inflated tyre's outer radius (:func:`inflated_radius`).

    Fx and Fz are means over the roll's last element pitch (:func:`last_pitch`, 8
    states): a meshed tyre is a polygon, and its Fx swings with where the tread columns
    are within the pitch (-86 to +116 N on 16 elements round, 25-65 N on 32;
    docs/rolling.md), so Fx at one state would put that phase into r_e (0.6 mm on 16
    round). A roll shorter than a pitch is read at its end.

    Returns (r_e, every roll tried).
    """
    r0 = inflated_radius(spec, mesh, pressure, settings)
    free = dataclasses.replace(roll, slip_ratio=0.0)
    tried: list[RadiusTry] = []
    radius = r0 - deflection / 3.0
    while len(tried) < max_rolls:
        trial = dataclasses.replace(free, rolling_radius=radius)
        fractions = (last_pitch(spec, trial) if element_pitch(spec, trial) < trial.distance
                     else [1.0])
        run, states = _roll_run(spec, mesh, deflection, pressure, trial, settings,
                                fractions, should_stop)
        fx, fz = (float(np.mean([s.force[k] for s in states])) for k in (0, 2))
        tried.append(RadiusTry(radius, fx, fz, run.seconds, run.increments))
        if abs(fx) <= tolerance * abs(fz):
            return radius, tried
        if len(tried) == 1:
            radius = r0
            continue
        a, b = tried[-2:]
        if b.fx == a.fx:
            break
        radius = 1.0 / (1.0 / b.radius - b.fx * (1.0 / b.radius - 1.0 / a.radius)
                        / (b.fx - a.fx))
    raise ResultsError(f"no free-rolling radius found: Fx at the radii tried (mm, N) was "
                       f"{[(round(t.radius, 3), round(t.fx, 1)) for t in tried]}; allow more "
                       "rolls (max_rolls) or a looser tolerance")


#: How far the free-rolling radius lies below the inflated tyre's radius, per mm of
#: deflection (:func:`estimated_radius`): a first guess. It came from a search of 20 mm
#: rolls (``farm roll --distance 20`` searched with the roll's own length until
#: 2026-11-30), 394.7 mm against 403.5 mm inflated on ``patch`` at 200 kPa and 15 mm;
#: measured from rolling trees' own states (:mod:`analysis.free_rolling`) the drop is
#: 0.71-0.75 there and 0.38-0.54 on ``lean`` at 80-102 kPa - in millimetres nearly
#: constant, 8.9-10.9 mm over 15-28 mm of deflection (docs/rolling.md). The answer's
#: study (issue 46) keeps 0.59 and measures each tree's offset.
FREE_RADIUS_DROP = 0.59


def estimated_radius(spec: ModelSpec, mesh: TyreMesh, deflection: float, pressure: float,
                     settings: SolverSettings) -> float:
    """The free-rolling radius's estimate, R - :data:`FREE_RADIUS_DROP` x deflection, mm,
    R the inflated tyre's radius (:func:`inflated_radius`, cached): no roll, where a
    search (:func:`free_rolling_radius`) costs about three. A roll at it is not free
    rolling exactly: its Fx at kappa = 0 shows the gap (issue 46's study stores it)."""
    return inflated_radius(spec, mesh, pressure, settings) - FREE_RADIUS_DROP * deflection


def motion_radius(spec: ModelSpec, mesh: TyreMesh, motion: RoadMotion, deflection: float,
                  pressure: float, settings: SolverSettings,
                  should_stop: Callable[[], bool] | None = None,
                  ) -> tuple[float, list[RadiusTry]]:
    """The radius a roll of ``motion`` turns the rim with - the given one, the estimate
    (:func:`estimated_radius`) or a search (:func:`cached_free_radius`) - and the search's
    rolls (none for the other two, or when the cache answered). Rolls from rest and
    rolling trees' trunks take theirs here."""
    if motion.rolling_radius is not None:
        return motion.rolling_radius, []
    if motion.radius_estimate:
        return estimated_radius(spec, mesh, deflection, pressure, settings), []
    return cached_free_radius(spec, mesh, deflection, pressure, search_roll(spec, motion),
                              settings, should_stop)


def inflated_radius(spec: ModelSpec, mesh: TyreMesh, pressure: float,
                    settings: SolverSettings) -> float:
    """The inflated, unloaded tyre's radius at the road's first touch, mm (the wheel
    centre is the origin; :func:`farm.solve.contact.touch_height`, cached)."""
    touch_z, _ = touch_height(spec, mesh, pressure, settings)
    return -touch_z
