"""Warm starts: a loop's evaluations continue from the solved states of its own points.

The optimisers say which evaluated point a batch lies near (``base``: the current point
of a trial step, the point of a Jacobian's columns; :mod:`jobs.loops.optimizers`,
:mod:`jobs.loops.secant`). :class:`WarmStarts` turns that into forward evaluations that
continue from the base's kept solver state (:mod:`farm.solve.continuation`):

- a point with no base (a loop's initial guess, an anchor) is solved from rest and
  keeps its state;
- a single point near a base (a trial step) continues from the base's state and keeps
  its own, so the next step can continue from it;
- many points near a base (the columns of a finite-difference Jacobian) are solved in
  ccx runs of ``columns_per_run`` points each, every run continuing from the base's
  state through its points one step at a time (they are 0.1 N apart).

Measured on the default reduced mesh (docs/inverse.md, "Warm starts"): a point from
rest takes ~6 s; a step from a neighbour ~0.7 s; eight Jacobian columns ~3 s in one run.

Keys: a continuation's key names the evaluation it starts from, so the same point
reached along another path is another evaluation, and what a key holds never depends
on which loop asked first (:func:`jobs.inverse.evaluate.task_key`). The path of a loop
is deterministic, so a re-run asks for the same keys and replays them from the cache.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from jobs.guard import Failed, Result, Solved
from jobs.identity import canonical
from jobs.inverse.problem import Problem
from jobs.loops.evaluator import Evaluation, Evaluator, LoopStats


class WarmStarts:
    """A loop's forward evaluations, continued from its own solved points.

    Parameters
    ----------
    problem : Problem
    evaluator : Evaluator
    stats : LoopStats
        The loop's counters.
    columns_per_run : int
        Points of a batch near one base solved in one ccx run.
    enabled : bool
        False: every point is the plain evaluation from rest (the path before warm
        starts, ``warm_starts = false``).
    """

    def __init__(self, problem: Problem, evaluator: Evaluator, stats: LoopStats,
                 columns_per_run: int, enabled: bool = True) -> None:
        self.problem, self.evaluator, self.stats = problem, evaluator, stats
        self.columns_per_run, self.enabled = columns_per_run, enabled
        # single points this loop solved keeping their state: point -> evaluation (the
        # state itself stays in the evaluation cache until a solve continues from it)
        self._solved: dict[bytes, Evaluation] = {}

    def run(self, points: Sequence[np.ndarray], base: np.ndarray | None = None
            ) -> list[Result]:
        """One round: a result per point, each with one measurement."""
        points = [np.asarray(p, dtype=float) for p in points]
        if not self.enabled:
            return self.evaluator.run([self.problem.forward_evaluation(p) for p in points],
                                      self.stats)
        start = self._start(base)
        if start is None or len(points) == 1:
            batch = [self._single(p, start) for p in points]
        else:
            n = self.columns_per_run
            batch = [self.problem.forward_evaluation(points[k], then=points[k + 1:k + n],
                                                     start=start)
                     for k in range(0, len(points), n)]
        results = self.evaluator.run(batch, self.stats)
        out: list[Result] = []
        for e, r in zip(batch, results, strict=True):
            if e.points == 1 and e.argument.keep_state and isinstance(r, Solved):
                self._solved[_tag(e.argument.forces)] = e
            out += _per_point(r, e.points)
        return out

    def around(self, x: np.ndarray, points: Sequence[np.ndarray]) -> list[Result]:
        """Results at x and at ``points`` near it (a Jacobian's columns): one round, or
        with warm starts x first and the points from its state."""
        if not self.enabled:
            return self.run([x, *points])
        return [*self.run([x]), *self.run(points, base=x)]

    def _start(self, base: np.ndarray | None) -> tuple[str, bytes] | None:
        """(key, kept state) of the evaluation that solved ``base``; None: from rest (no
        base, a base this loop did not solve, or its state is gone from the cache)."""
        e = None if base is None else self._solved.get(_tag(base))
        if e is None:
            return None
        state = self.evaluator.cache.state(e.key)
        return None if state is None else (e.key, state)

    def _single(self, p: np.ndarray, start: tuple[str, bytes] | None) -> Evaluation:
        known = self._solved.get(_tag(p))
        if known is not None:  # asked again (the loop's final point): the same evaluation
            return known
        return self.problem.forward_evaluation(p, keep_state=True, start=start)


def _tag(x) -> bytes:
    """A point as the forward model solves it (rounded as evaluation keys round it)."""
    return np.asarray(canonical(x), dtype=float).tobytes()


def _per_point(result: Result, points: int) -> list[Result]:
    """One single-measurement result per point of an evaluation of ``points`` points."""
    if isinstance(result, Failed) or points == 1:
        return [result] * points
    return [Solved((m,), m.solve_seconds) for m in result.measurements]
