"""Submit a study to Dask and follow it to the end: ``farm sweep submit|resume``.

Submission and resumption are one idempotent operation: the study is expanded, the
client creates the group and reserves room for every experiment (the store's only
metadata writer), experiments the store holds as done are skipped, and one task per
remaining load path goes to the cluster. Workers write their own experiments; a task
that raises (a bug, a store outage) has its experiments recorded as failed by the
client, so a sweep always ends with every experiment done or failed with a reason.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import storage
from farm.ccx.runner import ccx_version
from jobs.cluster import connect, dashboard_link
from jobs.errors import ClusterError
from jobs.expand import Experiment, PathPlan, experiments, parameters, plan
from jobs.storeio import ensure_group
from jobs.study import Study
from jobs.tasks import PathOutcome, PathTask, run_path

POLL_SECONDS = 0.25
TASK_RETRIES = 2  # for exceptions raised by a task; lost workers are Dask's allowed-failures


@dataclass
class SweepReport:
    """How a sweep ended. ``ok`` only if every experiment of the study is done."""

    study: Study
    total: int
    skipped: int = 0  # done before this sweep started
    done: list[str] = field(default_factory=list)
    failed: dict[str, str] = field(default_factory=dict)
    experiments: dict[str, Experiment] = field(default_factory=dict)
    wall_seconds: float = 0.0
    solve_seconds: float = 0.0
    ccx_runs: int = 0
    dashboard: str = ""

    @property
    def ok(self) -> bool:
        return self.skipped + len(self.done) == self.total and not self.failed


class Progress:
    """Callbacks a front end implements to show a sweep (all optional)."""

    def started(self, dashboard: str, workers: int, total: int, skipped: int) -> None: ...
    def advanced(self, done: int, failed: int, running: int) -> None: ...
    def finished(self, report: SweepReport) -> None: ...


def solver_version(client, embedded: bool) -> str:
    """``CalculiX <version>`` of the workers (part of every experiment id)."""
    if embedded:
        return f"CalculiX {ccx_version()}"
    if not client.scheduler_info().get("workers"):
        try:
            client.wait_for_workers(1, timeout=60)
        except TimeoutError as e:
            raise ClusterError("the scheduler has no workers: start some with "
                               "`dask worker <scheduler address>`") from e
    return f"CalculiX {client.submit(ccx_version, pure=False).result()}"


def _todo(paths: list[PathPlan], status: dict[str, int], retry_failed: bool) -> list[PathPlan]:
    wanted = {storage.PENDING} | ({storage.FAILED} if retry_failed else set())
    return [p for p in paths if any(status.get(e.id, storage.PENDING) in wanted
                                    for e in p.experiments)]


def run_sweep(study: Study, *, scheduler: str | None = None, workers: int | None = None,
              retry_failed: bool = False, progress: Progress | None = None,
              on_client: Callable[[object], None] | None = None) -> SweepReport:
    """Run every experiment of ``study`` that is not done yet; return the report."""
    progress = progress or Progress()
    start = time.perf_counter()
    with connect(scheduler, workers) as client:
        if on_client is not None:
            on_client(client)
        solver = solver_version(client, scheduler is None)
        paths = plan(study, solver)
        exps = experiments(paths)
        ensure_group(study, solver)
        storage.reserve(study.store, study.group_name, [e.id for e in exps], parameters(exps))
        status = storage.statuses(study.store, study.group_name, [e.id for e in exps])
        report = SweepReport(study, len(exps), experiments={e.id: e for e in exps},
                             dashboard=dashboard_link(client))
        before = {i for i, s in status.items() if s == storage.DONE}
        report.skipped = len(before)
        todo = _todo(paths, status, retry_failed)
        for p in paths:
            if p not in todo:
                report.failed.update({e.id: "failed before (use --retry-failed)"
                                      for e in p.experiments if status[e.id] == storage.FAILED})
        progress.started(report.dashboard, len(client.scheduler_info()["workers"]), report.total,
                         report.skipped)
        _follow(client, study, todo, report, progress, before)
    report.wall_seconds = time.perf_counter() - start
    progress.finished(report)
    return report


def _submit(client, study: Study, path: PathPlan):
    task = PathTask(path, study.model.to_dict(), study.settings, study.store, study.group_name,
                    study.retry_smaller_increments)
    return client.submit(run_path, task, key=path.key, pure=False, retries=TASK_RETRIES)


def _record(report: SweepReport, outcome: PathOutcome, before: set[str]) -> None:
    # a task skips what is done: either before this sweep (counted in report.skipped) or
    # by an earlier attempt of the same task on a worker that was lost (done now)
    fresh = [i for i in (*outcome.done, *outcome.skipped) if i not in before]
    report.done += [i for i in fresh if i not in report.done]
    report.failed.update(dict(outcome.failed))
    for i in fresh:
        report.failed.pop(i, None)
    report.solve_seconds += outcome.solve_seconds
    report.ccx_runs += outcome.ccx_runs


def _follow(client, study: Study, todo: list[PathPlan], report: SweepReport,
            progress: Progress, before: set[str]) -> None:
    """Wait for the tasks, recording outcomes; on interruption cancel them (kills ccx)."""
    futures = {_submit(client, study, p): p for p in todo}
    pending = dict(futures)
    last_running = 0.0
    try:
        while pending:
            for fut in [f for f in pending if f.status in ("finished", "error", "cancelled")]:
                path = pending.pop(fut)
                if fut.status == "finished":
                    _record(report, fut.result(), before)
                else:
                    _task_failed(study, report, path, fut)
                fut.release()
            now = time.monotonic()
            if now - last_running > 1.0:
                last_running = now
                running = sum(len(v) for v in client.processing().values())
                progress.advanced(len(report.done), len(report.failed), running)
            if pending:
                time.sleep(POLL_SECONDS)
        progress.advanced(len(report.done), len(report.failed), 0)
    except BaseException:
        client.cancel(list(pending))  # the workers' cancellation checks kill their ccx
        raise


def _task_failed(study: Study, report: SweepReport, path: PathPlan, fut) -> None:
    """A task raised (after its retries) or was cancelled: record its experiments."""
    try:
        exc = fut.exception()
        reason = f"task error: {type(exc).__name__}: {exc}"
    except Exception as e:  # cancelled futures raise here
        reason = f"task {fut.status}: {type(e).__name__}"
    status = storage.statuses(study.store, study.group_name, [e.id for e in path.experiments])
    for e in path.experiments:
        if status.get(e.id) == storage.DONE:
            report.done.append(e.id)
            continue
        storage.write_failure(study.store, study.group_name, e.id, reason, {})
        report.failed[e.id] = reason
