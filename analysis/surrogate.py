"""A surrogate of the farm's own virtual experiments (issue 28, first part): load
parameters -> inner-surface fields and tread forces, with a predictive uncertainty.

The outputs are a field (many columns: reduced by PCA) and scalars (forces, moments: each
its own target), and one Gaussian process per PCA score and per scalar maps the
standardised load parameters to it (the PCA-GP emulator of Higdon et al., 2008). The
scalars are not put through the field's PCA: a PCA of field and forces together mixes a
force that varies little, or not smoothly, into every score (measured on a synthetic
combined store: Fx 9-11 % of range held out that way, 0.0004 % with its own GP). Each
kernel - a constant times an anisotropic Matern 5/2 (one length scale per parameter)
plus a small white noise - is fitted by the marginal likelihood, unlike
:class:`analysis.camera.learners.GPOnScores`: a ccx run is deterministic, so there are no noisy
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

import warnings

import numpy as np
from scipy.linalg import cho_solve
from sklearn.base import BaseEstimator, MultiOutputMixin, RegressorMixin
from sklearn.decomposition import PCA
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel
from sklearn.utils.validation import check_is_fitted

from analysis.errors import ParameterError

#: Acquisition criteria of :meth:`FieldSurrogate.next_batch`.
CRITERIA = ("variance", "integrated")


class FieldSurrogate(MultiOutputMixin, RegressorMixin, BaseEstimator):
    """Gaussian processes from load parameters to a field's PCA scores and to scalars.

    Parameters
    ----------
    n_field : int or None, default=None
        The first ``n_field`` output columns are the field; the rest are scalars. None:
        every column is the field.
    n_components : int or float, default=0.9999999
        PCA components of the field kept: a count, or the fraction of its variance to
        explain (as :class:`sklearn.decomposition.PCA`). What is left out is added to the
        predictive variance (``residual_var_``).
    restarts : int, default=3
        Restarts of each kernel optimiser (from random length scales).
    seed : int, default=0

    Attributes
    ----------
    p_mean_, p_scale_ : ndarray of shape (n_parameters,)
        Standardisation of the load parameters.
    pca_ : sklearn.decomposition.PCA or None
        PCA of the field (None without one).
    t_mean_, t_scale_ : ndarray of shape (n_targets,)
        Standardisation of the GPs' targets: the field's scores, then the scalars.
    weight_ : ndarray of shape (n_targets,)
        Weight of each target's variance in :meth:`uncertainty`: the field counts as one
        target (its scores weighted by 1 / its total variance), each scalar as one.
    gps_ : list of sklearn.gaussian_process.GaussianProcessRegressor
        One per target.
    std_scale_ : ndarray of shape (n_targets,)
        Leave-one-out calibration of each GP's standard deviation (at least 1).
    residual_var_ : ndarray of shape (n_outputs,)
        Mean squared PCA truncation residual of each output column on the training data
        (0 for the scalars).
    n_components_ : int
    """

    def __init__(self, n_field=None, n_components=0.9999999, restarts=3, seed=0):
        self.n_field = n_field
        self.n_components = n_components
        self.restarts = restarts
        self.seed = seed

    def fit(self, P, Y):
        """Fit on load parameters P (K, n_parameters) and outputs Y (K, n_outputs)."""
        P, Y = _two_d(P, "P"), _two_d(Y, "Y")
        if P.shape[0] != Y.shape[0] or P.shape[0] < 3:
            raise ParameterError(f"P has {P.shape[0]} rows and Y {Y.shape[0]}: the "
                                 "surrogate needs the same experiments in both, at least 3")
        n_field = Y.shape[1] if self.n_field is None else self.n_field
        if not 0 <= n_field <= Y.shape[1]:
            raise ParameterError(f"n_field={n_field} must be between 0 and the "
                                 f"{Y.shape[1]} columns of Y")
        self.p_mean_ = P.mean(axis=0)
        self.p_scale_ = _scale(P)
        F, scalars = Y[:, :n_field], Y[:, n_field:]
        self.pca_ = PCA(self.n_components, svd_solver="full").fit(F) if n_field else None
        S = self.pca_.transform(F) if self.pca_ else np.empty((len(Y), 0))
        self.n_components_ = S.shape[1]
        T = np.hstack([S, scalars])
        self.t_mean_, self.t_scale_ = T.mean(axis=0), _scale(T)
        field_var = max(float(F.var(axis=0).sum()), 1e-300) if n_field else 1.0
        self.weight_ = np.concatenate([np.full(S.shape[1], 1.0 / field_var),
                                       1.0 / self.t_scale_[S.shape[1]:] ** 2])
        Ps, Ts = self._p(P), (T - self.t_mean_) / self.t_scale_
        with warnings.catch_warnings():
            # On deterministic data the nugget ends at its lower bound (the GP interpolates)
            # and L-BFGS-B reports "ABNORMAL" there: expected, not a failed fit. The fit's
            # quality is what the leave-one-out scale and the study's CV measure.
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.gps_ = [_gp(P.shape[1], self.restarts, self.seed).fit(Ps, Ts[:, k])
                         for k in range(T.shape[1])]
        self.std_scale_ = np.array([_loo_scale(gp) for gp in self.gps_])
        residual = np.zeros_like(Y)
        if self.pca_:
            residual[:, :n_field] = F - self.pca_.inverse_transform(S)
        self.residual_var_ = (residual**2).mean(axis=0)
        return self

    def _p(self, P):
        return (_two_d(P, "P") - self.p_mean_) / self.p_scale_

    def _targets(self, Ps):
        """Mean and calibrated standard deviation of every target: two (K, n_targets)."""
        mean, std = zip(*(gp.predict(Ps, return_std=True) for gp in self.gps_), strict=True)
        return (np.column_stack(mean) * self.t_scale_ + self.t_mean_,
                np.column_stack(std) * self.t_scale_ * self.std_scale_)

    def predict(self, P, return_std=False):
        """Outputs (K, n_outputs) at P (K, n_parameters); with ``return_std``, also their
        predictive standard deviations (K, n_outputs)."""
        check_is_fitted(self)
        mean, std = self._targets(self._p(P))
        c = self.n_components_
        parts, spreads = [mean[:, c:]], [std[:, c:] ** 2]
        if self.pca_ is not None:
            parts.insert(0, self.pca_.inverse_transform(mean[:, :c]))
            spreads.insert(0, std[:, :c] ** 2 @ self.pca_.components_**2)
        Y = np.hstack(parts)
        if not return_std:
            return Y
        return Y, np.sqrt(np.hstack(spreads) + self.residual_var_)

    def loo_predict(self):
        """Leave-one-out predictions of the training outputs: (K, n_outputs).

        Closed form per GP (Rasmussen & Williams, 2006, eq. 5.12) with its kernel and the
        field's PCA basis as fitted on all K experiments: cheaper than a refit per
        experiment and a little optimistic for it, so an adaptive study's stopping rule
        uses it and its benchmark measures on experiments never trained on."""
        check_is_fitted(self)
        T = np.column_stack([gp.y_train_ - _loo(gp)[0] for gp in self.gps_])
        T = T * self.t_scale_ + self.t_mean_
        c = self.n_components_
        parts = [T[:, c:]]
        if self.pca_ is not None:
            parts.insert(0, self.pca_.inverse_transform(T[:, :c]))
        return np.hstack(parts)

    def uncertainty(self, P):
        """Weighted total predictive variance at P (:attr:`weight_`): (K,). The
        acquisition of an adaptive study (largest first)."""
        check_is_fitted(self)
        return self._targets(self._p(P))[1] ** 2 @ self.weight_

    def next_batch(self, candidates, size, avoid=None, criterion="variance"):
        """Indices of ``size`` rows of ``candidates`` (K, n_parameters) to run next.

        Greedy: the row of largest score, then the same with that row added to the
        training set (at any value: a GP's variance does not depend on it) and the
        kernels kept, and so on. ``criterion`` "variance": the score is
        :meth:`uncertainty` (where the surrogate is least sure; MacKay's ALM), which
        favours the corners of the load space; "integrated": the reduction of the total
        predictive variance over all candidates that running the row would bring (Cohn,
        1996, ALC), the candidates standing for the load space (Sobol' points), which
        targets the average held-out error instead.

        ``avoid`` (J, n_parameters): points to count as observed although they are not
        in the training set - an adaptive study's failed experiments, so that a batch
        does not return to where ccx just failed (their neighbourhood is the most
        uncertain, having no data).
        """
        check_is_fitted(self)
        C = self._p(candidates)
        if not 1 <= size <= len(C):
            raise ParameterError(f"batch size {size} must be between 1 and the "
                                 f"{len(C)} candidates")
        X = self.gps_[0].X_train_
        if avoid is not None and len(avoid):
            X = np.vstack([X, self._p(avoid)])
        believers = [GaussianProcessRegressor(gp.kernel_, optimizer=None) for gp in self.gps_]
        weights = (self.t_scale_ * self.std_scale_) ** 2 * self.weight_
        chosen: list[int] = []
        if criterion not in CRITERIA:
            raise ParameterError(f"criterion must be one of {', '.join(CRITERIA)}, got "
                                 f"{criterion!r}")
        for _ in range(size):
            Xb = np.vstack([X, C[chosen]]) if chosen else X
            score = np.zeros(len(C))
            for believer, w in zip(believers, weights, strict=True):
                believer.fit(Xb, np.zeros(len(Xb)))
                if criterion == "variance":
                    score += w * believer.predict(C, return_std=True)[1] ** 2
                else:  # sum over x of cov(x, c)^2 / var(c): the variance running c removes
                    S = believer.predict(C, return_cov=True)[1]
                    score += w * (S**2).sum(axis=0) / np.maximum(np.diag(S), 1e-300)
            score[chosen] = -np.inf
            chosen.append(int(np.argmax(score)))
        return np.asarray(chosen)


def _gp(n_parameters: int, restarts: int, seed: int) -> GaussianProcessRegressor:
    # Matern 5/2, not the RBF: the farm's maps bend where the patch starts to slide, and an
    # RBF's infinitely smooth prior is overconfident there. On results/sensor_window.zarr
    # (44 combined cases, 5-fold CV of the six totals) the RBF gave Fy 3.7 %, Mz 12.4 % of
    # range and 59-80 % of errors within 2 std; Matern 5/2 Fy 2.3 %, Mz 9.8 %, 73-86 %.
    kernel = (ConstantKernel(1.0, (1e-3, 1e3))
              * Matern(np.ones(n_parameters), (1e-2, 1e3), nu=2.5)
              + WhiteKernel(1e-6, (1e-10, 1e-4)))
    return GaussianProcessRegressor(kernel, normalize_y=False, n_restarts_optimizer=restarts,
                                    random_state=seed)


def _loo(gp: GaussianProcessRegressor) -> tuple[np.ndarray, np.ndarray]:
    """Leave-one-out residuals r_i = y_i - mu_{-i} of a fitted GP and their variances:
    r_i = [K^-1 y]_i / [K^-1]_ii, variance 1 / [K^-1]_ii (Rasmussen & Williams, 2006,
    eq. 5.12): two (K,)."""
    K_inv = cho_solve((gp.L_, True), np.eye(len(gp.X_train_)))
    d = np.diag(K_inv)
    return (K_inv @ np.ravel(gp.y_train_)) / d, 1.0 / d


def _loo_scale(gp: GaussianProcessRegressor) -> float:
    """sqrt of the mean squared standardised leave-one-out residual of a fitted GP (at
    least 1)."""
    r, var = _loo(gp)
    return max(1.0, float(np.sqrt(np.mean(r**2 / var))))


def _scale(A: np.ndarray) -> np.ndarray:
    """Column standard deviations, 1 where a column is constant."""
    s = A.std(axis=0)
    return np.where(s > 0, s, 1.0)


def _two_d(A, name: str) -> np.ndarray:
    A = np.asarray(A, dtype=float)
    if A.ndim != 2 or not np.isfinite(A).all():
        raise ParameterError(f"{name} must be a finite 2-D array (experiments x columns), "
                             f"got shape {A.shape}")
    return A
