"""Input checks shared by the estimators (scikit-learn conventions, our error classes)."""

from __future__ import annotations

from numbers import Integral
from typing import TYPE_CHECKING

import dask.array as da
import numpy as np
from sklearn.utils.validation import validate_data

from analysis.errors import ComponentsError, ParameterError
from analysis.moments import Moments, check_finite, compute_moments


def check_xy(estimator, X, y):
    """Validate (X, y) for ``fit``; returns (X, Y as 2-D, y_was_1d).

    Dask arrays pass through untouched (they are reduced chunk-wise later); anything
    else goes through scikit-learn's ``validate_data`` after our own finiteness check,
    so that NaN/inf give a :class:`~analysis.errors.NonFiniteError`.
    """
    if isinstance(X, da.Array) or isinstance(y, da.Array):
        X, y = da.asarray(X), da.asarray(y)
        if X.ndim != 2 or y.ndim not in (1, 2) or X.shape[0] != y.shape[0]:
            raise ParameterError(f"X must be (K, N) and y (K,) or (K, M); got {X.shape}, {y.shape}")
        estimator.n_features_in_ = X.shape[1]
        return X, (y[:, None] if y.ndim == 1 else y), y.ndim == 1
    for arr, what in ((X, "inputs X"), (y, "outputs y")):
        if arr is None:
            continue  # validate_data says that y is required
        try:
            values = np.asarray(arr)
        except (TypeError, ValueError):
            continue
        if values.dtype.kind == "f" and values.ndim:  # other dtypes: validate_data explains
            check_finite(values, what)
    X, y = validate_data(
        estimator, X, y, multi_output=True, y_numeric=True, dtype=np.float64, ensure_min_samples=2
    )
    one_d = y.ndim == 1
    return X, (y[:, None] if one_d else y), one_d


def check_n_components(n_components, *, allow_none: bool, name: str = "n_components") -> None:
    """Type/range check of a component count parameter (validation happens in ``fit``)."""
    if n_components is None and allow_none:
        return
    if isinstance(n_components, bool) or not isinstance(n_components, Integral) or n_components < 1:
        raise ParameterError(f"{name} must be a positive integer, got {n_components!r}")


def too_many_components(asked: int, available: int, n_samples: int, why: str) -> ComponentsError:
    """The one-line error for asking more components than the data supports."""
    return ComponentsError(
        f"{asked} components asked but only {available} available: {why} "
        f"({n_samples} experiments support at most {n_samples - 1} after centring)",
        available,  # lets a caller asking for "all" fall back to the maximum
    )


class MomentsFitMixin:
    """``fit`` for the estimators that learn from centred sums of products.

    ``fit`` validates, reduces (X, y) to :class:`~analysis.moments.Moments` (chunk-wise for
    dask arrays) and hands them to the estimator's own ``fit_moments``.
    """

    _n_components_may_be_none = True

    if TYPE_CHECKING:  # what the estimator that mixes this in provides
        n_components: int | None

        def fit_moments(self, moments: Moments) -> object: ...

    def fit(self, X, y):
        """Fit on X of shape (K, N) and y of shape (K,) or (K, M); numpy or dask arrays.

        Returns
        -------
        self
        """
        check_n_components(self.n_components, allow_none=self._n_components_may_be_none)
        X, Y, one_d = check_xy(self, X, y)
        self.fit_moments(compute_moments(X, Y))
        self._predict_1d = one_d
        return self
