"""Run an inverse study on Dask: ``farm invert study.toml``.

The client solves (or replays) the reference experiment, then runs every loop of the
study in its own thread; the loops' evaluations go to the workers through one shared
:class:`~jobs.loops.evaluator.Evaluator`. When all loops have ended, the client writes
the study's group of the store. Re-running the same study replays every evaluation
from the cache (no ccx): that is how a loop is resumed after the client died.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from farm.mesh import mesh_for
from jobs.cluster import connect, dashboard_link
from jobs.inverse.loop import LoopResult, LoopSpec, LoopState, expand_loops, run_loop
from jobs.inverse.mask import masks_for
from jobs.inverse.problem import Problem, build_problem
from jobs.inverse.store import write_results
from jobs.inverse.study import InverseStudy
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluator, Interrupted, LoopStats
from jobs.sweep import solver_version

POLL_SECONDS = 0.5


@dataclass
class InverseReport:
    """How an inverse study ended. ``ok`` when every loop ended without failing."""

    study: InverseStudy
    problem: Problem | None = None
    results: list[LoopResult] = field(default_factory=list)
    errors: dict[str, str] = field(default_factory=dict)
    totals: LoopStats = field(default_factory=LoopStats)
    wall_seconds: float = 0.0
    dashboard: str = ""

    @property
    def ok(self) -> bool:
        return not self.errors and all(r.status != "failed" for r in self.results)


class Progress:
    """Callbacks a front end implements to follow the loops (all optional)."""

    def started(self, dashboard: str, workers: int, loops: list[LoopState]) -> None: ...
    def advanced(self, loops: list[LoopState]) -> None: ...
    def loop_finished(self, state: LoopState, result: LoopResult | None, error: str) -> None: ...
    def finished(self, report: InverseReport) -> None: ...


def run_inverse(study: InverseStudy, *, scheduler: str | None = None,
                workers: int | None = None, progress: Progress | None = None,
                on_client: Callable[[object], None] | None = None,
                write: bool = True) -> InverseReport:
    """Run every loop of ``study`` and write the results group; return the report."""
    progress = progress or Progress()
    start = time.perf_counter()
    specs = expand_loops(study)
    masks = masks_for(study.mask, mesh_for(study.model).inner_nodes,
                      {m for c in study.conditions for m in c.methods})  # bad input: now
    report = InverseReport(study)
    with connect(scheduler, workers) as client:
        if on_client is not None:
            on_client(client)
        solver = solver_version(client, scheduler is None)
        evaluator = Evaluator(client, EvaluationCache(study.cache))
        report.dashboard = dashboard_link(client)
        report.problem = build_problem(study, evaluator, solver)
        states = [LoopState(s.label, s.optimizer.max_evaluations) for s in specs]
        progress.started(report.dashboard, len(client.scheduler_info()["workers"]), states)
        _run_loops(study, report, specs, states, evaluator, masks, progress)
        report.totals = evaluator.total
    if write and report.results:
        write_results(study, report.problem, report.results)
    report.wall_seconds = time.perf_counter() - start
    progress.finished(report)
    return report


def _run_loops(study: InverseStudy, report: InverseReport, specs: list[LoopSpec],
               states: list[LoopState], evaluator: Evaluator, masks: dict,
               progress: Progress) -> None:
    """One thread per loop; the client thread polls for progress."""
    problem = report.problem
    pool = ThreadPoolExecutor(max_workers=max(1, len(specs)), thread_name_prefix="loop")
    futures: dict[Future, int] = {
        pool.submit(run_loop, study, problem, s, evaluator, st, masks.get(s.method)): k
        for k, (s, st) in enumerate(zip(specs, states, strict=True))}
    results: dict[int, LoopResult] = {}
    try:
        pending = set(futures)
        while pending:
            for fut in [f for f in pending if f.done()]:
                pending.discard(fut)
                _collect(fut, futures[fut], states, results, report, progress)
            progress.advanced(states)
            if pending:
                time.sleep(POLL_SECONDS)
    except BaseException:
        evaluator.close()  # loops stop at their next evaluation; in-flight tasks cancelled
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    report.results = [results[k] for k in sorted(results)]


def _collect(fut: Future, k: int, states: list[LoopState], results: dict,
             report: InverseReport, progress: Progress) -> None:
    state = states[k]
    try:
        results[k] = fut.result()
        progress.loop_finished(state, results[k], "")
    except Interrupted:
        state.status = "interrupted"
    except Exception as e:  # one loop's failure (e.g. its guess) does not stop the others
        state.status = "failed"
        report.errors[state.label] = f"{type(e).__name__}: {e}"
        progress.loop_finished(state, None, report.errors[state.label])


def summary_line(report: InverseReport) -> str:
    """One line: loops, evaluations, solver runs and time."""
    t = report.totals
    n = len(report.results)
    best = np.nanmedian([r.objective for r in report.results]) if n else float("nan")
    return (f"{n} solves, {t.evaluations} evaluations ({t.solved} solved by ccx, {t.cached} "
            f"from the cache, {t.shared} shared between loops), {t.rounds} rounds, "
            f"median final objective {best:.3g}, {report.wall_seconds:.1f} s wall")
