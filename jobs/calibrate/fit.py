"""The calibration loop: least squares on log-parameters, evaluations on the workers.

Residuals are the log force ratios ln(F_model / F_ref) of the reference points (the
relative error to first order; with theta = ln(E / E_start) and forces that scale with
a common modulus, as the uninflated model's do exactly, the problem is linear and one
Gauss-Newton step solves it), plus sqrt(w) theta per parameter: a weak pull towards the
start values that picks one solution when there are more parameters than points (the
full model's three moduli against its two thesis points) and is negligible otherwise
(w = 1e-4: one e-fold of a parameter weighs as a 1 % force error). One evaluation of a
parameter set is one load path per pressure, all submitted together; the Jacobian's
columns are solved side by side (:func:`jobs.loops.optimizers.least_squares`). The loop
stops as soon as every point is within ``target`` (relative), or when the optimiser
converges.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from farm.errors import SpecError
from farm.specs import ModelSpec, SolverSettings
from jobs.calibrate.evaluate import curve_evaluation, fz
from jobs.calibrate.params import Parameters
from jobs.calibrate.references import ReferencePoint
from jobs.guard import Failed
from jobs.loops import optimizers
from jobs.loops.evaluator import Evaluation, Evaluator, LoopStats

PENALTY = 10.0  # relative residual of a parameter set that cannot be solved


@dataclass(frozen=True)
class CalibrationSettings:
    """Budget and tolerances. ``fd_step`` is in theta (a relative step of the parameter)."""

    max_evaluations: int = 60
    fd_step: float = 0.02
    prior_weight: float = 1e-4
    target: float = 0.005
    tolerance: float = 1e-6


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """A finished calibration.

    ``forces`` and ``start_forces`` are the model's Fz at each reference point (N),
    fitted and at the start; ``residuals`` the relative errors of the fit.
    """

    parameters: Parameters
    points: tuple[ReferencePoint, ...]
    theta: np.ndarray
    values: dict
    forces: np.ndarray
    start_forces: np.ndarray
    status: str
    message: str
    theta_history: np.ndarray
    cost_history: np.ndarray
    stats: LoopStats
    wall_seconds: float

    @property
    def residuals(self) -> np.ndarray:
        refs = np.array([p.force for p in self.points])
        return (self.forces - refs) / refs

    def spec(self):
        return self.parameters.spec(self.theta)


@dataclass
class CalibrationState:
    """Live state for progress displays."""

    budget: int
    parameter_sets: int = 0
    best: float = float("nan")
    worst_point: float = float("nan")
    status: str = "running"
    stats: LoopStats = field(default_factory=LoopStats)


def _paths(points: Sequence[ReferencePoint]) -> dict[float, tuple[float, ...]]:
    """One load path per pressure, through that pressure's reference deflections."""
    paths: dict[float, set[float]] = {}
    for p in points:
        paths.setdefault(p.pressure, set()).add(p.deflection)
    return {k: tuple(sorted(v)) for k, v in sorted(paths.items())}


class _Forces:
    """Forces at the reference points of many parameter sets, one round per batch."""

    def __init__(self, params, points, evaluator, settings, solver, stats) -> None:
        self.params, self.points, self.evaluator = params, points, evaluator
        self.settings, self.solver, self.stats = settings, solver, stats
        self.paths = _paths(points)

    def __call__(self, thetas: Sequence[np.ndarray]) -> list[np.ndarray | None]:
        specs: list[ModelSpec | None] = []  # None: theta makes no valid model
        batch: list[Evaluation] = []
        where: list[tuple[int, float, int]] = []  # (spec, pressure, position in batch)
        for theta in thetas:
            try:
                spec = self.params.spec(theta)
            except SpecError:
                specs.append(None)
                continue
            specs.append(spec)
            for pressure, defl in self.paths.items():
                where.append((len(specs) - 1, pressure, len(batch)))
                batch.append(curve_evaluation(spec, defl, pressure, self.settings, self.solver))
        results = self.evaluator.run(batch, self.stats) if batch else []
        out: list[np.ndarray | None] = []
        for i, spec in enumerate(specs):
            got = {p: results[j] for k, p, j in where if k == i}
            if spec is None or any(isinstance(r, Failed) for r in got.values()):
                out.append(None)
                continue
            out.append(np.array([fz(got[p.pressure])[self.paths[p.pressure].index(p.deflection)]
                                 for p in self.points]))
        return out


def start_inside(params: Parameters, step: float) -> Parameters:
    """``params`` rebased one finite-difference ``step`` inside wherever its start lies
    within a step of a bound (a preset fitted against one, e.g. reinforced-calibrated's
    bead at 20 MPa): TRF scales each step by the distance to the bound, so a start on it
    never moved (13 evaluations of one point). Rebased rather than started at a small
    theta, because TRF's first trust region is the size of the start theta (1 if zero):
    a start 0.003 from zero crawled (+0.3 % of force per step)."""
    low, high = params.bounds()
    x0 = np.clip(np.zeros(len(params.names)), low + step, high - step)
    return params if not np.any(x0) else Parameters(params.names, params.spec(x0))


def calibrate(params: Parameters, points: Sequence[ReferencePoint], evaluator: Evaluator,
              solver: str, settings: SolverSettings,
              cal: CalibrationSettings | None = None,
              state: CalibrationState | None = None) -> CalibrationResult:
    """Fit ``params`` to ``points``; every evaluation goes through ``evaluator``."""
    start = time.perf_counter()
    cal = cal or CalibrationSettings()
    params = start_inside(params, cal.fd_step)
    state = state or CalibrationState(cal.max_evaluations)
    points = tuple(points)
    refs = np.array([p.force for p in points])
    forces_of = _Forces(params, points, evaluator, settings, solver, state.stats)
    n = len(params.names)
    seen: dict[bytes, np.ndarray] = {}
    thetas, costs = [], []

    def residuals(batch: Sequence[np.ndarray]) -> list[np.ndarray]:
        out = []
        for theta, f in zip(batch, forces_of(batch), strict=True):
            rel = np.full(refs.size, PENALTY) if f is None else (f - refs) / refs
            log = np.full(refs.size, PENALTY) if f is None else np.log(np.maximum(f, 1e-9) / refs)
            r = np.concatenate([log, np.sqrt(cal.prior_weight) * np.asarray(theta)])
            seen[np.asarray(theta, float).tobytes()] = rel
            thetas.append(np.array(theta, float))
            costs.append(float(np.linalg.norm(r)))
            out.append(r)
        state.best = float(np.min(costs))
        state.parameter_sets = len(costs)
        return out

    def good_enough(theta: np.ndarray, _: float) -> bool:
        rel = seen.get(np.asarray(theta, float).tobytes())
        if rel is not None:
            state.worst_point = float(np.max(np.abs(rel)))
        return rel is not None and bool(np.all(np.abs(rel) <= cal.target))

    outcome = optimizers.least_squares(
        residuals, np.zeros(n), max_evaluations=cal.max_evaluations, fd_step=cal.fd_step,
        ftol=cal.tolerance, xtol=cal.tolerance, gtol=cal.tolerance, bounds=params.bounds(),
        stop=good_enough)
    fitted, begin = forces_of([outcome.x, np.zeros(n)])
    status = "target_reached" if outcome.status == "stopped" else outcome.status
    state.status = status if fitted is not None else "failed"
    nan = np.full(refs.size, np.nan)
    return CalibrationResult(
        params, points, outcome.x, params.values(outcome.x),
        nan if fitted is None else fitted, nan if begin is None else begin,
        state.status, outcome.message, np.array(thetas).reshape(-1, n), np.array(costs),
        state.stats, time.perf_counter() - start)
