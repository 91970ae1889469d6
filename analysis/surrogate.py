"""A surrogate of the farm's own virtual experiments (issue 28, first part): load
parameters -> inner-surface fields and tread forces, with a predictive uncertainty.

The outputs (column blocks: a field, then each force as a block of its own, so that a
3000-column field does not drown a force) are block-scaled
(:class:`analysis.combined.BlockScaler`) and reduced by PCA, and one Gaussian process per
PCA score maps the standardised load parameters to it (the PCA-GP emulator of Higdon et
al., 2008). Each kernel - a constant times an anisotropic RBF (one length scale per
parameter) plus a small white noise - is fitted by the marginal likelihood, unlike
:class:`analysis.learners.GPOnScores`: a ccx run is deterministic, so there are no noisy
copies of one experiment for the likelihood to mistake for independent evidence.

The predictive standard deviation of each score is scaled by its leave-one-out
calibration (a likelihood-fitted GP on smooth deterministic data is overconfident: the
standardised LOO residuals, closed-form for a GP, say by how much; Bachoc, 2013), then
propagated to every output column (the scores taken as independent) with the PCA's
truncation residual of that column on the training data added. And
:meth:`FieldSurrogate.next_batch` picks the candidates an adaptive study should run next:
greedily the largest total predictive variance, each pick added as a pseudo-observation
(a GP's variance does not depend on the observed values, so the batch spreads out without
running anything: the "kriging believer" batch of Ginsbourger et al., 2010).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import cho_solve
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin
from sklearn.decomposition import PCA
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.utils.validation import check_is_fitted

from analysis.combined import BlockScaler
from analysis.errors import ParameterError


class FieldSurrogate(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """Gaussian process from load parameters to the PCA scores of block-scaled outputs.

    Parameters
    ----------
    n_components : int or float, default=0.9999999
        PCA components kept: a count, or the fraction of the block-scaled variance to
        explain (as :class:`sklearn.decomposition.PCA`). The default keeps what a
        deterministic solver's outputs hold beyond round-off: a fraction of 0.99999 left
        1.1 % of a field's range out on the test's smooth map. What is left out is added
        to the predictive variance (``residual_var_``).
    blocks : sequence of int, optional
        Column count of each output block, for example ``[n_field, 1, 1, 1, 1]`` for a
        field and four forces; default one block.
    restarts : int, default=3
        Restarts of the kernel optimiser (from random length scales).
    seed : int, default=0

    Attributes
    ----------
    p_mean_, p_scale_ : ndarray of shape (n_parameters,)
        Standardisation of the load parameters.
    scaler_ : BlockScaler
    pca_ : sklearn.decomposition.PCA
    score_scale_ : ndarray of shape (n_components_,)
        Standard deviation of each training score (the GPs' targets have unit variance).
    gps_ : list of sklearn.gaussian_process.GaussianProcessRegressor
        One per PCA score.
    std_scale_ : ndarray of shape (n_components_,)
        Leave-one-out calibration of each GP's standard deviation (at least 1).
    residual_var_ : ndarray of shape (n_outputs,)
        Mean squared PCA truncation residual of each output column on the training data.
    n_components_ : int
    """

    def __init__(self, n_components=0.9999999, blocks=None, restarts=3, seed=0):
        self.n_components = n_components
        self.blocks = blocks
        self.restarts = restarts
        self.seed = seed

    def fit(self, P, Y):
        """Fit on load parameters P (K, n_parameters) and outputs Y (K, n_outputs)."""
        P, Y = _two_d(P, "P"), _two_d(Y, "Y")
        if P.shape[0] != Y.shape[0] or P.shape[0] < 3:
            raise ParameterError(f"P has {P.shape[0]} rows and Y {Y.shape[0]}: the "
                                 "surrogate needs the same experiments in both, at least 3")
        self.p_mean_ = P.mean(axis=0)
        scale = P.std(axis=0)
        self.p_scale_ = np.where(scale > 0, scale, 1.0)
        self.scaler_ = BlockScaler(self.blocks).fit(Y)
        Z = self.scaler_.transform(Y)
        self.pca_ = PCA(self.n_components, svd_solver="full").fit(Z)
        T = self.pca_.transform(Z)
        scale = T.std(axis=0)
        self.score_scale_ = np.where(scale > 0, scale, 1.0)
        self.n_components_ = T.shape[1]
        Ps, T = self._p(P), T / self.score_scale_
        self.gps_ = [_gp(P.shape[1], self.restarts, self.seed).fit(Ps, T[:, k])
                     for k in range(self.n_components_)]
        self.std_scale_ = np.array([_loo_scale(gp) for gp in self.gps_])
        residual = Y - self.scaler_.inverse_transform(self.pca_.inverse_transform(
            self.pca_.transform(Z)))
        self.residual_var_ = (residual**2).mean(axis=0)
        return self

    def _p(self, P):
        return (_two_d(P, "P") - self.p_mean_) / self.p_scale_

    def predict(self, P, return_std=False):
        """Outputs (K, n_outputs) at P (K, n_parameters); with ``return_std``, also their
        predictive standard deviations (K, n_outputs)."""
        check_is_fitted(self)
        mean, std = self._scores(self._p(P))
        Y = self.scaler_.inverse_transform(self.pca_.inverse_transform(mean))
        if not return_std:
            return Y
        loadings = (self.pca_.components_ * self.scaler_.scale_) ** 2  # (n_comp, n_out)
        return Y, np.sqrt(std**2 @ loadings + self.residual_var_)

    def _scores(self, Ps):
        """Mean and standard deviation of every PCA score: two (K, n_components_)."""
        mean, std = zip(*(gp.predict(Ps, return_std=True) for gp in self.gps_), strict=True)
        return (np.column_stack(mean) * self.score_scale_,
                np.column_stack(std) * self.score_scale_ * self.std_scale_)

    def uncertainty(self, P):
        """Total predictive variance of the block-scaled outputs at P: (K,). The
        acquisition of an adaptive study (largest first)."""
        check_is_fitted(self)
        return (self._scores(self._p(P))[1] ** 2).sum(axis=1)

    def next_batch(self, candidates, size):
        """Indices of ``size`` rows of ``candidates`` (K, n_parameters) to run next.

        Greedy: the row of largest :meth:`uncertainty`, then the same with that row added
        to the training set at its predicted scores and the kernel kept, and so on.
        """
        check_is_fitted(self)
        C = self._p(candidates)
        if not 1 <= size <= len(C):
            raise ParameterError(f"batch size {size} must be between 1 and the "
                                 f"{len(C)} candidates")
        X = self.gps_[0].X_train_
        believers = [GaussianProcessRegressor(gp.kernel_, optimizer=None) for gp in self.gps_]
        chosen: list[int] = []
        for _ in range(size):
            Xb = np.vstack([X, C[chosen]]) if chosen else X
            var = np.zeros(len(C))
            for believer, scale in zip(believers, self.score_scale_ * self.std_scale_,
                                       strict=True):
                # a GP's variance depends on the inputs only: any targets do
                believer.fit(Xb, np.zeros(len(Xb)))
                var += (scale * believer.predict(C, return_std=True)[1]) ** 2
            var[chosen] = -np.inf
            chosen.append(int(np.argmax(var)))
        return np.asarray(chosen)


def _gp(n_parameters: int, restarts: int, seed: int) -> GaussianProcessRegressor:
    kernel = (ConstantKernel(1.0, (1e-3, 1e3))
              * RBF(np.ones(n_parameters), (1e-2, 1e3))
              + WhiteKernel(1e-6, (1e-10, 1e-1)))
    return GaussianProcessRegressor(kernel, normalize_y=False, n_restarts_optimizer=restarts,
                                    random_state=seed)


def _loo_scale(gp: GaussianProcessRegressor) -> float:
    """sqrt of the mean squared standardised leave-one-out residual of a fitted GP (at
    least 1): closed form, r_i = [K^-1 y]_i / [K^-1]_ii with variance 1 / [K^-1]_ii
    (Rasmussen & Williams, 2006, eq. 5.12)."""
    n = len(gp.X_train_)
    K_inv = cho_solve((gp.L_, True), np.eye(n))
    d = np.diag(K_inv)
    r = (K_inv @ np.ravel(gp.y_train_)) / d
    return max(1.0, float(np.sqrt(np.mean(r**2 * d))))


def _two_d(A, name: str) -> np.ndarray:
    A = np.asarray(A, dtype=float)
    if A.ndim != 2 or not np.isfinite(A).all():
        raise ParameterError(f"{name} must be a finite 2-D array (experiments x columns), "
                             f"got shape {A.shape}")
    return A
