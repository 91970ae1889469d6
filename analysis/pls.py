"""PLS regression by SIMPLS (de Jong 1993), as MATLAB's ``plsregress`` (thesis §5.5).

SIMPLS finds, one component at a time, the weight r maximising the covariance of the
score t = X̄r with Ȳ, subject to t being orthogonal to the earlier scores; it deflates
the cross-covariance S = X̄ᵀȲ by projecting out the span of the X loadings. Everything
runs on the moments (X̄ᵀX̄, X̄ᵀȲ), so in the reduced coordinates of
:mod:`analysis.moments` a thesis-sized fit is a handful of 6 x 6 SVDs.

Conventions follow ``plsregress``: scores have unit norm, weights are scaled so that
t = X̄ r, y loadings q = Ȳᵀt, coefficients B = R Qᵀ, and PCTVAR is the fraction of the
total sum of squares of X̄ (Ȳ) captured by each component: ||p_a||² / ||X̄||_F²
(||q_a||² / ||Ȳ||_F²). scikit-learn's NIPALS ``PLSRegression(scale=False)`` is the
same model for a single response and close to it for several.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import (
    BaseEstimator,
    ClassNamePrefixFeaturesOutMixin,
    MultiOutputMixin,
    RegressorMixin,
    TransformerMixin,
)
from sklearn.utils.validation import check_is_fitted, validate_data

from analysis._base import MomentsFitMixin, check_n_components, too_many_components
from analysis.moments import Moments


def simpls(xx: np.ndarray, xy: np.ndarray, n_components: int, n_samples: int) -> dict:
    """SIMPLS on moments. ``xx`` (p, p) = X̄ᵀX̄, ``xy`` (p, q) = X̄ᵀȲ.

    Returns
    -------
    dict with ``weights`` R (p, A), ``x_loadings`` P (p, A), ``y_loadings`` Q (q, A).
    """
    p, q = xy.shape
    R, P, V = np.zeros((p, n_components)), np.zeros((p, n_components)), np.zeros((p, n_components))
    Q = np.zeros((q, n_components))
    S = xy.copy()
    s_first = None
    for a in range(n_components):
        u, s, vt = np.linalg.svd(S, full_matrices=False)
        s_first = s[0] if s_first is None else s_first
        # Deflated S ~ 0: the scores already span everything X̄ says about Ȳ.
        if s[0] <= s_first * max(p, q) * np.finfo(float).eps * 10 or s_first == 0:
            raise too_many_components(n_components, a, n_samples, "X̄ᵀȲ is exhausted")
        r = u[:, 0]
        t_norm = np.sqrt(r @ xx @ r)
        R[:, a] = r / t_norm
        P[:, a] = xx @ R[:, a]  # = X̄ᵀt with t = X̄r / ||X̄r||
        Q[:, a] = s[0] * vt[0] / t_norm  # = Ȳᵀt
        v = _orthogonalise(P[:, a], V[:, :a])
        V[:, a] = v
        # Project S on the orthocomplement of the loadings; the second pass removes
        # what rounding let back in along earlier basis vectors (as plsregress does).
        S -= np.outer(v, v @ S)
        S -= V[:, : a + 1] @ (V[:, : a + 1].T @ S)
    return {"weights": R, "x_loadings": P, "y_loadings": Q}


def _orthogonalise(v: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """Unit vector of v minus its projection on orthonormal ``basis`` (MGS, twice)."""
    for _ in range(2):
        for j in range(basis.shape[1]):
            v = v - (basis[:, j] @ v) * basis[:, j]
    return v / np.linalg.norm(v)


class SIMPLSRegression(
    MomentsFitMixin,
    ClassNamePrefixFeaturesOutMixin,
    TransformerMixin,
    RegressorMixin,
    MultiOutputMixin,
    BaseEstimator,
):
    """PLS regression by SIMPLS, numerically like MATLAB ``plsregress`` (no scaling).

    Parameters
    ----------
    n_components : int, default=2
        Number of PLS components A; at most min(K-1, N) and the rank of X̄ᵀȲ allows.

    Attributes
    ----------
    x_weights_ : ndarray of shape (n_features, n_components)
        R, with X̄ R = T the orthonormal scores (``stats.W`` of plsregress).
    x_loadings_ : ndarray of shape (n_features, n_components)
        P = X̄ᵀT (XL of plsregress).
    y_loadings_ : ndarray of shape (n_targets, n_components)
        Q = ȲᵀT (YL of plsregress).
    pctvar_ : ndarray of shape (2, n_components)
        Fraction of the sum of squares of X̄ (row 0) and Ȳ (row 1) explained by each
        component (PCTVAR of plsregress, a fraction despite its name).
    coef_ : ndarray of shape (n_targets, n_features)
        ``y = X @ coef_.T + intercept_``; coef_.T = R Qᵀ (BETA of plsregress).
    intercept_ : ndarray of shape (n_targets,)
    x_mean_, y_mean_ : ndarrays of shape (n_features,), (n_targets,)
    n_features_in_ : int
    """

    _n_components_may_be_none = False
    n_components: int  # never None here (the mixin's may be)

    def __init__(self, n_components=2):
        self.n_components = n_components

    def fit_moments(self, moments: Moments):
        """Fit from precomputed :class:`~analysis.moments.Moments`.

        Returns
        -------
        self : SIMPLSRegression
        """
        check_n_components(self.n_components, allow_none=False)
        A, K = self.n_components, moments.n_samples
        limit = min(K - 1, moments.x_mean.shape[0])
        if limit < A:
            raise too_many_components(A, limit, K, "min(K-1, n_features)")
        fit = simpls(moments.xx, moments.xy, A, K)
        R, P = moments.x_full(fit["weights"]), moments.x_full(fit["x_loadings"])
        Q = moments.y_full(fit["y_loadings"])
        sign = np.where(Q.sum(axis=0) < 0, -1.0, 1.0)  # deterministic SVD sign
        self.x_weights_, self.x_loadings_, self.y_loadings_ = R * sign, P * sign, Q * sign
        # plsregress: PCTVAR = [sum(XL.^2) / ||X0||²; sum(YL.^2) / ||Y0||²]
        x_var = (fit["x_loadings"] ** 2).sum(0) / moments.x_ss
        self.pctvar_ = np.vstack([x_var, (fit["y_loadings"] ** 2).sum(0) / moments.y_ss])
        self.x_mean_, self.y_mean_ = moments.x_mean, moments.y_mean
        self.coef_ = (self.x_weights_ @ self.y_loadings_.T).T
        self.intercept_ = self.y_mean_ - self.x_mean_ @ self.coef_.T
        self.n_features_in_ = moments.x_mean.shape[0]
        self._n_features_out = A  # transform() gives A scores (get_feature_names_out)
        self._predict_1d = False
        return self

    def linear_factors(self) -> tuple[np.ndarray, np.ndarray]:
        """(L, R) with ``coef_.T == L @ R``: the weights (N, A) and Qᵀ (A, M)."""
        check_is_fitted(self)
        return self.x_weights_, self.y_loadings_.T

    def transform(self, X):
        """Scores T = (X - x̄) R, shape (K, n_components); orthonormal on the training X."""
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return (X - self.x_mean_) @ self.x_weights_

    def predict(self, X):
        """Predicted forces, shape (K,) or (K, M)."""
        Y = self.transform(X) @ self.y_loadings_.T + self.y_mean_
        return Y.ravel() if self._predict_1d else Y


def pctvar_from_scores(scores: np.ndarray, X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """PCTVAR for any PLS fit with mutually orthogonal scores (SIMPLS or NIPALS).

    For orthogonal scores t_a, component a explains ||t̂_aᵀX̄||² of ||X̄||_F² (t̂ the unit
    score) -- what plsregress computes from its loadings, but valid for scikit-learn's
    ``PLSRegression`` too, which does not expose it.

    Parameters
    ----------
    scores : ndarray of shape (K, A)
    X : ndarray of shape (K, N)
    Y : ndarray of shape (K, M) or (K,)

    Returns
    -------
    ndarray of shape (2, A): fractions for X (row 0) and Y (row 1).
    """
    T = scores / np.linalg.norm(scores, axis=0)
    Xc = X - X.mean(axis=0)
    Yc = np.reshape(Y, (Y.shape[0], -1)) - np.reshape(Y, (Y.shape[0], -1)).mean(axis=0)
    return np.vstack(
        [((T.T @ Xc) ** 2).sum(1) / (Xc**2).sum(), ((T.T @ Yc) ** 2).sum(1) / (Yc**2).sum()]
    )
