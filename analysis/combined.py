"""Helpers of the combined-load analysis (issue 13): block scaling, latent counts, CV.

- :class:`BlockScaler` centres every column and divides each *block* of columns (one
  unit family: displacements in mm, strains in 1; or one force component) by one number,
  the block's total standard deviation, so that each block carries the same total
  variance. Per-column scaling would blow up the near-constant nodes far from the
  contact (and their measurement noise); per-block scaling keeps each block's shape.
- :func:`latent_count`: how many latent variables PCA finds in a field, by two rules.
- :class:`BlockRegression`: PLSR (SIMPLS) or PCR between block-scaled X and Y.
- :func:`cross_validate`: k-fold CV of the component count, with measurement noise
  added to the held-out inputs, and with ``train_noise`` to the training inputs too (a
  model trained on measurements sees noise in training as well; issue 25 reports an
  independent run with errors 1.5-2x larger that way, so the analysis reports both).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin, TransformerMixin
from sklearn.utils.validation import check_is_fitted

from analysis.errors import ComponentsError, ParameterError
from analysis.moments import compute_moments
from analysis.pcr import PCRegression
from analysis.pls import SIMPLSRegression
from analysis.selection import fit_at_most
from analysis.splits import folds as path_folds

METHODS = {"plsr": SIMPLSRegression, "pcr": PCRegression}
#: eigenvalues below this fraction of the largest count as zero (rounding)
RANK_RTOL = 1e-10


class BlockScaler(TransformerMixin, BaseEstimator):
    """Centre columns; divide each block of columns by its total standard deviation.

    Parameters
    ----------
    blocks : sequence of int, optional
        Column count of each block, in order; default one block of all columns.

    Attributes
    ----------
    mean_ : ndarray of shape (n_features,)
    scale_ : ndarray of shape (n_features,)
        The block's sqrt(sum of its column variances), repeated over its columns (1 for
        a constant block).
    """

    def __init__(self, blocks: Sequence[int] | None = None):
        self.blocks = blocks

    def fit(self, X, y=None):
        """Learn means and block scales from X of shape (K, n_features); returns self."""
        X = np.asarray(X, dtype=float)
        blocks = [X.shape[1]] if self.blocks is None else list(self.blocks)
        if sum(blocks) != X.shape[1] or min(blocks) < 1:
            raise ParameterError(
                f"blocks {blocks} must be positive and add up to the {X.shape[1]} columns of X"
            )
        self.mean_ = X.mean(axis=0)
        var = X.var(axis=0, ddof=1) if X.shape[0] > 1 else np.zeros(X.shape[1])
        edges = np.cumsum([0, *blocks])
        scale = np.empty(X.shape[1])
        for lo, hi in itertools.pairwise(edges):
            s = float(np.sqrt(var[lo:hi].sum()))
            scale[lo:hi] = s if s > 0 else 1.0
        self.scale_ = scale
        return self

    def transform(self, X):
        check_is_fitted(self)
        return (np.asarray(X, dtype=float) - self.mean_) / self.scale_

    def inverse_transform(self, X):
        check_is_fitted(self)
        return np.asarray(X, dtype=float) * self.scale_ + self.mean_


@dataclass(frozen=True)
class LatentCount:
    """What PCA of one field finds: its eigenvalues and three counts of latent variables.

    ``n_99`` / ``n_999``: fewest components explaining 99 % / 99.9 % of the variance.
    ``n_gap``: the eigenvalue-gap rule: the k with the largest ratio lambda_k /
    lambda_(k+1) of consecutive eigenvalues, where eigenvalues below :data:`RANK_RTOL` x
    lambda_1 count as zero (so an exactly rank-r field gives r); k < rank when the rank is
    the most K samples allow (K - 1), whose drop to zero says nothing about the field.
    """

    eigenvalues: np.ndarray
    n_99: int
    n_999: int
    n_gap: int
    gap_ratio: float


def latent_count(X) -> LatentCount:
    """PCA of X (K, n_features), centred: eigenvalues and the counts of :class:`LatentCount`."""
    X = np.asarray(X, dtype=float)
    Xc = X - X.mean(axis=0)
    lam = np.linalg.svd(Xc, compute_uv=False) ** 2
    if lam.size == 0 or lam[0] <= 0:
        return LatentCount(lam, 0, 0, 0, float("nan"))
    frac = np.cumsum(lam) / lam.sum()
    n99 = int(np.searchsorted(frac, 0.99 - 1e-12) + 1)
    n999 = int(np.searchsorted(frac, 0.999 - 1e-12) + 1)
    floor = RANK_RTOL * lam[0]
    rank = int(np.sum(lam > floor))
    # Eigenvalues beyond the rank are zero up to rounding; compared against the floor, an
    # exactly low-rank field's gap sits at its rank. But when the rank is the most the
    # samples allow (K - 1 after centring), that drop says nothing about the field: a
    # 8-experiment store would always report 7. Only k < rank are considered then.
    full = rank >= min(X.shape[0] - 1, X.shape[1])
    top = rank if full else min(rank + 1, lam.size)
    ratios = lam[: top - 1] / np.maximum(lam[1:top], floor)
    if ratios.size == 0:
        return LatentCount(lam, n99, n999, rank, float("nan"))
    k = int(np.argmax(ratios))
    return LatentCount(lam, n99, n999, k + 1, float(ratios[k]))


class BlockRegression(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """PLSR (SIMPLS) or PCR on block-scaled X and Y, predictions in Y's own units.

    Parameters
    ----------
    method : {"plsr", "pcr"}
    n_components : int
    x_blocks, y_blocks : sequence of int, optional
        Column blocks of X and Y for :class:`BlockScaler` (default one block each).

    Attributes
    ----------
    x_scaler_, y_scaler_ : BlockScaler
    model_ : SIMPLSRegression or PCRegression
    n_components_ : int
        Components actually used (fewer than asked when X̄ᵀȲ or X̄ is exhausted).
    """

    def __init__(self, method="plsr", n_components=2, x_blocks=None, y_blocks=None):
        self.method = method
        self.n_components = n_components
        self.x_blocks = x_blocks
        self.y_blocks = y_blocks

    def fit(self, X, Y):
        """Fit on X (K, n_features) and Y (K, n_targets); returns self."""
        if self.method not in METHODS:
            raise ParameterError(f"method must be one of {sorted(METHODS)}, got {self.method!r}")
        self.x_scaler_ = BlockScaler(self.x_blocks).fit(X)
        self.y_scaler_ = BlockScaler(self.y_blocks).fit(Y)
        moments = compute_moments(self.x_scaler_.transform(X), self.y_scaler_.transform(Y))
        self.model_ = fit_at_most(METHODS[self.method], moments, int(self.n_components))
        self.n_components_ = _n(self.model_)
        return self

    def predict(self, X):
        """Predictions of shape (K, n_targets), in Y's units."""
        check_is_fitted(self)
        return self.y_scaler_.inverse_transform(self.model_.predict(self.x_scaler_.transform(X)))


def add_noise(X: np.ndarray, sigma: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """X plus independent N(0, sigma_j^2) noise on column j (sigma of shape (n_features,))."""
    return X + rng.standard_normal(X.shape) * sigma


def cross_validate(
    X: np.ndarray,
    Y: np.ndarray,
    *,
    methods: Sequence[str] = ("plsr",),
    folds: int = 5,
    max_components: int = 15,
    sigmas: dict | None = None,
    draws: int = 1,
    seed: int = 0,
    x_blocks=None,
    y_blocks=None,
    train_noise: bool = False,
    groups: np.ndarray | None = None,
) -> dict[tuple[str, str], tuple[int, pd.DataFrame]]:
    """Component count with the least k-fold CV error, per method and noise scenario.

    Each fold is predicted by a :class:`BlockRegression` fitted on the other folds'
    noise-free data (with ``train_noise``: on ``draws`` noisy copies of them, the
    scenario's noise, as a model trained on measurements sees them), from its inputs
    plus ``draws`` draws of N(0, sigma²) noise (one
    sigma per column, per scenario of ``sigmas``; ``None`` or zeros: no noise). The
    error is the mean squared error in block-scaled Y units (each block of Y weighs the
    same: Fx counts as much as Fz), averaged over folds; a tie goes to the smaller
    count. Folds are shuffled by ``seed``; with ``groups`` ((K,) load path of each row,
    :func:`analysis.splits.path_groups`) a fold holds whole load paths (the states of
    one roll). One fit per fold and method serves every scenario, and (SIMPLS builds its
    components one after the other) every PLS count.

    Returns
    -------
    dict mapping (method, scenario) to (best count, table with columns n_components,
    mse_mean, mse_std, folds)
    """
    K = X.shape[0]
    sigmas = {"noise-free": None} if sigmas is None else sigmas
    if not 2 <= folds <= K:
        raise ParameterError(f"folds must be between 2 and the {K} training experiments, "
                             f"got {folds}")
    top = min(max_components, K - int(np.ceil(K / folds)) - 1)
    if top < 1:
        raise ComponentsError(f"{K} experiments in {folds} folds leave no room for one component")
    mse = {(m, sc): np.empty((folds, top)) for m in methods for sc in sigmas}
    # the states of one roll stay in one fold (issue 45); one experiment per group:
    # the shuffled KFold of before
    split = path_folds(np.arange(K) if groups is None else groups, folds, seed)
    for f, (train, test) in enumerate(split):
        clean = _fitted(X[train], Y[train], x_blocks, y_blocks)
        for k, (sc, sigma) in enumerate(sigmas.items()):
            noisy = sigma is not None and np.any(np.asarray(sigma) > 0)
            rng = np.random.default_rng([seed, f, k])
            xs, ys, moments = clean
            if noisy and train_noise:
                Xn = np.concatenate([add_noise(X[train], sigma, rng) for _ in range(draws)])
                xs, ys, moments = _fitted(Xn, np.concatenate([Y[train]] * draws),
                                          x_blocks, y_blocks)
            Xt = (np.concatenate([add_noise(X[test], sigma, rng) for _ in range(draws)])
                  if noisy else X[test])
            Xs, Ys = xs.transform(Xt), ys.transform(np.concatenate([Y[test]] * (
                draws if noisy else 1)))
            for m in methods:
                for a, pred in enumerate(_predictions(m, moments, top, Xs)):
                    mse[m, sc][f, a] = np.mean((pred - Ys) ** 2)
    out = {}
    for key, err in mse.items():
        table = pd.DataFrame({
            "n_components": np.arange(1, top + 1),
            "mse_mean": err.mean(0),
            "mse_std": err.std(0),
            "folds": folds,
        })
        out[key] = (int(table.loc[table["mse_mean"].idxmin(), "n_components"]), table)
    return out


def _fitted(X: np.ndarray, Y: np.ndarray, x_blocks, y_blocks):
    """Block scalers of ``X`` and ``Y`` and the moments of the scaled data."""
    xs, ys = BlockScaler(x_blocks).fit(X), BlockScaler(y_blocks).fit(Y)
    return xs, ys, compute_moments(xs.transform(X), ys.transform(Y))


def _predictions(method: str, moments, top: int, Xs: np.ndarray):
    """Predictions of Xs with 1..top components (an exhausted fit stops changing)."""
    if method == "plsr":
        fit = fit_at_most(SIMPLSRegression, moments, top)
        scores = (Xs - fit.x_mean_) @ fit.x_weights_
        pred = np.broadcast_to(fit.y_mean_, (Xs.shape[0], fit.y_mean_.size)).copy()
        for a in range(top):
            if a < fit.n_components:
                pred = pred + np.outer(scores[:, a], fit.y_loadings_[:, a])
            yield pred
        return
    model = None
    for a in range(1, top + 1):
        if model is None or _n(model) == a - 1:
            model = fit_at_most(METHODS[method], moments, a)
        yield model.predict(Xs)


def _n(model) -> int:
    return int(getattr(model, "n_components_", None) or model.n_components)
