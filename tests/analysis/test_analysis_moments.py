"""Moments: the reduced (wide) and chunk-wise (tall) forms are exact."""

from __future__ import annotations

import dask.array as da
import numpy as np
import pytest

from analysis.moments import compute_moments


def _full(m):
    """Expand reduced moments back to node space: X̄ᵀX̄, X̄ᵀȲ, ȲᵀȲ."""
    bx = np.eye(m.x_mean.size) if m.x_basis is None else m.x_basis
    by = np.eye(m.y_mean.size) if m.y_basis is None else m.y_basis
    return bx @ m.xx @ bx.T, bx @ m.xy @ by.T, by @ m.yy @ by.T


@pytest.mark.parametrize(("K", "N", "M"), [(7, 60, 30), (7, 30, 60), (50, 8, 4), (50, 8, 70)])
@pytest.mark.parametrize("lazy", [False, True])
def test_moments_reproduce_the_centred_products(random_xy, K, N, M, lazy):
    X, Y = random_xy(K, N, M, seed=K * N)
    if lazy:
        X, Y = da.from_array(X, chunks=(9, N)), da.from_array(Y, chunks=(9, M))
    m = compute_moments(X, Y)
    X, Y = np.asarray(X), np.asarray(Y)
    Xc, Yc = X - X.mean(0), Y - Y.mean(0)
    xx, xy, yy = _full(m)
    scale = np.abs(Xc).max() ** 2 * K
    np.testing.assert_allclose(xx, Xc.T @ Xc, atol=1e-12 * scale)
    np.testing.assert_allclose(xy, Xc.T @ Yc, atol=1e-12 * np.abs(Xc.T @ Yc).max() * 10)
    np.testing.assert_allclose(yy, Yc.T @ Yc, atol=1e-12 * np.abs(Yc.T @ Yc).max() * 10)
    np.testing.assert_allclose(m.x_mean, X.mean(0))
    assert m.x_ss == pytest.approx((Xc**2).sum(), rel=1e-12)


def test_wide_data_never_forms_node_by_node_matrices(random_xy):
    X, Y = random_xy(7, 2000, 500)
    m = compute_moments(X, Y)
    assert m.xx.shape == (6, 6) and m.xy.shape == (6, 6) and m.yy.shape == (6, 6)
    np.testing.assert_allclose(m.x_basis.T @ m.x_basis, np.eye(6), atol=1e-12)


def test_chunked_moments_survive_a_large_mean():
    """Strains ~1e-3 sitting on an offset of 1e3: the textbook one-pass formula
    ΣxxT - K x̄x̄ᵀ loses every digit; the shifted accumulation keeps them."""
    rng = np.random.default_rng(0)
    X = 1e3 + 1e-3 * rng.standard_normal((400, 5))
    Y = X[:, :2] * 2.0
    m = compute_moments(da.from_array(X, chunks=(64, 5)), da.from_array(Y, chunks=(64, 2)))
    Xc = X - X.mean(0)
    np.testing.assert_allclose(m.xx, Xc.T @ Xc, rtol=1e-6)
    naive = X.T @ X - 400 * np.outer(X.mean(0), X.mean(0))
    assert np.abs(naive - Xc.T @ Xc).max() > 1e-3 * np.abs(Xc.T @ Xc).max()  # it really fails


@pytest.mark.parametrize("rank", [None, 20])
def test_many_rows_are_reduced_through_the_gram_matrix_to_the_same_moments(random_xy, rank):
    """K >= GRAM_ROWS (a sensor study's noisy draws): the Gram route reproduces the
    centred products to 1e-10 of their scale and its basis is orthonormal; a block of
    low rank keeps only its rank's directions, as the SVD does."""
    from analysis.moments import GRAM_ROWS

    K, N = GRAM_ROWS + 44, 700
    X, Y = random_xy(K, N, 9, seed=3)
    if rank is not None:
        X = X[:, :rank] @ np.random.default_rng(1).standard_normal((rank, N))
    m = compute_moments(X, Y)
    Xc, Yc = X - X.mean(0), Y - Y.mean(0)
    xx, xy, _ = _full(m)
    scale = np.abs(Xc.T @ Xc).max()
    np.testing.assert_allclose(xx, Xc.T @ Xc, atol=1e-10 * scale)
    np.testing.assert_allclose(xy, Xc.T @ Yc, atol=1e-10 * np.abs(Xc.T @ Yc).max())
    r = m.x_basis.shape[1]
    assert r == (K - 1 if rank is None else rank)
    np.testing.assert_allclose(m.x_basis.T @ m.x_basis, np.eye(r), atol=1e-8)
