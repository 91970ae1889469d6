"""Initial guesses x0 of the inverse loops (thesis §4.3-4.5, §5.2/§6.2).

- ``scaled``: ``scale`` x the true forces (90 % in the thesis) + N(0, σ) per node;
- ``uniform``: the same force on every unknown, the test section's secant stiffness
  times the deflection over the number of nodes in contact (= Fz_ref / n; §4.5), times
  ``scale``, + N(0, σ);
- ``offset``: the thickness-offset guess (§5.2, §6.2): the measured (noisy, when the
  condition has noise) inner surface offset by the wall thickness gives the outer
  surface; its vertical displacement prescribed on the unknown nodes gives reaction
  forces (one ccx run, :func:`farm.solve.forces.offset_outer_uz`), + N(0, σ);
- ``surrogate``: the load read from the measured field by inverting a surrogate of a
  sweep group of the same mesh (the ``[distribution]`` group), and the surrogate's
  tread force map at that load on the unknowns (issue 28; a :class:`FieldGuess`, built
  by analysis/surrogate_guess.py and handed in by ``farm invert``), times ``scale``;
  + N(0, σ). No solver run;
- ``distribution``: the statistical "tyre distribution" of §6.2
  (:mod:`jobs.inverse.distribution`), trained on a sweep group of the same mesh: its
  normalised force map at the reference deflection on the unknowns, times the uniform
  guess' total (Fz_ref x ``scale``), so that it differs from ``uniform`` in shape only;
  + N(0, σ). No solver run.

Random parts are seeded by the loop's (study seed, condition, repeat), the same for
every method and optimiser of a repeat, so that they start from the same point.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from farm.solve.forces import offset_outer_uz
from jobs.errors import JobError, StudyError
from jobs.guard import Failed
from jobs.inverse.distribution import TyreDistribution, guess_from
from jobs.inverse.objective import Objective
from jobs.inverse.problem import Problem
from jobs.inverse.study import Condition
from jobs.loops.evaluator import Evaluator, LoopStats


class GuessError(JobError, RuntimeError):
    """The thickness-offset guess could not be solved."""


class FieldGuess(Protocol):
    """Vertical force guesses (n,) on the unknown tread ``nodes`` from a measured inner
    displacement field (N, 3) (:class:`analysis.surrogate_guess.SurrogateGuess`); the
    node ids of the field's rows and of the force map it was trained on."""

    inner_nodes_: np.ndarray
    tread_nodes_: np.ndarray

    def __call__(self, measured: np.ndarray, nodes: np.ndarray) -> np.ndarray: ...


def check_guess_mesh(guess: FieldGuess, inner_nodes: np.ndarray,
                     tread_nodes: np.ndarray) -> None:
    """The surrogate guess must be trained on the study's mesh: its field rows are read
    as the study's inner nodes, in order (one StudyError, before anything runs)."""
    same = all(np.array_equal(np.asarray(a), np.asarray(b))
               for a, b in ((guess.inner_nodes_, inner_nodes), (guess.tread_nodes_, tread_nodes)))
    if not same:
        raise StudyError(f"distribution.group: the surrogate guess was trained on another mesh "
                         f"({np.size(guess.inner_nodes_)} inner and {np.size(guess.tread_nodes_)} "
                         f"tread nodes vs {np.size(inner_nodes)} and {np.size(tread_nodes)}); "
                         "train on a sweep of the same [model.mesh]")


def guess_stream(seed: Sequence[int]) -> list[int]:
    return [*seed, 3]


def initial_guess(problem: Problem, condition: Condition, seed: Sequence[int],
                  objective: Objective, evaluator: Evaluator, stats: LoopStats,
                  distribution: TyreDistribution | None = None,
                  surrogate: FieldGuess | None = None) -> np.ndarray:
    """x0 of one loop, shape (n,), N (``distribution``, ``surrogate``: the trained
    models, for ``initial = "distribution"`` and ``"surrogate"``)."""
    rng = np.random.default_rng(guess_stream(seed))
    jitter = rng.normal(0.0, condition.guess_sigma, problem.n) if condition.guess_sigma else 0.0
    if condition.initial == "scaled":
        base = condition.scale * problem.x_true
    elif condition.initial == "uniform":
        total = float(problem.reference.total_force[2])
        base = np.full(problem.n, condition.scale * total / problem.n)
    elif condition.initial == "distribution":
        if distribution is None:
            raise GuessError("initial = \"distribution\" without a trained distribution")
        total = float(problem.reference.total_force[2])
        base = guess_from(distribution, problem.mesh.tread_nodes, problem.nodes,
                          {"deflection": problem.deflection}, condition.scale * total)
    elif condition.initial == "surrogate":
        if surrogate is None:
            raise GuessError("initial = \"surrogate\" without a trained surrogate")
        measured_u, _ = objective.measured(0)  # what the loop's camera sees, noise included
        base = condition.scale * np.asarray(surrogate(measured_u, problem.nodes), dtype=float)
    else:
        base = offset_guess(problem, objective, evaluator, stats)
    return base + jitter


def offset_guess(problem: Problem, objective: Objective, evaluator: Evaluator,
                 stats: LoopStats) -> np.ndarray:
    """Reaction forces of the unknowns with the offset inner surface prescribed."""
    measured_u, _ = objective.measured(0)
    uz = offset_outer_uz(problem.mesh, measured_u, problem.nodes)
    result = evaluator.run([problem.prescribed_evaluation(uz)], stats)[0]
    if isinstance(result, Failed):
        raise GuessError(f"the thickness-offset guess failed: {result.reason}")
    where = {int(n): k for k, n in enumerate(problem.mesh.tread_nodes)}
    force = result.measurement.reaction_force
    return np.array([force[where[int(n)], 2] for n in problem.nodes])
