"""What a worker runs: solve one load path and write its experiments into the store.

A task is idempotent: it first skips experiments the store already holds as done (a
task re-run after its worker died redoes only what was lost), writes each experiment
into its own store slot (status last), and records solver failures as data.

Failure policy (the solver's outcome is classified by :mod:`farm.ccx.outcome`):

1. non-convergence (too many cutbacks, increment below minimum, too many increments,
   divergence) is retried ONCE with four times smaller increments, which often gets a
   contact path through a difficult touch-down;
2. if a path of several deflections still fails, each deflection is solved on its own,
   so that one deflection beyond the model's reach does not take its neighbours down;
3. what still fails is written as failed with the reason; input errors, nonpositive
   Jacobians, timeouts and crashes are recorded at once (retrying would not help, or
   is Dask's business: a lost worker's task is re-run elsewhere).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import storage
from farm.errors import FarmError, SolverError
from farm.experiment import run_load_path
from farm.specs import LoadPath, ModelSpec, SolverSettings
from jobs.expand import Experiment, PathPlan
from jobs.loops.guard import smaller_increments

RETRY_SMALLER = {"too_many_cutbacks", "increment_below_minimum", "max_increments", "diverged"}


@dataclass(frozen=True)
class PathTask:
    """Everything a worker needs, as plain picklable values."""

    path: PathPlan
    model: dict
    settings: SolverSettings
    store: str
    group: str
    retry_smaller_increments: bool = True


@dataclass(frozen=True)
class PathOutcome:
    """What a task did: experiment ids done, failed (with reasons) and skipped."""

    key: str
    done: tuple[str, ...] = ()
    failed: tuple[tuple[str, str], ...] = ()
    skipped: tuple[str, ...] = ()
    solve_seconds: float = 0.0
    ccx_runs: int = 0


def _info(result, m) -> dict:
    return {"solve_seconds": m.solve_seconds, "increments": result.increments,
            "ccx_runs": result.ccx_runs, "contact_nodes": m.contact_nodes}


def _solve(model: ModelSpec, exps: list[Experiment], settings: SolverSettings,
           task: PathTask, should_stop, retried: bool = False) -> PathOutcome:
    """Solve the experiments as one path; on failure apply the retry policy."""
    path = LoadPath(tuple(e.deflection for e in exps), exps[0].pressure)
    try:
        result = run_load_path(model, path, settings, should_stop=should_stop)
    except SolverError as e:
        if e.outcome not in RETRY_SMALLER:
            if e.outcome == "cancelled":
                raise
            return _record_failure(task, exps, str(e))
        if task.retry_smaller_increments and not retried:
            smaller = smaller_increments(settings)
            return _solve(model, exps, smaller, task, should_stop, retried=True)
        if len(exps) > 1:
            parts = [_solve(model, [x], settings, task, should_stop, retried) for x in exps]
            return PathOutcome(task.path.key, sum((p.done for p in parts), ()),
                               sum((p.failed for p in parts), ()), (),
                               sum(p.solve_seconds for p in parts),
                               sum(p.ccx_runs for p in parts))
        return _record_failure(task, exps, str(e))
    except FarmError as e:  # a mesh or results error: deterministic, recorded as data
        return _record_failure(task, exps, f"{type(e).__name__}: {e}")
    for x, m in zip(exps, result.measurements, strict=True):
        storage.write_experiment(task.store, task.group, x.id, m.arrays(), _info(result, m))
    return PathOutcome(task.path.key, done=tuple(x.id for x in exps),
                       solve_seconds=result.solve_seconds, ccx_runs=result.ccx_runs)


def _record_failure(task: PathTask, exps: list[Experiment], reason: str) -> PathOutcome:
    for x in exps:
        storage.write_failure(task.store, task.group, x.id, reason, {})
    return PathOutcome(task.path.key, failed=tuple((x.id, reason) for x in exps))


def cancellation_check() -> Callable[[], bool] | None:
    """A poll that turns True once Dask cancels the task running in this thread.

    Dask cannot interrupt a running task; a cancelled one is only marked on its worker.
    The runner polls this and kills ccx, so a cancelled sweep leaves no solver behind.
    """
    try:
        from distributed import get_worker
        from distributed.worker import thread_state

        worker, key = get_worker(), thread_state.key
    except (ImportError, ValueError, AttributeError):
        return None
    last = [0.0, False]

    def stop() -> bool:
        now = time.monotonic()
        if now - last[0] > 1.0:  # reading worker state is cheap, but once a second is plenty
            last[0] = now
            ts = worker.state.tasks.get(key)
            last[1] = ts is None or ts.state in ("cancelled", "released", "forgotten")
        return last[1]

    return stop


def run_path(task: PathTask) -> PathOutcome:
    """Worker entry point: solve the path's experiments not yet done, write them."""
    ids = [e.id for e in task.path.experiments]
    status = storage.statuses(task.store, task.group, ids)
    todo = [e for e in task.path.experiments if status.get(e.id) != storage.DONE]
    skipped = tuple(e.id for e in task.path.experiments if status.get(e.id) == storage.DONE)
    if not todo:
        return PathOutcome(task.path.key, skipped=skipped)
    model = ModelSpec.from_dict(task.model)
    outcome = _solve(model, todo, task.settings, task, cancellation_check())
    return dataclasses.replace(outcome, skipped=skipped)
