"""Objectives of the virtual inverse problem (thesis eqs. 4.1, 4.2 and their combination).

Residuals are arranged so that their 2-norm IS the thesis' objective:

- displacement (eq. 4.1): r = (U*(x) - U) / sqrt(N), all three components of the N
  measured inner nodes, so ||r|| = sqrt(sum of squares / N) in mm;
- strain (eq. 4.2): the same with the solver's nodal strains (xx, yy, xy, local frame);
- combined (the third formulation §4.2 suggests): both, each divided by its noise
  level (1 mm, 0.04 %: the thesis made the two equivalent in §4.4), so that
  ||r||² = f_U²/σ_U² + f_ε²/σ_ε², dimensionless.

Noise (§4.4) is added to the reference measurement, never to the forward model (whose
evaluations stay cacheable): per evaluation, a new draw for every evaluation (the
thesis: "compared to a noisy version of the virtual experiment at each iteration"), or
per solve, one draw for the whole loop. Draws are seeded by (study seed, condition,
repeat[, evaluation index]), so a loop replays identically on resume.

Regularisation (beyond the thesis; §5.2 names both) appends rows sqrt(λ) L (x - c) / s:
``tikhonov`` (L = I, c = 0: towards zero forces), ``smoothness`` (L = first differences
of consecutive unknowns along each tread row, c = 0) or ``guess`` (L = I, c = x0:
towards the initial guess, the prior that §6.2's "physically meaningful initial guess"
- e.g. the statistical tyre distribution - provides); s is the mean initial-guess force,
so λ is dimensionless relative to the data term's units squared.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np

from farm.measure.measurement import Measurement
from jobs.guard import Failed, Result
from jobs.inverse.problem import Problem
from jobs.inverse.study import NoiseSettings

PENALTY = 1e3  # residual entry of a failed evaluation: far above any real one


class Objective:
    """Residuals of one loop: its method, noise stream, mask and regularisation.

    Parameters
    ----------
    problem : Problem
    method : "displacement", "strain" or "combined"
    noise : NoiseSettings or None
        None for noise-free conditions.
    draw : "per_evaluation" or "per_solve"
    seed : sequence of int
        The loop's noise stream.
    mask : ndarray of bool, shape (n_inner,) or None
        Inner nodes that enter the objective (None: all).
    regularisation : (kind, weight, scale)
    center : ndarray, shape (n,) or None
        c of the regularisation rows: the initial guess for ``guess`` (None: zero, which
        changes the residuals but not their Jacobian), else zero.
    """

    def __init__(self, problem: Problem, method: str, noise: NoiseSettings | None, draw: str,
                 seed: Sequence[int], mask: np.ndarray | None = None,
                 regularisation: tuple[str, float, float] = ("none", 0.0, 1.0),
                 center: np.ndarray | None = None) -> None:
        self.problem, self.method, self.noise, self.draw = problem, method, noise, draw
        self.seed = [int(s) for s in seed]
        n_inner = problem.reference.displacement.shape[0]
        self.mask = np.ones(n_inner, bool) if mask is None else np.asarray(mask, bool)
        self.n_nodes = int(self.mask.sum())
        self.sigma = NoiseSettings() if noise is None else noise
        kind, weight, scale = regularisation
        self.reg = _operator(problem, kind) * np.sqrt(weight) / scale if kind != "none" \
            else np.zeros((0, problem.n))
        self.center = (np.asarray(center, dtype=float) if kind == "guess" and center is not None
                       else np.zeros(problem.n))

    def measured(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """The (noisy) reference displacement and strain seen at evaluation ``index``."""
        u, e = self.problem.reference.displacement, self.problem.reference.strain
        if self.noise is None:
            return u, e
        rng = np.random.default_rng(noise_stream(self.seed, self.draw, index))
        return (u + rng.normal(0.0, self.noise.displacement, u.shape),
                e + rng.normal(0.0, self.noise.strain, e.shape))

    def data_residuals(self, m: Measurement, index: int) -> np.ndarray:
        """The data part of the residuals (the thesis' objective is its 2-norm)."""
        u, e = self.measured(index)
        k = self.mask
        du = (m.displacement[k] - u[k]).ravel() / np.sqrt(self.n_nodes)
        de = (m.strain[k] - e[k]).ravel() / np.sqrt(self.n_nodes)
        if self.method == "displacement":
            return du
        if self.method == "strain":
            return de
        return np.concatenate([du / self.sigma.displacement, de / self.sigma.strain])

    def size(self) -> int:
        per = 3 * self.n_nodes
        return (2 * per if self.method == "combined" else per) + self.reg.shape[0]

    def residuals(self, result: Result, x: np.ndarray, index: int) -> np.ndarray:
        """All residuals of evaluation ``index`` at ``x`` (penalty if it failed)."""
        if isinstance(result, Failed):
            return np.full(self.size(), PENALTY)
        return np.concatenate([self.data_residuals(result.measurement, index),
                               self.reg @ (x - self.center)])


def noise_stream(seed: Sequence[int], draw: str, index: int) -> list[int]:
    """Entropy of the noise draw of evaluation ``index`` (distinct tags per stream)."""
    return [*seed, 1, index] if draw == "per_evaluation" else [*seed, 2]


def _operator(problem: Problem, kind: str) -> np.ndarray:
    """L of the regularisation term, shape (rows, n)."""
    if kind in ("tikhonov", "guess"):
        return np.eye(problem.n)
    rows = []
    for r in np.unique(problem.grid[:, 0]):  # consecutive unknowns along each tread row
        along = np.flatnonzero(problem.grid[:, 0] == r)
        along = along[np.argsort(problem.grid[along, 1])]
        for a, b in itertools.pairwise(along):
            row = np.zeros(problem.n)
            row[a], row[b] = -1.0, 1.0
            rows.append(row)
    return np.array(rows).reshape(-1, problem.n)


def field_rmse(m: Measurement, reference: Measurement) -> dict[str, float]:
    """RMSE of each direction against the noise-free reference (Tables 4.2/4.4).

    Displacements in mm, strains dimensionless (tables print microstrain).
    """
    out = {}
    for var, names in (("displacement", ("Ux", "Uy", "Uz")), ("strain", ("exx", "eyy", "exy"))):
        diff = getattr(m, var) - getattr(reference, var)
        for k, name in enumerate(names):
            out[name] = float(np.sqrt(np.mean(diff[:, k] ** 2)))
    return out
