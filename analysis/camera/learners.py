"""Learners that map sensor features to tyre forces, compared side by side (issue 27).

- :class:`PLSCV`: the baseline. PLSR (SIMPLS) on block-scaled inputs and targets
  (:class:`analysis.combined.BlockRegression`) with the component count chosen by k-fold
  cross-validation on the training data only. Noisy copies of one experiment are one
  *group*: they never sit on both sides of a fold, or the CV would score a model on
  the very experiment it was trained on.
- :class:`GPOnScores`: PLSR plus a Gaussian process on its scores for the nonlinear
  rest (GP regression on reduced features, as in the strain-based force-estimation
  literature), its kernel chosen by grouped CV.

Both follow scikit-learn's conventions (parameters in ``__init__``, ``fit`` returns
self, learned attributes end in ``_``), so they can be persisted with skops and
wrapped by :mod:`analysis.camera.predict`.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.model_selection import GroupKFold, KFold
from sklearn.utils.validation import check_is_fitted

from analysis.combined import BlockRegression
from analysis.errors import ComponentsError, ParameterError


class PLSCV(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """PLSR on block-scaled X and Y, the component count chosen by k-fold CV.

    Parameters
    ----------
    max_components : int, default=10
        Largest count tried (fewer when the folds leave fewer experiments).
    folds : int, default=5
    x_blocks, y_blocks : sequence of int, optional
        Column blocks of X and Y (:class:`analysis.combined.BlockScaler`).
    seed : int, default=0
        Shuffles the folds when no groups are given.

    Attributes
    ----------
    n_components_ : int
        The count with the least CV error (block-scaled mean squared error of Y; a tie
        goes to the smaller count).
    cv_table_ : dict of ndarray of shape (n_counts,)
        ``n_components``, ``mse_mean``, ``mse_std`` over the folds.
    model_ : BlockRegression
        Refitted on all of X with ``n_components_``.
    """

    def __init__(self, max_components=10, folds=5, x_blocks=None, y_blocks=None, seed=0):
        self.max_components = max_components
        self.folds = folds
        self.x_blocks = x_blocks
        self.y_blocks = y_blocks
        self.seed = seed

    def fit(self, X, Y, groups=None):
        """Fit on X (K, n_features), Y (K, n_targets); ``groups`` (K,) keeps the noisy
        draws of one experiment in one fold. Returns self."""
        X, Y = np.asarray(X, dtype=float), np.asarray(Y, dtype=float)
        splits = self._splits(X.shape[0], groups)
        smallest = min(len(train) for train, _ in splits)
        top = min(int(self.max_components), smallest - 1)
        if top < 1:
            raise ComponentsError(f"{X.shape[0]} rows in {self.folds} folds leave no room "
                                  "for one PLS component: give more experiments")
        err = np.empty((len(splits), top))
        for f, (train, test) in enumerate(splits):
            err[f] = _fold_errors(X[train], Y[train], X[test], Y[test], top,
                                  self.x_blocks, self.y_blocks)
        mean = err.mean(axis=0)
        # plain arrays, not a DataFrame: a fitted model is saved with skops
        self.cv_table_ = {"n_components": np.arange(1, top + 1), "mse_mean": mean,
                          "mse_std": err.std(axis=0)}
        self.n_components_ = int(np.argmin(mean) + 1)
        self.model_ = BlockRegression("plsr", self.n_components_, self.x_blocks,
                                      self.y_blocks).fit(X, Y)
        self.n_components_ = self.model_.n_components_
        return self

    def _splits(self, n: int, groups) -> list[tuple[np.ndarray, np.ndarray]]:
        dummy = np.zeros(n)
        if groups is not None:
            k = len(np.unique(groups))
            if not 2 <= self.folds <= k:
                raise ParameterError(f"folds must be between 2 and the {k} training "
                                     f"experiments, got {self.folds}")
            return list(GroupKFold(self.folds).split(dummy, groups=groups))
        if not 2 <= self.folds <= n:
            raise ParameterError(f"folds must be between 2 and the {n} training rows, "
                                 f"got {self.folds}")
        return list(KFold(self.folds, shuffle=True, random_state=self.seed).split(dummy))

    def predict(self, X):
        """Predictions (K, n_targets) in Y's units."""
        check_is_fitted(self)
        return self.model_.predict(X)

    def transform(self, X):
        """PLS scores (K, n_components_) of block-scaled X."""
        check_is_fitted(self)
        return self.model_.model_.transform(self.model_.x_scaler_.transform(X))


def _fold_errors(Xf, Yf, Xt, Yt, top: int, x_blocks, y_blocks) -> np.ndarray:
    """Block-scaled MSE of the held-out rows for 1..top components (one SIMPLS fit:
    its components are built one after the other)."""
    fit = BlockRegression("plsr", top, x_blocks, y_blocks).fit(Xf, Yf)
    pls = fit.model_
    scores = pls.transform(fit.x_scaler_.transform(Xt))
    target = fit.y_scaler_.transform(Yt)
    pred = np.broadcast_to(pls.y_mean_, target.shape).copy()
    out = np.empty(top)
    for a in range(top):
        if a < fit.n_components_:
            pred += np.outer(scores[:, a], pls.y_loadings_[:, a])
        out[a] = np.mean((pred - target) ** 2)
    return out


class GPOnScores(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """PLSR plus a Gaussian process on its scores for what the linear model misses.

    The GP models the PLSR's residuals (block-scaled) as a function of the PLS scores
    (each scaled to unit variance), so it can only add the nonlinear part. Its kernel -
    an isotropic RBF plus white noise, on normalised residuals - is chosen from
    :data:`GP_GRID` by grouped k-fold CV, not by the marginal likelihood: noisy draws of
    one experiment share their target, and the likelihood reads them as independent
    evidence. It then picks short length scales and almost no noise, interpolates the
    training draws and loses to the plain PLSR on held-out experiments (measured on
    examples/sensor_window.toml at 0.5 mm noise: Fz 7.0 % vs 1.8 % of range). When no
    kernel beats "no correction" in CV, the model is the PLSR alone (``gp_`` is None).

    Parameters
    ----------
    max_components, folds, x_blocks, y_blocks, seed
        As :class:`PLSCV`, which chooses the scores.

    Attributes
    ----------
    pls_ : PLSCV
    score_scale_ : ndarray of shape (n_components_,)
        Standard deviation of each training score.
    kernel_ : tuple of (float, float) or None
        The chosen (length scale, noise level), None when the GP did not help.
    cv_mse_ : ndarray of shape (1 + len(GP_GRID),)
        Grouped-CV mean squared residual: without correction, then per kernel of
        :data:`GP_GRID`.
    gp_ : sklearn.gaussian_process.GaussianProcessRegressor or None
    """

    def __init__(self, max_components=10, folds=5, x_blocks=None, y_blocks=None, seed=0):
        self.max_components = max_components
        self.folds = folds
        self.x_blocks = x_blocks
        self.y_blocks = y_blocks
        self.seed = seed

    def fit(self, X, Y, groups=None):
        """Fit on X (K, n_features), Y (K, n_targets); returns self."""
        X = np.asarray(X, dtype=float)
        self.pls_ = PLSCV(self.max_components, self.folds, self.x_blocks, self.y_blocks,
                          self.seed).fit(X, Y, groups)
        T = self.pls_.transform(X)
        scale = T.std(axis=0)
        self.score_scale_ = np.where(scale > 0, scale, 1.0)
        T = T / self.score_scale_
        R = self._scaled(Y) - self._scaled(self.pls_.predict(X))
        splits = self.pls_._splits(X.shape[0], groups)
        # row 0: no correction; row i: GP_GRID[i - 1] (arrays, so skops can save them)
        mse = [np.mean([np.mean(R[te] ** 2) for _, te in splits])]
        for kernel in GP_GRID:
            mse.append(np.mean([
                np.mean((_gp(kernel).fit(T[tr], R[tr]).predict(T[te]).reshape(R[te].shape)
                         - R[te]) ** 2) for tr, te in splits]))
        self.cv_mse_ = np.asarray(mse)
        best = int(np.argmin(self.cv_mse_))
        self.kernel_ = None if best == 0 else GP_GRID[best - 1]
        self.gp_ = None if self.kernel_ is None else _gp(self.kernel_).fit(T, R)
        self.n_components_ = T.shape[1]
        return self

    def _scaled(self, Y):
        return self.pls_.model_.y_scaler_.transform(np.asarray(Y, dtype=float))

    def predict(self, X):
        """Predictions (K, n_targets) in Y's units."""
        check_is_fitted(self)
        linear = self.pls_.predict(X)
        if self.gp_ is None:
            return linear
        T = self.pls_.transform(X) / self.score_scale_
        correction = np.asarray(self.gp_.predict(T)).reshape(linear.shape)
        return self.pls_.model_.y_scaler_.inverse_transform(self._scaled(linear)
                                                            + correction)


#: (length scale in unit-variance scores, white-noise level of normalised residuals)
GP_GRID = tuple((length, noise) for length in (0.5, 1.0, 2.0, 4.0)
                for noise in (0.01, 0.03, 0.1, 0.3, 1.0, 3.0))


def _gp(kernel: tuple[float, float]) -> GaussianProcessRegressor:
    """A GP with the fixed kernel ``C(1) * RBF(length) + White(noise)`` on normalised
    targets (no optimiser: the grid and the grouped CV choose)."""
    length, noise = kernel
    k = (ConstantKernel(1.0, "fixed") * RBF(length, "fixed")
         + WhiteKernel(noise, "fixed"))
    return GaussianProcessRegressor(k, normalize_y=True, optimizer=None)


#: learner name -> class (the CLI's ``--learners``)
LEARNERS = {"plsr": PLSCV, "gp": GPOnScores}


def learner(name: str, **params):
    """A learner by name; unknown names raise :class:`ParameterError` listing the known."""
    if name not in LEARNERS:
        raise ParameterError(f"unknown learner {name!r}; known: {', '.join(LEARNERS)}")
    return LEARNERS[name](**params)
