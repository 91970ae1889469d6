"""Submit a study to Dask and follow it to the end: ``farm sweep submit|resume``.

Submission and resumption are one idempotent operation on the one driver
(:mod:`jobs.driver`): the study is expanded, the client creates the group and reserves
room for every experiment (the store's only metadata writer), experiments the store
holds as done are skipped, and one task per remaining load path goes to the cluster.
Workers write their own experiments; a task that raises (a bug, a store outage) has its
experiments recorded as failed by the client, so a sweep always ends with every
experiment done or failed with a reason. A task the scheduler gives up because its
workers died (``KilledWorker``) is resubmitted under a new key instead
(:class:`jobs.cluster.Attempts`): it skips what its predecessors wrote.

A model-space study (``[models]``, :mod:`jobs.design`) is the same sweep over several
groups: :func:`parts` splits it into one plain study per distinct model, each with its
own group, ids, dedup and resume exactly as a one-model study; the load paths of all of
them go to the cluster together in one driver run, with one progress and one report.
Meshes are shared: a worker meshes each geometry once (:func:`farm.mesh.mesh_for`), so
material-only variants of a design reuse one mesh.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import storage
from jobs.cluster import Attempts, ClusterSpec
from jobs.design import model_design
from jobs.driver import Strategy, cluster_spec, drive, solver_version
from jobs.expand import (
    Experiment,
    PathPlan,
    RollTreePlan,
    TreePlan,
    experiments,
    parameters,
    plan,
    tree_plan,
)
from jobs.progress import Progress, RunReport, Session
from jobs.rolling_trees import RollTreeTask, run_rolling_tree
from jobs.storeio import ensure_group
from jobs.study import Study, with_own_loads
from jobs.tasks import PathOutcome, PathTask, run_path
from jobs.trees import TreeTask, run_branch, run_trunk, trunk_outcome
from jobs.wording import plural

TASK_RETRIES = 2  # for exceptions raised by a task; lost workers: jobs.cluster.Attempts


@dataclass
class SweepReport(RunReport):
    """How a sweep ended. ``ok`` only if every experiment of the study is done."""

    study: Study
    total: int
    skipped: int = 0  # done before this sweep started
    done: list[str] = field(default_factory=list)
    failed: dict[str, str] = field(default_factory=dict)
    experiments: dict[str, Experiment] = field(default_factory=dict)
    solve_seconds: float = 0.0
    ccx_runs: int = 0
    resubmitted: int = 0  # tasks resubmitted because their workers died
    group_of: dict[str, str] = field(default_factory=dict)  # experiment id -> its group
    nothing_to_do: bool = False  # answered from the store alone, no cluster started

    @property
    def ok(self) -> bool:
        return self.skipped + len(self.done) == self.total and not self.failed

    def summary(self) -> str:
        """One line: experiments, solver runs, resubmissions (if any) and time."""
        lost = (f", {plural(self.resubmitted, 'task')} resubmitted after lost workers"
                if self.resubmitted else "")
        return (f"{plural(self.total, 'experiment')} ({self.skipped} already done, "
                f"{len(self.done)} done now, {len(self.failed)} failed), "
                f"{plural(self.ccx_runs, 'ccx run')}{lost}, {self.wall_seconds:.1f} s")


@dataclass(frozen=True)
class SweepState:
    """What a progress display shows of a sweep."""

    total: int
    skipped: int
    done: int
    failed: int
    running: int
    #: states already in the store whose tasks still run (a rolling tree writes its
    #: trunk and each branch as they end, its task returns after the last: issue 46)
    stored: int = 0


#: how often a sweep reads the store for the states of its running tasks (seconds)
STORED_EVERY_S = 30.0


class _Plain:
    """A plain future with the face of :class:`jobs.cluster.Attempts` (no resubmission):
    a tree's tasks depend on each other's futures, and Dask itself recomputes a lost
    trunk for the slides that still need it."""

    def __init__(self, future) -> None:
        self.future = future

    @property
    def status(self) -> str:
        return self.future.status

    def result(self):
        return self.future.result()

    def exception(self):
        return self.future.exception()

    def resubmit(self) -> bool:
        return False

    def stop(self):
        return self.future

    def release(self) -> None:
        self.future.release()


def _wanted(retry_failed: bool) -> set[int]:
    """The statuses of experiments a sweep runs."""
    return {storage.PENDING} | ({storage.FAILED} if retry_failed else set())


def _todo(paths: list, status: dict[str, int], retry_failed: bool) -> list:
    wanted = _wanted(retry_failed)
    return [p for p in paths if any(status.get(e.id, storage.PENDING) in wanted
                                    for e in p.experiments)]


def parts(study: Study) -> list[Study]:
    """The one-group studies a sweep runs: the study itself, or one per distinct model
    of its ``[models]`` design, named by its group (as :attr:`Study.group_name`); under
    ``loads = "own"`` each with its own load cases (:func:`jobs.study.with_own_loads`)."""
    design = model_design(study)
    if design is None:
        return [study]
    own = study.models is not None and study.models.loads == "own"
    models = design.distinct()
    return [replace(with_own_loads(study, k, len(models)) if own else study, model=model,
                    group=group, models=None)
            for k, (group, model) in enumerate(models.items())]


def _held(study: Study) -> frozenset[str]:
    """Ids the study's group holds already (none for a new group), a slot whose id was
    damaged too: reserving then gives a lost id back (:func:`storage.reserve`)."""
    return storage.held_ids(study.store, study.group_name)


def _account(report: SweepReport, study: Study, paths: list[PathPlan], status: dict[str, int],
             todo: list[PathPlan]) -> set[str]:
    """Count one group's experiments into ``report``: its total, and its experiments
    that failed before and are not run again; return the ids done before."""
    exps = experiments(paths)
    ids = [e.id for e in exps]
    report.total += len(exps)
    report.experiments.update({e.id: e for e in exps})
    report.group_of.update(dict.fromkeys(ids, study.group_name))
    for p in paths:
        if p not in todo:
            report.failed.update({e.id: "failed before (use --retry-failed)"
                                  for e in p.experiments if status[e.id] == storage.FAILED})
    return {i for i, s in status.items() if s == storage.DONE}


class Sweep(Strategy[SweepReport]):
    """The sweep strategy: one Dask task per load path still to do, over every group of
    the study (:func:`parts`)."""

    poll_seconds = 0.25

    def __init__(self, study: Study, retry_failed: bool = False) -> None:
        self.study, self.retry_failed = study, retry_failed
        self.parts = parts(study)
        self.report = SweepReport(study, 0)
        # a tree's tasks are entered under the PathPlan of their experiments
        self._pending: dict[Attempts | _Plain, tuple[Study, PathPlan]] = {}
        self._trunks: dict[str, list] = {}  # tree key -> [trunk future, slides running]
        self._tree_of: dict[str, str] = {}  # slide key -> its tree's key
        self._status: dict[str, int] = {}  # experiment id -> status when the sweep began
        self._before: set[str] = set()
        self._client: Any = None  # the session's dask client, from start()
        self._running, self._last = 0, 0.0
        self._stored, self._stored_at = 0, 0.0
        self._prepared: tuple[str, list[tuple[Study, PathPlan]]] | None = None

    def made(self) -> bool:
        """Whether every group of the study exists already (a sweep ran before)."""
        try:
            have = set(storage.list_groups(self.study.store))
        except storage.NotAStoreError:
            return False
        return all(part.group_name in have for part in self.parts)

    def prepare(self, solver: str) -> int:
        """The client's part before any cluster: create and reserve every group, find
        the paths still to do; how many there are (0: :func:`run_sweep` stops there)."""
        todo = [(part, p) for part in self.parts for p in self._start_part(part, solver)]
        self.report.skipped = len(self._before)
        self._prepared = (solver, todo)
        return len(todo)

    def start(self, session: Session) -> None:
        self._client = session.client
        if self._prepared is not None and self._prepared[0] == session.solver:
            for part, p in self._prepared[1]:
                self._add(part, p)
            return
        self.report, self._before = SweepReport(self.study, 0), set()  # prepared in vain
        for part in self.parts:  # a group's paths run while the next group is made
            for p in self._start_part(part, session.solver):
                self._add(part, p)
        self.report.skipped = len(self._before)

    def _start_part(self, study: Study, solver: str) -> list:
        """Create and reserve one group; its paths (or trees) still to do."""
        ensure_group(study, solver)
        trees = study.tree is not None and study.tree.solve == "tree"
        paths: list = tree_plan(study, solver) if trees else plan(study, solver, _held(study))
        exps = experiments(paths)
        ids = [e.id for e in exps]
        rolling = study.rolling is not None
        storage.reserve(study.store, study.group_name, ids,
                        parameters(exps, study.combined, rolling,
                                   trees=study.rolling is not None
                                   and bool(study.rolling.branch_from)))
        status = storage.statuses(study.store, study.group_name, ids)
        self._status.update(status)  # a tree's slides to submit (_submit_tree)
        todo = _todo(paths, status, self.retry_failed)
        self._before |= _account(self.report, study, paths, status, todo)
        return todo

    def _add(self, s: Study, p: PathPlan | TreePlan | RollTreePlan) -> None:
        if isinstance(p, TreePlan):
            self._submit_tree(s, p)
        elif isinstance(p, RollTreePlan):  # one task: the trunk, then its branches
            task = RollTreeTask(p, s.model, s.settings, s.store, s.group_name,
                                s.retry_smaller_increments)
            attempts = Attempts(self._client, run_rolling_tree, (task,), key=p.key,
                                retries=TASK_RETRIES)
            self._pending[attempts] = (s, PathPlan(p.key, p.pressure, p.experiments, p.motion))
        else:
            self._pending[self._submit(s, p)] = (s, p)

    def _submit_tree(self, s: Study, tree: TreePlan) -> None:
        """A trunk task, the small task that hands its outcome to the client, and a task
        per slide with experiments still to do, each taking the trunk's result."""
        client = self._client
        wanted, status = _wanted(self.retry_failed), self._status
        base = TreeTask(tree, s.model, s.settings, s.store, s.group_name,
                        s.retry_smaller_increments)
        trunk = client.submit(run_trunk, base, key=tree.key, pure=False, retries=TASK_RETRIES)
        done = client.submit(trunk_outcome, trunk, key=f"{tree.key}-outcome", pure=False)
        self._pending[_Plain(done)] = (s, PathPlan(tree.key, tree.pressure, tree.trunk,
                                                   tree.motion))
        slides = [b for b in tree.branches
                  if any(status.get(e.id, storage.PENDING) in wanted for e in b.experiments)]
        self._trunks[tree.key] = [trunk, len(slides)]
        for b in slides:
            self._tree_of[b.key] = tree.key
            task = replace(base, branch=b)
            fut = client.submit(run_branch, task, trunk, key=b.key, pure=False,
                                retries=TASK_RETRIES)
            self._pending[_Plain(fut)] = (s, PathPlan(b.key, tree.pressure, b.experiments,
                                                      b.experiments[-1].motion))
        if not slides:
            self._trunks.pop(tree.key)[0].release()  # only the outcome task holds it now

    def _slide_done(self, key: str) -> None:
        """Release a trunk's states once its last slide is done (until then they stay
        on the workers; the client never fetches them)."""
        tree = self._tree_of.pop(key, None)
        if tree is None:
            return
        held = self._trunks[tree]
        held[1] -= 1
        if held[1] <= 0:
            self._trunks.pop(tree)[0].release()

    def _submit(self, s: Study, path: PathPlan) -> Attempts:
        task = PathTask(path, s.model, s.settings, s.store, s.group_name,
                        s.retry_smaller_increments)
        return Attempts(self._client, run_path, (task,), key=path.key, retries=TASK_RETRIES)

    def poll(self) -> bool:
        for fut in [f for f in self._pending if f.status in ("finished", "error", "cancelled")]:
            if fut.status == "error" and fut.resubmit():  # its workers died: next attempt
                self.report.resubmitted += 1
                continue
            part, path = self._pending.pop(fut)
            self._slide_done(path.key)
            if fut.status == "finished":
                self._record(fut.result())
            else:
                self._task_failed(part, path, fut)
            fut.release()
        now = time.monotonic()
        if now - self._last > 1.0:  # the scheduler's view, once a second is plenty
            self._last = now
            self._running = sum(len(v) for v in self._client.processing().values())
        if now - self._stored_at > STORED_EVERY_S:
            self._stored_at, self._stored = now, self._in_store()
        if not self._pending:
            self._running = self._stored = 0
        return not self._pending

    def _in_store(self) -> int:
        """How many experiments of the tasks still running are done in the store."""
        # keyed by the store's identity: an S3 store (FsspecStore) is not hashable
        by_group: dict[tuple[int, str], tuple[Any, list[str]]] = {}
        for s, path in self._pending.values():
            by_group.setdefault((id(s.store), s.group_name), (s.store, []))[1].extend(
                e.id for e in path.experiments)
        counted = set(self.report.done) | self._before
        try:
            return sum(1 for (_, group), (store, ids) in by_group.items()
                       for i, status in storage.statuses(store, group, ids).items()
                       if status == storage.DONE and i not in counted)
        except storage.StoreError:  # a store that does not answer now: next time
            return self._stored

    def state(self) -> SweepState:
        r = self.report
        return SweepState(r.total, r.skipped, len(r.done), len(r.failed), self._running,
                          self._stored)

    def cancel(self) -> None:
        if self._pending:  # no further attempts; the workers' checks kill their ccx
            self._client.cancel([f.stop() for f in self._pending]
                                + [held[0] for held in self._trunks.values()])

    def finish(self, session: Session) -> SweepReport:
        return self.report

    def _record(self, outcome: PathOutcome) -> None:
        # a task skips what is done: either before this sweep (counted in report.skipped) or
        # by an earlier attempt of the same task on a worker that was lost (done now)
        report = self.report
        fresh = [i for i in (*outcome.done, *outcome.skipped) if i not in self._before]
        report.done += [i for i in fresh if i not in report.done]
        report.failed.update(dict(outcome.failed))
        for i in fresh:
            report.failed.pop(i, None)
        report.solve_seconds += outcome.solve_seconds
        report.ccx_runs += outcome.ccx_runs

    def _task_failed(self, s: Study, path: PathPlan, fut) -> None:
        """A task raised (after its retries) or was cancelled: record its experiments."""
        try:
            exc = fut.exception()
            reason = f"task error: {type(exc).__name__}: {exc}"
        except Exception as e:  # cancelled futures raise here
            reason = f"task {fut.status}: {type(e).__name__}"
        status = storage.statuses(s.store, s.group_name, [e.id for e in path.experiments])
        for exp in path.experiments:
            if status.get(exp.id) == storage.DONE:
                self.report.done.append(exp.id)
                continue
            storage.write_failure(s.store, s.group_name, exp.id, reason, {})
            self.report.failed[exp.id] = reason


def run_sweep(study: Study, *, scheduler: str | None = None, workers: int | None = None,
              retry_failed: bool = False, progress: Progress | None = None,
              on_client: Callable[[object], None] | None = None,
              cluster: ClusterSpec | None = None) -> SweepReport:
    """Run every experiment of ``study`` that is not done yet; return the report.

    ``cluster`` (:class:`jobs.cluster.ClusterSpec`, e.g. SLURM) replaces ``scheduler``
    and ``workers``.

    A sweep of groups made before, on an embedded cluster, first does the client's part
    (:meth:`Sweep.prepare`: groups, reservations, statuses); when the store holds every
    experiment as done (or failed, without ``retry_failed``) it ends there, without
    starting a cluster (``nothing_to_do``; issue 25: it took 16 s to learn that). A
    remote cluster's workers may run another solver version than this machine, which
    changes every id, so only they can tell what is left: the sweep connects first."""
    sweep = Sweep(study, retry_failed)
    spec = cluster_spec(cluster, scheduler, workers)
    if spec.embedded and sweep.made():
        start = time.perf_counter()
        solver = solver_version(None, embedded=True)
        if not sweep.prepare(solver):
            report = sweep.report
            report.nothing_to_do, report.solver = True, solver
            report.wall_seconds = time.perf_counter() - start
            if progress is not None:
                progress.finished(report)
            return report
    return drive(sweep, cluster=spec, progress=progress, on_client=on_client)
