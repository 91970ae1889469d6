"""Split-conformal prediction intervals (Vovk et al. 2005; Lei et al. 2018).

A model's residuals on calibration data it was not fitted on (a held-out split, or
out-of-fold predictions) give, per target, the half-width q of an interval
``prediction ± q`` that holds a fresh observation with probability at least
``1 - alpha`` -- for any model and any error distribution, as long as the calibration
and the new data are exchangeable (drawn alike). The guarantee is marginal (averaged over
new inputs), per target (not joint over targets), and only as good as the calibration
data are like the data predicted: residuals of noise-free simulations understate the
error on measured clouds.
"""

from __future__ import annotations

import math

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from analysis.errors import NonFiniteError, ParameterError

__all__ = ["ConformalIntervals", "conformal_rank"]


def conformal_rank(n: int, alpha: float) -> int:
    """k = ceil((n + 1)(1 - alpha)): the rank (1-based, ascending) of the calibration
    score that is the interval's half-width; k > n means the interval is infinite.

    A relative 1e-12 is taken off the product first, so that e.g. n = 9, alpha = 0.1
    gives k = 9 although (9 + 1) * 0.9 rounds to 9.000000000000002 in floating point.
    """
    return math.ceil((n + 1) * (1.0 - alpha) * (1.0 - 1e-12))


class ConformalIntervals(BaseEstimator):
    """Per-target split-conformal intervals ``prediction ± quantile_``.

    Parameters
    ----------
    alpha : float, default=0.1
        Miscoverage level in (0, 1): the intervals hold a fresh observation with
        probability >= 1 - alpha (0.9 by default), per target.

    Attributes
    ----------
    quantile_ : ndarray of shape (n_targets,)
        Half-width per target: the k-th smallest |residual|, k = ceil((n+1)(1-alpha))
        with n = ``n_calibration_`` (the finite-sample correction that makes coverage
        >= 1 - alpha rather than about it). When k > n, i.e. n < (1 - alpha) / alpha
        (fewer than 9 residuals for alpha = 0.1, 19 for 0.05), no finite width has the
        guarantee and the half-width is ``inf``: every interval is (-inf, inf).
    n_calibration_ : int
        Number of calibration residuals n.
    scaled_ : bool
        Whether the scores were residuals over each row's difficulty (``fit``'s
        ``scale``); then ``interval`` needs the new rows' difficulty too.
    n_targets_ : int
    """

    def __init__(self, alpha: float = 0.1):
        self.alpha = alpha

    def fit(self, residuals, y=None, scale=None):
        """Learn the half-widths from calibration residuals (truth - prediction).

        Parameters
        ----------
        residuals : array_like of shape (n_cal, n_targets) or (n_cal,)
            Residuals of predictions the model made without having seen those rows.
        y : ignored
        scale : array_like of shape (n_cal,), optional
            Each row's difficulty (> 0, computed without that row): the scores are then
            ``|residual| / scale`` and an interval's half-width ``quantile_ * scale`` of
            its own row (normalised conformal intervals, Papadopoulos et al. 2008; Lei et
            al. 2018 §5.2): the same marginal guarantee, wider where a row is harder.

        Returns
        -------
        self : ConformalIntervals
        """
        alpha = self.alpha
        if not (isinstance(alpha, (int, float, np.floating)) and 0.0 < float(alpha) < 1.0):
            raise ParameterError(f"alpha must be a number in (0, 1), got {alpha!r}")
        r = np.asarray(residuals, dtype=np.float64)
        if r.ndim == 1:
            r = r[:, None]
        if r.ndim != 2 or r.shape[0] < 1 or r.shape[1] < 1:
            raise ParameterError(f"residuals must have shape (n_cal, n_targets) with "
                                 f"n_cal >= 1, got {np.shape(residuals)}")
        if not np.isfinite(r).all():
            raise NonFiniteError("the calibration residuals contain NaN or inf; drop those "
                                 "rows before calibrating the intervals")
        n = r.shape[0]
        self.scaled_ = scale is not None
        if self.scaled_:
            r = r / _scale(scale, n)[:, None]
        k = conformal_rank(n, float(alpha))
        # k > n: no finite width has the guarantee (too few residuals for this alpha)
        self.quantile_ = np.full(r.shape[1], np.inf) if k > n else np.sort(np.abs(r), axis=0)[k - 1]
        self.n_calibration_ = n
        self.n_targets_ = r.shape[1]
        return self

    def _check(self, name: str, a) -> np.ndarray:
        check_is_fitted(self)
        a = np.asarray(a, dtype=np.float64)
        shape_ok = (a.ndim == 2 and a.shape[1] == self.n_targets_) or (
            a.ndim == 1 and self.n_targets_ == 1)
        if not shape_ok:
            raise ParameterError(f"{name} must have shape (K, {self.n_targets_}) (the targets "
                                 f"the intervals were calibrated on), got {a.shape}")
        return a

    def interval(self, prediction, scale=None) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds around point predictions.

        Parameters
        ----------
        prediction : array_like of shape (K, n_targets)
            (or (K,) for a single target)
        scale : array_like of shape (K,), optional
            Each row's difficulty; required when the intervals were fitted with one.

        Returns
        -------
        lower, upper : ndarrays of the shape of ``prediction``
            ``prediction -+ quantile_`` (times each row's ``scale``; ±inf where
            ``quantile_`` is inf).
        """
        p = self._check("prediction", prediction)
        q = self.quantile_[0] if p.ndim == 1 else self.quantile_
        if getattr(self, "scaled_", False):  # intervals saved before scales: unscaled
            if scale is None:
                raise ParameterError("these intervals were calibrated on scaled residuals: "
                                     "give each row's scale")
            w = _scale(scale, p.shape[0])
            q = q * (w if p.ndim == 1 else w[:, None])
        return p - q, p + q

    def coverage(self, y_true, prediction, scale=None) -> np.ndarray:
        """Fraction of the rows whose truth lies inside its interval, per target.

        Parameters
        ----------
        y_true, prediction : array_like of shape (K, n_targets)

        Returns
        -------
        ndarray of shape (n_targets,)
        """
        p = self._check("prediction", prediction)
        y = self._check("y_true", y_true)
        if y.shape != p.shape:
            raise ParameterError(f"y_true {y.shape} and prediction {p.shape} must have the "
                                 "same shape")
        lower, upper = self.interval(p, scale)
        inside = (lower <= y) & (y <= upper)
        return np.atleast_1d(inside.mean(axis=0))


def _scale(scale, n: int) -> np.ndarray:
    """``scale`` as n positive numbers (inf allowed: an unbounded interval)."""
    w = np.asarray(scale, dtype=np.float64)
    if w.shape != (n,) or np.isnan(w).any() or not (w > 0).all():
        raise ParameterError(f"scale must be {n} positive numbers (one per row), got shape "
                             f"{w.shape}")
    return w
