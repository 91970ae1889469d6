"""Cross-covariance PCA (thesis §5.3): the SVD of X̄ᵀȲ, and what it must reveal."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.cross_decomposition import PLSSVD

from analysis import data
from analysis.crosscov import CrossCovariancePCA, direction_importance


@pytest.mark.parametrize(("K", "N", "M"), [(7, 150, 60), (7, 40, 200), (60, 15, 8)])
def test_equals_svd_of_the_formed_cross_covariance(random_xy, K, N, M):
    X, Y = random_xy(K, N, M, seed=2)
    T = (X - X.mean(0)).T @ (Y - Y.mean(0))
    fit = CrossCovariancePCA().fit(X, Y)
    s = np.linalg.svd(T, compute_uv=False)
    r = fit.n_components_
    assert r == min(K - 1, N, M)
    np.testing.assert_allclose(fit.singular_values_, s[:r], rtol=1e-9)
    W, V = fit.x_components_, fit.y_components_
    np.testing.assert_allclose(W.T @ W, np.eye(r), atol=1e-10)
    np.testing.assert_allclose(V.T @ V, np.eye(r), atol=1e-10)
    np.testing.assert_allclose(W * fit.singular_values_ @ V.T, T, atol=1e-9 * s[0])  # eq. 5.2


def test_first_vectors_match_scikit_learn_plssvd(random_xy):
    X, Y = random_xy(7, 80, 30, seed=9)
    ours = CrossCovariancePCA(3).fit(X, Y)
    theirs = PLSSVD(3, scale=False).fit(X, Y)
    for k in range(3):
        assert abs(ours.x_components_[:, k] @ theirs.x_weights_[:, k]) == pytest.approx(1, abs=1e-8)


def test_eigen_forces_are_oriented_to_push(random_xy):
    X, Y = random_xy(7, 50, 20, seed=1)
    fit = CrossCovariancePCA().fit(X, Y)
    sums = fit.y_components_.sum(0)
    assert np.all((sums >= 0) | (np.abs(sums) < 1e-8))


def _fits(ds, directions):
    Y = np.asarray(data.outputs(ds).compute())
    return {
        d: CrossCovariancePCA().fit(np.asarray(data.inputs(ds, d).compute()), Y) for d in directions
    }


def test_single_latent_variable_gives_a_dominant_first_mode(thesis_ds):
    """Only the deflection varies (as in the thesis' dataset): σ₁ dominates every
    direction, σ₂/σ₁ < 0.1 (the thesis' Fig. 5.1/5.3 finding)."""
    fits = _fits(thesis_ds, data.DIRECTIONS)
    for d, fit in fits.items():
        s = fit.singular_values_
        assert s[1] / s[0] < 0.1, d
    imp = direction_importance({d: f.singular_values_[0] for d, f in fits.items()})
    top = imp[imp["rank"] == 1].set_index("family")["direction"].to_dict()
    assert top == {"displacement": "Uz", "strain": "exx", "surface_strain": "cst_exx"}


def test_signal_only_in_uz_ranks_uz_first(uz_only_store):
    ds = data.load(uz_only_store)
    fits = _fits(ds, ["Ux", "Uy", "Uz"])
    imp = direction_importance({d: f.singular_values_[0] for d, f in fits.items()}).set_index(
        "direction"
    )
    assert imp.loc["Uz", "rank"] == 1 and imp.loc["Uz", "importance"] == 1.0
    assert imp.loc[["Ux", "Uy"], "importance"].max() < 0.05


def test_importance_is_normalised_within_each_unit_family():
    imp = direction_importance({"Ux": 1.0, "Uz": 4.0, "exx": 0.02, "eyy": 0.01}).set_index(
        "direction"
    )
    assert imp.loc["Uz", "importance"] == 1.0 and imp.loc["exx", "importance"] == 1.0
    assert imp.loc["Ux", "importance"] == 0.25 and imp.loc["eyy", "importance"] == 0.5


def test_a_direction_without_signal_reports_zero():
    X = np.zeros((6, 10))
    Y = np.random.default_rng(0).standard_normal((6, 4))
    fit = CrossCovariancePCA().fit(X, Y)
    assert fit.n_components_ == 1 and fit.singular_values_[0] == 0.0
