"""One virtual inverse solve: a condition, a method, an optimiser and a repeat.

A loop runs in a client thread. It asks the shared :class:`~jobs.loops.evaluator.
Evaluator` for forward evaluations in batches and blocks only itself; it keeps the
history of every evaluation (x and the objective the optimiser saw), and ends with
the forward evaluation at its final x, from which Tables 4.1-4.4 are computed.
"""

from __future__ import annotations

import threading
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from farm.measure.measurement import Measurement
from farm.specs import content_hash
from jobs.guard import Failed
from jobs.identity import value_key
from jobs.inverse.distribution import TyreDistribution
from jobs.inverse.guesses import FieldGuess, initial_guess
from jobs.inverse.objective import Objective, field_rmse
from jobs.inverse.problem import Problem
from jobs.inverse.regularisation import discrepancy_weight, expected_noise_norm
from jobs.inverse.study import Condition, InverseStudy, OptimizerSettings
from jobs.inverse.warm import WarmStarts
from jobs.loops import optimizers
from jobs.loops.evaluator import Evaluator, Interrupted, LoopStats
from jobs.loops.jacobians import JacobianStore, fd_jacobian, fd_points
from jobs.loops.secant import Shared, secant_least_squares


@dataclass(frozen=True)
class LoopSpec:
    """What distinguishes one loop of a study from the others."""

    condition: Condition
    method: str
    optimizer: OptimizerSettings
    repeat: int

    @property
    def label(self) -> str:
        return f"{self.condition.name}/{self.method}/{self.optimizer.name}#{self.repeat}"


def expand_loops(study: InverseStudy) -> list[LoopSpec]:
    """Every loop of the study: conditions x methods x optimisers x repeats."""
    return [LoopSpec(c, m, study.optimizer(o), r)
            for c in study.conditions for m in c.methods for o in c.optimizers
            for r in range(c.repeats)]


def loop_seed(study: InverseStudy, spec: LoopSpec) -> list[int]:
    """Seed of a loop's noise and guess: shared by the methods/optimisers of a repeat."""
    return [study.seed, int(content_hash(spec.condition.name)[:8], 16), spec.repeat]


def loop_id(study: InverseStudy, spec: LoopSpec) -> str:
    """Content hash of a loop: the problem and everything about this solve."""
    optimizer = vars(spec.optimizer).copy()
    if not optimizer["warm_starts"]:  # then the run length means nothing
        del optimizer["columns_per_run"]
    for name, default in (("weight_rule", "fixed"), ("discrepancy", 1.0),
                          ("jacobian_patience", 0), ("warm_starts", False)):
        if optimizer[name] == default:  # settings added later: old loops keep their ids
            del optimizer[name]
    body = {"problem": study.problem_hash(), "seed": loop_seed(study, spec),
            "condition": vars(spec.condition) | {"repeats": None},
            "method": spec.method, "optimizer": optimizer}
    if spec.condition.initial in ("distribution", "surrogate"):
        body["distribution"] = vars(study.distribution)  # the training group of either
    return value_key(body)


@dataclass
class LoopState:
    """Live state of a loop, for progress displays (written by the loop's thread)."""

    label: str
    budget: int
    status: str = "queued"
    best: float = float("nan")
    stats: LoopStats = field(default_factory=LoopStats)
    result: LoopResult | None = None  # once the loop ended
    error: str = ""  # once the loop failed


@dataclass(frozen=True, eq=False)
class LoopResult:
    """A finished (or interrupted) loop.

    ``x_history`` (k, n) and ``f_history`` (k,) hold every evaluation in order, the
    objective as the optimiser saw it (noisy when the condition has noise);
    ``final`` the forward evaluation at ``x`` (None when it failed) and ``rmse`` its
    field errors against the noise-free reference (mm, strain).
    """

    spec: LoopSpec
    id: str
    x0: np.ndarray
    x: np.ndarray
    objective: float
    status: str
    message: str
    x_history: np.ndarray
    f_history: np.ndarray
    final: Measurement | None
    rmse: dict
    stats: LoopStats
    wall_seconds: float
    weight: float = 0.0  # the regularisation weight λ the loop used



def _objective(study: InverseStudy, problem: Problem, spec: LoopSpec, seed,
               mask: np.ndarray | None, scale: float, weight: float | None = None,
               center: np.ndarray | None = None) -> Objective:
    opt = spec.optimizer
    weight = opt.weight if weight is None else weight
    return Objective(problem, spec.method, study.noise if spec.condition.noise else None,
                     opt.noise_draw, seed, mask, (opt.regularisation, weight, scale), center)


def run_loop(study: InverseStudy, problem: Problem, spec: LoopSpec, evaluator: Evaluator,
             state: LoopState, mask: np.ndarray | None = None,
             stop: Callable[[np.ndarray, float], bool] | None = None,
             distribution: TyreDistribution | None = None,
             surrogate: FieldGuess | None = None) -> LoopResult:
    """Run one loop to its end; raises :class:`Interrupted` if the run shuts down.

    ``distribution``: the trained "tyre distribution", for ``initial = "distribution"``;
    ``surrogate``: the trained surrogate guess, for ``initial = "surrogate"``.
    """
    start = time.perf_counter()
    state.status = "running"
    seed = loop_seed(study, spec)
    probe = _objective(study, problem, spec, seed, mask, 1.0)
    x0 = initial_guess(problem, spec.condition, seed, probe, evaluator, state.stats,
                       distribution, surrogate)
    scale = max(float(np.mean(np.abs(x0))), 1e-9)
    opt = spec.optimizer
    xs: list[np.ndarray] = []
    fs: list[float] = []
    current: list[Objective] = []
    warm = warm_starts(problem, evaluator, state.stats, opt)

    def batch(points, base=None):
        results = warm.run(points, base)
        out = []
        for p, result in zip(points, results, strict=True):
            r = current[0].residuals(result, p, len(fs))
            xs.append(np.array(p, dtype=float))
            fs.append(float(np.linalg.norm(r)))
            out.append(r)
        state.best = float(np.min(fs))
        return out

    def solve(start: np.ndarray, weight: float) -> optimizers.Outcome:
        current[:] = [_objective(study, problem, spec, seed, mask, scale, weight, x0)]
        shared = (_shared_jacobians(study, problem, spec, evaluator, state, mask, scale, weight)
                  if opt.jacobian == "shared" else None)
        return _optimise(opt, batch, start, stop, shared, warm.enabled)

    weight = opt.weight
    if opt.weight_rule == "discrepancy" and spec.condition.noise:
        # two stages: the unregularised solution, λ from the linearisation there, then
        # the regularised solve from it (jobs/inverse/regularisation.py)
        first = solve(x0, 0.0)
        weight = _discrepancy(study, problem, spec, seed, mask, scale, first.x, x0, warm)
        outcome = solve(first.x, weight)
    else:
        outcome = solve(x0, 0.0 if opt.weight_rule == "discrepancy" else weight)
        weight = 0.0 if opt.weight_rule == "discrepancy" else weight
    last = warm.run([outcome.x])[0]
    final = None if isinstance(last, Failed) else last.measurement
    status = "failed" if final is None else outcome.status
    message = last.reason if isinstance(last, Failed) else outcome.message
    if spec.optimizer.weight_rule == "discrepancy":  # stored with the solve (the report reads it)
        message = f"{WEIGHT_TAG} {weight:.6g}; {message}"
    state.status = status
    return LoopResult(spec, loop_id(study, spec), x0, outcome.x, outcome.objective, status,
                      message, np.array(xs).reshape(-1, problem.n), np.array(fs), final,
                      {} if final is None else field_rmse(final, problem.reference),
                      state.stats, time.perf_counter() - start, weight)


#: How a solve's message records the weight the discrepancy principle chose.
WEIGHT_TAG = "discrepancy weight"


def _discrepancy(study: InverseStudy, problem: Problem, spec: LoopSpec, seed, mask,
                 scale: float, x1: np.ndarray, x0: np.ndarray, warm: WarmStarts) -> float:
    """λ by the discrepancy principle on the linearisation at x1, the unregularised
    solution (jobs.inverse.regularisation); x0 is the guess (the centre of ``guess``).

    One forward-difference Jacobian at x1 (n evaluations; the regularised solve's first
    Jacobian at x1 then comes from the evaluator's cache).
    """
    data = _objective(study, problem, spec, seed, mask, scale, 0.0)
    h, points = fd_points(x1, np.full(problem.n, spec.optimizer.fd_step),
                          np.full(problem.n, np.inf))
    results = warm.around(x1, points)
    solved = [res for res in results if not isinstance(res, Failed)]
    if len(solved) < len(results):
        return spec.optimizer.weight  # a failed column: no linearisation to choose on
    r = [data.data_residuals(res.measurement, 0) for res in solved]
    unit = _objective(study, problem, spec, seed, mask, scale, 1.0, x0)
    noise = study.noise
    delta = expected_noise_norm(spec.method, noise.displacement, noise.strain, data.n_nodes)
    return discrepancy_weight(fd_jacobian(r[0], r[1:], h), r[0], unit.reg, x1 - unit.center,
                              delta, spec.optimizer.discrepancy)


GTOL_OFF = 1e-15


def warm_starts(problem: Problem, evaluator: Evaluator, stats: LoopStats,
                opt: OptimizerSettings) -> WarmStarts:
    """How a loop with optimiser ``opt`` evaluates: warm starts for least squares with
    ``warm_starts`` on; Nelder-Mead, the thesis' optimiser, solves every point from rest."""
    return WarmStarts(problem, evaluator, stats, opt.columns_per_run,
                      opt.name == "least-squares" and opt.warm_starts)


def _optimise(opt: OptimizerSettings, batch, x0: np.ndarray, stop,
              shared: Shared | None = None, warm: bool = False) -> optimizers.Outcome:
    if opt.name == "nelder-mead":
        return optimizers.nelder_mead(batch, x0, max_evaluations=opt.max_evaluations,
                                      xatol=opt.xatol, fatol=opt.fatol, stop=stop)
    if opt.jacobian != "full":  # Jacobian reuse (jobs.loops.secant, docs/inverse.md)
        return secant_least_squares(batch, x0, max_evaluations=opt.max_evaluations,
                                    fd_step=opt.fd_step, ftol=opt.tolerance,
                                    xtol=opt.tolerance, stop=stop, shared=shared,
                                    radius=opt.jacobian_radius if shared else 0.0,
                                    patience=opt.jacobian_patience, warm_starts=warm)
    # No gradient test (gtol): it is not scale-free, and strain residuals (~1e-3) have a
    # gradient below any useful gtol at the start - a reproduction run with gtol = 1e-5
    # stopped every strain solve at its initial guess. Stop on ftol/xtol only.
    return optimizers.least_squares(batch, x0, max_evaluations=opt.max_evaluations,
                                    fd_step=opt.fd_step, ftol=opt.tolerance,
                                    xtol=opt.tolerance, gtol=GTOL_OFF, stop=stop,
                                    warm_starts=warm)


_STORES: weakref.WeakKeyDictionary[Problem, JacobianStore] = weakref.WeakKeyDictionary()
_STORES_LOCK = threading.Lock()  # the loops of a run start side by side


def jacobian_store(problem: Problem) -> JacobianStore:
    """The Jacobians shared by every loop of ``problem`` (one per run of a study)."""
    with _STORES_LOCK:
        return _STORES.setdefault(problem, JacobianStore())


# Initial guesses every loop can recompute for free (no solver run): the anchors
CHEAP_GUESSES = ("scaled", "uniform")


def _shared_jacobians(study: InverseStudy, problem: Problem, spec: LoopSpec,
                      evaluator: Evaluator, state: LoopState, mask, scale: float,
                      weight: float) -> Shared:
    """Full Jacobians shared by the loops of a study, deterministically.

    They are computed only at anchors: the start points of the study's loops with the
    same method and optimiser (those with a guess that costs no solver run), which
    every loop recomputes itself; a loop is served the anchor nearest its point
    within ``jacobian_radius`` x ||x||, and it computes its own elsewhere. A Jacobian
    at an anchor is differenced against the noise-free reference (noise only shifts
    the target), so it is the same bits whichever loop computed it: a loop's path does
    not depend on which loop got there first, and a re-run replays from the cache.
    Its evaluations cost the loop's budget nothing (they are in its stats).
    """
    opt = spec.optimizer
    anchors: list[np.ndarray] = []
    for other in expand_loops(study):
        if (other.method, other.optimizer) != (spec.method, opt) or \
                other.condition.initial not in CHEAP_GUESSES:
            continue
        seed = loop_seed(study, other)
        a = initial_guess(problem, other.condition, seed,
                          _objective(study, problem, other, seed, mask, 1.0), evaluator,
                          LoopStats())
        if not any(np.array_equal(a, b) for b in anchors):
            anchors.append(a)
    clean = _objective(study, problem, replace(spec, condition=replace(
        spec.condition, noise=False)), loop_seed(study, spec), mask, scale, weight)
    key = (spec.method, clean.mask.tobytes(), clean.reg.tobytes(), opt.fd_step)
    store = jacobian_store(problem)
    step = np.full(problem.n, opt.fd_step)

    def at(anchor: np.ndarray) -> np.ndarray:
        h, points = fd_points(anchor, step, np.full(problem.n, np.inf))
        results = warm_starts(problem, evaluator, state.stats, opt).around(anchor, points)
        r = [clean.residuals(res, p, 0) for p, res in zip([anchor, *points], results,
                                                          strict=True)]
        return fd_jacobian(r[0], r[1:], h)

    def shared(x: np.ndarray):
        limit = opt.jacobian_radius * float(np.linalg.norm(x))
        near = [(float(np.linalg.norm(a - x)), k) for k, a in enumerate(anchors)]
        near = [d_k for d_k in near if d_k[0] <= limit]
        if not near:
            return None
        anchor = anchors[min(near)[1]]
        jac, origin, _ = store.get_or_compute(key, anchor, 0.0, lambda: at(anchor))
        return jac, origin

    return shared


__all__ = ["WEIGHT_TAG", "Interrupted", "LoopResult", "LoopSpec", "LoopState", "expand_loops",
           "run_loop"]
