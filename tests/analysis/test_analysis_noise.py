"""Monte Carlo noise (thesis §5.6): exactness at σ = 0, agreement with the analytic law."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.cross_decomposition import PLSRegression

from analysis.errors import ParameterError
from analysis.noise import (
    analytic_std,
    contact_mask,
    linear_factors,
    monte_carlo,
    monte_carlo_noisy_training,
    noisy_predictions,
    totals_operator,
)
from analysis.pcr import PCRegression
from analysis.pls import SIMPLSRegression


@pytest.fixture(scope="module")
def model_and_ref(thesis_xy, thesis_ds):
    from analysis import data

    X, Y = thesis_xy
    xy = data.tread_index(thesis_ds)[["x", "y"]].to_numpy()
    return SIMPLSRegression(3).fit(X, Y), X[3], Y[3], totals_operator(xy)


def test_zero_noise_reproduces_the_noise_free_prediction_exactly(model_and_ref):
    model, x_ref, _, G = model_and_ref
    res = monte_carlo(model, x_ref, [0.0, 0.5], totals=G, n_draws=50, seed=1)
    free = model.predict(x_ref[None, :])[0]
    assert np.array_equal(res.node_mean[0], free)
    assert np.array_equal(res.reference_prediction, free)
    assert not res.node_std[0].any() and not res.totals_std[0].any()
    assert res.node_std[1].max() > 0
    draws = noisy_predictions(model, x_ref, 0.0, n_draws=5)
    assert all(np.array_equal(d, free) for d in draws)


@pytest.mark.parametrize(
    "estimator",
    [
        SIMPLSRegression(3),
        PCRegression(3),
        PLSRegression(3, scale=False),
        PLSRegression(2, scale=True),
    ],
)
@pytest.mark.parametrize("sampling", ["inputs", "subspace"])
def test_monte_carlo_std_converges_to_the_analytic_std(thesis_xy, estimator, sampling):
    """Prediction noise is N(0, σ² BᵀB): with D draws the sample std of each node is
    within a few 1/sqrt(2D) of σ sqrt(diag BᵀB), B computed here from coef_ directly."""
    X, Y = thesis_xy
    est = estimator.fit(X, Y)
    G = np.ones((Y.shape[1], 1))
    D, sigma = 20000, 0.7
    res = monte_carlo(est, X[2], [sigma], totals=G, n_draws=D, seed=5, sampling=sampling)
    B = est.coef_.T
    exact = sigma * np.sqrt((B**2).sum(0))
    live = exact > 1e-9 * exact.max()
    np.testing.assert_allclose(res.node_std_analytic[0], exact, rtol=1e-8, atol=1e-12 * exact.max())
    rel = res.node_std[0][live] / exact[live] - 1
    assert np.abs(rel).max() < 5 / np.sqrt(2 * D)
    assert abs(res.totals_std[0, 0] / res.totals_std_analytic[0, 0] - 1) < 5 / np.sqrt(2 * D)


def test_error_of_the_std_shrinks_like_one_over_sqrt_draws(model_and_ref):
    model, x_ref, _, G = model_and_ref
    errs = []
    for D in (100, 10000):
        res = monte_carlo(model, x_ref, [1.0], totals=G, n_draws=D, seed=2)
        live = res.node_std_analytic[0] > 0
        errs.append(np.mean(np.abs(res.node_std[0][live] / res.node_std_analytic[0][live] - 1)))
    assert errs[1] < errs[0] / 4  # ideal: /10


def test_vectorised_draws_equal_a_loop_over_predict(model_and_ref):
    """Same random numbers, one predict() per draw: the array form changes nothing."""
    model, x_ref, _, G = model_and_ref
    D, sigma, seed = 30, 0.3, 4
    res = monte_carlo(model, x_ref, [sigma], totals=G, n_draws=D, seed=seed)
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    E = rng.standard_normal((D, x_ref.size))
    loop = np.array([model.predict((x_ref + sigma * e)[None, :])[0] for e in E])
    np.testing.assert_allclose(res.node_mean[0], loop.mean(0), rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(res.node_std[0], loop.std(0, ddof=1), rtol=1e-9, atol=1e-9)
    scale = np.abs(loop @ G).max()  # Mx, My are ~0 here (symmetric synthetic patch)
    np.testing.assert_allclose(
        res.totals_mean[0], (loop @ G).mean(0), rtol=1e-10, atol=1e-12 * scale
    )


def test_std_is_linear_in_sigma_and_mean_is_unbiased(model_and_ref):
    model, x_ref, _, G = model_and_ref
    sig = np.array([0.25, 0.5, 1.0, 2.0])
    res = monte_carlo(model, x_ref, sig, totals=G, n_draws=400, seed=0)
    per_sigma = res.node_std_analytic / sig[:, None]
    np.testing.assert_allclose(
        per_sigma, np.broadcast_to(per_sigma[0], per_sigma.shape), rtol=1e-12
    )
    se = res.totals_std_analytic[:, 0] / np.sqrt(400)
    assert np.all(np.abs(res.totals_mean[:, 0] - res.reference_prediction @ G[:, 0]) < 5 * se)


def test_totals_operator_signs():
    """A downward road force at +y tilts about +x (Mx > 0); at +x, My < 0 (TYDEX C)."""
    G = totals_operator(np.array([[0.0, 50.0], [80.0, 0.0]]))
    np.testing.assert_allclose(np.array([10.0, 0.0]) @ G, [10.0, 500.0, 0.0])
    np.testing.assert_allclose(np.array([0.0, 10.0]) @ G, [10.0, 0.0, -800.0])


def test_analytic_std_without_forming_b(model_and_ref):
    model, _, _, G = model_and_ref
    L, R = linear_factors(model)
    np.testing.assert_allclose(L @ R, model.coef_.T, rtol=1e-10, atol=1e-14)
    node, tot = analytic_std(L, R, [2.0], G)
    B = model.coef_.T
    np.testing.assert_allclose(node[0], 2.0 * np.linalg.norm(B, axis=0), rtol=1e-9)
    direct = 2.0 * np.linalg.norm(B @ G, axis=0)
    np.testing.assert_allclose(tot[0], direct, rtol=1e-9, atol=1e-9 * direct.max())


def test_seeded_and_reproducible(model_and_ref):
    model, x_ref, _, G = model_and_ref
    a = monte_carlo(model, x_ref, [1.0], totals=G, n_draws=20, seed=9)
    b = monte_carlo(model, x_ref, [1.0], totals=G, n_draws=20, seed=9)
    c = monte_carlo(model, x_ref, [1.0], totals=G, n_draws=20, seed=10)
    assert np.array_equal(a.node_std, b.node_std) and not np.array_equal(a.node_std, c.node_std)


@pytest.mark.parametrize(
    ("sigmas", "draws", "sampling"),
    [([-1.0], 10, "inputs"), ([np.nan], 10, "inputs"), ([1.0], 1, "inputs"), ([1.0], 5, "x")],
)
def test_bad_noise_parameters(model_and_ref, sigmas, draws, sampling):
    model, x_ref, _, G = model_and_ref
    with pytest.raises(ParameterError):
        monte_carlo(model, x_ref, sigmas, totals=G, n_draws=draws, sampling=sampling)


def test_subspace_sampling_is_exact_at_zero_and_matches_in_distribution(model_and_ref):
    model, x_ref, _, G = model_and_ref
    a = monte_carlo(model, x_ref, [0.0, 1.0], totals=G, n_draws=4000, seed=3)
    b = monte_carlo(model, x_ref, [0.0, 1.0], totals=G, n_draws=4000, seed=3, sampling="subspace")
    assert np.array_equal(a.node_mean[0], b.node_mean[0]) and not b.node_std[0].any()
    np.testing.assert_array_equal(a.node_std_analytic, b.node_std_analytic)
    live = a.node_std_analytic[1] > 0
    rel = b.node_std[1][live] / a.node_std[1][live] - 1
    assert np.abs(rel).max() < 2 * 5 / np.sqrt(2 * 4000)  # two independent estimates


def test_contact_mask_keeps_loaded_nodes():
    assert contact_mask(np.array([0.0, 5.0, 1e-9, 2.0])).tolist() == [False, True, False, True]


# --- noise in training too (issue 25) ---------------------------------------------------


@pytest.fixture(scope="module")
def interpolating():
    """7 experiments, 6 latent variables of falling strength, SIMPLS with all 6: the
    clean model resolves the weak directions, which training noise swamps."""
    rng = np.random.default_rng(0)
    T = rng.standard_normal((7, 6)) * [5.0, 2.0, 1.0, 0.5, 0.3, 0.2]
    X = T @ rng.standard_normal((6, 300))
    Y = T @ rng.standard_normal((6, 40)) * 100 + 50
    return SIMPLSRegression(6), X, Y, np.ones((40, 1))


def test_noisy_training_at_zero_sigma_is_the_clean_result_exactly(model_and_ref, thesis_xy):
    model, x_ref, _, G = model_and_ref
    X, Y = thesis_xy
    clean = monte_carlo(model, x_ref, [0.0], totals=G, n_draws=10, seed=1)
    noisy = monte_carlo_noisy_training(model, X, Y, x_ref, [0.0], totals=G, n_fits=3,
                                       n_draws=4, seed=1)
    for field in ("reference_prediction", "node_mean", "node_std", "totals_mean",
                  "totals_std"):
        assert np.array_equal(getattr(noisy, field), getattr(clean, field)), field
    assert np.isnan(noisy.node_std_analytic).all() and np.isnan(noisy.totals_std_analytic).all()
    assert (noisy.n_fits, noisy.n_draws) == (3, 12)


def test_noisy_training_pools_refits_on_noisy_training_inputs(interpolating):
    """The statistics are those of an explicit loop: clone, fit on X + σE, predict noisy
    copies of x_ref, pooled over refits x draws (ddof=1), seeded level -> refit."""
    est, X, Y, G = interpolating
    sigma, F, D, seed = 0.3, 4, 6, 9
    res = monte_carlo_noisy_training(est, X, Y, X[3], [0.0, sigma], totals=G, n_fits=F,
                                     n_draws=D, seed=seed)
    preds = []
    for child in np.random.SeedSequence(seed).spawn(2)[1].spawn(F):
        rng = np.random.default_rng(child)
        model = clone(est).fit(X + sigma * rng.standard_normal(X.shape), Y)
        e = rng.standard_normal((D, X.shape[1]))
        preds.append(model.predict(X[3] + sigma * e))
    P = np.concatenate(preds)
    np.testing.assert_allclose(res.node_mean[1], P.mean(0), rtol=1e-9)
    np.testing.assert_allclose(res.node_std[1], P.std(0, ddof=1), rtol=1e-8)
    np.testing.assert_allclose(res.totals_std[1], (P @ G).std(0, ddof=1), rtol=1e-8)
    np.testing.assert_allclose(res.reference_prediction, clone(est).fit(X, Y).predict(X[3:4])[0])


def test_noise_in_training_changes_the_spread_and_is_seeded(interpolating):
    """Would fail if the training noise were ignored: refits on noisy inputs disagree on the
    weak latent directions the clean model resolves, so the spread grows well past the
    Monte Carlo error (measured: 1.28-1.35x over seeds 0-3). Same seed, same numbers;
    another seed, other numbers."""
    est, X, Y, G = interpolating
    clean = monte_carlo(clone(est).fit(X, Y), X[3], [0.1], totals=G, n_draws=4000, seed=1)
    kw = {"totals": G, "n_fits": 40, "n_draws": 100}
    noisy = monte_carlo_noisy_training(est, X, Y, X[3], [0.1], seed=1, **kw)
    ratio = noisy.node_std[0].mean() / clean.node_std[0].mean()
    assert ratio > 1.15  # MC error of either mean std is ~1-3 %
    again = monte_carlo_noisy_training(est, X, Y, X[3], [0.1], seed=1, **kw)
    other = monte_carlo_noisy_training(est, X, Y, X[3], [0.1], seed=2, **kw)
    assert np.array_equal(again.node_std, noisy.node_std)
    assert np.array_equal(again.node_mean, noisy.node_mean)
    assert not np.array_equal(other.node_std, noisy.node_std)


def test_noisy_training_levels_do_not_depend_on_each_other(interpolating):
    est, X, Y, G = interpolating
    one = monte_carlo_noisy_training(est, X, Y, X[3], [0.2, 0.5], totals=G, n_fits=3,
                                     n_draws=5, seed=4)
    both = monte_carlo_noisy_training(est, X, Y, X[3], [0.2, 0.5, 0.9], totals=G, n_fits=3,
                                      n_draws=5, seed=4)
    np.testing.assert_array_equal(one.node_std, both.node_std[:2])


@pytest.mark.parametrize(("fits", "draws", "sampling"), [(0, 5, "inputs"), (2, 1, "inputs"),
                                                          (2, 5, "bogus")])
def test_noisy_training_bad_parameters(interpolating, fits, draws, sampling):
    est, X, Y, G = interpolating
    with pytest.raises(ParameterError):
        monte_carlo_noisy_training(est, X, Y, X[3], [0.1], totals=G, n_fits=fits,
                                   n_draws=draws, sampling=sampling)
