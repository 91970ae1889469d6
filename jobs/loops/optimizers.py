"""The two optimisers of the loops, over a batch-evaluating function.

Both take ``evaluate(points) -> residual vectors`` which solves a batch of points in ONE
round on the workers (see :class:`jobs.loops.evaluator.Evaluator`), and a budget of
evaluations (every solver evaluation counts, finite-difference columns included).

- :func:`nelder_mead`: the thesis' unconstrained Nelder-Mead (§4.2), scipy's
  implementation. Its initial simplex is solved as one batch (n + 1 points side by
  side); after that every evaluation depends on the previous one.
- :func:`least_squares`: scipy's trust-region reflective least squares with a
  forward-difference Jacobian whose n columns are solved as one batch: one round per
  Jacobian instead of n sequential evaluations (the first one together with x0).

The objective value is the residuals' 2-norm, so that with residuals scaled by
1/sqrt(N) it is exactly the RMS of thesis eqs. 4.1/4.2.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize

BatchFunction = Callable[..., list[np.ndarray]]
"""``evaluate(points)``, or with ``warm_starts`` ``evaluate(points, base=x)``: ``x``
(evaluated alone before) is where the points lie near, so their solves may continue
from its solved state (:mod:`jobs.inverse.warm`)."""

# scipy's Nelder-Mead initial simplex: 5 % of each nonzero coordinate, 0.00025 for zeros.
NONZDELT, ZDELT = 0.05, 0.00025


@dataclass(frozen=True)
class Outcome:
    """How a loop ended.

    ``status`` is ``converged`` (the optimiser's own tolerance was met),
    ``max_evaluations`` (the budget ran out; ``x`` is the best point seen) or
    ``stopped`` (a caller's stop condition).
    """

    x: np.ndarray
    objective: float
    status: str
    message: str
    iterations: int


class BudgetSpent(Exception):
    """Raised inside the objective when the evaluation budget is spent."""


class Tracker:
    """Counts evaluations against the budget and remembers the best point.

    ``warm``: pass each batch's ``base`` on to ``evaluate`` (see :data:`BatchFunction`).
    """

    def __init__(self, evaluate: BatchFunction, budget: int,
                 stop: Callable[[np.ndarray, float], bool] | None, warm: bool = False) -> None:
        self.evaluate, self.budget, self.stop, self.warm = evaluate, budget, stop, warm
        self.used = 0
        self.best_x: np.ndarray | None = None
        self.best_f = np.inf
        self.stopped = False

    def around(self, x: np.ndarray, points: Sequence[np.ndarray]) -> list[np.ndarray]:
        """r(x) and r at ``points`` near it: one round, or with warm starts x first and
        then the points from its solved state (two rounds)."""
        if not self.warm:
            return self.batch([x, *points])
        r = self.batch([x])[0]
        return [r, *self.batch(points, base=x)]

    def batch(self, points: Sequence[np.ndarray], base: np.ndarray | None = None
              ) -> list[np.ndarray]:
        if self.stopped or self.used + len(points) > self.budget:
            raise BudgetSpent
        self.used += len(points)
        points = [np.asarray(p, dtype=float) for p in points]
        out = (self.evaluate(points, base=base) if self.warm and base is not None
               else self.evaluate(points))
        for p, r in zip(points, out, strict=True):
            f = float(np.linalg.norm(r))
            if f < self.best_f:
                self.best_x, self.best_f = np.array(p, dtype=float), f
                if self.stop is not None and self.stop(self.best_x, f):
                    self.stopped = True
        return out


def initial_simplex(x0: np.ndarray) -> np.ndarray:
    """scipy's default Nelder-Mead simplex around ``x0``, shape (n + 1, n)."""
    x0 = np.asarray(x0, dtype=float)
    sim = np.tile(x0, (x0.size + 1, 1))
    for k in range(x0.size):
        sim[k + 1, k] = (1 + NONZDELT) * x0[k] if x0[k] != 0 else ZDELT
    return sim


def nelder_mead(evaluate: BatchFunction, x0: np.ndarray, *, max_evaluations: int,
                xatol: float, fatol: float,
                stop: Callable[[np.ndarray, float], bool] | None = None) -> Outcome:
    """Minimise ``||evaluate([x])[0]||`` with scipy's Nelder-Mead from ``x0``."""
    tracker = Tracker(evaluate, max_evaluations, stop)
    sim = initial_simplex(x0)
    try:
        values = tracker.batch(list(sim))  # the n + 1 vertices side by side: one round
    except BudgetSpent:
        return Outcome(np.asarray(x0, float), np.inf, "max_evaluations", "budget too small", 0)
    known = {p.tobytes(): float(np.linalg.norm(r)) for p, r in zip(sim, values, strict=True)}

    def f(x: np.ndarray) -> float:
        hit = known.pop(np.asarray(x, float).tobytes(), None)  # scipy re-evaluates the simplex
        return hit if hit is not None else float(np.linalg.norm(tracker.batch([x])[0]))

    try:
        res = scipy.optimize.minimize(
            f, x0, method="Nelder-Mead",
            options={"initial_simplex": sim, "xatol": xatol, "fatol": fatol,
                     "maxfev": 10 * max_evaluations, "maxiter": 10 * max_evaluations})
    except BudgetSpent:
        status = "stopped" if tracker.stopped else "max_evaluations"
        # no best point when every residual so far was NaN or infinite: report the start
        best = tracker.best_x if tracker.best_x is not None else np.asarray(x0, float)
        return Outcome(best, tracker.best_f, status,
                       f"{status} after {tracker.used} evaluations", -1)
    status = "converged" if res.success else "max_evaluations"
    return Outcome(np.asarray(res.x), float(res.fun), status, str(res.message), int(res.nit))


def least_squares(evaluate: BatchFunction, x0: np.ndarray, *, max_evaluations: int,
                  fd_step: float | np.ndarray, x_scale: float | np.ndarray = 1.0,
                  ftol: float = 1e-8, xtol: float = 1e-8, gtol: float = 1e-8,
                  bounds: tuple = (-np.inf, np.inf),
                  stop: Callable[[np.ndarray, float], bool] | None = None,
                  warm_starts: bool = False) -> Outcome:
    """Minimise ``||r(x)||`` by TRF with a Jacobian whose columns are solved in parallel.

    ``fd_step`` is the absolute forward-difference step per unknown (units of x); a
    column whose step would leave ``bounds`` is differenced backwards. The first round
    solves x0 and the Jacobian's columns at x0 together (scipy always asks for both);
    with ``warm_starts`` x0 comes first, and the columns (base: their point) and every
    trial point (base: the point of the last Jacobian, TRF's current point) are passed
    their base.
    """
    tracker = Tracker(evaluate, max_evaluations, stop, warm_starts)
    x0 = np.asarray(x0, dtype=float)
    step = np.broadcast_to(np.asarray(fd_step, dtype=float), x0.shape)
    upper = np.broadcast_to(np.asarray(bounds[1], dtype=float), x0.shape)
    last: dict[bytes, np.ndarray] = {}
    ready: dict[bytes, list[np.ndarray]] = {}  # Jacobian columns solved ahead of time
    current: list[np.ndarray] = []  # where the last Jacobian was taken: TRF's iterate

    def steps(x: np.ndarray) -> np.ndarray:
        return np.where(x + step > upper, -step, step)

    def columns(x: np.ndarray) -> list[np.ndarray]:
        h = steps(x)
        return [x + h[j] * np.eye(x.size)[j] for j in range(x.size)]

    def fun(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        last.clear()
        if not tracker.used:  # scipy always wants J at x0: solve its columns alongside
            r, *cols = tracker.around(x, columns(x))
            ready[x.tobytes()] = cols
        else:
            r = tracker.batch([x], base=current[0] if current else None)[0]
        last[x.tobytes()] = r
        return r

    def jac(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float)
        base = last.get(x.tobytes())
        cols = ready.pop(x.tobytes(), None)
        if base is None:  # not expected (scipy asks for J where it just evaluated r)
            base, *cols = tracker.around(x, columns(x))
        elif cols is None:
            cols = tracker.batch(columns(x), base=x)
        current[:] = [x]
        h = steps(x)
        return np.column_stack([(c - base) / h[j] for j, c in enumerate(cols)])

    try:
        res = scipy.optimize.least_squares(fun, x0, jac=jac, method="trf", x_scale=x_scale,
                                           ftol=ftol, xtol=xtol, gtol=gtol, bounds=bounds,
                                           max_nfev=10 * max_evaluations)
    except BudgetSpent:
        status = "stopped" if tracker.stopped else "max_evaluations"
        return Outcome(tracker.best_x if tracker.best_x is not None else x0, tracker.best_f,
                       status, f"{status} after {tracker.used} evaluations", -1)
    return Outcome(np.asarray(res.x), float(np.linalg.norm(res.fun)),
                   "converged" if res.status > 0 else "max_evaluations", str(res.message),
                   int(res.nfev))
