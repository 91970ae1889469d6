"""Monte Carlo measurement-noise studies on a fitted linear model (thesis §5.6).

Zero-mean Gaussian noise of standard deviation σ is added to every input of a reference
experiment (thesis §4.4 levels: 1 mm on displacement, 0.04 % = 4e-4 on strain) and the
model predicts the tread forces for each draw. The model is linear, ŷ = ŷ_ref + σ e B
with B = coef_ᵀ (N x M) of rank A, so:

- all draws of a level are one product, evaluated as (E L) R with B = L R
  (L: N x A, R: A x M), which costs D·N·A instead of D·N·M; drawing the D x N normals
  is then the floor, and ``sampling="subspace"`` lowers it to D x A normals with the
  same distribution of predictions (see :func:`monte_carlo`);
- the prediction noise is exactly Gaussian with covariance σ² BᵀB, whose diagonal gives
  the analytic standard deviation per node, reported beside the Monte Carlo one;
- totals are linear too: Fz = Σ F_i, Mx = Σ y_i F_i, My = -Σ x_i F_i (the moments of
  vertical nodal forces about the contact centre, x and y from ``tread_xyz``, whose
  origin is on the wheel axis above the contact centre for the pure vertical load
  cases of chapter 5);
- the thesis' Table 5.1 puts the *nodal-average* standard deviation beside each total
  (:func:`nodal_average_std`), not the standard deviation of the total itself; both are
  reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from analysis.errors import ParameterError

#: thesis §4.4 / §5.6 noise levels per input family (store units: mm, strain = 1)
THESIS_SIGMA = {"displacement": 1.0, "strain": 4e-4, "surface_strain": 4e-4}
TOTALS = ("Fz", "Mx", "My")


@dataclass(frozen=True)
class NoiseResult:
    """Statistics of predicted forces per noise level.

    Attributes
    ----------
    sigmas : ndarray (L,)
    reference_prediction : ndarray (M,)
        Noise-free prediction ŷ_ref.
    node_mean, node_std, node_std_analytic : ndarrays (L, M)
        Per tread node: mean and standard deviation (ddof=1) over draws, and σ·sqrt(diag BᵀB).
    totals_mean, totals_std, totals_std_analytic : ndarrays (L, 3)
        Fz (N), Mx and My (N mm) over draws.
    n_draws : int
    """

    sigmas: np.ndarray
    reference_prediction: np.ndarray
    node_mean: np.ndarray
    node_std: np.ndarray
    node_std_analytic: np.ndarray
    totals_mean: np.ndarray
    totals_std: np.ndarray
    totals_std_analytic: np.ndarray
    n_draws: int


def totals_operator(tread_xy: np.ndarray) -> np.ndarray:
    """G (M, 3) with forces @ G = (Fz, Mx, My) for vertical nodal forces.

    Mx = Σ y_i F_i and My = -Σ x_i F_i: the x and y components of Σ r_i x (0, 0, F_i).
    """
    xy = np.asarray(tread_xy, dtype=float)
    return np.column_stack([np.ones(len(xy)), xy[:, 1], -xy[:, 0]])


def linear_factors(estimator) -> tuple[np.ndarray, np.ndarray]:
    """(L, R) with ``estimator.coef_.T == L @ R`` for a fitted linear regressor.

    Uses the estimator's own low-rank factors when it has them (ours, and
    scikit-learn's ``PLSRegression`` without scaling); otherwise factors ``coef_`` by
    a thin SVD, once.
    """
    if hasattr(estimator, "linear_factors"):
        return estimator.linear_factors()
    if getattr(estimator, "scale", True) is False and hasattr(estimator, "x_rotations_"):
        return estimator.x_rotations_, estimator.y_loadings_.T
    B = np.atleast_2d(estimator.coef_).T
    U, s, Vt = np.linalg.svd(B, full_matrices=False)
    r = max(1, int(np.sum(s > s[0] * max(B.shape) * np.finfo(float).eps))) if s[0] > 0 else 1
    return U[:, :r] * s[:r], Vt[:r]


def monte_carlo(
    estimator,
    x_ref: np.ndarray,
    sigmas,
    *,
    totals: np.ndarray,
    n_draws: int = 100,
    seed: int = 0,
    sampling: str = "inputs",
) -> NoiseResult:
    """Noise sweep: ``n_draws`` noisy copies of ``x_ref`` per σ, predicted at once.

    Parameters
    ----------
    estimator : fitted linear regressor (``predict``, ``coef_``)
    x_ref : ndarray of shape (N,)
        Noise-free inputs of the reference experiment.
    sigmas : sequence of float, length L
        Noise standard deviations in input units.
    totals : ndarray of shape (M, 3)
        :func:`totals_operator` of the tread nodes.
    n_draws : int
        Draws per level (thesis: 100). Level ℓ draws from its own child of
        ``SeedSequence(seed)``, so a level's draws do not depend on the other levels.
    sampling : {"inputs", "subspace"}
        ``"inputs"`` draws the full noise vector e ~ N(0, I_N) of every draw, as the
        thesis does. ``"subspace"`` draws only its component in the model's A-dimensional
        input subspace, g ~ N(0, I_A): with L = Q R_L (thin QR), e L = (e Q) R_L and
        e Q ~ N(0, I_A), so the predictions have exactly the same joint distribution
        for N/A times fewer random numbers.

    Returns
    -------
    NoiseResult
    """
    sig = np.atleast_1d(np.asarray(sigmas, dtype=float))
    if n_draws < 2 or np.any(sig < 0) or not np.all(np.isfinite(sig)):
        raise ParameterError(f"need n_draws >= 2 and finite sigmas >= 0; got {n_draws}, {sig}")
    L, R = linear_factors(estimator)
    draw = _sampler(L, sampling)
    base = np.ravel(estimator.predict(np.asarray(x_ref, dtype=float)[None, :]))
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(len(sig))]
    # The products are small (D x N by N x A); BLAS threads only contend for cores here.
    with threadpool_limits(limits=1, user_api="blas"):
        stats = [
            _level(base, draw, R, s, g, n_draws, totals) for s, g in zip(sig, rngs, strict=True)
        ]
    node_sd, tot_sd = analytic_std(L, R, sig, totals)
    node_mean, node_std, tot_mean, tot_std = (np.array(a) for a in zip(*stats, strict=True))
    return NoiseResult(sig, base, node_mean, node_std, node_sd, tot_mean, tot_std, tot_sd, n_draws)


def _sampler(L: np.ndarray, sampling: str):
    """``draw(rng, D) -> (D, A)``: the input noise seen through L, e L for unit σ."""
    if sampling not in ("inputs", "subspace"):
        raise ParameterError(f"sampling must be 'inputs' or 'subspace', got {sampling!r}")
    if sampling == "inputs" or L.shape[1] >= L.shape[0]:
        return lambda rng, d: rng.standard_normal((d, L.shape[0])) @ L
    R_L = np.linalg.qr(L, mode="r")  # (A, A)
    return lambda rng, d: rng.standard_normal((d, R_L.shape[0])) @ R_L


def _level(base, draw, R, sigma, rng, n_draws, totals):
    """One level: D draws in one array operation; returns node and totals statistics.

    Statistics of ŷ = base + σZ are formed from the unit-σ noise Z = (eL)R, so that
    σ = 0 gives exactly the noise-free prediction and a zero std (no rounding from
    averaging D copies of the same number). (eL)R costs D·N·A + D·A·M flops, not D·N·M.
    """
    Z = draw(rng, n_draws) @ R
    Zt = Z @ totals
    return (
        base + sigma * Z.mean(0),
        sigma * Z.std(0, ddof=1),
        base @ totals + sigma * Zt.mean(0),
        sigma * Zt.std(0, ddof=1),
    )


def noisy_predictions(
    estimator, x_ref: np.ndarray, sigma: float, *, n_draws: int = 100, seed: int = 0
) -> np.ndarray:
    """The individual noisy predictions (D, M) of one level (input sampling)."""
    L, R = linear_factors(estimator)
    base = np.ravel(estimator.predict(np.asarray(x_ref, dtype=float)[None, :]))
    Z = _sampler(L, "inputs")(np.random.default_rng(seed), n_draws) @ R
    return base + sigma * Z


def analytic_std(L: np.ndarray, R: np.ndarray, sigmas, totals: np.ndarray):
    """Exact std of predictions under N(0, σ²I) input noise: σ·sqrt(diag(BᵀB)), B = L R.

    Returns
    -------
    node_std : ndarray (L, M)
    totals_std : ndarray (L, 3)
    """
    sig = np.atleast_1d(np.asarray(sigmas, dtype=float))
    G = L.T @ L  # (A, A): BᵀB = Rᵀ G R without forming the N x M matrix B
    node = np.sqrt(np.einsum("aj,ab,bj->j", R, G, R))
    RT = R @ totals
    tot = np.sqrt(np.einsum("ak,ab,bk->k", RT, G, RT))
    return sig[:, None] * node, sig[:, None] * tot


def nodal_average_std(node_std: np.ndarray, totals: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Thesis Table 5.1's ± for (Fz, Mx, My): nodal averages of standard deviations.

    Thesis §5.6 reports, beside each predicted total, "the nodal averaged standard
    deviation": the mean over the contact nodes of each node's standard deviation.
    For Fz that is mean_i std(F_i); for a moment it is the std of each node's moment,
    std(g_i F_i) = |g_i| std(F_i) with g_i = y_i (Mx) or -x_i (My). It is not the
    standard deviation of the total, which vanishes for the moments whenever the
    predicted forces are symmetric about the contact centre.

    Parameters
    ----------
    node_std : ndarray of shape (M,) or (L, M)
        Standard deviation of each tread node's force (per noise level).
    totals : ndarray of shape (M, 3)
        :func:`totals_operator` of the tread nodes.
    mask : ndarray of bool, shape (M,)
        The nodes to average over (:func:`contact_mask`).

    Returns
    -------
    ndarray of shape (3,) or (L, 3), in the units of ``node_std @ totals``.
    """
    weights = np.abs(np.asarray(totals, dtype=float)[mask])  # (m, 3)
    return np.asarray(node_std)[..., mask] @ weights / max(int(mask.sum()), 1)


def contact_mask(y_ref: np.ndarray, rtol: float = 1e-6) -> np.ndarray:
    """Tread nodes carrying force in the reference experiment (|F| > rtol·max|F|).

    Nodal averages exclude nodes off the contact patch, as the thesis' average nodal
    force does (§5.6); otherwise they would depend on how much tread is meshed.
    """
    y = np.abs(np.asarray(y_ref, dtype=float))
    return y > rtol * y.max() if y.max() > 0 else np.ones_like(y, dtype=bool)
