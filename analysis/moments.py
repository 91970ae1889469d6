"""Centred second moments of (X, Y): the sufficient statistics of every analysis here.

Cross-covariance PCA (eqs. 5.1-5.2), PCR (eqs. 5.3-5.7) and SIMPLS (de Jong 1993) only
ever touch the data through X̄ᵀX̄, X̄ᵀȲ, ȲᵀȲ and the means. :class:`Moments` holds
those, possibly in *reduced coordinates*, so that each method costs the same whatever
the shape of the data:

- wide data (K experiments <= N nodes, the thesis' case: K = 7, N ~ 1000): the thin SVD
  X̄ = U S Bᵀ gives X̄ = X̃ Bᵀ with X̃ = U S (K x r) and B (N x r) orthonormal, r <= K-1.
  Every method is equivariant under this orthogonal change of basis, so it runs on the
  r x r and r x q matrices and maps its vectors back with B. Cost O(K² N), exact; no
  N x N covariance is ever formed. From :data:`GRAM_ROWS` experiments on (a sensor
  study's noisy draws) the basis comes from the K x K Gram matrix instead of the SVD:
  the same moments to about 1e-10, several times faster.
- tall data (K > N, e.g. 10,000 experiments): X̄ᵀX̄ (N x N) and X̄ᵀȲ are accumulated
  chunk by chunk along ``experiment`` (dask), one pass over the store.

The same applies to Y with M tread nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import dask
import dask.array as da
import numpy as np

from analysis.errors import NonFiniteError


@dataclass(frozen=True)
class Moments:
    """Centred second moments, in reduced coordinates where a basis is given.

    Attributes
    ----------
    n_samples : int
        K, the number of experiments.
    x_mean : ndarray of shape (N,)
    y_mean : ndarray of shape (M,)
    xx : ndarray of shape (p, p)
        X̃ᵀX̃, with X̄ = X̃ x_basisᵀ (or X̃ = X̄ when ``x_basis`` is None, p = N).
    xy : ndarray of shape (p, q)
        X̃ᵀỸ.
    yy : ndarray of shape (q, q)
        ỸᵀỸ.
    x_basis : ndarray of shape (N, p) or None
        Orthonormal columns spanning the row space of X̄.
    y_basis : ndarray of shape (M, q) or None
    """

    n_samples: int
    x_mean: np.ndarray
    y_mean: np.ndarray
    xx: np.ndarray
    xy: np.ndarray
    yy: np.ndarray
    x_basis: np.ndarray | None = None
    y_basis: np.ndarray | None = None

    @property
    def x_ss(self) -> float:
        """Total sum of squares of X̄, ||X̄||_F² (invariant under the reduction)."""
        return float(np.trace(self.xx))

    @property
    def y_ss(self) -> float:
        """Total sum of squares of Ȳ."""
        return float(np.trace(self.yy))

    def x_full(self, v: np.ndarray) -> np.ndarray:
        """Map vectors (p, ...) from reduced X coordinates to node space (N, ...)."""
        return v if self.x_basis is None else self.x_basis @ v

    def y_full(self, v: np.ndarray) -> np.ndarray:
        """Map vectors (q, ...) from reduced Y coordinates to node space (M, ...)."""
        return v if self.y_basis is None else self.y_basis @ v


def compute_moments(X, Y) -> Moments:
    """Moments of X (K, N) and Y (K, M); numpy or dask arrays.

    Dask arrays that are tall (K > N) are reduced chunk-wise (out of core); wide ones are
    small in K and are brought into memory for the exact SVD reduction.
    """
    if isinstance(X, da.Array) or isinstance(Y, da.Array):
        X, Y = da.asarray(X), da.asarray(Y)
        if X.shape[0] > X.shape[1] or Y.shape[0] > Y.shape[1]:
            return _tall_moments(X, Y)
        X, Y = dask.compute(X, Y)
    X = np.asarray(X, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    check_finite(X, "inputs X")
    check_finite(Y, "outputs Y")
    x_mean, y_mean = X.mean(axis=0), Y.mean(axis=0)
    Xt, x_basis = _reduce(X - x_mean)
    Yt, y_basis = _reduce(Y - y_mean)
    return Moments(X.shape[0], x_mean, y_mean, Xt.T @ Xt, Xt.T @ Yt, Yt.T @ Yt, x_basis, y_basis)


def check_finite(A: np.ndarray, what: str) -> None:
    """Raise :class:`NonFiniteError` naming the offending rows of ``A``."""
    bad = ~np.isfinite(A)
    if bad.any():
        rows = np.flatnonzero(bad.reshape(A.shape[0], -1).any(axis=1))
        shown = ", ".join(map(str, rows[:5])) + (", ..." if len(rows) > 5 else "")
        raise NonFiniteError(
            f"{what} contain NaN or inf values in {len(rows)} of {A.shape[0]} "
            f"samples (rows {shown}); drop those experiments or fix the store"
        )


#: From this many rows on, a wide block is reduced through its Gram matrix
#: (:func:`_gram_reduce`) instead of its SVD: the same basis, 7x faster on 800 x 3400
#: (one BLAS thread; 2.3 s against 0.31 s), what a sensor study's thousands of noisy
#: draws need; small designs (the thesis' K = 7) keep the SVD.
GRAM_ROWS = 256


def _reduce(A: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Centred A (K, n) -> (Ã, basis) with A = Ã basisᵀ, exact; identity if tall."""
    if A.shape[0] > A.shape[1]:
        return A, None
    if A.shape[0] >= GRAM_ROWS:
        return _gram_reduce(A)
    U, s, Bt = np.linalg.svd(A, full_matrices=False)
    # Centring leaves rank <= K-1; directions at rounding level carry no data. An
    # all-constant block keeps one (zero) coordinate so that shapes stay valid.
    rank = int(np.sum(s > s[0] * max(A.shape) * np.finfo(float).eps))
    rank = max(rank, 1)
    return U[:, :rank] * s[:rank], Bt[:rank].T


def _gram_reduce(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_reduce` of a wide A (K, n) through A Aᵀ = U S² Uᵀ: Ã = U S, basis =
    Aᵀ U / S. Squaring halves the digits of the smallest directions, so those below
    1e-6 of the largest singular value (under 1e-12 of the sum of squares) are dropped
    where the SVD keeps everything above rounding; A = Ã basisᵀ to about 1e-10 of
    ||A||² (tests/analysis/test_analysis_moments.py)."""
    lam, U = np.linalg.eigh(A @ A.T)
    lam, U = lam[::-1], U[:, ::-1]  # largest first, as the SVD's
    top = max(float(lam[0]), 0.0)
    keep = max(int(np.sum(lam > top * 1e-12)), 1) if top > 0 else 1
    s = np.sqrt(np.clip(lam[:keep], 0.0, None))
    basis = (A.T @ U[:, :keep]) / np.where(s > 0, s, 1.0)
    return U[:, :keep] * s, basis


def _tall_moments(X: da.Array, Y: da.Array) -> Moments:
    """One chunk-wise pass: per-block shifted sums and cross-products, summed in a tree.

    Each block of experiments contributes Σxs, Σys, XsᵀXs, XsᵀYs, YsᵀYs with the data
    shifted by the first experiment; a pairwise tree adds the blocks, so only a few
    N x N partial sums are alive at a time. The shift avoids the cancellation of the
    textbook ΣxxT - K x̄x̄ᵀ when the mean is large against the spread (the shifted-data
    algorithm, Chan, Golub & LeVeque 1983); centring is exact afterwards.
    """
    K = X.shape[0]
    Y = Y.rechunk({0: X.chunks[0], 1: -1})
    X = X.rechunk({1: -1})
    x0, y0 = X[0], Y[0]
    blocks = zip(X.to_delayed().ravel(), Y.to_delayed().ravel(), strict=True)
    total = _tree_sum([dask.delayed(_block_stats)(xb, yb, x0, y0) for xb, yb in blocks])
    (sx, sy, xx, xy, yy, ok), x0, y0 = dask.compute(total, x0, y0)
    if not ok:
        raise NonFiniteError("inputs X or outputs Y contain NaN or inf values")
    mx, my = sx / K, sy / K
    xx = xx - K * np.outer(mx, mx)
    xy = xy - K * np.outer(mx, my)
    yy = yy - K * np.outer(my, my)
    if X.shape[0] <= X.shape[1] or Y.shape[0] <= Y.shape[1]:
        return _reduce_gram(K, x0 + mx, y0 + my, xx, xy, yy)
    return Moments(K, x0 + mx, y0 + my, xx, xy, yy)


def _block_stats(xb, yb, x0, y0) -> tuple:
    xs, ys = xb - x0, yb - y0
    finite = bool(np.isfinite(xs).all() and np.isfinite(ys).all())
    return xs.sum(0), ys.sum(0), xs.T @ xs, xs.T @ ys, ys.T @ ys, finite


def _tree_sum(parts: list):
    """Pairwise tree of :func:`_add_stats` over delayed block statistics."""
    while len(parts) > 1:
        paired = [
            dask.delayed(_add_stats)(a, b) for a, b in zip(parts[::2], parts[1::2], strict=False)
        ]
        parts = paired + parts[len(paired) * 2 :]
    return parts[0]


def _add_stats(a: tuple, b: tuple) -> tuple:
    """Sum two blocks' statistics into ``a``'s arrays (each partial feeds one sum only,
    and adding in place spares a 72 MB allocation per N = 3000 block)."""
    for u, v in zip(a[:5], b[:5], strict=True):
        np.add(u, v, out=u)
    return (*a[:5], a[5] and b[5])


def _reduce_gram(K, x_mean, y_mean, xx, xy, yy) -> Moments:
    """Reduce the wider side of Gram moments to its range (for mixed tall/wide data)."""

    def basis(g):
        lam, vec = np.linalg.eigh(g)
        keep = lam > max(lam.max(), 0.0) * g.shape[0] * np.finfo(float).eps
        keep[-1] = True  # eigh sorts ascending: always keep the largest
        return vec[:, keep]

    bx = basis(xx) if xx.shape[0] >= K else None
    by = basis(yy) if yy.shape[0] >= K else None
    xx_r = xx if bx is None else bx.T @ xx @ bx
    yy_r = yy if by is None else by.T @ yy @ by
    xy_r = xy if bx is None else bx.T @ xy
    xy_r = xy_r if by is None else xy_r @ by
    return Moments(K, x_mean, y_mean, xx_r, xy_r, yy_r, bx, by)
