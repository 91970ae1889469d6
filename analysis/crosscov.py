"""PCA of the cross-covariance between inner-surface measurements and tread forces.

Thesis section 5.3: T = X̄ᵀȲ (eq. 5.1) and its SVD T = W Σ Vᵀ (eq. 5.2). Columns of W
are the "eigen-deformations"/"eigen-strains" (where on the inner surface a direction
informs about the forces), columns of V the "eigen-forces", Σ ranks the modes.

T is N x M (about 1000 x 400) but of rank <= K-1 (6 in the thesis): with the reduced
moments of :mod:`analysis.moments` the SVD is that of a (K-1) x (K-1) core matrix,
mapped back to node space with orthonormal bases. This is exact, not an approximation.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, ClassNamePrefixFeaturesOutMixin, TransformerMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from analysis._base import MomentsFitMixin, check_n_components, too_many_components
from analysis.data import family
from analysis.moments import Moments


class CrossCovariancePCA(
    MomentsFitMixin, ClassNamePrefixFeaturesOutMixin, TransformerMixin, BaseEstimator
):
    """SVD of the cross-covariance T = X̄ᵀȲ (thesis eqs. 5.1-5.2).

    Parameters
    ----------
    n_components : int or None, default=None
        Number of singular triplets to keep; ``None`` keeps all non-trivial ones,
        ``min(rank X̄, rank Ȳ)``.

    Attributes
    ----------
    singular_values_ : ndarray of shape (n_components_,)
        Σ, descending.
    x_components_ : ndarray of shape (n_features, n_components_)
        W, orthonormal columns ("eigen-deformations" / "eigen-strains").
    y_components_ : ndarray of shape (n_targets, n_components_)
        V, orthonormal columns ("eigen-forces"), each oriented so that its sum is
        non-negative (mode k raises the total force), which fixes the SVD's sign.
    n_components_ : int
    x_mean_ : ndarray of shape (n_features,)
    y_mean_ : ndarray of shape (n_targets,)
    n_features_in_ : int
    """

    def __init__(self, n_components=None):
        self.n_components = n_components

    def fit_moments(self, moments: Moments):
        """Fit from precomputed :class:`~analysis.moments.Moments` (out-of-core entry).

        Returns
        -------
        self : CrossCovariancePCA
        """
        check_n_components(self.n_components, allow_none=True)
        A, s, Bt = np.linalg.svd(moments.xy, full_matrices=False)
        rank = int(np.sum(s > s[0] * max(moments.xy.shape) * np.finfo(float).eps))
        # T == 0 (a direction without signal) still reports one mode with σ = 0.
        available = max(rank, 1)
        n = available if self.n_components is None else self.n_components
        if n > available:
            raise too_many_components(n, available, moments.n_samples, "rank of X̄ᵀȲ")
        W, V = moments.x_full(A[:, :n]), moments.y_full(Bt[:n].T)
        sign = _orientation(V)
        self.singular_values_ = s[:n]
        self.x_components_, self.y_components_ = W * sign, V * sign
        self.n_components_ = self._n_features_out = n
        self.x_mean_, self.y_mean_ = moments.x_mean, moments.y_mean
        self.n_features_in_ = moments.x_mean.shape[0]
        return self

    def transform(self, X):
        """Scores X̄W, shape (K, n_components_)."""
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return (X - self.x_mean_) @ self.x_components_


def _orientation(V: np.ndarray) -> np.ndarray:
    """Signs (+1/-1 per column) making each eigen-force push the road harder.

    Column sums decide; a column summing to ~0 (e.g. an antisymmetric pitch mode) is
    oriented by its largest-magnitude entry instead, so the result is deterministic.
    """
    sums = V.sum(axis=0)
    peak = V[np.argmax(np.abs(V), axis=0), np.arange(V.shape[1])]
    tiny = np.abs(sums) < 1e-8 * np.sqrt(V.shape[0])
    key = np.where(tiny, peak, sums)
    return np.where(key < 0, -1.0, 1.0)


def direction_importance(first_singular_values: Mapping[str, float]) -> pd.DataFrame:
    """Importance of each direction: its σ₁ over the strongest σ₁ of its unit family.

    Thesis Figs. 5.1-5.4 normalise each direction to the strongest direction (Uz among
    displacements, exx among strains). Displacements (mm) and strains (1) have different
    units, so comparing σ₁ across families would be meaningless; each family is
    normalised on its own.

    Returns
    -------
    DataFrame with columns direction, family, sigma1, importance, rank (1 = strongest).
    """
    frame = pd.DataFrame(
        {
            "direction": list(first_singular_values),
            "family": [family(d) for d in first_singular_values],
            "sigma1": [float(v) for v in first_singular_values.values()],
        }
    )
    best = frame.groupby("family")["sigma1"].transform("max")
    frame["importance"] = np.where(best > 0, frame["sigma1"] / best.where(best > 0, 1.0), 0.0)
    frame["rank"] = frame.groupby("family")["sigma1"].rank(ascending=False, method="first")
    return frame.astype({"rank": int})
