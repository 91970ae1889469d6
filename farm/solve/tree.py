"""Load-path trees (issue 29): a trunk solved once, branches continued from its states.

Every combined-load experiment of a study used to be a ccx run of its own: inflate, turn
the road to its tilt, push it up to the deflection with friction on, then slide it. Its
neighbours in the design repeat the same inflation and nearly the same rise. A tree
shares them:

- the **trunk** (:func:`solve_trunk`) is one ccx run per model, pressure, friction and
  tilt: the first step is the one-run path of :mod:`farm.solve.contact` up to the first
  deflection; each further deflection is a step of its own that raises the road
  (:func:`farm.ccx.deck.road_step_lines`). ``*RESTART, WRITE`` appends the solver's
  state at the end of every step to the restart file, so the trunk leaves one state per
  deflection (:func:`split_restart` cuts them apart). Its states at the deflections are
  experiments too (friction and tilt, no slide);
- a **branch** (:func:`solve_branch`) reads one of those states (``*RESTART, READ``) and
  slides the road in one step, with results at fractions of the slide: every fraction
  is the experiment of that shift (a monotonic slide passes through the same states as a
  shorter one along the same line).

Every later step holds the road where the last one left it for its first increment,
then moves it (step-time amplitudes: step time starts at 0 in a new step, so the first
step's would start over). Without the hold ccx 2.20 begins such a step with a linear
iteration that sees the whole preload as out of balance and diverges "whatever the
increment" (:func:`farm.ccx.deck.road_step_lines` has the source lines; on the coarse
tilted trunk of the tests the hold took a trunk that re-rooted in its third step to one
run of 8 s instead of three of 21 s).

Measured on the patch mesh with ``reinforced-calibrated`` before the hold (200 kPa, mu
0.6, tilt 2 degrees, slide (3, -4) mm; docs/combined-loads.md, "Load-path trees"): a
trunk through 10, 15 and 20 mm took 127 s, each branch 43-53 s, the same experiment
from rest 110-168 s; Fz agreed within 0.01 %, Fx and Fy within 0.7 %. Friction
remembers its path: a branch's partial-slip forces are as close to the run from rest as
two runs from rest with different increments are to each other (tests/farm/test_tree.py).
"""

from __future__ import annotations

import dataclasses
import itertools
import struct
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from farm.ccx import deck as D
from farm.ccx.frd import FrdFile, read_frd
from farm.ccx.runner import CcxRun, run_ccx, scratch_dir
from farm.errors import ResultsError, SolverError, SpecError
from farm.mesh.tyremesh import TyreMesh
from farm.solve.contact import (
    combined_state,
    path_deck,
    path_state,
    road_of,
    run_deck_keeping,
    slave_faces,
    stage,
    tilted_gap,
    touch_height,
)
from farm.solve.states import PathSolution, SolvedState
from farm.specs import LoadPath, ModelSpec, RoadMotion, SolverSettings

_VERSION_RECORD = b"Version"  # the first record of every step's block in a restart file


@dataclass(frozen=True, eq=False)
class Trunk:
    """A solved trunk: its states and the solver state at each of its deflections.

    ``solution`` holds the inflated reference and one state per deflection of ``path``
    (friction and tilt, unshifted); ``restarts[k]`` is ccx's restart block at
    ``path.deflections[k]``, zlib-compressed (:func:`solve_branch` continues from it);
    ``fractions`` are those of every branch's slide at which results are written (ccx
    takes ``*TIME POINTS`` only before the first step, so the trunk defines them).
    ``failure``: why the trunk stopped before its last deflection (a partial trunk: its
    ``path`` holds the deflections it reached), else None. ``reroots``: why each ccx run
    of the trunk but the last stopped, where the rest was re-rooted from rest
    (:func:`solve_trunk`).
    """

    path: LoadPath
    solution: PathSolution
    restarts: tuple[bytes, ...]
    touch_z: float
    fractions: tuple[float, ...] = (1.0,)
    failure: str | None = None
    reroots: tuple[str, ...] = ()

    @property
    def motion(self) -> RoadMotion:
        """Friction and tilt of the trunk (a zero motion for a vertical trunk)."""
        return self.path.motion or RoadMotion()


def split_restart(data: bytes) -> list[bytes]:
    """Cut a ccx restart file into its blocks, one per step written.

    The file is Fortran sequential unformatted (each record: its length as a 4-byte
    integer, the bytes, the length again); ccx's ``restartwrite`` starts every step's
    block with an 80-character record holding its version. Each block holds the whole
    model and state, so one block alone is a restart file of that step.
    """
    starts, pos = [], 0
    while pos < len(data):
        if pos + 4 > len(data):
            raise ResultsError(f"restart file cut short at byte {pos} of {len(data)}")
        (n,) = struct.unpack_from("<i", data, pos)
        end = pos + 8 + n
        if n < 0 or end > len(data) or data[end - 4:end] != data[pos:pos + 4]:
            raise ResultsError(f"restart file: record at byte {pos} is not a Fortran record")
        if data[pos + 4:pos + 4 + len(_VERSION_RECORD)] == _VERSION_RECORD:
            starts.append(pos)
        pos = end
    if not starts or starts[0] != 0:
        raise ResultsError("restart file does not start with a version record")
    return [data[a:b] for a, b in zip(starts, [*starts[1:], len(data)], strict=True)]


def _pressure_lines(spec: ModelSpec, mesh: TyreMesh, pressure: float) -> list[str]:
    return D.cavity_pressure_lines(mesh, pressure, None) if spec.inflated else []


#: ccx's IG in a slide (:attr:`farm.specs.SolverSettings.grow_after`, at least): an
#: increment grows once two in a row took at most this many iterations. Frictional
#: slides of ``patch`` converge in 5-9, so at ccx's default 4 a slide cut back once kept
#: its increment: the 1024-experiment study's slowest slides ran 30-60 min at 1/640-1/3000
#: of the slide (docs/combined-loads.md). Measured side by side
#: (``benchmarks/bench_static_branch.py``, 2026-12-01): its stalled slide (tree 7, 30.1 mm,
#: (3.89, 1.62) mm) stopped at a 15 min cap after its first fifth under IG 4 and took 95 s
#: under IG 10, equal there within 0.001 % of |F|; another slide of that level stopped
#: with nothing under IG 4 (192 s under IG 10), and the third, which IG 4 finished,
#: equals within 0.002 %; the
#: two stalled slides under IG 10 equal IG 10 with a 4x smaller largest increment within
#: 0.045 % at every state. The same choice as the rolling branches'
#: (:data:`farm.solve.rolling_tree.BRANCH_GROW_AFTER`).
SLIDE_GROW_AFTER = 10


def _controls(motion: RoadMotion, settings: SolverSettings, grow: int = 0) -> list[str]:
    """The friction controls with IG ``settings.grow_after``, or ``grow`` if larger."""
    ig = max(settings.grow_after, grow)
    return D.friction_controls_lines(ig) if motion.friction > 0 else []


def trunk_deck(spec: ModelSpec, mesh: TyreMesh, path: LoadPath, settings: SolverSettings,
               touch_z: float, fractions: Sequence[float] = (1.0,)) -> tuple[str, float]:
    """The trunk's deck: the one-run path to the first deflection, then one step per
    further deflection; restart output at every step's end. Returns (deck, road start z).
    """
    if path.motion is not None and path.motion.moves:
        raise SpecError("a trunk does not slide: give it a motion with friction and tilt "
                        "only (the slide is a branch's)")
    motion = path.motion or RoadMotion()
    first = LoadPath(path.deflections[:1], path.pressure, path.motion)
    gap = tilted_gap(spec, motion.tilt)
    z_start = touch_z - gap
    road = road_of(spec, mesh, z_start)
    steps: list[str] = []
    for k, (before, d) in enumerate(itertools.pairwise(path.deflections)):
        steps += [*D.static_step_lines(1.0, settings, first=D.STEP_DWELL),
                  *_controls(motion, settings),
                  *D.road_step_lines(road, (gap + before, (0.0, 0.0)), (gap + d, (0.0, 0.0)),
                                     motion.tilt, motion.rise, f"RISE{k + 2}"),
                  *_pressure_lines(spec, mesh, path.pressure),
                  *D.output_lines(time_points=True, contact=True, points="STEP_END"),
                  "*END STEP"]
    model = [*D.restart_lines(read=False, write=True), "*TIME POINTS, NAME=STEP_END", "1",
             "*TIME POINTS, NAME=SLIDE", *(D.fnum(_slide_time(f)) for f in fractions)]
    # no cut before the rise (SolverSettings.split_rise): a trunk's layout is one step per
    # level with a restart block at each step's end, and its trunks have not failed there
    one_step = dataclasses.replace(settings, split_rise=False)
    deck, _, z = path_deck(spec, mesh, first, one_step, touch_z, model=model, then=steps)
    assert abs(z - z_start) < 1e-9, "the trunk's road starts where the one-run path's does"
    return deck, z_start


def _run_trunk(deck: str, settings: SolverSettings, should_stop
               ) -> tuple[CcxRun | None, FrdFile, list[bytes], SolverError | None]:
    """The trunk's run: (run, results, restart blocks, None), or, when ccx fails after
    finishing some steps, (None, their results, their blocks, the error): every step
    that converged wrote its state before the failure. Raises when none did."""
    with scratch_dir(keep=settings.keep_scratch, prefix="trunk-") as workdir:
        try:
            run: CcxRun | None = run_ccx(deck, workdir, jobname="trunk",
                                         threads=settings.threads, timeout=settings.timeout,
                                         should_stop=should_stop)
            error = None
        except SolverError as e:
            run, error = None, e
        rout = workdir / "trunk.rout"
        try:
            blocks = split_restart(rout.read_bytes()) if rout.exists() else []
        except ResultsError:  # cut short by the failure: nothing to continue from
            blocks = []
        if error is not None and (not blocks or error.outcome == "cancelled"):
            raise error
        return run, read_frd(workdir / "trunk.frd"), blocks, error


def solve_trunk(spec: ModelSpec, mesh: TyreMesh, path: LoadPath, settings: SolverSettings,
                should_stop: Callable[[], bool] | None = None,
                fractions: Sequence[float] = (1.0,)) -> Trunk:
    """Solve a trunk: inflate (cached), tilt, rise through ``path.deflections``, keeping
    the solver's state at each deflection.

    ``path.motion`` may hold friction and tilt (and a stick slope), never a shift;
    ``fractions`` (strictly increasing in (0, 1]) are where its branches' slides write
    their results.

    One ccx run as a rule. When a later step fails nevertheless (before the hold of
    :func:`farm.ccx.deck.road_step_lines` they did as a rule), the trunk is
    **re-rooted**: the deflections it did not reach
    become a trunk of their own, whose first step is the one-run path from rest to the
    first of them (:attr:`Trunk.reroots` says why each happened). Every state is still
    the state of a path from rest, and every level keeps a saved state for its slides.

    Raises :class:`~farm.errors.SolverError` (located along the trunk) when ccx fails
    before the first deflection; a re-rooted part that fails so gives a partial trunk
    (:attr:`Trunk.failure`): the deflections before it keep their states.
    """
    path.check_against(spec)
    fractions = _fractions(fractions)
    pieces: list[Trunk] = []
    failure = None
    while len(done := [d for t in pieces for d in t.path.deflections]) < len(path.deflections):
        rest = LoadPath(path.deflections[len(done):], path.pressure, path.motion)
        try:
            pieces.append(_solve_piece(spec, mesh, rest, settings, should_stop, fractions))
        except SolverError as e:
            if not pieces or e.outcome == "cancelled":
                raise
            failure = f"{e} (re-rooted from rest at {rest.deflections[0]:g} mm)"
            break
    return _joined(pieces, failure)


def _joined(pieces: Sequence[Trunk], failure: str | None) -> Trunk:
    """One trunk of its re-rooted parts, in order (a state's solve_seconds counts the
    parts before it: what reaching it cost)."""
    first = pieces[0]
    if len(pieces) == 1 and failure is None:
        return first
    states: list[SolvedState] = []
    spent = 0.0
    for t in pieces:
        states += [dataclasses.replace(s, solve_seconds=spent + s.solve_seconds)
                   for s in t.solution.states]
        spent += t.solution.solve_seconds
    solution = PathSolution(first.solution.reference, tuple(states), spent,
                            sum(t.solution.ccx_runs for t in pieces),
                            sum(t.solution.increments for t in pieces))
    path = LoadPath(tuple(d for t in pieces for d in t.path.deflections),
                    first.path.pressure, first.path.motion)
    return Trunk(path, solution, tuple(b for t in pieces for b in t.restarts), first.touch_z,
                 first.fractions, failure,
                 tuple(t.failure for t in pieces if t.failure is not None))


def _solve_piece(spec: ModelSpec, mesh: TyreMesh, path: LoadPath, settings: SolverSettings,
                 should_stop: Callable[[], bool] | None, fractions: list[float]) -> Trunk:
    """One ccx run of a trunk from rest through ``path.deflections`` (partial when a
    later step fails, raises when it stops before the first)."""
    runs: list[CcxRun] = []
    touch_z = mesh.bottom_z
    if spec.inflated:
        touch_z, inflation = touch_height(spec, mesh, path.pressure, settings, should_stop)
        runs += [inflation] if inflation is not None else []
    deck, z_start = trunk_deck(spec, mesh, path, settings, touch_z, fractions)
    start = time.perf_counter()
    try:
        run, frd, blocks, error = _run_trunk(deck, settings, should_stop)
    except SolverError as e:
        raise (e.located(_trunk_stage(spec, path, e.reached)) if e.reached is not None
               else e) from e
    seconds = time.perf_counter() - start
    failure = None
    if error is not None:  # a partial trunk: the deflections it reached
        failure = str(error.located(_trunk_stage(spec, path, error.reached))
                      if error.reached is not None else error)
        path = LoadPath(path.deflections[:len(blocks)], path.pressure, path.motion)
    if len(blocks) != len(path.deflections):
        raise ResultsError(f"the trunk wrote {len(blocks)} restart blocks for "
                           f"{len(path.deflections)} deflections")
    t0 = 1.0 if spec.inflated else 0.0
    times = [t0 + 1.0 + k for k in range(len(path.deflections))]
    before = sum(r.seconds for r in runs)
    states = _states(spec, mesh, frd, path, z_start, times,
                     # a trunk's motion has no shift (trunk_deck refuses one)
                     [(d, path.motion) for d in path.deflections],
                     # a failed run's progress is not kept: its whole time (an upper bound)
                     lambda t: before + (run.seconds_to(t) if run else seconds))
    reference = _reference(spec, mesh, frd, path, z_start)
    solution = PathSolution(reference, tuple(states), before + (run.seconds if run else seconds),
                            len(runs) + 1,
                            sum(r.increments for r in runs) + (run.increments if run else 0))
    return Trunk(path, solution, tuple(zlib.compress(b, 1) for b in blocks), touch_z,
                 tuple(fractions), failure)


def _slide_time(fraction: float) -> float:
    """Step time of a branch at which its road has slid by ``fraction`` of the shift: the
    road holds still for the first :data:`~farm.ccx.deck.STEP_DWELL` of the step."""
    return D.STEP_DWELL + fraction * (1.0 - D.STEP_DWELL)


def _fractions(fractions: Sequence[float]) -> list[float]:
    out = [float(f) for f in fractions]
    if not out or any(not 0 < f <= 1 for f in out) or any(
            b <= a for a, b in itertools.pairwise(out)):
        raise SpecError(f"slide fractions must increase strictly within (0, 1], got {out}")
    return out


def _trunk_stage(spec: ModelSpec, path: LoadPath, time: float) -> str:
    """Where along the trunk ``time`` (total time) lies."""
    t0 = 1.0 if spec.inflated else 0.0
    if time < t0 + 1.0 or len(path.deflections) == 1:  # at t0 + 1 the first step is done
        return stage(spec, LoadPath(path.deflections[:1], path.pressure, path.motion), time)
    k = min(int(time - t0 - 1.0), len(path.deflections) - 2)
    a, b = path.deflections[k], path.deflections[k + 1]
    return f"in the trunk's rise from {a:g} to {b:g} mm"


def _states(spec: ModelSpec, mesh: TyreMesh, frd: FrdFile, path: LoadPath, z_start: float,
            times: Sequence[float], cases: Sequence[tuple[float, RoadMotion | None]],
            seconds: Callable[[float], float]) -> list[SolvedState]:
    """The states at ``times``, one per (deflection, motion) case."""
    faces = slave_faces(mesh)
    road = road_of(spec, mesh, z_start)
    tilt = path.motion.tilt if path.motion else 0.0
    gap = tilted_gap(spec, tilt)
    out = []
    for t, (d, m) in zip(times, cases, strict=True):
        z = z_start + gap + d
        out.append(path_state(frd, mesh, faces, t, d, z, seconds(t)) if m is None else
                   combined_state(frd, mesh, faces, road, t, d, z, m, seconds(t)))
    return out


def _reference(spec: ModelSpec, mesh: TyreMesh, frd: FrdFile, path: LoadPath,
               z_start: float) -> SolvedState:
    """The inflated tyre, road clear (as the one-run path's reference)."""
    if not spec.inflated:
        raise SpecError("a trunk needs the inflated full model (its reference is the "
                        "inflated tyre)")
    faces = slave_faces(mesh)
    if path.motion is None:
        return path_state(frd, mesh, faces, 1.0, 0.0, np.nan)
    still = RoadMotion(friction=path.motion.friction, stick_slope=path.motion.stick_slope)
    return combined_state(frd, mesh, faces, road_of(spec, mesh, z_start), 1.0, 0.0, np.nan,
                           still)


def branch_deck(spec: ModelSpec, mesh: TyreMesh, trunk: Trunk, level: int,
                shift: tuple[float, float], settings: SolverSettings) -> str:
    """The deck of a branch: read the trunk's state at ``level``, slide the road by
    ``shift`` (mm along x and the road's lateral axis) in one step, results at the
    trunk's ``fractions`` of the slide."""
    motion = trunk.motion
    gap = tilted_gap(spec, motion.tilt)
    road = road_of(spec, mesh, trunk.touch_z - gap)
    d = trunk.path.deflections[level]
    return "\n".join([
        *D.restart_lines(read=True, write=False),
        *D.static_step_lines(1.0, settings, first=D.STEP_DWELL),
        *_controls(motion, settings, SLIDE_GROW_AFTER),
        *D.road_step_lines(road, (gap + d, (0.0, 0.0)), (gap + d, shift), motion.tilt,
                           motion.rise, "SLIDE"),
        *_pressure_lines(spec, mesh, trunk.path.pressure),
        *D.output_lines(time_points=True, contact=True, points="SLIDE"), "*END STEP"]) + "\n"


def solve_branch(spec: ModelSpec, mesh: TyreMesh, trunk: Trunk, level: int,
                 shift: tuple[float, float], settings: SolverSettings,
                 should_stop: Callable[[], bool] | None = None) -> PathSolution:
    """Slide the road from the trunk's state at ``trunk.path.deflections[level]``.

    Returns the trunk's reference and one state per fraction f of ``trunk.fractions``:
    the road slid by f times ``shift``. A slide that stops raises its
    :class:`~farm.errors.SolverError` holding the states it reached (``partial``, in
    order; None: none), as a roll does.
    """
    fractions = trunk.fractions
    if not 0 <= level < len(trunk.restarts):
        raise SpecError(f"the trunk has {len(trunk.restarts)} deflections, no level {level}")
    motion = trunk.motion
    full = dataclasses.replace(motion, shift_x=shift[0], shift_y=shift[1])
    d = trunk.path.deflections[level]
    gap = tilted_gap(spec, motion.tilt)

    def states(frd: FrdFile, seconds: Callable[[float], float]) -> list[SolvedState]:
        times = sorted({b.time for b in frd.results_named("DISP")})
        if len(times) > len(fractions):
            raise ResultsError(f"the branch wrote {len(times)} states for {len(fractions)} "
                               "slide fractions")
        return _states(spec, mesh, frd, trunk.path, trunk.touch_z - gap, times,
                       [(d, full.scaled(f)) for f in fractions[:len(times)]], seconds)

    run, frd, error = run_deck_keeping(
        branch_deck(spec, mesh, trunk, level, shift, settings), settings, should_stop,
        "branch", inputs={"rin": zlib.decompress(trunk.restarts[level])})
    if error is None and frd is not None:
        done = states(frd, run.seconds_to)
        if len(done) != len(fractions):
            raise ResultsError(f"the branch wrote {len(done)} states for {len(fractions)} "
                               "slide fractions")
        return PathSolution(trunk.solution.reference, tuple(done), run.seconds, 1,
                            run.increments)
    assert error is not None
    if error.reached is not None:
        error = error.located(f"in the slide from the trunk's {d:g} mm state")
    try:  # what it reached before it stopped (the reader drops a diverged output)
        reached = states(frd, lambda t: run.seconds) if frd is not None else []
    except ResultsError:
        reached = []
    raise error.with_partial(tuple(reached) or None)
