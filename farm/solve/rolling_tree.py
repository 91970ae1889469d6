"""Rolling trees (issue 45): a roll's trunk solved once, branches rolled on from its end.

A roll from rest repeats, for every experiment, the inflation, the rise and the roll-in
that its neighbours in the design also do; on `patch` the roll-in (about 135 mm until Fx
is steady, docs/rolling.md) is most of a roll's cost. A rolling tree shares them, as the
static load-path trees share the rise (:mod:`farm.solve.tree`):

- the **trunk** (:func:`solve_rolling_trunk`) is the one-run roll of
  :func:`farm.solve.rolling.roll_deck` (inflate, tilt, rise, roll at the trunk's slip),
  with ``*RESTART, WRITE``: the solver's state at the roll's end is kept. Its states
  along the roll are experiments too;
- a **branch** (:func:`solve_rolling_branch`) reads that state and rolls on in one step
  with its own slip ratio and slip angle (friction, camber and the rolling radius are
  the trunk's): the road travels on from where the trunk left it, the rim turns on
  from the trunk's spin. Its states are kept at the trunk's ``fractions`` of the branch.

A new step starts with a hold (:func:`farm.ccx.deck.road_step_lines` says why: ccx's
first iteration of a step whose prescribed displacements move is linear and sees the
whole preload as out of balance): road and rim stay where the trunk left them for the
first :data:`BRANCH_DWELL` of the step, then move on. The pause costs
nothing physically - the model is quasi-static and rate-free - so a branch that rolls
on at the trunk's own slip is the same roll as one run from rest
(tests/farm/test_rolling_tree.py).

Kinematics as in :mod:`farm.solve.rolling`: over the branch the road moves by
``branch.travel`` in its plane and the rim turns by ``branch.spin``, on top of the
trunk's.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from farm.ccx import deck as D
from farm.ccx.frd import FrdFile, read_frd
from farm.ccx.outcome import Outcome
from farm.ccx.runner import CcxRun, failure, run_ccx, scratch_dir
from farm.errors import ResultsError, SpecError
from farm.mesh.tyremesh import TyreMesh
from farm.solve.contact import combined_state, slave_faces, tilted_gap, touch_height
from farm.solve.rolling import (
    RIM_PIECE_RAD,
    RIM_PIECES,
    STEP_GROW_AFTER,
    STEP_HOLD,
    RolledState,
    capped_increments,
    roll_deck,
    roll_split,
    rolled_at,
    travel_cap,
    turned,
    turned_mesh,
)
from farm.solve.states import SolvedState
from farm.solve.tree import split_restart
from farm.specs import MAX_BRANCH_MM, ModelSpec, RoadMotion, Roll, SolverSettings

#: The ``*TIME POINTS`` a branch writes its states at (defined by the trunk's deck:
#: ccx takes time points only before the first step).
BRANCH_POINTS = "BRANCH"

#: ccx's IG in a branch (:attr:`farm.specs.SolverSettings.grow_after`, at least): the
#: increments after a branch's hold grow once two of them took at most this many
#: iterations. A roll that starts moving, from rest or after the hold, is cut to
#: 1e-4-1e-5 of its step before it converges, and grows back by 1.5x an increment; at
#: ccx's default 4 a kappa = 0 branch of the coarse model from a 60 mm trunk converged
#: an increment of 0.67 mm in 10 iterations at 62 mm, kept that size, and then stopped
#: "increment below minimum" at a tread node's entry. At 10 it grew past it (as a
#: growth factor of 4 did): the one-run roll takes that place with 5 mm increments.
BRANCH_GROW_AFTER = STEP_GROW_AFTER

#: The part of a branch's step for which road and rim hold still (the hold of
#: :func:`farm.ccx.deck.road_step_lines`). ccx tries the first moving increment at the
#: hold's size, and a branch's first moving increment converges only at about 1e-4 (16
#: round) to 2e-3 (`patch`) of its step: with a hold of 0.1 of the step (3 mm of a
#: 30 mm branch, :data:`~farm.ccx.deck.STEP_DWELL` as the static trees') a branch of
#: `patch` failed three tries (13, 12 and 8 iterations) before converging 1/64 of it,
#: a third of its iterations. With 0.002 its branches took 1.60x less ccx time, their
#: states within 0.071 % of |F| and 0.099 % of the camera field's RMS
#: (`benchmarks/bench_branch_hold.py --mesh patch`, docs/rolling.md). The hold is a
#: pause in step time, not in travel (the model is rate-free).
BRANCH_DWELL = STEP_HOLD


@dataclass(frozen=True, eq=False)
class RollingTrunk:
    """A solved rolling trunk: its states and the solver's state at the roll's end.

    ``roll`` is the trunk's roll (friction, camber and rolling radius shared by every
    branch), ``states`` its states at the fractions it was asked for, ``restart`` ccx's
    restart block at the roll's end (zlib-compressed). ``branch_mm`` is the longest
    branch the road was made for and ``fractions`` the fractions of a branch at which
    branches write their states. The rest is what a branch's results are read with:
    the stored ``mesh`` and the mesh as ``solved`` (turned by ``start``, rad: a windowed
    mesh's start, :func:`trunk_start`), the inflated tyre on it (``reference``), the
    ``road`` and the contact centre's height ``centre_z`` (mm).
    """

    roll: Roll
    deflection: float
    pressure: float
    states: tuple[RolledState, ...]
    restart: bytes
    branch_mm: float
    fractions: tuple[float, ...]
    mesh: TyreMesh
    solved: TyreMesh
    start: float
    reference: SolvedState
    road: D.Road
    centre_z: float
    seconds: float
    increments: int

    def read(self, frd: FrdFile, t: float, fraction: float, travelled: float, spin: float,
             seconds: float) -> RolledState:
        """The rolled state at time ``t`` of ``frd`` (the trunk's or a branch's), at
        ``travelled`` mm and ``spin`` rad from the roll's start."""
        roll = self.roll
        motion = RoadMotion(friction=roll.friction, tilt=roll.tilt, rise="normal")
        state = combined_state(frd, self.solved, slave_faces(self.solved), self.road, t,
                               self.deflection, self.centre_z, motion, seconds)
        return rolled_at(state, self.reference, self.mesh, roll.rolling_radius, fraction,
                         travelled, spin, self.start)

    def read_all(self, frd: FrdFile, at: Sequence[tuple[float, float]],
                 seconds: Callable[[float], float]) -> tuple[RolledState, ...]:
        """The trunk's own states at (time, fraction of its roll) ``at``."""
        roll = self.roll
        return tuple(self.read(frd, t, f, f * roll.distance, f * roll.spin, seconds(t))
                     for t, f in at)


def branch_time(fraction: float) -> float:
    """Step time of a branch at ``fraction`` of its travel: road and rim hold still for
    the first :data:`BRANCH_DWELL` of the step."""
    return BRANCH_DWELL + fraction * (1.0 - BRANCH_DWELL)


def _fractions(fractions: Sequence[float]) -> tuple[float, ...]:
    out = tuple(float(f) for f in fractions)
    if not out or any(not 0 < f <= 1 for f in out) or any(
            b <= a for a, b in itertools.pairwise(out)):
        raise SpecError(f"branch fractions must increase strictly within (0, 1], got "
                        f"{list(out)}")
    return out


def trunk_start(spec: ModelSpec, roll: Roll, branch_mm: float) -> float:
    """The turn given to the tyre before the trunk: a windowed mesh starts with its
    window ahead by the trunk's spin and a free-rolling branch's, so that a branch ends
    with the window about the contact (0 on a uniform mesh)."""
    if not spec.mesh.windowed:
        return 0.0
    return -(roll.spin + branch_mm / roll.rolling_radius)


def solve_rolling_trunk(spec: ModelSpec, mesh: TyreMesh, deflection: float,
                        pressure: float, roll: Roll, settings: SolverSettings, *,
                        branch_mm: float, fractions: Sequence[float] = (1.0,),
                        branch_fractions: Sequence[float] = (1.0,),
                        should_stop: Callable[[], bool] | None = None) -> RollingTrunk:
    """Roll the trunk and keep the solver's state at its end.

    ``fractions``: the trunk's own states (of its roll); ``branch_mm``: the longest
    branch that will roll on from it (the road is made long enough); ``branch_fractions``:
    where along a branch its states are written.

    Raises :class:`~farm.errors.SolverError` when the trunk's roll stops, holding the
    states it reached (``partial``, as a roll from rest does): without the roll's end no
    branch can start.
    """
    if not 0 < branch_mm <= MAX_BRANCH_MM:
        raise SpecError(f"a branch rolls 0-{MAX_BRANCH_MM:g} mm, got {branch_mm!r}")
    if not spec.inflated or spec.road != "contact":
        raise SpecError("rolling needs the inflated full model with the contact road "
                        "(model kind 'full', road 'contact')")
    along = _fractions(branch_fractions)
    touch_z, _ = touch_height(spec, mesh, pressure, settings, should_stop)
    start = trunk_start(spec, roll, branch_mm)
    solved = turned_mesh(mesh, start)
    model = [*D.restart_lines(read=False, write=True), f"*TIME POINTS, NAME={BRANCH_POINTS}",
             *(D.fnum(branch_time(f)) for f in along)]
    deck, times, road, z_start = roll_deck(spec, solved, deflection, pressure, roll,
                                           settings, touch_z, fractions, model=model,
                                           ahead=branch_mm)
    centre_z = z_start + tilted_gap(spec, roll.tilt) + deflection
    blank = RollingTrunk(roll, deflection, pressure, (), b"", float(branch_mm), along, mesh,
                         solved, start, None, road, centre_z, 0.0, 0)  # type: ignore[arg-type]
    return _run_trunk(blank, deck, list(zip(times, fractions, strict=True)), settings,
                      should_stop)


def _run_trunk(blank: RollingTrunk, deck: str, at: list[tuple[float, float]],
               settings: SolverSettings, should_stop: Callable[[], bool] | None
               ) -> RollingTrunk:
    """Run the trunk's deck; ``blank`` is the trunk but for what the run gives (its
    reference, restart block, states, seconds and increments); ``at``: (time, fraction)
    of each of its states."""
    with scratch_dir(keep=settings.keep_scratch, prefix="rtrunk-") as workdir:
        run = run_ccx(deck, workdir, jobname="trunk", threads=settings.threads,
                      timeout=settings.timeout, should_stop=should_stop, check=False)
        if run.outcome is not Outcome.CONVERGED:
            error = failure(run)
            if run.outcome is Outcome.CANCELLED or error.reached is None:
                raise error
            reached = [(t, f) for t, f in at if t <= error.reached + 1e-9]
            try:  # what it reached before it stopped (the reader drops a diverged output)
                cut = read_frd(run.file("frd"), allow_truncated=True)
                kept = _filled(blank, cut, run, b"").read_all(cut, reached, lambda t: run.seconds)
            except ResultsError:
                kept = ()
            raise error.located(f"in the trunk's straight roll of {blank.roll.distance:g} mm"
                                ).with_partial(kept or None)
        frd = read_frd(run.file("frd"))
        blocks = split_restart((workdir / "trunk.rout").read_bytes())
    steps = 1 if roll_split(blank.roll) is None else 2  # a frictionless rise: its own step
    if len(blocks) != steps:
        raise ResultsError(f"the rolling trunk wrote {len(blocks)} restart blocks, not {steps}")
    trunk = _filled(blank, frd, run, zlib.compress(blocks[-1], 1))
    return dataclasses.replace(trunk, states=trunk.read_all(frd, at, run.seconds_to))


def _filled(blank: RollingTrunk, frd: FrdFile, run: CcxRun, restart: bytes) -> RollingTrunk:
    """``blank`` with the run's inflated reference, restart block, seconds and increments."""
    reference = combined_state(frd, blank.solved, slave_faces(blank.solved), blank.road, 1.0,
                               0.0, np.nan, RoadMotion(friction=blank.roll.friction))
    return dataclasses.replace(blank, reference=reference, restart=restart,
                               seconds=run.seconds, increments=run.increments)


def rim_step_lines(mesh: TyreMesh, before: float, after: float) -> list[str]:
    """Step cards turning the bead seat on from ``before`` to ``after`` rad about +y:
    held for the step's first :data:`BRANCH_DWELL`, then along the circle
    (one amplitude per node and dof, as :func:`farm.solve.rolling.rim_lines`; names new
    to the run, ``RB_<node>_<dof>``)."""
    seat = np.asarray(mesh.node_sets["BEAD_SEAT"])
    xyz = mesh.nodes[seat - 1]
    pieces = max(RIM_PIECES, math.ceil(abs(after - before) / RIM_PIECE_RAD))
    times = branch_time(0.0) + np.linspace(0.0, 1.0 - branch_time(0.0), pieces + 1)
    u = np.stack([turned(xyz, phi) - xyz for phi in np.linspace(before, after, pieces + 1)],
                 axis=1)
    amplitudes, boundary = [], []
    for k, n in enumerate(seat):
        for dof in (1, 3):
            name = f"RB_{n}_{dof}"
            amplitudes += D.amplitude_lines(
                name, [(0.0, float(u[k, 0, dof - 1])), *zip(times, u[k, :, dof - 1],
                                                          strict=True)])
            boundary += [f"*BOUNDARY, AMPLITUDE={name}", f"{n}, {dof}, {dof}, 1"]
    return [*amplitudes, *boundary]


def check_branch(trunk: RollingTrunk, branch: Roll) -> None:
    """Refuse a branch that is not a continuation of ``trunk``'s roll (one line)."""
    roll = trunk.roll
    for name in ("friction", "tilt", "rolling_radius", "friction_from"):
        if getattr(branch, name) != getattr(roll, name):
            raise SpecError(f"a branch keeps its trunk's {name} ({getattr(roll, name)!r}), "
                            f"got {getattr(branch, name)!r}: give it its own trunk")
    if branch.distance > trunk.branch_mm:
        raise SpecError(f"the branch rolls {branch.distance:g} mm, its trunk's road was made "
                        f"for {trunk.branch_mm:g}: solve the trunk with branch_mm >= "
                        f"{branch.distance:g}")


def branch_deck(trunk: RollingTrunk, branch: Roll, settings: SolverSettings) -> str:
    """The deck of a branch: read the trunk's end state, roll on by ``branch`` in one
    step, results at the trunk's ``fractions`` of the branch."""
    roll = trunk.roll
    rise = trunk.centre_z - trunk.road.z_top  # the road's travel to the deflection
    before = (rise, roll.travel)
    after = (rise, (roll.travel[0] + branch.travel[0], roll.travel[1] + branch.travel[1]))
    cap = travel_cap(settings) * (1.0 - BRANCH_DWELL) / branch.distance
    capped = capped_increments(settings, cap)
    grow = max(settings.grow_after, BRANCH_GROW_AFTER)
    controls = D.friction_controls_lines(grow) if roll.friction > 0 else []
    return "\n".join([
        *D.restart_lines(read=True, write=False),
        *D.static_step_lines(1.0, capped, first=min(BRANCH_DWELL, cap)), *controls,
        *D.road_step_lines(trunk.road, before, after, roll.tilt, "normal", "BROAD",
                           dwell=BRANCH_DWELL),
        *rim_step_lines(trunk.solved, roll.spin, roll.spin + branch.spin),
        *D.cavity_pressure_lines(trunk.solved, trunk.pressure, None),
        *D.output_lines(time_points=True, contact=True, points=BRANCH_POINTS),
        "*END STEP"]) + "\n"


def solve_rolling_branch(trunk: RollingTrunk, branch: Roll, settings: SolverSettings,
                         should_stop: Callable[[], bool] | None = None
                         ) -> list[RolledState]:
    """Roll on from the trunk's end by ``branch`` (its slip ratio, slip angle and
    distance; friction, camber and rolling radius are the trunk's).

    Returns one state per fraction f of ``trunk.fractions``: the road travelled by the
    trunk's roll and f of the branch's, the rim turned by the trunk's spin and f of the
    branch's. A branch that stops raises :class:`~farm.errors.SolverError` holding the
    states it reached (``partial``, as a roll from rest does; None: none).
    """
    check_branch(trunk, branch)
    deck = branch_deck(trunk, branch, settings)
    roll = trunk.roll

    def states(frd: FrdFile, seconds: Callable[[float], float]) -> list[RolledState]:
        times = sorted({b.time for b in frd.results_named("DISP")})
        if len(times) > len(trunk.fractions):
            raise ResultsError(f"the branch wrote {len(times)} states for "
                               f"{len(trunk.fractions)} fractions")
        return [trunk.read(frd, t, f, roll.distance + f * branch.distance,
                           roll.spin + f * branch.spin, seconds(t))
                for t, f in zip(times, trunk.fractions, strict=False)]

    with scratch_dir(keep=settings.keep_scratch, prefix="rbranch-") as workdir:
        run = run_ccx(deck, workdir, jobname="branch", threads=settings.threads,
                      timeout=settings.timeout, should_stop=should_stop, check=False,
                      inputs={"rin": zlib.decompress(trunk.restart)})
        if run.outcome is Outcome.CONVERGED:
            done = states(read_frd(run.file("frd")), run.seconds_to)
            if len(done) != len(trunk.fractions):
                raise ResultsError(f"the branch wrote {len(done)} states for "
                                   f"{len(trunk.fractions)} fractions")
            return done
        error = failure(run)
        if run.outcome is Outcome.CANCELLED:
            raise error
        where = f"in the branch rolled on from the trunk's {roll.distance:g} mm"
        error = error.located(where) if error.reached is not None else error
        try:  # what it reached before it stopped (the reader drops a diverged output)
            reached = states(read_frd(run.file("frd"), allow_truncated=True),
                             lambda t: run.seconds)
        except ResultsError:
            reached = []
        raise error.with_partial(tuple(reached) or None)
