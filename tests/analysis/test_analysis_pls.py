"""SIMPLS: against a literal plsregress transcription, NIPALS, and the PCTVAR definition."""

from __future__ import annotations

import dask.array as da
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.cross_decomposition import PLSRegression

from analysis.errors import ComponentsError
from analysis.pls import SIMPLSRegression, pctvar_from_scores


def plsregress_reference(X, Y, ncomp):
    """Line-by-line transcription of MATLAB plsregress/simpls on the raw data matrices
    (no reduced coordinates, no moments): the independent oracle for our SIMPLS."""
    X0, Y0 = X - X.mean(0), Y - Y.mean(0)
    dx, dy = X0.shape[1], Y0.shape[1]
    XL, YL, W, V = (
        np.zeros((dx, ncomp)),
        np.zeros((dy, ncomp)),
        np.zeros((dx, ncomp)),
        np.zeros((dx, ncomp)),
    )
    XS = np.zeros((X0.shape[0], ncomp))
    Cov = X0.T @ Y0
    for i in range(ncomp):
        U, S, Vt = np.linalg.svd(Cov, full_matrices=False)
        ri, ci, si = U[:, 0], Vt[0], S[0]
        ti = X0 @ ri
        normti = np.linalg.norm(ti)
        ti = ti / normti
        XL[:, i] = X0.T @ ti
        YL[:, i] = si * ci / normti
        XS[:, i] = ti
        W[:, i] = ri / normti
        vi = XL[:, i].copy()
        for _ in range(2):
            for j in range(i):
                vi = vi - (vi @ V[:, j]) * V[:, j]
        vi /= np.linalg.norm(vi)
        V[:, i] = vi
        Cov = Cov - np.outer(vi, vi @ Cov)
        Cov = Cov - V[:, : i + 1] @ (V[:, : i + 1].T @ Cov)
    beta = W @ YL.T
    pctvar = np.vstack([(XL**2).sum(0) / (X0**2).sum(), (YL**2).sum(0) / (Y0**2).sum()])
    return {"beta": beta, "XL": XL, "YL": YL, "XS": XS, "W": W, "pctvar": pctvar}


SHAPES = [(7, 120, 40), (7, 30, 300), (60, 12, 5), (25, 25, 25)]  # wide, wide+many y, tall, square


@pytest.mark.parametrize(("K", "N", "M"), SHAPES)
@pytest.mark.parametrize("A", [1, 3])
def test_simpls_matches_plsregress_transcription(random_xy, K, N, M, A):
    X, Y = random_xy(K, N, M, seed=K + N)
    ref = plsregress_reference(X, Y, A)
    fit = SIMPLSRegression(A).fit(X, Y)
    np.testing.assert_allclose(
        fit.coef_.T, ref["beta"], rtol=1e-8, atol=1e-10 * np.abs(ref["beta"]).max()
    )
    np.testing.assert_allclose(fit.pctvar_, ref["pctvar"], rtol=1e-9, atol=1e-14)
    # loadings and scores equal up to the (arbitrary) sign of each component
    sign = np.sign((fit.y_loadings_ * ref["YL"]).sum(0))
    np.testing.assert_allclose(fit.y_loadings_ * sign, ref["YL"], rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(fit.transform(X) * sign, ref["XS"], atol=1e-8)


@pytest.mark.parametrize(("K", "N"), [(7, 200), (40, 10), (15, 15)])
@pytest.mark.parametrize("A", [1, 2, 4])
def test_simpls_equals_nipals_for_one_response(random_xy, K, N, A):
    """de Jong (1993): for a single response SIMPLS and NIPALS give the same model."""
    X, Y = random_xy(K, N, 1, seed=A)
    y = Y[:, 0]
    ours = SIMPLSRegression(A).fit(X, y)
    theirs = PLSRegression(A, scale=False).fit(X, y)
    np.testing.assert_allclose(
        ours.coef_, theirs.coef_, rtol=1e-9, atol=1e-12 * np.abs(ours.coef_).max()
    )
    np.testing.assert_allclose(ours.predict(X), theirs.predict(X), rtol=1e-10)
    assert ours.predict(X).shape == (K,)


def test_simpls_vs_nipals_multi_response_thesis_like(thesis_xy):
    """Several responses: the two algorithms differ in general, but on data with one
    dominant latent variable (the thesis' case) their fitted forces agree to 1e-4 of
    ||Ȳ||, and exactly (interpolation) with all K-1 components."""
    X, Y = thesis_xy
    y_norm = np.linalg.norm(Y - Y.mean(0))
    for a in range(1, X.shape[0]):
        ours = SIMPLSRegression(a).fit(X, Y).predict(X)
        theirs = PLSRegression(a, scale=False, tol=1e-12, max_iter=5000).fit(X, Y).predict(X)
        assert np.linalg.norm(ours - theirs) / y_norm < 1e-4
    np.testing.assert_allclose(ours, Y, atol=1e-8 * np.abs(Y).max())


def test_simpls_differs_from_nipals_on_generic_multi_response(random_xy):
    """The tolerance above is a property of the data, not of the algorithms."""
    X, Y = random_xy(30, 8, 6, seed=11)
    ours = SIMPLSRegression(2).fit(X, Y).predict(X)
    theirs = PLSRegression(2, scale=False, tol=1e-12, max_iter=5000).fit(X, Y).predict(X)
    assert np.linalg.norm(ours - theirs) / np.linalg.norm(Y - Y.mean(0)) > 1e-6


@pytest.mark.parametrize(("K", "N", "M"), SHAPES)
def test_pctvar_fractions_and_independent_computation(random_xy, K, N, M):
    X, Y = random_xy(K, N, M, seed=3)
    A = min(4, K - 1)
    fit = SIMPLSRegression(A).fit(X, Y)
    assert np.all(fit.pctvar_ >= 0)
    assert np.all(fit.pctvar_.sum(1) <= 1 + 1e-12)
    np.testing.assert_allclose(fit.pctvar_, pctvar_from_scores(fit.transform(X), X, Y), rtol=1e-9)
    # cumulative Y fraction = 1 - residual of least squares on the first a scores
    Yc, T = Y - Y.mean(0), fit.transform(X)
    for a in range(1, A + 1):
        resid = Yc - T[:, :a] @ np.linalg.lstsq(T[:, :a], Yc, rcond=None)[0]
        explained = 1 - (resid**2).sum() / (Yc**2).sum()
        assert fit.pctvar_[1, :a].sum() == pytest.approx(explained, rel=1e-9, abs=1e-12)


def test_pctvar_of_nipals_scores_matches_its_own_deflation(random_xy):
    """pctvar_from_scores on scikit-learn's scores equals ||t||²||p||² / ||X̄||², the
    variance each NIPALS deflation step removes."""
    X, Y = random_xy(20, 9, 3, seed=5)
    fit = PLSRegression(3, scale=False).fit(X, Y)
    pv = pctvar_from_scores(fit.x_scores_, X, Y)
    tt = (fit.x_scores_**2).sum(0)
    Xc = X - X.mean(0)
    np.testing.assert_allclose(pv[0], tt * (fit.x_loadings_**2).sum(0) / (Xc**2).sum(), rtol=1e-9)


def test_scores_are_orthonormal_and_weights_give_them(thesis_xy):
    X, Y = thesis_xy
    fit = SIMPLSRegression(4).fit(X, Y)
    T = fit.transform(X)
    np.testing.assert_allclose(T.T @ T, np.eye(4), atol=1e-10)
    np.testing.assert_allclose(fit.x_loadings_, (X - X.mean(0)).T @ T, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize(("K", "N", "M"), [(7, 50, 20), (200, 12, 6), (40, 30, 60)])
def test_dask_input_gives_the_numpy_model(random_xy, K, N, M):
    """The out-of-core path (chunk-wise moments) fits the same model as in memory."""
    X, Y = random_xy(K, N, M, seed=7)
    ref = SIMPLSRegression(3).fit(X, Y)
    lazy = SIMPLSRegression(3).fit(
        da.from_array(X, chunks=(16, N)), da.from_array(Y, chunks=(16, M))
    )
    np.testing.assert_allclose(
        lazy.coef_, ref.coef_, rtol=1e-7, atol=1e-9 * np.abs(ref.coef_).max()
    )
    np.testing.assert_allclose(lazy.pctvar_, ref.pctvar_, rtol=1e-7, atol=1e-12)


def test_too_many_components_is_one_clear_line(random_xy):
    X, Y = random_xy(4, 30, 5)
    with pytest.raises(ComponentsError, match="5 components asked but only 3") as info:
        SIMPLSRegression(5).fit(X, Y)
    assert "\n" not in str(info.value)


def test_exhausted_cross_covariance_is_detected():
    """Rank-2 X with K = 10: a third component has nothing left to explain."""
    rng = np.random.default_rng(0)
    X = rng.standard_normal((10, 2)) @ rng.standard_normal((2, 20))
    Y = X @ rng.standard_normal((20, 3))
    with pytest.raises(ComponentsError, match="exhausted"):
        SIMPLSRegression(3).fit(X, Y)


@settings(max_examples=25, deadline=None)
@given(
    K=st.integers(4, 30),
    N=st.integers(2, 60),
    M=st.integers(1, 12),
    A=st.integers(1, 5),
    seed=st.integers(0, 2**16),
)
def test_property_simpls_equals_plsregress_and_pctvar_is_a_partition(K, N, M, A, seed):
    """Any shape (wide, tall, one or many responses): same model as the transcription,
    PCTVAR rows non-negative and summing to at most 1."""
    A = min(A, K - 1, N)
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((K, N)) + 3.0
    Y = X @ rng.standard_normal((N, M)) + rng.standard_normal((K, M))
    try:
        fit = SIMPLSRegression(A).fit(X, Y)
    except ComponentsError:
        return  # X̄ᵀȲ exhausted before A components (e.g. M = 1 and tiny K): correct refusal
    ref = plsregress_reference(X, Y, A)
    scale = np.abs(ref["beta"]).max()
    np.testing.assert_allclose(fit.coef_.T, ref["beta"], rtol=1e-6, atol=1e-8 * scale)
    assert np.all(fit.pctvar_ >= -1e-15) and np.all(fit.pctvar_.sum(1) <= 1 + 1e-12)
