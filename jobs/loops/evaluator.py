"""Solver evaluations of many client-side loops, deduplicated, cached and spread on Dask.

A loop asks for a batch of evaluations and blocks its own thread (never a worker) until
they are back. Each evaluation is one Dask task whose key is the content hash of what it
solves; the :class:`Evaluator` answers from the cache when it can, joins a task already
in flight when another loop asked for the same thing, and submits otherwise. Because
tasks never wait on tasks, any number of loops can share any number of workers without
deadlock. A worker lost mid-task costs that task only: the scheduler re-runs it
elsewhere, and a task the scheduler gives up after lost workers is resubmitted under a
new key (``<key>-retry<n>``, :class:`jobs.cluster.Attempts`).

Worker functions return a typed result of :mod:`jobs.guard`: :class:`~jobs.guard.Solved`
or :class:`~jobs.guard.Failed`. A deterministic failure (the solver did not converge for
this input) is cached like a result: re-solving it would fail the same way. A transient
one (a timeout) and an exception (a bug, a lost task after its retries) are not cached:
the loop sees a failed evaluation, and a later run tries again.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from jobs.guard import Failed, Result
from jobs.loops.cache import EvaluationCache

TASK_RETRIES = 2


@dataclass(frozen=True)
class Evaluation:
    """One solver evaluation: its content hash, the worker function and its argument."""

    key: str
    function: Callable[[Any], Result]
    argument: Any
    prefix: str = "eval"
    points: int = 1  # the points it solves (one ccx run may solve several in a row)

    @property
    def task_key(self) -> str:
        return f"{self.prefix}-{self.key}"


@dataclass
class LoopStats:
    """What one loop spent (updated by the evaluator; read by progress displays).

    ``evaluations`` counts the points evaluated (an evaluation that solves several in
    one ccx run counts each). ``rounds`` counts the batches the loop waited for: the
    sequential evaluations of the loop's critical path, whatever the batch sizes.
    ``solved`` counts the evaluations this loop submitted to the workers (ccx runs, for
    the forward model), ``cached`` those answered from the cache and ``shared`` those
    another loop had in flight.
    """

    evaluations: int = 0
    rounds: int = 0
    solved: int = 0
    cached: int = 0
    shared: int = 0
    failed: int = 0
    solver_seconds: float = 0.0
    wait_seconds: float = 0.0
    lock: threading.Lock = field(default_factory=threading.Lock, repr=False)


class Interrupted(Exception):
    """The run is shutting down (interrupted or failed): loops stop where they are."""


class Evaluator:
    """Shared by every loop of a run; thread-safe.

    Parameters
    ----------
    client : distributed.Client or None
        Where evaluations run; ``None`` runs them in the calling thread (tests, tools).
    cache : EvaluationCache
        Finished evaluations (the client is its only writer).
    """

    def __init__(self, client, cache: EvaluationCache) -> None:
        self.client, self.cache = client, cache
        self._lock = threading.Lock()
        self._inflight: dict[str, Any] = {}
        self.total = LoopStats()
        self.closed = threading.Event()

    def close(self) -> None:
        """Stop every loop at its next evaluation and cancel what is in flight."""
        self.closed.set()
        with self._lock:
            pending, self._inflight = list(self._inflight.values()), {}
        if self.client is not None and pending:
            self.client.cancel([f for f in pending if not isinstance(f, _Done)])

    def run(self, batch: Sequence[Evaluation], stats: LoopStats | None = None
            ) -> list[Result]:
        """Results of ``batch``, in order; blocks until all are back (one round).

        Raises :class:`Interrupted` once :meth:`close` was called.
        """
        if self.closed.is_set():
            raise Interrupted
        start = time.perf_counter()
        sources, futures = self._dispatch(batch)
        results = [self._result(e, futures.get(e.key), sources[e.key]) for e in batch]
        if self.closed.is_set():
            raise Interrupted
        waited = time.perf_counter() - start
        for s in (stats, self.total):
            if s is not None:
                self._count(s, batch, sources, results, waited)
        return results

    def _dispatch(self, batch: Sequence[Evaluation]) -> tuple[dict[str, str], dict]:
        """Decide per unique key: cached, shared (in flight) or solved (submitted now)."""
        sources: dict[str, str] = {}
        futures: dict[str, Any] = {}
        with self._lock:
            for e in batch:
                if e.key in sources:
                    continue
                if e.key in self.cache:
                    sources[e.key] = "cached"
                elif e.key in self._inflight:
                    sources[e.key], futures[e.key] = "shared", self._inflight[e.key]
                else:
                    sources[e.key] = "solved"
                    futures[e.key] = self._inflight[e.key] = self._submit(e)
        return sources, futures

    def _submit(self, e: Evaluation):
        if self.client is None:
            return _Done(e.function, e.argument)
        return self.client.submit(e.function, e.argument, key=e.task_key, pure=False,
                                  retries=TASK_RETRIES)

    def _result(self, e: Evaluation, future, source: str) -> Result:
        if source == "cached":
            hit = self.cache.get(e.key)
            if hit is not None:
                return hit
        try:
            result = future.result()
        except Exception as exc:  # a task error or a lost task: not cached, reported
            result = Failed(f"task error: {type(exc).__name__}: {exc}", type(exc).__name__,
                            transient=True)
        with self._lock:
            # whichever loop's thread sees the result first caches it, so that it is in
            # the cache before any caller of run() has it: a warm start reads the kept
            # state of a point from the cache (jobs/inverse/warm.py), and the loop that
            # joined a shared evaluation must find it there as surely as the one that
            # submitted it, or its path would depend on which thread woke first
            first = future is not None and self._inflight.get(e.key) is future
            if first:
                del self._inflight[e.key]
                if not (isinstance(result, Failed) and result.transient):
                    self.cache.put(e.key, result)
        return result

    @staticmethod
    def _count(s: LoopStats, batch, sources, results, waited: float) -> None:
        with s.lock:
            s.evaluations += sum(e.points for e in batch)
            s.rounds += 1
            s.wait_seconds += waited
            seen = set()
            for e, r in zip(batch, results, strict=True):
                if e.key in seen:
                    continue
                seen.add(e.key)
                kind = sources[e.key]
                setattr(s, kind, getattr(s, kind) + 1)
                if isinstance(r, Failed):
                    s.failed += 1
                elif kind == "solved":
                    s.solver_seconds += r.solve_seconds


class _Done:
    """A finished 'future' for evaluations run in the calling thread (no client)."""

    def __init__(self, function, argument) -> None:
        try:
            self._value, self._error = function(argument), None
        except Exception as e:
            self._value, self._error = None, e

    def result(self):
        if self._error is not None:
            raise self._error
        return self._value
