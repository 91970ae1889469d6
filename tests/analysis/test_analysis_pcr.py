"""PCR (thesis §5.4): exact identities with least squares and with the eigenproblems."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from analysis.errors import ComponentsError
from analysis.pcr import PCRegression


@pytest.mark.parametrize(("K", "N", "M"), [(50, 6, 6), (80, 10, 4), (30, 5, 12)])
def test_all_modes_on_full_rank_data_is_least_squares(random_xy, K, N, M):
    """Tall, full-rank X: all modes make PCR the ordinary least-squares fit, and α is the
    least-squares map between the explicitly computed scores Z_X = X̄u_X, Z_Y = Ȳu_Y."""
    X, Y = random_xy(K, N, M, seed=N)
    fit = PCRegression().fit(X, Y)
    Xc, Yc = X - X.mean(0), Y - Y.mean(0)
    ols = np.linalg.lstsq(Xc, Yc, rcond=None)[0]
    np.testing.assert_allclose(fit.coef_.T, ols, rtol=1e-8, atol=1e-10)
    Zx, Zy = Xc @ fit.x_components_, Yc @ fit.y_components_
    np.testing.assert_allclose(
        fit.alpha_, np.linalg.lstsq(Zx, Zy, rcond=None)[0], rtol=1e-8, atol=1e-10
    )


@pytest.mark.parametrize(("K", "N", "M"), [(7, 100, 40), (7, 40, 100)])
def test_all_modes_on_wide_data_is_minimum_norm_least_squares(random_xy, K, N, M):
    """Thesis shape (K << N): with all K-1 modes PCR returns pinv(X̄)Ȳ and interpolates."""
    X, Y = random_xy(K, N, M, seed=1)
    fit = PCRegression().fit(X, Y)
    Xc, Yc = X - X.mean(0), Y - Y.mean(0)
    min_norm = np.linalg.lstsq(Xc, Yc, rcond=None)[0]  # drops the rounding-level 7th s.v.
    np.testing.assert_allclose(fit.coef_.T, min_norm, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(fit.predict(X), Y, atol=1e-8 * np.abs(Y).max())
    assert fit.n_components_ == K - 1


def test_explained_variance_is_the_eigen_spectrum(random_xy):
    """Fig. 5.7: fractions are the eigenvalues of ȲᵀȲ (not of the regression)."""
    X, Y = random_xy(9, 60, 30, seed=4)
    fit = PCRegression(2).fit(X, Y)
    lam = np.linalg.eigvalsh(np.cov(Y.T))[::-1]
    lam = lam[lam > lam[0] * 1e-12]
    np.testing.assert_allclose(fit.y_explained_variance_ratio_, lam / lam.sum(), rtol=1e-8)
    assert fit.y_explained_variance_ratio_.sum() == pytest.approx(1.0)
    assert np.all(np.diff(fit.y_explained_variance_ratio_) <= 1e-15)


@pytest.mark.parametrize("r", [1, 2, 3])
def test_prediction_follows_eqs_5_5_to_5_7(random_xy, r):
    """ŷ = ȳ + ((x - x̄) u_X α) u_Yᵀ, with orthonormal eigenvector columns."""
    X, Y = random_xy(12, 40, 15, seed=r)
    fit = PCRegression(r).fit(X, Y)
    assert fit.x_components_.shape == (40, r) and fit.alpha_.shape == (r, r)
    np.testing.assert_allclose(fit.x_components_.T @ fit.x_components_, np.eye(r), atol=1e-10)
    manual = Y.mean(0) + ((X - X.mean(0)) @ fit.x_components_ @ fit.alpha_) @ fit.y_components_.T
    np.testing.assert_allclose(fit.predict(X), manual, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(
        fit.predict(X), X @ fit.coef_.T + fit.intercept_, rtol=1e-8, atol=1e-8
    )


def test_more_modes_fit_the_training_data_better(thesis_xy):
    X, Y = thesis_xy
    errors = [np.linalg.norm(PCRegression(r).fit(X, Y).predict(X) - Y) for r in range(1, 7)]
    assert all(b <= a * (1 + 1e-9) for a, b in itertools.pairwise(errors))
    assert errors[-1] < 1e-8 * np.linalg.norm(Y)


def test_single_response_uses_one_output_mode(random_xy):
    X, Y = random_xy(30, 5, 1)
    fit = PCRegression(3).fit(X, Y[:, 0])
    assert fit.alpha_.shape == (3, 1)
    assert fit.predict(X).shape == (30,)


def test_too_many_modes(random_xy):
    X, Y = random_xy(5, 20, 3)
    with pytest.raises(ComponentsError, match="rank of X̄"):
        PCRegression(5).fit(X, Y)


def test_outputs_without_variance_have_undefined_variance_explained(random_xy):
    """Constant Y: each mode's share of zero variance is 0/0, reported as NaN (as
    scikit-learn's PCA does), with a warning; it used to be a confident 100 %. The fit
    itself is still defined: it predicts the constant."""
    X, Y = random_xy(9, 30, 5)
    flat = np.full_like(Y, 3.0)
    with pytest.warns(UserWarning, match="no variance"):
        fit = PCRegression().fit(X, flat)
    assert np.isnan(fit.y_explained_variance_ratio_).all()
    assert fit.x_explained_variance_ratio_.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(fit.predict(X), 3.0)
    with pytest.warns(UserWarning, match="no variance"):
        fit = PCRegression(1).fit(np.ones_like(X), Y)  # constant inputs: nothing to regress on
    assert np.isnan(fit.x_explained_variance_ratio_).all()
    np.testing.assert_allclose(fit.predict(X), np.broadcast_to(Y.mean(0), Y.shape))
