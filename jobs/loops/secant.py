"""Least squares with Jacobian reuse: Levenberg-Marquardt steps on a secant Jacobian.

:func:`jobs.loops.optimizers.least_squares` recomputes a forward-difference Jacobian
(n solver runs) at every accepted point. Here a full Jacobian is computed rarely, and
between two full ones every evaluated point corrects it by Broyden's rank-one "good"
update (Broyden 1965; Nocedal & Wright, *Numerical Optimization*, 2nd ed., §11.1,
eq. 11.27): ``J += (y - J s) s^T / (s^T s)`` with ``s`` the step and ``y`` the change of
the residuals, which makes J exact along the last step at the cost of the one
evaluation the step needed anyway. For a linear residual the update never spoils an
exact Jacobian (y = J s); for a smooth one it tracks the change of J along the path.

Why a small Levenberg-Marquardt loop (Nocedal & Wright §10.3, Marquardt's diagonal
scaling, Moré 1978's ratio test) rather than scipy's TRF fed the secant matrix: TRF
keeps its Jacobian fixed through rejected steps and asks for a new one only at an
accepted point, so it can neither refresh a secant model that has just failed nor use
the rejected point's information. Here:

- every step's predicted-vs-actual reduction ratio rho is checked; a step with
  rho < 1/4 on a Jacobian not computed at the current point is answered by a full
  Jacobian there (the secant model failed; after ``patience`` such steps answered by
  more damping, a shorter step often being enough), on a fresh one by more damping (the
  step was too long);
- the convergence tests are scipy's (``ftol`` on the cost reduction with rho > 1/4,
  ``xtol`` on the step), but pass only on a Jacobian computed within ``radius`` of the
  point: a secant Jacobian's stationary point J^T r = 0 is not the problem's when the
  residual does not vanish (noisy targets), so the last steps are always taken on a
  full Jacobian, and the answer is the full-Jacobian method's within its tolerance;
- full Jacobians may come from elsewhere (``shared``: e.g. the inverse loops'
  :class:`~jobs.loops.jacobians.JacobianStore`, a Jacobian another loop of the study
  needed at a nearby point); ``radius`` (relative to ||x||) says how near is near
  enough for the convergence tests.

Bounds are kept by projecting each step on the box (the inverse loops have none).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from jobs.loops.jacobians import fd_jacobian, fd_points
from jobs.loops.optimizers import BatchFunction, BudgetSpent, Outcome, Tracker

MU0 = 1e-3  # initial damping, relative to diag(J^T J) (Marquardt)
MU_MAX = 1e12  # beyond this the step is nothing: stop
ACCEPT = 1e-4  # rho above which a step is taken (Moré 1978)
POOR, GOOD = 0.25, 0.75  # rho thresholds: refresh / shrink damping, as in scipy's TRF
Shared = Callable[[np.ndarray], "tuple[np.ndarray, np.ndarray] | None"]


@dataclass
class _Model:
    """The Jacobian in use and the point it was last computed at (full differences)."""

    jacobian: np.ndarray
    origin: np.ndarray
    updates: int = 0

    def fresh(self, x: np.ndarray, radius: float) -> bool:
        scale = max(float(np.linalg.norm(x)), 1e-12)
        return bool(np.linalg.norm(x - self.origin) <= radius * scale)

    def update(self, s: np.ndarray, y: np.ndarray) -> None:
        """Broyden's good update (Nocedal & Wright eq. 11.27)."""
        ss = float(s @ s)
        if ss > 0:
            self.jacobian += np.outer(y - self.jacobian @ s, s) / ss
            self.updates += 1


def secant_least_squares(evaluate: BatchFunction, x0: np.ndarray, *, max_evaluations: int,
                         fd_step: float | np.ndarray, ftol: float = 1e-8, xtol: float = 1e-8,
                         bounds: tuple = (-np.inf, np.inf), radius: float = 0.0,
                         shared: Shared | None = None, patience: int = 0,
                         stop: Callable[[np.ndarray, float], bool] | None = None,
                         warm_starts: bool = False) -> Outcome:
    """Minimise ``||r(x)||`` by Levenberg-Marquardt on a Broyden-updated Jacobian.

    ``fd_step`` is the absolute forward-difference step (units of x). ``radius`` (relative
    to ||x||): how far from x a full Jacobian may have been computed to count as fresh
    (0: only at x itself). ``shared(x)``: a full Jacobian computed elsewhere for a point
    near x, as ``(J, where)``, or None (then it is computed here). Every evaluation of
    this function counts against ``max_evaluations``, Jacobian columns included; shared
    Jacobians cost this loop's budget nothing. ``patience``: how many poor steps (rho <
    1/4) on a stale Jacobian are answered by more damping (one evaluation each) before a
    full Jacobian (n evaluations); 0 refreshes at the first (docs/inverse.md).
    ``warm_starts``: every trial point is passed the current point as its base, the
    columns of a Jacobian their point (:data:`jobs.loops.optimizers.BatchFunction`).
    """
    tracker = Tracker(evaluate, max_evaluations, stop, warm_starts)
    x = np.asarray(x0, dtype=float).copy()
    lower, upper = (np.broadcast_to(np.asarray(b, dtype=float), x.shape) for b in bounds)
    step = np.broadcast_to(np.asarray(fd_step, dtype=float), x.shape)
    accepted = 0

    def full(x: np.ndarray, r: np.ndarray | None) -> tuple[np.ndarray, _Model]:
        """r(x) (solved alongside the columns when not known) and a full Jacobian."""
        h, points = fd_points(x, step, upper)
        known = {}

        def compute() -> np.ndarray:
            if r is not None:
                return fd_jacobian(r, tracker.batch(points, base=x), h)
            known["r"], *out = tracker.around(x, points)
            return fd_jacobian(known["r"], out, h)

        got = None if shared is None else shared(x)
        jac, origin = (compute(), x.copy()) if got is None else got
        if r is None:
            r = known["r"] if "r" in known else tracker.batch([x])[0]
        return r, _Model(jac, origin)

    try:
        r, model = full(x, None)
        mu = MU0
        strikes = 0  # poor steps on stale models since the model last failed
        while True:
            s = _step(model.jacobian, r, mu)
            s = np.clip(x + s, lower, upper) - x
            small = float(np.linalg.norm(s)) <= xtol * (xtol + float(np.linalg.norm(x)))
            if (small or mu > MU_MAX) and model.fresh(x, radius):
                return _done(x, r, "converged", "the step is below xtol", accepted)
            if small or mu > MU_MAX:  # stalled on a stale model: refresh it here
                r, model = full(x, r)
                mu = MU0
                continue
            fresh = model.fresh(x, radius)  # the step is taken on a full Jacobian
            r_new = tracker.batch([x + s], base=x)[0]
            cost, new = 0.5 * float(r @ r), 0.5 * float(r_new @ r_new)
            predicted = cost - 0.5 * float(np.sum((r + model.jacobian @ s) ** 2))
            rho = (cost - new) / predicted if predicted > 0 else -1.0
            model.update(s, r_new - r)
            if rho > ACCEPT:
                x, r, accepted = x + s, r_new, accepted + 1
                if cost - new < ftol * cost and rho > POOR:
                    if fresh:
                        return _done(x, r, "converged", "the cost reduction is below ftol",
                                     accepted)
                    r, model = full(x, r)  # confirm on a full Jacobian (see the docstring)
                    mu = MU0
                    continue
            if rho < POOR and not fresh and strikes >= patience:
                r, model = full(x, r)  # the secant model failed
                mu, strikes = MU0, 0
            elif rho < POOR and not fresh:
                mu, strikes = mu * 4.0, strikes + 1
            elif rho < POOR:
                mu *= 4.0
            elif rho > GOOD:
                mu = max(mu / 4.0, 1e-12)
    except BudgetSpent:
        status = "stopped" if tracker.stopped else "max_evaluations"
        best = tracker.best_x if tracker.best_x is not None else x
        return Outcome(best, tracker.best_f, status, f"{status} after {tracker.used} "
                       "evaluations", accepted)


def _step(jac: np.ndarray, r: np.ndarray, mu: float) -> np.ndarray:
    """The damped Gauss-Newton step: min ||J s + r||^2 + mu ||D s||^2, D^2 = diag(J^T J)."""
    d = np.sqrt(np.maximum(np.sum(jac**2, axis=0), 1e-300))
    a = np.vstack([jac, np.sqrt(mu) * np.diag(d)])
    b = np.concatenate([-r, np.zeros(jac.shape[1])])
    return np.linalg.lstsq(a, b, rcond=None)[0]


def _done(x: np.ndarray, r: np.ndarray, status: str, message: str, accepted: int) -> Outcome:
    return Outcome(x, float(np.linalg.norm(r)), status, message, accepted)
