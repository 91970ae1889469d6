"""Principal component regression as in thesis section 5.4 (eqs. 5.3-5.7).

Input and output are each projected on their r* leading eigenvectors (of K_X = X̄ᵀX̄,
eq. 5.3, and K_Y = ȲᵀȲ, eq. 5.4), giving scores Z_X = X̄u_X (5.5) and Z_Y = Ȳu_Y (5.6);
a linear map α between the scores (5.7) is fitted by least squares. Prediction:
ŷ = ȳ + ((x - x̄) u_X α) u_Yᵀ, i.e. the coefficient matrix is u_X α u_Yᵀ.

The eigenvectors come from the reduced moments (thin SVD of the K x N centred data for
wide data), so K_X (N x N) is never formed for the thesis-sized case.
"""

from __future__ import annotations

import warnings

import numpy as np
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from analysis._base import MomentsFitMixin, check_n_components, too_many_components
from analysis.errors import UndefinedVarianceWarning
from analysis.moments import Moments


class PCRegression(MomentsFitMixin, MultiOutputMixin, RegressorMixin, BaseEstimator):
    """PCR with r* input and output modes (thesis §5.4).

    Parameters
    ----------
    n_components : int or None, default=None
        r*, the number of input modes, and of output modes as far as rank Ȳ allows
        (a single response has one); ``None`` uses all modes of X̄ and of Ȳ, which
        makes PCR the minimum-norm least-squares fit.

    Attributes
    ----------
    x_components_ : ndarray of shape (n_features, n_components_)
        u_X*, leading eigenvectors of X̄ᵀX̄.
    y_components_ : ndarray of shape (n_targets, r_y)
        u_Y*, leading eigenvectors of ȲᵀȲ; r_y = min(n_components_, rank Ȳ), or
        rank Ȳ when ``n_components`` is None.
    alpha_ : ndarray of shape (n_components_, r_y)
        Least-squares map between scores, Z_Y ≈ Z_X α_ (eq. 5.7, row-vector form).
    x_explained_variance_ratio_ : ndarray of shape (rank X̄,)
        Eigenvalues of X̄ᵀX̄ over their sum, all modes.
    y_explained_variance_ratio_ : ndarray of shape (rank Ȳ,)
        Eigenvalues of ȲᵀȲ over their sum, all modes: "percent of variance in the
        output explained by each mode" (Fig. 5.7).

        Data without variance (the same X, or Y, in every experiment) have one mode of
        eigenvalue 0 and an undefined fraction 0/0: it is NaN, with an
        :class:`~analysis.errors.UndefinedVarianceWarning`, as scikit-learn's PCA
        reports it, never 100 %. The fit itself stays defined: constant outputs are
        predicted as their mean, and constant inputs give a zero ``coef_``. The
        ``farm analyse`` studies refuse such outputs with a
        :class:`~analysis.errors.NoVarianceError` instead.
    coef_ : ndarray of shape (n_targets, n_features)
        Linear model, ``y = X @ coef_.T + intercept_``.
    intercept_ : ndarray of shape (n_targets,)
    x_mean_, y_mean_ : ndarrays of shape (n_features,), (n_targets,)
    n_components_ : int
    n_features_in_ : int
    """

    def __init__(self, n_components=None):
        self.n_components = n_components

    def fit_moments(self, moments: Moments):
        """Fit from precomputed :class:`~analysis.moments.Moments`.

        Returns
        -------
        self : PCRegression
        """
        check_n_components(self.n_components, allow_none=True)
        lam_x, ex = _eig_desc(moments.xx)
        lam_y, ey = _eig_desc(moments.yy)
        r = lam_x.size if self.n_components is None else self.n_components
        if r > lam_x.size:
            raise too_many_components(r, lam_x.size, moments.n_samples, "rank of X̄")
        # r* modes on both sides (thesis); Ȳ may have fewer (one response: rank 1).
        # "All modes" means all on both sides, which makes PCR least squares.
        ry = lam_y.size if self.n_components is None else min(r, lam_y.size)
        ex, ey = ex[:, :r], ey[:, :ry]
        # Z_XᵀZ_X = diag(λ_x): the normal equations of (5.7) are diagonal.
        lam_r = lam_x[:r, None]
        self.alpha_ = np.divide(
            ex.T @ moments.xy @ ey, lam_r, out=np.zeros((r, ey.shape[1])), where=lam_r > 0
        )
        self.x_components_ = moments.x_full(ex)
        self.y_components_ = moments.y_full(ey)
        self.x_explained_variance_ratio_ = _ratios(lam_x, "inputs")
        self.y_explained_variance_ratio_ = _ratios(lam_y, "outputs")
        self.n_components_ = r
        self.x_mean_, self.y_mean_ = moments.x_mean, moments.y_mean
        self.coef_ = (self.x_components_ @ self.alpha_ @ self.y_components_.T).T
        self.intercept_ = self.y_mean_ - self.x_mean_ @ self.coef_.T
        self.n_features_in_ = moments.x_mean.shape[0]
        self._predict_1d = False
        return self

    def linear_factors(self) -> tuple[np.ndarray, np.ndarray]:
        """(L, R) with ``coef_.T == L @ R``: L (n_features, r), R (r, n_targets)."""
        check_is_fitted(self)
        return self.x_components_ @ self.alpha_, self.y_components_.T

    def predict(self, X):
        """Predicted forces, shape (K,) or (K, M)."""
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        L, R = self.linear_factors()
        Y = ((X - self.x_mean_) @ L) @ R + self.y_mean_
        return Y.ravel() if self._predict_1d else Y


def _eig_desc(gram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Non-trivial eigenpairs of a symmetric PSD matrix, eigenvalues descending.

    Data without variance (gram == 0) keeps one mode with its true eigenvalue 0, so
    that shapes stay valid; the callers divide by eigenvalues only where they are > 0.
    """
    lam, vec = np.linalg.eigh(gram)
    lam, vec = np.clip(lam[::-1], 0.0, None), vec[:, ::-1]
    keep = lam > lam[0] * gram.shape[0] * np.finfo(float).eps
    keep[0] = True
    return lam[keep], vec[:, keep]


def _ratios(lam: np.ndarray, what: str) -> np.ndarray:
    """Eigenvalues over their sum; NaN (and a warning) when there is no variance at all."""
    total = lam.sum()
    if total > 0:
        return lam / total
    warnings.warn(
        f"the {what} have no variance: the fraction of variance explained is 0/0, reported as NaN",
        UndefinedVarianceWarning,
        stacklevel=3,
    )
    return np.full(lam.shape, np.nan)
