"""What a worker runs for a rolling tree (issue 45): the trunk, then every branch.

A rolling tree (:class:`jobs.expand.RollTreePlan`, :mod:`farm.solve.rolling_tree`) is
one Dask task: it rolls the trunk straight at kappa = 0 (after a free-rolling radius
search where the study asks for one, cached as for plain rolls), stores the trunk's
states, then rolls every branch with states still to do on from the trunk's end, one
after another. Why one task and not a task per branch, as the static trees have
(:mod:`jobs.trees`): a branch starts from ccx's restart block of the trunk, which a task
per branch would read from the store once per branch, and a rolling study's parallelism
lies across its trees (one per pressure, deflection, friction and camber). The trunk is
saved in the store once rolled (:mod:`farm.solve.rolling_trunk_file`,
:mod:`storage.saved`): a task re-run after its worker died, or a resumed study, rolls on
from it instead of rolling the trunk again (its states are not written twice either: the
task skips what the store holds as done); it is removed when every state of the tree is
done or failed.

Failures are data, as everywhere: the guard's retry with smaller increments for the
trunk and for each branch; a trunk that still fails fails every experiment of its tree
still to do, with its reason; a branch that still fails fails its own states.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import storage
import storage.saved
from farm.errors import ResultsError, SolverError
from farm.measure.camera import camera_state
from farm.measure.measurement import measure
from farm.mesh import TyreMesh, mesh_for
from farm.solve import rolling_trunk_file
from farm.solve.rolling import RolledState, motion_radius, with_stick_slope
from farm.solve.rolling_tree import RollingTrunk, solve_rolling_branch, solve_rolling_trunk
from farm.solve.states import PathSolution
from farm.specs import ModelSpec, Roll, SolverSettings
from jobs.expand import Experiment, PathPlan, RollBranchPlan, RollTreePlan
from jobs.guard import Failed, Solved, cancellation_check, guarded
from jobs.tasks import PathOutcome, PathTask, write_outcome

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RollTreeTask:
    """A rolling tree as plain picklable values (as :class:`jobs.tasks.PathTask`)."""

    tree: RollTreePlan
    model: ModelSpec
    settings: SolverSettings
    store: storage.StoreLike
    group: str
    retry_smaller_increments: bool = True

    def path_task(self, key: str, exps: tuple[Experiment, ...]) -> PathTask:
        """The plain task :func:`jobs.tasks.write_outcome` writes ``exps`` with."""
        tree = self.tree
        return PathTask(PathPlan(key, tree.pressure, exps, tree.motion), self.model,
                        self.settings, self.store, self.group, self.retry_smaller_increments)


def run_rolling_tree(task: RollTreeTask) -> PathOutcome:
    """Worker entry point: solve the tree's states not yet done and write them, under
    the tree's claim (:func:`storage.claim`, as :func:`jobs.tasks.run_path`)."""
    tree = task.tree
    should_stop = cancellation_check()
    with storage.claim(task.store, task.group, tree.key, should_stop=should_stop) as go:
        if not go:
            return PathOutcome(tree.key)
        status = storage.statuses(task.store, task.group, [e.id for e in tree.experiments])
        done = {i for i, s in status.items() if s == storage.DONE}
        skipped = tuple(e.id for e in tree.experiments if e.id in done)
        trunk = [e for e in tree.trunk if e.id not in done]
        branches = [b for b in tree.branches if any(e.id not in done for e in b.experiments)]
        if not trunk and not branches:
            return PathOutcome(tree.key, skipped=skipped)
        parts = _solve(task, trunk, branches, done, should_stop)
        return PathOutcome(tree.key, sum((p.done for p in parts), ()),
                           sum((p.failed for p in parts), ()), skipped,
                           sum(p.solve_seconds for p in parts), sum(p.ccx_runs for p in parts))


def _solve(task: RollTreeTask, trunk_todo: list[Experiment], branches: list[RollBranchPlan],
           done: set[str], should_stop: Callable[[], bool] | None) -> list[PathOutcome]:
    """The trunk (read back from the store where an earlier task saved it), then each
    branch; what each wrote."""
    tree, mesh = task.tree, mesh_for(task.model)
    shape = _shape(tree)
    trunk = None if trunk_todo else _saved_trunk(task, mesh, shape)
    if trunk is not None:
        parts = [PathOutcome(tree.key)]  # nothing solved: the trunk cost an earlier task
    else:
        rolled = _rolled_trunk(task, mesh, shape, trunk_todo, done, should_stop)
        if isinstance(rolled, PathOutcome):  # it failed: so did the tree's states
            return [rolled]
        trunk, parts = rolled[0], [rolled[1]]
        _save_trunk(task, trunk)
    for b in branches:
        parts.append(_branch(task, mesh, trunk, b, done, should_stop))
    _drop_if_finished(task)
    return parts


@dataclass(frozen=True)
class _Shape:
    """What a tree's trunk is rolled for, whatever its radius: the longest branch (mm),
    where along a branch its states lie, and the trunk's own states (of its roll)."""

    branch_mm: float
    along: tuple[float, ...]
    own: tuple[float, ...]


def _shape(tree: RollTreePlan) -> _Shape:
    distance = tree.motion.roll
    branch_mm = _travel(tree.branches[0].experiments[-1]) - distance
    along = tuple((_travel(e) - distance) / branch_mm for e in tree.branches[0].experiments)
    return _Shape(branch_mm, along, tuple(_travel(e) / distance for e in tree.trunk) or (1.0,))


def _rolled_trunk(task: RollTreeTask, mesh: TyreMesh, shape: _Shape,
                  trunk_todo: list[Experiment], done: set[str],
                  should_stop: Callable[[], bool] | None
                  ) -> tuple[RollingTrunk, PathOutcome] | PathOutcome:
    """Roll the trunk (after its radius) and write its states still to do; where it
    fails, every state of the tree still to do is written failed (the outcome alone)."""
    tree = task.tree
    spec = with_stick_slope(task.model, tree.motion)  # the motion's own, where it sets one
    radius, seconds, runs = _radius(task, spec, mesh, should_stop)
    todo = tuple(e for e in tree.experiments if e.id not in done)
    if isinstance(radius, Failed):
        return write_outcome(task.path_task(tree.key, todo), list(todo), radius)
    roll = tree.motion.as_roll(radius)

    def solve_trunk(settings: SolverSettings) -> RollingTrunk:
        try:
            return solve_rolling_trunk(spec, mesh, tree.deflection, tree.pressure, roll,
                                       settings, branch_mm=shape.branch_mm,
                                       fractions=shape.own, branch_fractions=shape.along,
                                       should_stop=should_stop)
        except SolverError as e:  # the trunk's states it reached, measured, still to do
            if not isinstance(e.partial, tuple) or not tree.trunk:
                raise  # (a trunk without stored states keeps nothing)
            reached = _measured(mesh, e.partial, tree.trunk[:len(e.partial)], tree.pressure,
                                e.partial[-1].solved.solve_seconds, 1, 0).measurements
            kept = tuple(m for x, m in zip(tree.trunk, reached, strict=False)
                         if x.id not in done)
            raise e.with_partial(kept or None) from e

    trunk = guarded(solve_trunk, task.settings, retry=task.retry_smaller_increments)
    if isinstance(trunk, Failed):  # the trunk's states it reached stored, the rest failed
        failed = dataclasses.replace(trunk, reason=f"the tree's trunk ({roll.distance:g} mm "
                                     f"straight) stopped: {trunk.reason}")
        return write_outcome(task.path_task(tree.key, todo), list(todo), failed)
    if not trunk_todo:  # its states were stored before: what rolling it again cost
        return trunk, PathOutcome(tree.key, solve_seconds=seconds + trunk.seconds,
                                  ccx_runs=runs + 1)
    solved = _measured(mesh, trunk.states[:len(tree.trunk)], tree.trunk, tree.pressure,
                       seconds + trunk.seconds, runs + 1, trunk.increments)
    keep = [k for k, e in enumerate(tree.trunk) if e.id not in done]
    return trunk, write_outcome(task.path_task(tree.key, tuple(trunk_todo)), trunk_todo,
                                dataclasses.replace(solved, measurements=tuple(
                                    solved.measurements[k] for k in keep)))


def _save_trunk(task: RollTreeTask, trunk: RollingTrunk) -> None:
    """Keep the trunk for the next task of its tree (a lost worker's, a resumed study's);
    a store that refuses it (a full disk) costs a roll later, not this task."""
    try:
        storage.saved.save(task.store, task.group, task.tree.key, rolling_trunk_file.dumps(trunk))
    except (storage.StoreError, OSError) as e:
        log.warning("the rolling trunk %s was not saved (%s): a later task rolls it again",
                    task.tree.key, e)


def _saved_trunk(task: RollTreeTask, mesh: TyreMesh, shape: _Shape) -> RollingTrunk | None:
    """The trunk an earlier task of this tree saved in the store, or None. One that does
    not read back, or was rolled for other branches or another radius, is removed (and
    rolled again)."""
    tree = task.tree
    data = storage.saved.load(task.store, task.group, tree.key)
    if data is None:
        return None
    try:
        trunk = rolling_trunk_file.loads(data, mesh)
    except ResultsError:
        trunk = None
    motion, radius = tree.motion, tree.motion.rolling_radius
    if trunk is not None and (
            trunk.branch_mm, trunk.fractions, trunk.deflection, trunk.pressure,
    ) == (shape.branch_mm, shape.along, tree.deflection, tree.pressure) and (
            trunk.roll == motion.as_roll(trunk.roll.rolling_radius if radius is None
                                         else radius)):
        return trunk
    storage.saved.drop(task.store, task.group, tree.key)
    return None


def _drop_if_finished(task: RollTreeTask) -> None:
    """Remove the tree's saved trunk once every state of the tree is done or failed: no
    branch will roll on from it (a failed one retried with ``--retry-failed`` rolls the
    trunk again)."""
    ids = [e.id for e in task.tree.experiments]
    status = storage.statuses(task.store, task.group, ids)
    if all(status.get(i) in (storage.DONE, storage.FAILED) for i in ids):
        storage.saved.drop(task.store, task.group, task.tree.key)


def _radius(task: RollTreeTask, spec: ModelSpec, mesh: TyreMesh,
            should_stop: Callable[[], bool] | None
            ) -> tuple[float | Failed, float, int]:
    """The trunk's rolling radius (:func:`farm.solve.rolling.motion_radius`: the study's,
    the estimate, or a search cached per model, pressure, deflection and roll as for
    plain rolls), with the search's seconds and runs."""
    tree, found = task.tree, []

    def find(settings: SolverSettings) -> float:
        radius, tried = motion_radius(spec, mesh, tree.motion, tree.deflection,
                                      tree.pressure, settings, should_stop)
        found.extend(tried)
        return radius

    radius = guarded(find, task.settings, retry=task.retry_smaller_increments)
    if isinstance(radius, Failed):
        return dataclasses.replace(radius, reason=f"no free-rolling radius for the tree's "
                                   f"trunk: {radius.reason}", partial=None), 0.0, 0
    return radius, sum(t.seconds for t in found), len(found)


def _branch(task: RollTreeTask, mesh: TyreMesh, trunk: RollingTrunk, b: RollBranchPlan,
            done: set[str], should_stop: Callable[[], bool] | None) -> PathOutcome:
    """Roll one branch on from the trunk's end and write its states still to do; a
    branch that stops stores the states it reached (as a roll from rest does)."""
    roll = trunk.roll
    branch = Roll(friction=roll.friction, slip_ratio=b.slip_ratio, slip_angle=b.slip_angle,
                  tilt=roll.tilt, distance=trunk.branch_mm, rolling_radius=roll.rolling_radius,
                  friction_from=roll.friction_from)
    todo = [e for e in b.experiments if e.id not in done]
    keep = {e.id for e in todo}

    def kept(states: Sequence[RolledState], seconds: float) -> Solved:
        """The states of ``todo`` among those solved (a prefix of the branch's)."""
        solved = _measured(mesh, states, b.experiments[:len(states)], task.tree.pressure,
                           seconds, 1, 0)
        return dataclasses.replace(solved, measurements=tuple(
            m for e, m in zip(b.experiments, solved.measurements, strict=False)
            if e.id in keep))

    def solve(settings: SolverSettings) -> Solved:
        try:
            states = solve_rolling_branch(trunk, branch, settings, should_stop)
        except SolverError as e:
            if isinstance(e.partial, tuple):  # the states it reached, measured
                reached = kept(e.partial, max(s.solved.solve_seconds for s in e.partial))
                raise e.with_partial(reached.measurements or None) from e
            raise
        return kept(states, max(s.solved.solve_seconds for s in states))

    result = guarded(solve, task.settings, retry=task.retry_smaller_increments)
    if isinstance(result, Failed):
        result = dataclasses.replace(result, reason=f"the branch at kappa {b.slip_ratio:g}, "
                                     f"alpha {b.slip_angle:g} deg from the trunk's "
                                     f"{roll.distance:g} mm: {result.reason}")
    return write_outcome(task.path_task(b.key, tuple(todo)), todo, result)


def _measured(mesh: TyreMesh, states: Sequence[RolledState], exps: Sequence[Experiment],
              pressure: float, seconds: float, runs: int, increments: int) -> Solved:
    """Rolled states measured as the camera sees them (as
    :func:`farm.measure.camera.rolling_solution` does), each with its experiment's motion."""
    seen = tuple(dataclasses.replace(camera_state(s, mesh), motion=e.motion)
                 for s, e in zip(states, exps, strict=True))
    solution = PathSolution(states[0].reference, seen, seconds, runs, increments)
    return Solved(tuple(measure(mesh, solution, pressure, inflated=True)), seconds, runs,
                  increments)


def _travel(e: Experiment) -> float:
    """Road travel (mm) of a rolling experiment's state."""
    assert e.motion is not None and e.motion.rolls
    return e.motion.roll
