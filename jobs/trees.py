"""What a worker runs for a ``[loads.tree]`` sweep: trunks and the slides that continue them.

A tree (:class:`jobs.expand.TreePlan`, :mod:`farm.solve.tree`) is one trunk task and one
task per slide; each slide task takes the trunk task's result (its saved solver states)
as an argument, so Dask runs it after the trunk, wherever the state is, and never a task
waits on another. Like :mod:`jobs.tasks`, every task skips what the store holds as
done, writes each experiment into its own slot, and records failures as data.

Fallbacks (the issue's "keep the current retry as the fallback"; docs/combined-loads.md,
"Load-path trees"): a trunk whose step fails goes on from rest at the first deflection
it did not reach (:func:`farm.solve.tree.solve_trunk` re-roots it, so every level keeps
a saved state for its slides); when a re-rooted part fails before its first deflection,
the levels left are solved as the plain sweep would (one path, split deflection by
deflection on failure); a trunk that fails before its first deflection even with
smaller increments is recorded as failed, with its slides (the same path from rest
would stop at the same first touch). A slide that fails from the trunk's state runs
from rest where the trunk's own experiment at its level is done. A reason is recorded
only when the last attempt fails, and it names every attempt.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import storage
import storage.saved
from farm.errors import ResultsError, SolverError
from farm.measure.measurement import measure
from farm.mesh import mesh_for
from farm.solve import trunk_file
from farm.solve.states import PathSolution
from farm.solve.tree import Trunk, solve_branch, solve_trunk
from farm.specs import LoadPath, ModelSpec, RoadMotion, SolverSettings
from jobs.expand import BranchPlan, Experiment, PathPlan, TreePlan
from jobs.guard import Failed, Solved, cancellation_check, guarded
from jobs.tasks import PathOutcome, PathTask, solve_experiments, write_outcome

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TreeTask:
    """A tree's trunk, or one of its slides (``branch``), as plain picklable values."""

    tree: TreePlan
    model: ModelSpec
    settings: SolverSettings
    store: storage.StoreLike
    group: str
    retry_smaller_increments: bool = True
    branch: BranchPlan | None = None

    def path_task(self, key: str, exps: tuple[Experiment, ...],
                  motion: RoadMotion | None) -> PathTask:
        """The plain sweep's task for ``exps`` (writes, and the fallback from rest)."""
        return PathTask(PathPlan(key, self.tree.pressure, exps, motion), self.model,
                        self.settings, self.store, self.group, self.retry_smaller_increments)


@dataclass(frozen=True, eq=False)
class TrunkResult:
    """A trunk task's result: what it wrote, the trunk its slides continue (None: the
    trunk failed before its first deflection, ``reason`` says why; a partial trunk holds
    the deflections it reached), and per level whether the trunk's own experiment there
    is done (by the trunk, from rest, or before)."""

    outcome: PathOutcome
    trunk: Trunk | None
    reason: str = ""
    levels_done: tuple[bool, ...] = ()


def trunk_outcome(result: TrunkResult) -> PathOutcome:
    """The small part of a trunk's result the client reads (the states stay on workers)."""
    return result.outcome


def _todo(task: TreeTask, exps: tuple[Experiment, ...]) -> tuple[list[Experiment], tuple[str, ...]]:
    status = storage.statuses(task.store, task.group, [e.id for e in exps])
    todo = [e for e in exps if status.get(e.id) != storage.DONE]
    return todo, tuple(e.id for e in exps if status.get(e.id) == storage.DONE)


def run_trunk(task: TreeTask) -> TrunkResult:
    """Worker entry point: solve the trunk (or read the one saved in the store), write
    its own experiments not yet done."""
    tree = task.tree
    should_stop = cancellation_check()
    with storage.claim(task.store, task.group, tree.key, should_stop=should_stop) as go:
        if not go:
            return TrunkResult(PathOutcome(tree.key), None, "cancelled",
                               (False,) * len(tree.trunk))
        todo, skipped = _todo(task, tree.trunk)
        if _tree_done(task):  # e.g. a second client's trunk, after the first finished
            return TrunkResult(PathOutcome(tree.key, skipped=skipped), None,
                               "every experiment of the tree is done", (True,) * len(skipped))
        mesh = mesh_for(task.model)
        result, saved = _solved_or_saved(task, mesh, should_stop)
        trunk = None if isinstance(result, Failed) else result
        reason = (result.reason if isinstance(result, Failed)
                  else trunk.failure if trunk is not None and trunk.failure else "")
        parts = _trunk_parts(task, todo, trunk, reason, mesh, should_stop)
        if saved and parts:  # the trunk's runs were made before, not now
            parts[0] = dataclasses.replace(parts[0], solve_seconds=0.0, ccx_runs=0)
        done = {*skipped, *(i for p in parts for i in p.done)}
        outcome = PathOutcome(tree.key, tuple(i for p in parts for i in p.done),
                              tuple(f for p in parts for f in p.failed), skipped,
                              sum(p.solve_seconds for p in parts),
                              sum(p.ccx_runs for p in parts))
        _drop_if_finished(task)
        return TrunkResult(outcome, trunk, reason,
                           tuple(e.id in done for e in tree.trunk))


def _solved_or_saved(task: TreeTask, mesh, should_stop) -> tuple[Trunk | Failed, bool]:
    """The trunk saved in the store (True), else solved now and saved (False)."""
    saved = _saved_trunk(task)
    if saved is not None:
        return saved, True
    tree = task.tree
    path = LoadPath(tree.deflections, tree.pressure, tree.motion)

    def solve(settings: SolverSettings) -> Trunk:
        return solve_trunk(task.model, mesh, path, settings, should_stop, tree.fractions)

    result = guarded(solve, task.settings, retry=task.retry_smaller_increments)
    if not isinstance(result, Failed):
        _save_trunk(task, result)
    return result, False


def _trunk_parts(task: TreeTask, todo: list[Experiment], trunk: Trunk | None, reason: str,
                 mesh, should_stop) -> list[PathOutcome]:
    """Write the trunk's own experiments of ``todo``: those it reached from its states
    (first), the rest failed (no trunk) or solved as the plain sweep would."""
    tree = task.tree
    reached = len(trunk.restarts) if trunk is not None else 0
    level = {e.id: k for k, e in enumerate(tree.trunk)}
    parts: list[PathOutcome] = []
    mine = [e for e in todo if level[e.id] < reached]
    if trunk is not None and mine:
        states = measure(mesh, trunk.solution, tree.pressure, inflated=True)
        solution = trunk.solution
        parts.append(write_outcome(task.path_task(tree.key, tuple(mine), tree.motion), mine,
                                   Solved(tuple(states[level[e.id]] for e in mine),
                                          solution.solve_seconds, solution.ccx_runs,
                                          solution.increments)))
    elif trunk is not None:
        parts.append(PathOutcome(tree.key, solve_seconds=trunk.solution.solve_seconds,
                                 ccx_runs=trunk.solution.ccx_runs))
    rest = [e for e in todo if level[e.id] >= reached]
    if not rest:
        return parts
    plain = task.path_task(tree.key, tuple(rest), tree.motion)
    if trunk is None:
        # stopped before its first deflection, after the guard's retry: its first step
        # is the one-run path's deck up to there, so from rest would stop at the same
        # place (the first touch, as a rule); recorded, not repeated
        parts.append(write_outcome(plain, rest, Failed(
            f"{reason} (the trunk, before its first deflection; the same path from "
            "rest was not tried again)")))
    else:  # the levels a partial trunk did not reach: as the plain sweep does
        parts.append(solve_experiments(plain, rest, should_stop))
    return parts


def _save_trunk(task: TreeTask, trunk: Trunk) -> None:
    """Keep the trunk for the next task that needs it; a store that refuses it (a full
    disk) costs a solve later, not this task."""
    try:
        storage.saved.save(task.store, task.group, task.tree.key, trunk_file.dumps(trunk))
    except (storage.StoreError, OSError) as e:
        log.warning("the trunk %s was not saved (%s): a later task solves it again",
                    task.tree.key, e)


def _saved_trunk(task: TreeTask) -> Trunk | None:
    """The trunk an earlier task saved in the store (a lost worker, a resumed study, a
    second client: issue 50), or None. A saved trunk that does not read back is removed
    and solved again."""
    data = storage.saved.load(task.store, task.group, task.tree.key)
    if data is None:
        return None
    try:
        return trunk_file.loads(data)
    except ResultsError:
        storage.saved.drop(task.store, task.group, task.tree.key)
        return None


def _tree_status(task: TreeTask) -> list[int | None]:
    tree = task.tree
    ids = [e.id for e in tree.trunk] + [e.id for b in tree.branches for e in b.experiments]
    status = storage.statuses(task.store, task.group, ids)
    return [status.get(i) for i in ids]


def _tree_done(task: TreeTask) -> bool:
    """Whether every experiment of the tree is done: no task needs the trunk."""
    return all(s == storage.DONE for s in _tree_status(task))


def _drop_if_finished(task: TreeTask) -> None:
    """Remove the tree's saved trunk once every experiment of the tree is done or
    failed: no slide will continue from it (a failed one retried later, with
    ``--retry-failed``, solves the trunk again)."""
    if all(s in (storage.DONE, storage.FAILED) for s in _tree_status(task)):
        storage.saved.drop(task.store, task.group, task.tree.key)


def run_branch(task: TreeTask, trunk: TrunkResult) -> PathOutcome:
    """Worker entry point: slide from the trunk's state (from rest if the trunk or the
    slide fails), write the slide's experiments not yet done."""
    branch = task.branch
    assert branch is not None, "run_branch needs a TreeTask with its branch"
    tree = task.tree
    should_stop = cancellation_check()
    with storage.claim(task.store, task.group, branch.key, should_stop=should_stop) as go:
        if not go:
            return PathOutcome(branch.key)
        todo, skipped = _todo(task, branch.experiments)
        if not todo:
            return PathOutcome(branch.key, skipped=skipped)
        d = tree.deflections[branch.level]
        result: Solved | Failed = Failed(f"the trunk did not reach {d:g} mm: {trunk.reason}")
        if trunk.trunk is not None and branch.level < len(trunk.trunk.restarts):
            result = _slide(task, branch, trunk.trunk, should_stop)
        if isinstance(result, Failed):
            known = branch.level < len(trunk.levels_done)
            slid = result
            if not known or trunk.levels_done[branch.level]:
                result = _from_rest(task, branch, should_stop, result.reason)
            else:  # from rest it would stop where the trunk's own path from rest did
                result = dataclasses.replace(result, reason=(
                    f"{result.reason}; not tried from rest: the trunk's own experiment at "
                    f"{d:g} mm failed from rest too"))
            if isinstance(result, Failed) and result.partial is None:
                result = dataclasses.replace(result, partial=slid.partial)
        motion = branch.experiments[-1].motion
        plain = task.path_task(branch.key, branch.experiments, motion)
        result = _wanted(result, branch, {e.id for e in todo})
        outcome = dataclasses.replace(write_outcome(plain, todo, result), skipped=skipped)
        _drop_if_finished(task)
        return outcome


def _wanted(result: Solved | Failed, branch: BranchPlan, wanted: set[str]) -> Solved | Failed:
    """``result`` with the measurements of the slide's experiments in ``wanted`` only
    (those still to do; a failed slide's: of those it reached, issue 45)."""
    def kept(solved: Solved, strict: bool) -> Solved:
        return dataclasses.replace(solved, measurements=tuple(
            m for e, m in zip(branch.experiments, solved.measurements, strict=strict)
            if e.id in wanted))

    if isinstance(result, Solved):
        return kept(result, True)
    if result.partial is None:
        return result
    reached = kept(result.partial, False)
    return dataclasses.replace(result, partial=reached if reached.measurements else None)


def _slide(task: TreeTask, branch: BranchPlan, trunk: Trunk, should_stop) -> Solved | Failed:
    """The slide from the trunk's state; a slide that stops keeps the fractions it
    reached (:attr:`Failed.partial`, measured; issue 45), as a roll does."""
    model = task.model
    mesh = mesh_for(model)

    def measured(states: tuple, seconds: float) -> tuple:
        reached = PathSolution(trunk.solution.reference, states, seconds, 1, 0)
        return tuple(measure(mesh, reached, task.tree.pressure, inflated=True))

    def solve(settings: SolverSettings) -> Solved:
        try:
            s = solve_branch(model, mesh, trunk, branch.level, branch.shift, settings,
                             should_stop)
        except SolverError as e:
            if isinstance(e.partial, tuple):
                raise e.with_partial(measured(e.partial, e.partial[-1].solve_seconds)) from e
            raise
        return Solved(measured(s.states, s.solve_seconds), s.solve_seconds, s.ccx_runs,
                      s.increments)

    return guarded(solve, task.settings, retry=task.retry_smaller_increments)


def _from_rest(task: TreeTask, branch: BranchPlan, should_stop, why: str) -> Solved | Failed:
    """The slide's experiments as one path from rest (the plain sweep's one-run path,
    with results at the tree's fractions)."""
    from farm.experiment import run_load_path

    tree = task.tree
    path = LoadPath((tree.deflections[branch.level],), tree.pressure,
                    branch.experiments[-1].motion, tree.fractions)

    def solve(settings: SolverSettings) -> Solved:
        r = run_load_path(task.model, path, settings, should_stop=should_stop)
        return Solved(r.measurements[-len(tree.fractions):], r.solve_seconds, r.ccx_runs,
                      r.increments)

    result = guarded(solve, task.settings, retry=task.retry_smaller_increments)
    if isinstance(result, Failed):
        return dataclasses.replace(result, reason=f"{why}; from rest: {result.reason}")
    return result
