"""Choosing the number of components by k-fold cross-validation.

The thesis (§5.2) names k-fold cross-validation as a data-driven regulariser but chose
its component counts by eye (3 modes, Figs. 5.5-5.10). This makes the choice explicit:
the count with the lowest mean squared prediction error over the held-out folds.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from sklearn.base import clone
from sklearn.model_selection import KFold, cross_val_score

from analysis.errors import ComponentsError, ParameterError


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
