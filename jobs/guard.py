"""The worker side of every job: one guard around a solve, and its typed result.

Sweeps (:mod:`jobs.tasks`) and optimisation loops (:mod:`jobs.loops`) run their solves
through :func:`guarded`, which applies the failure policy that
:class:`farm.ccx.outcome.Outcome` owns:

1. an outcome worth it (:attr:`Outcome.retry_smaller`: non-convergence, a crash) is
   retried ONCE with four times smaller increments and, for a combined-load path, its
   rise in a step of its own (:attr:`farm.specs.SolverSettings.split_rise`);
2. what still fails comes back as :class:`Failed` data with its reason - a sweep records
   it in the store, a loop caches it (the same input would fail again) unless it is
   :attr:`~Failed.transient` (a timeout: not a property of the input);
3. a cancellation raises: the job is being stopped, there is nothing to record.

A mesh or results error of the physics layer (:class:`farm.errors.FarmError`) is
deterministic and recorded as data too; anything else (a bug) raises.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

from farm.ccx.outcome import Outcome
from farm.errors import FarmError, SolverError
from farm.measure.measurement import Measurement
from farm.specs import SolverSettings
from jobs import events


@dataclass(frozen=True, eq=False)
class Solved:
    """A successful solve: one measurement per state of its load path.

    ``state``: the solver's saved state at the end of the path (a compressed ccx restart
    file) when the solve kept it for others to continue from
    (:mod:`farm.solve.continuation`), else None.
    """

    measurements: tuple[Measurement, ...]
    solve_seconds: float
    ccx_runs: int = 1
    increments: int = 0
    state: bytes | None = None

    @property
    def measurement(self) -> Measurement:
        """The only measurement of a single-state solve (loop evaluations)."""
        if len(self.measurements) != 1:
            raise ValueError(f"a solve of {len(self.measurements)} states has no single "
                             "measurement: index .measurements")
        return self.measurements[0]


@dataclass(frozen=True)
class Failed:
    """A solve that failed for a reason worth recording (failures are data).

    ``outcome`` is an :class:`~farm.ccx.outcome.Outcome` value, or the error class name
    for failures outside ccx (a mesh error, a lost task).
    """

    reason: str
    outcome: str = "error"
    transient: bool = False
    #: the states its load path reached before it stopped (a roll, issue 45), solved
    #: and measured: the task stores them and records the rest as failed
    partial: Solved | None = None

    @property
    def retry_smaller(self) -> bool:
        """True when the solver's outcome says smaller steps (or pieces) may get through."""
        try:
            return Outcome(self.outcome).retry_smaller
        except ValueError:  # not a solver outcome
            return False


Result = Solved | Failed
T = TypeVar("T")


def smaller_increments(settings: SolverSettings) -> SolverSettings:
    """The retry's settings: four times smaller increments (and room for more of them),
    and a combined path's rise begun in a step of its own, where increments start small
    again before first touch (``split_rise``: the retry that got the first-touch
    failures through, docs/combined-loads.md "First touch"; smaller increments alone
    got none of them through)."""
    return dataclasses.replace(
        settings, initial_increment=settings.initial_increment / 4,
        max_increment=settings.max_increment / 4,
        min_increment=min(settings.min_increment, settings.initial_increment / 400),
        max_increments=settings.max_increments * 4, split_rise=True)


def guarded(solve: Callable[[SolverSettings], T], settings: SolverSettings, *,
            retry: bool = True) -> T | Failed:
    """Run ``solve(settings)`` under the policy above; ``retry=False`` skips step 1.
    ``solve`` returns a :class:`Solved` for sweeps and loops, anything for other jobs
    (a :class:`farm.experiment.PathResult` for the convergence study). In a Dask task the
    solver's progress and the outcome go to the scheduler's farm page
    (:mod:`jobs.events`)."""
    start = time.perf_counter()
    with events.publishing():
        result = _guarded(solve, settings, retry)
    if isinstance(result, Failed):
        events.finished("failed", time.perf_counter() - start, result.reason)
    else:
        events.finished("done", time.perf_counter() - start)
    return result


def _guarded(solve: Callable[[SolverSettings], T], settings: SolverSettings,
             retry: bool) -> T | Failed:
    tries: list[SolverError] = []
    try:
        start = time.perf_counter()
        try:
            return solve(settings)
        except SolverError as e:
            if not (retry and Outcome(e.outcome).retry_smaller):
                raise
            tries.append(e)
            failed = time.perf_counter() - start
            return _counting_the_failed_try(solve(smaller_increments(settings)), failed)
    except SolverError as e:
        outcome = Outcome(e.outcome)
        if outcome is Outcome.CANCELLED:
            raise
        return Failed(str(e), outcome.value, outcome.transient, _furthest([*tries, e]))
    except FarmError as e:
        return Failed(f"{type(e).__name__}: {e}", type(e).__name__)


def _furthest(tries: list[SolverError]) -> Solved | None:
    """Of the failed tries of a path, the states the one that got furthest reached
    (:attr:`farm.errors.SolverError.partial`: measurements; issue 45), as a
    :class:`Solved` whose seconds are the last state's and whose runs count every try;
    None where no try kept a state."""
    kept = [e.partial for e in tries if isinstance(e.partial, tuple) and e.partial
            and all(isinstance(m, Measurement) for m in e.partial)]
    if not kept:
        return None
    best: tuple[Measurement, ...] = max(kept, key=len)
    return Solved(best, float(best[-1].solve_seconds), ccx_runs=len(tries))


def _counting_the_failed_try(result: T, seconds: float) -> T:
    """A retry's result with the failed first try counted in: one more ccx run and its
    wall time in the path's solver seconds (what the experiment cost; a state's own
    ``solve_seconds`` stays the retry's). Results other than :class:`Solved` as they are."""
    if isinstance(result, Solved):
        return dataclasses.replace(result, solve_seconds=result.solve_seconds + seconds,
                                   ccx_runs=result.ccx_runs + 1)
    return result


def cancellation_check() -> Callable[[], bool] | None:
    """A poll that turns True once Dask cancels the task running in this thread.

    Dask cannot interrupt a running task; a cancelled one is only marked on its worker.
    The runner polls this and kills ccx, so a cancelled job leaves no solver behind.
    """
    try:
        from distributed import get_worker
        from distributed.worker import thread_state

        worker, key = get_worker(), thread_state.key
    except (ImportError, ValueError, AttributeError):
        return None
    checked_at, cancelled = 0.0, False

    def stop() -> bool:
        nonlocal checked_at, cancelled
        now = time.monotonic()
        if now - checked_at > 1.0:  # reading worker state is cheap, but once a second is plenty
            checked_at = now
            ts = worker.state.tasks.get(key)
            cancelled = ts is None or ts.state in ("cancelled", "released", "forgotten")
        return cancelled

    return stop
