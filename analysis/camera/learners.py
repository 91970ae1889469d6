"""Learners that map sensor features to tyre forces, compared side by side (issue 27).

- :class:`PLSCV`: the baseline. PLSR (SIMPLS) on block-scaled inputs and targets
  (:class:`analysis.combined.BlockRegression`) with the component count chosen by k-fold
  cross-validation on the training data only. Noisy copies of one experiment are one
  *group*: they never sit on both sides of a fold, or the CV would score a model on
  the very experiment it was trained on.
- :class:`GPOnScores`: PLSR plus a Gaussian process on its scores for the nonlinear
  rest (GP regression on reduced features, as in the strain-based force-estimation
  literature), its kernel chosen by grouped CV.
- :class:`KRROnScores` (issue 46): PLSR plus scikit-learn's kernel ridge regression (RBF)
  on its scores, the kernel *and how many scores it reads* chosen by grouped CV.
- :class:`AutoLearner` (``"auto"``, issue 46): one outer grouped CV over the learners
  above on the training data, then the one with the least CV error refitted.

All follow scikit-learn's conventions (parameters in ``__init__``, ``fit`` returns
self, learned attributes end in ``_``), so they can be persisted with skops and
wrapped by :mod:`analysis.camera.predict`.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.kernel_ridge import KernelRidge
from sklearn.model_selection import GroupKFold, KFold
from sklearn.utils.validation import check_is_fitted

from analysis.combined import BlockRegression, BlockScaler
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
        self.score_scale_ = unit_scale(T)
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


class KRROnScores(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """PLSR plus kernel ridge regression (RBF) on its scores for what the linear model misses.

    Like :class:`GPOnScores`, the kernel ridge models the PLSR's block-scaled residuals as
    a function of the PLS scores (each scaled to unit variance), and the grouped k-fold CV
    of the training data chooses among "no correction" and :data:`KRR_GRID`. Unlike it,
    the CV also chooses *how many scores* the correction reads: the PLSR's own count, or
    every component the folds allow (up to ``max_components``). A target the PLSR cannot
    follow at all (``y = x0**2`` of a symmetric ``x0``) has no linear covariance with X,
    so the CV-chosen count may leave its direction out of the scores; the GP, which reads
    only those, then falls back to the PLSR, and this learner does not. Each fold refits
    the PLS, so no fold scores a correction on scores its own test rows shaped. When no
    setting beats "no correction" by more than one standard error of its per-fold gain
    (the one-standard-error rule: on linear data the best setting's gain is noise, a
    fraction of a percent), the model is the PLSR alone (``krr_`` is None) and predicts
    exactly as :class:`PLSCV`.

    Why kernel ridge: residual learners on the scores (extra trees, gradient boosting, an
    MLP), each with a small grid chosen by this grouped CV, were compared with it on
    held-out experiments of five small synthetic problems (docs/sensor.md, "The
    learners", and ``benchmarks/bench_learners.py``, where the figures are); kernel
    ridge was the best or close to it on most targets and the fastest. Trees have a
    second cost: skops does not trust ``sklearn.tree._tree.Tree`` (scikit-learn indexes
    its node arrays without bounds checks, so a crafted model file could read memory out
    of bounds on predict), and trusting it would break what
    :mod:`analysis.camera.predict.persist` promises; KernelRidge is one of skops' trusted
    estimators. Kernel ridge with an RBF kernel is the GP's posterior mean; what it adds
    over :class:`GPOnScores` is the choice of scores.

    Parameters
    ----------
    max_components, folds, x_blocks, y_blocks, seed
        As :class:`PLSCV`, which gives the linear part and its component count.

    Attributes
    ----------
    pls_ : PLSCV
        The linear part (all of :class:`PLSCV`'s attributes).
    n_components_ : int
        ``pls_.n_components_``.
    cv_counts_ : ndarray of shape (n_counts,)
        The score counts tried (1 or 2 of them).
    cv_mse_ : ndarray of shape (1 + n_counts * len(KRR_GRID),)
        Grouped-CV mean squared residual (block-scaled): without correction, then per
        count of ``cv_counts_`` the settings of :data:`KRR_GRID` in order.
    cv_gain_se_ : ndarray of shape (2,)
        The best setting's mean gain over no correction (``cv_mse_[0]`` minus its
        ``cv_mse_``) and that gain's standard error over the folds; the correction is
        kept when the first is larger.
    params_ : tuple of (float, float) or None
        The chosen (length scale, ridge alpha), None when no correction helped.
    n_scores_ : int
        Scores the correction reads (0 when there is none).
    scores_ : analysis.combined.BlockRegression or None
        The PLS fitted with every component the folds allow, whose first ``n_scores_``
        scores the correction reads; None without correction.
    score_scale_ : ndarray of shape (n_scores_,)
        Standard deviation of each training score read.
    krr_ : sklearn.kernel_ridge.KernelRidge or None
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
        self.pls_ = PLSCV(self.max_components, self.folds, self.x_blocks, self.y_blocks,
                          self.seed).fit(X, Y, groups)
        self.n_components_ = n = self.pls_.n_components_
        top = int(self.pls_.cv_table_["n_components"][-1])
        counts = sorted({n, top})
        self.cv_counts_ = np.asarray(counts)
        splits = self.pls_._splits(X.shape[0], groups)
        err = np.empty((len(splits), 1 + len(counts) * len(KRR_GRID)))
        for f, (train, test) in enumerate(splits):
            fold = BlockRegression("plsr", top, self.x_blocks, self.y_blocks).fit(X[train],
                                                                                 Y[train])
            Tf, Rf = scores_residuals(fold, X[train], Y[train], n)
            Tt, Rt = scores_residuals(fold, X[test], Y[test], n)
            scale = unit_scale(Tf)
            err[f, 0] = np.mean(Rt ** 2)
            col = 1
            for k in counts:
                for params in KRR_GRID:
                    model = _krr(params).fit(Tf[:, :k] / scale[:k], Rf)
                    err[f, col] = np.mean((model.predict(Tt[:, :k] / scale[:k]) - Rt) ** 2)
                    col += 1
        self.cv_mse_ = err.mean(axis=0)
        best = int(np.argmin(self.cv_mse_))
        gain = err[:, 0] - err[:, best]  # per fold, paired
        self.cv_gain_se_ = np.array([gain.mean(), gain.std(ddof=1) / np.sqrt(len(gain))])
        if best == 0 or self.cv_gain_se_[0] <= self.cv_gain_se_[1]:
            self.params_, self.n_scores_, self.scores_, self.krr_ = None, 0, None, None
            self.score_scale_ = np.ones(0)
            return self
        self.params_ = KRR_GRID[(best - 1) % len(KRR_GRID)]
        self.scores_ = BlockRegression("plsr", top, self.x_blocks, self.y_blocks).fit(X, Y)
        T = self._all_scores(X)
        self.n_scores_ = min(counts[(best - 1) // len(KRR_GRID)], T.shape[1])
        self.score_scale_ = unit_scale(T[:, :self.n_scores_])
        R = self._scaled(Y) - self._scaled(self.pls_.predict(X))
        self.krr_ = _krr(self.params_).fit(T[:, :self.n_scores_] / self.score_scale_, R)
        return self

    def _all_scores(self, X) -> np.ndarray:
        assert self.scores_ is not None
        return self.scores_.model_.transform(self.scores_.x_scaler_.transform(X))

    def _scaled(self, Y):
        return self.pls_.model_.y_scaler_.transform(np.asarray(Y, dtype=float))

    def predict(self, X):
        """Predictions (K, n_targets) in Y's units."""
        check_is_fitted(self)
        linear = self.pls_.predict(X)
        if self.krr_ is None:
            return linear
        T = self._all_scores(X)[:, :self.n_scores_] / self.score_scale_
        correction = np.asarray(self.krr_.predict(T)).reshape(linear.shape)
        return self.pls_.model_.y_scaler_.inverse_transform(self._scaled(linear)
                                                            + correction)


#: (length scale in unit-variance scores, ridge alpha) of :class:`KRROnScores`
KRR_GRID = tuple((length, alpha) for length in (0.5, 1.0, 2.0, 4.0)
                 for alpha in (0.01, 0.1, 1.0, 10.0))


def _krr(params: tuple[float, float]) -> KernelRidge:
    length, alpha = params
    return KernelRidge(alpha=alpha, kernel="rbf", gamma=0.5 / length ** 2)


def unit_scale(T: np.ndarray) -> np.ndarray:
    """Standard deviation of each column of T, 1 for a constant one."""
    scale = T.std(axis=0)
    return np.where(scale > 0, scale, 1.0)


def scores_residuals(fit: BlockRegression, X, Y, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Scores (K, fit.n_components_) of X, and the block-scaled residuals (K, n_targets)
    of Y from the fit's first ``n`` components (SIMPLS builds them one after the other,
    so they are the ``n``-component PLSR)."""
    pls = fit.model_
    T = pls.transform(fit.x_scaler_.transform(X))
    m = min(n, fit.n_components_)
    linear = pls.y_mean_ + T[:, :m] @ pls.y_loadings_[:, :m].T
    return T, fit.y_scaler_.transform(Y) - linear


class AutoLearner(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """The learner with the least grouped-CV error on the training data, refitted on it.

    One outer grouped k-fold CV (the folds of :class:`PLSCV`: an experiment's noisy draws
    never straddle a fold) fits every candidate, with its own inner CV, on each outer
    training fold and scores it on the fold's held-out experiments; the candidate with
    the least mean error (block-scaled mean squared error of Y, as :class:`PLSCV`'s; a
    tie goes to the earlier candidate) is then refitted on all the data. Only the
    training data given to :meth:`fit` is used: held-out data stays the caller's.

    It costs about ``folds + 1`` fits of every candidate. Inside an outer fold, a
    candidate's own CV uses ``min(folds, experiments of that fold)`` folds.

    Parameters
    ----------
    max_components, folds, x_blocks, y_blocks, seed
        As :class:`PLSCV`; passed to every candidate.
    candidates : sequence of str, default=AUTO_CANDIDATES
        Names of :data:`LEARNERS` to choose among (not ``"auto"``).

    Attributes
    ----------
    candidates_ : tuple of str
    cv_errors_ : ndarray of shape (n_candidates,)
        Each candidate's outer grouped-CV error, in the order of ``candidates_``.
    cv_errors_std_ : ndarray of shape (n_candidates,)
        Its standard deviation over the outer folds.
    chosen_ : str
        The candidate with the least ``cv_errors_``.
    model_ : estimator
        ``chosen_`` refitted on all of X.
    n_components_ : int
        ``model_.n_components_``.
    """

    def __init__(self, max_components=10, folds=5, x_blocks=None, y_blocks=None, seed=0,
                 candidates=None):
        self.max_components = max_components
        self.folds = folds
        self.x_blocks = x_blocks
        self.y_blocks = y_blocks
        self.seed = seed
        self.candidates = candidates

    def fit(self, X, Y, groups=None):
        """Fit on X (K, n_features), Y (K, n_targets); ``groups`` (K,) keeps the noisy
        draws of one experiment in one fold. Returns self."""
        X, Y = np.asarray(X, dtype=float), np.asarray(Y, dtype=float)
        names = tuple(AUTO_CANDIDATES if self.candidates is None else self.candidates)
        if not names or any(n == "auto" or n not in LEARNERS for n in names):
            raise ParameterError(f"auto chooses among {', '.join(AUTO_CANDIDATES)}, got "
                                 f"{list(names)}")
        groups = None if groups is None else np.asarray(groups)
        splits = PLSCV(folds=self.folds, seed=self.seed)._splits(X.shape[0], groups)
        scaler = BlockScaler(self.y_blocks).fit(Y)
        err = np.empty((len(names), len(splits)))
        for f, (train, test) in enumerate(splits):
            inner = groups[train] if groups is not None else None
            count = len(np.unique(inner)) if inner is not None else train.size
            target = scaler.transform(Y[test])
            for i, name in enumerate(names):
                model = self._candidate(name, min(int(self.folds), count))
                pred = model.fit(X[train], Y[train], inner).predict(X[test])
                err[i, f] = np.mean((scaler.transform(pred) - target) ** 2)
        self.candidates_ = names
        self.cv_errors_ = err.mean(axis=1)
        self.cv_errors_std_ = err.std(axis=1)
        self.chosen_ = names[int(np.argmin(self.cv_errors_))]
        self.model_ = self._candidate(self.chosen_, self.folds).fit(X, Y, groups)
        self.n_components_ = self.model_.n_components_
        return self

    def _candidate(self, name: str, folds):
        return LEARNERS[name](max_components=self.max_components, folds=folds,
                              x_blocks=self.x_blocks, y_blocks=self.y_blocks, seed=self.seed)

    def predict(self, X):
        """Predictions (K, n_targets) in Y's units, by ``model_``."""
        check_is_fitted(self)
        return self.model_.predict(X)


#: what ``learner="auto"`` chooses among, in this order (a CV tie goes to the earlier)
AUTO_CANDIDATES = ("plsr", "gp", "krr")

#: learner name -> class (the CLI's ``--learner`` and ``--learners``)
LEARNERS: dict[str, type] = {"plsr": PLSCV, "gp": GPOnScores, "krr": KRROnScores,
                             "auto": AutoLearner}


def learner(name: str, **params):
    """A learner by name; unknown names raise :class:`ParameterError` listing the known."""
    if name not in LEARNERS:
        raise ParameterError(f"unknown learner {name!r}; known: {', '.join(LEARNERS)}")
    return LEARNERS[name](**params)
