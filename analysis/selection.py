"""Choosing the number of components by k-fold cross-validation.

The thesis (§5.2) names k-fold cross-validation as a data-driven regulariser but chose
its component counts by eye (3 modes, Figs. 5.5-5.10). This makes the choice explicit:
the count with the lowest mean squared prediction error over the held-out folds.
:func:`select_n_components` does it for any scikit-learn regressor on in-memory data;
:func:`cross_validate_simpls` for SIMPLS on the moments of each fold (numpy or dask).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.base import clone
from sklearn.model_selection import KFold, cross_val_score

from analysis.errors import ComponentsError, ParameterError
from analysis.moments import compute_moments
from analysis.pls import SIMPLSRegression


def select_n_components(
    estimator, X, y, *, max_components: int | None = None, cv: int = 5, seed: int | None = None
) -> tuple[int, pd.DataFrame]:
    """Cross-validated component count for a regressor with ``n_components``.

    Parameters
    ----------
    estimator : regressor with an ``n_components`` parameter (cloned, not modified)
    X : array of shape (K, N)
    y : array of shape (K,) or (K, M)
    max_components : int, optional
        Largest count tried; capped by the smallest training fold (K - ceil(K/cv) - 1).
    cv : int
        Number of folds (K-fold; ``cv = K`` is leave-one-out).
    seed : int, optional
        Shuffle the folds with this seed; ``None`` keeps the experiments' order.

    Returns
    -------
    best : int
    table : DataFrame with columns n_components, mse_mean, mse_std (one row per count)
    """
    X, y = np.asarray(X, dtype=float), np.asarray(y, dtype=float)
    K = X.shape[0]
    if not 2 <= cv <= K:
        raise ParameterError(f"cv must be between 2 and the number of experiments ({K}), got {cv}")
    cap = K - int(np.ceil(K / cv)) - 1  # rank limit of the smallest training fold
    top = cap if max_components is None else min(max_components, cap)
    if top < 1:
        raise ComponentsError(f"{K} experiments in {cv} folds leave no room for one component")
    folds = KFold(cv, shuffle=seed is not None, random_state=seed)
    rows = []
    for n in range(1, top + 1):
        model = clone(estimator).set_params(n_components=n)
        mse = -cross_val_score(model, X, y, cv=folds, scoring="neg_mean_squared_error")
        rows.append({"n_components": n, "mse_mean": mse.mean(), "mse_std": mse.std(ddof=0)})
    table = pd.DataFrame(rows)
    return int(table.loc[table["mse_mean"].idxmin(), "n_components"]), table


#: the default cross-validation is leave-one-out up to this many experiments, K-fold beyond
MAX_DEFAULT_FOLDS = 10


def default_folds(n_samples: int) -> int:
    """Folds of the default cross-validation: leave-one-out up to 10 experiments (the
    thesis' 7), 10-fold beyond (shuffled, see :func:`cross_validate_simpls`)."""
    return min(n_samples, MAX_DEFAULT_FOLDS)


def describe_cv(cv: int, n_samples: int) -> str:
    """The cross-validation in words, e.g. "leave-one-out cross-validation over 7 experiments"."""
    kind = "leave-one-out" if cv == n_samples else f"{cv}-fold"
    return f"{kind} cross-validation over {n_samples} experiments"


def _fold_mse(fit: SIMPLSRegression, X, Y, top: int) -> np.ndarray:
    """Mean squared error of a held-out fold's forces predicted with 1..``top``
    components of one fit, (top,): its first ``a`` components are the a-component fit."""
    Xt, Yt = np.asarray(X, dtype=float), np.asarray(Y, dtype=float)
    scores = (Xt - fit.x_mean_) @ fit.x_weights_
    pred = np.broadcast_to(fit.y_mean_, Yt.shape).copy()
    out = np.empty(top)
    for a in range(top):  # beyond an exhausted fit the prediction stops changing
        if a < fit.n_components:
            pred += np.outer(scores[:, a], fit.y_loadings_[:, a])
        out[a] = np.mean((pred - Yt) ** 2)
    return out


def cross_validate_simpls(
    X, Y, *, cv: int | None = None, max_components: int = 10, seed: int | None = 0
) -> tuple[int, pd.DataFrame]:
    """SIMPLS component count with the least held-out error of the tread forces.

    K-fold cross-validation over experiments: each fold's experiments are predicted by
    a SIMPLS model fitted to the others, and the count with the lowest mean squared
    error of the predicted forces (over the fold's experiments and all tread nodes,
    then averaged over folds, as scikit-learn's ``neg_mean_squared_error``) wins; a tie
    goes to the smaller count. Works on the moments of each training fold
    (:func:`~analysis.moments.compute_moments`), so numpy and dask arrays both work,
    and one fit per fold serves every count: SIMPLS builds its components one after
    the other, so the first ``a`` components of a fit are the ``a``-component fit.

    Parameters
    ----------
    X : array of shape (K, N)
    Y : array of shape (K, M)
    cv : int, optional
        Number of folds; default :func:`default_folds` (leave-one-out for K <= 10).
    max_components : int
        Largest count tried; also capped by the smallest training fold
        (K - ceil(K/cv) - 1) and by what X̄ᵀȲ supports in every fold.
    seed : int or None
        Shuffles the experiments before splitting them into folds (K-fold only: the
        experiments of a store are often ordered by load, and contiguous folds would
        test extrapolation); ``None`` keeps their order.

    Returns
    -------
    best : int
    table : DataFrame with columns n_components, mse_mean, mse_std, folds
    """
    K = X.shape[0]
    cv = default_folds(K) if cv is None else cv
    if not 2 <= cv <= K:
        raise ParameterError(f"cv must be between 2 and the number of experiments ({K}), got {cv}")
    top = min(max_components, K - int(np.ceil(K / cv)) - 1)
    if top < 1:
        raise ComponentsError(f"{K} experiments in {cv} folds leave no room for one component")
    folds = KFold(cv, shuffle=seed is not None and cv < K, random_state=seed if cv < K else None)
    mse = np.empty((cv, top))
    for f, (train, test) in enumerate(folds.split(np.zeros(K))):
        fit = fit_at_most(SIMPLSRegression, compute_moments(X[train], Y[train]), top)
        mse[f] = _fold_mse(fit, X[test], Y[test], top)
    table = pd.DataFrame({"n_components": np.arange(1, top + 1), "mse_mean": mse.mean(0),
                          "mse_std": mse.std(0, ddof=0), "folds": cv})
    return int(table.loc[table["mse_mean"].idxmin(), "n_components"]), table


def fit_at_most(cls, moments, n: int):
    """``cls(n)`` fitted on ``moments``, or with as many components as X̄ᵀȲ supports."""
    try:
        return cls(n).fit_moments(moments)
    except ComponentsError as exc:
        available = getattr(exc, "available", 0)
        if available < 1:
            raise
        return cls(available).fit_moments(moments)
