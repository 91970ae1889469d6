"""Choosing the regularisation weight λ without the truth: the discrepancy principle.

The regularised objective (:mod:`jobs.inverse.objective`) is ||r(x)||² + λ ||L x / s||².
Morozov's discrepancy principle (Morozov 1966; Hansen, "Discrete Inverse Problems",
SIAM 2010, §5.2; Engl, Hanke & Neubauer 1996, §4.3) takes the λ whose solution fits
the data exactly as well as the noise allows: ||r(x_λ)|| = τ δ, δ the expected norm of
the noise in the residual and τ >= 1 a safety factor. A smaller λ fits the noise (the
42-45 N nodal errors of the unregularised displacement solves, docs/inverse.md), a
larger one throws information away. It needs the noise level, which every condition of
a study states (§4.4: 1 mm on U, 0.04 % on strain), and never the true forces.

The data residual of a λ is that of the regularised Gauss-Newton step from a point x1
on the Jacobian J there (a linearisation):

    d(λ) = argmin ||r1 + J d||² + λ ||L (x1 + d - c) / s||²,   ρ(λ) = ||r1 + J d(λ)||,

ρ increases with λ, so the λ with ρ(λ) = τ δ is found by bisection in log λ. The loop
(``jobs/inverse/loop.py``) takes x1 = the unregularised solution, where the
linearisation holds for the regularised one nearby: a first measurement chose it at the
initial guess instead, and from the uniform guess one Gauss-Newton step could not reach
the noise level (ρ(0) > δ), so λ fell to its lower bound.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: Search range of λ (the weight is relative to the data term, L x / s is O(1)).
LOW, HIGH = 1e-12, 1e12


def expected_noise_norm(method: str, sigma_u: float, sigma_e: float, n_nodes: int) -> float:
    """E||noise|| of the residuals of ``method`` (jobs.inverse.objective's scaling).

    Each of the 3 N entries of the displacement residual carries noise of std
    σ_U / sqrt(N), so E||n||² = 3 σ_U²; likewise 3 σ_ε² for strain; the combined
    residual divides each part by its σ, so E||n||² = 6. ``n_nodes`` cancels; it is
    kept to make the scaling explicit (and checked: at least one node).
    """
    if n_nodes < 1:
        raise ValueError("no measured node")
    per = {"displacement": 3 * sigma_u**2, "strain": 3 * sigma_e**2, "combined": 6.0}
    return float(np.sqrt(per[method]))


def gauss_newton_step(jac: np.ndarray, r0: np.ndarray, reg: np.ndarray, x0: np.ndarray,
                      weight: float) -> np.ndarray:
    """d minimising ||r0 + J d||² + weight ||R (x0 + d)||², R = L / s, shape (n,).

    (A regularisation centred on c: pass x0 - c.)"""
    a = np.vstack([jac, np.sqrt(weight) * reg])
    b = np.concatenate([-r0, -np.sqrt(weight) * (reg @ x0)])
    return np.linalg.lstsq(a, b, rcond=None)[0]


def data_residual(jac: np.ndarray, r0: np.ndarray, reg: np.ndarray, x0: np.ndarray,
                  weight: float) -> float:
    """ρ(λ): the linearised data residual norm of the regularised step."""
    return float(np.linalg.norm(r0 + jac @ gauss_newton_step(jac, r0, reg, x0, weight)))


def bisect_log(rho: Callable[[float], float], target: float, low: float = LOW,
               high: float = HIGH, steps: int = 80) -> float:
    """The λ in [low, high] with rho(λ) = target, rho increasing (bisection in log λ).

    When even ``low`` over-shoots the target (the model cannot fit the data to the noise
    level), ``low``; when even ``high`` stays below it, ``high``.
    """
    if rho(low) >= target:
        return low
    if rho(high) <= target:
        return high
    a, b = np.log(low), np.log(high)
    for _ in range(steps):
        mid = 0.5 * (a + b)
        if rho(float(np.exp(mid))) < target:
            a = mid
        else:
            b = mid
        if b - a < 1e-3:  # λ to 0.1 %: far below what the residual can tell apart
            break
    return float(np.exp(0.5 * (a + b)))


def discrepancy_weight(jac: np.ndarray, r0: np.ndarray, reg: np.ndarray, x0: np.ndarray,
                       noise_norm: float, tau: float = 1.0) -> float:
    """λ with ρ(λ) = τ δ on the linearisation (J, r0) at x0 (module docstring).

    Parameters
    ----------
    jac : ndarray, shape (m, n)
        Jacobian of the data residuals at ``x0``.
    r0 : ndarray, shape (m,)
        Data residuals at ``x0`` (against the noisy measurement).
    reg : ndarray, shape (k, n)
        L / s, the regularisation operator without its weight.
    x0 : ndarray, shape (n,)
        The linearisation point, less the regularisation's centre c.
    noise_norm : float
        δ, the expected norm of the noise in ``r0`` (:func:`expected_noise_norm`).
    tau : float
        Safety factor τ (>= 1 in the theory; 1 by default).
    """
    if noise_norm <= 0:
        return 0.0  # no noise: nothing to regularise against
    return bisect_log(lambda w: data_residual(jac, r0, reg, x0, w), tau * noise_norm)
