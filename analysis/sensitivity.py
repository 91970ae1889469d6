"""Global sensitivity analysis of model choices: Sobol indices and Morris screening.

The thesis fixes one tyre model and asks what the sensors see (chapters 3-5); its §6.2
asks which *model choices* (materials, geometry, reinforcement) change the outputs.
These estimators answer that over a design of models: X holds the model parameters
row by row, in SALib's sample order, and y the farm's outputs of each row.

Both wrap SALib (Herman & Usher 2017, Iwanaga et al. 2022) and do not reimplement it:

- :class:`SobolIndices` calls ``SALib.analyze.sobol.analyze`` with
  ``calc_second_order=False`` on a Saltelli/Sobol' design of N base rows and
  N (D + 2) model runs (Saltelli 2002; Saltelli et al. 2010 estimators for S1 and
  Jansen 1999 for ST, as SALib implements them).
- :class:`MorrisScreening` calls ``SALib.analyze.morris.analyze`` on r trajectories of
  D + 1 runs each (Morris 1991; mu* of Campolongo et al. 2007), a cheap screen.

Confidence intervals are SALib's: ``num_resamples`` bootstrap resamples of the base
rows (trajectories for Morris), and the half-width z_(1+c)/2 times the bootstrap
standard deviation (a normal approximation of the bootstrap distribution), at
``conf_level`` c. Each output column is analysed on its own, with a fresh random
generator seeded by ``seed``, so a column's indices do not depend on the others.

SALib's Sobol analysis treats a seed of 0 like no seed (``if seed:``) and then draws
from numpy's global generator; the estimators pass ``numpy.random.default_rng(seed)``
instead, which is the same stream SALib builds from a nonzero integer seed, and makes
seed 0 reproducible too.
"""

from __future__ import annotations

import warnings
from numbers import Integral, Real

import numpy as np
import pandas as pd
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from analysis.errors import (
    DegenerateDesignWarning,
    DesignError,
    NonFiniteError,
    ParameterError,
    UndefinedVarianceWarning,
)

__all__ = [
    "MorrisScreening", "SobolIndices", "ci_width", "morris_rows", "sobol_rows",
]

#: A parameter whose A -> AB_j swap changes it in fewer base rows than this has NaN
#: indices. Why: the Jansen ST estimator averages (f(A) - f(AB_j))^2 over the N base rows
#: and Saltelli's S1 averages f(B) (f(AB_j) - f(A)); a row whose swap leaves the parameter
#: as it was adds exactly 0 to both. With no such row the indices are 0 +- 0 whatever the
#: model does; with one, the estimate is one difference and the bootstrap (which misses
#: that row in about (1 - 1/N)^N ~ 37 % of its resamples) cannot give it an interval.
#: Continuous parameters of a Sobol' design change in every row; level parameters (mesh
#: densities) in about 1 - 1/k of them, see jobs.design.
MIN_SWAPPED_ROWS = 2
NOT_ESTIMABLE = "not estimable: never varied by the design"

# Tolerance of the design-structure checks: the values of a SALib design may have
# travelled through text (TOML, JSON) and back, which keeps them to ~1e-15 relative.
_STRUCTURE_RTOL = 1e-9


def sobol_rows(n_base: int, n_vars: int) -> int:
    """Model runs of a Sobol' design without second-order indices: N (D + 2)."""
    return n_base * (n_vars + 2)


def morris_rows(n_trajectories: int, n_vars: int) -> int:
    """Model runs of a Morris design: r (D + 1)."""
    return n_trajectories * (n_vars + 1)


def _check_problem(names, bounds) -> tuple[tuple[str, ...], np.ndarray]:
    """Names and bounds of the D parameters, checked: (names, bounds of shape (D, 2))."""
    if isinstance(names, str) or names is None:
        raise ParameterError(f"names must be a sequence of parameter names, got {names!r}")
    names = tuple(str(n) for n in names)
    if not names:
        raise ParameterError("names must name at least one parameter, got none")
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        raise ParameterError(f"names must be unique, got {', '.join(dup)} more than once")
    try:
        b = np.asarray(bounds, dtype=float)
    except (TypeError, ValueError) as e:
        raise ParameterError(f"bounds must be (low, high) pairs of numbers, got {bounds!r}") from e
    if b.shape != (len(names), 2):
        raise ParameterError(
            f"bounds must be one (low, high) pair per name ({len(names)} names), "
            f"got shape {b.shape}"
        )
    bad = [n for n, (lo, hi) in zip(names, b, strict=True)
           if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi)]
    if bad:
        raise ParameterError(
            f"bounds of {', '.join(bad)} must be finite with low < high, got "
            + "; ".join(f"{n}: {tuple(b[names.index(n)])}" for n in bad)
        )
    return names, b


def _check_common(est) -> None:
    r = est.num_resamples
    if isinstance(r, bool) or not isinstance(r, Integral) or r < 2:
        raise ParameterError(f"num_resamples must be an integer >= 2, got {r!r}")
    c = est.conf_level
    # c <= 0 or not c < 1: not 0 < c < 1 (NaN too), in the two comparisons that
    # numbers.Real declares
    if isinstance(c, bool) or not isinstance(c, Real) or c <= 0 or not c < 1:
        raise ParameterError(f"conf_level must be a number in (0, 1), got {c!r}")
    s = est.seed
    if s is not None and (isinstance(s, bool) or not isinstance(s, Integral) or s < 0):
        raise ParameterError(f"seed must be a non-negative integer or None, got {s!r}")


def _check_xy(X, y, n_vars: int) -> tuple[np.ndarray, np.ndarray, bool]:
    """X as (rows, D) floats, y as (rows, k) floats, and whether y was 1-D."""
    try:
        X = np.asarray(X, dtype=float)
        y = np.asarray(y, dtype=float)
    except (TypeError, ValueError) as e:
        raise ParameterError(f"X and y must be numeric arrays: {e}") from e
    if X.ndim != 2 or X.shape[1] != n_vars:
        raise ParameterError(
            f"X must have shape (rows, {n_vars}) (one column per name), got {X.shape}"
        )
    if y.ndim not in (1, 2) or y.shape[0] != X.shape[0]:
        raise ParameterError(
            f"y must have shape ({X.shape[0]},) or ({X.shape[0]}, k) (one row per row of X), "
            f"got {y.shape}"
        )
    one_d = y.ndim == 1
    y = y[:, None] if one_d else y
    if y.shape[1] == 0:
        raise ParameterError("y has no output column")
    for arr, what in ((X, "design X"), (y, "outputs y")):
        if not np.all(np.isfinite(arr)):
            rows = np.flatnonzero(~np.all(np.isfinite(arr.reshape(len(arr), -1)), axis=1))
            raise NonFiniteError(
                f"{what} holds NaN or inf in {len(rows)} row(s) (first: {rows[0]}); "
                "a sensitivity analysis cannot drop rows of its design"
            )
    return X, y, one_d


def _check_bounds(X: np.ndarray, names, bounds: np.ndarray) -> None:
    span = bounds[:, 1] - bounds[:, 0]
    tol = _STRUCTURE_RTOL * np.maximum(span, np.abs(bounds).max(axis=1))
    low, high = np.less(X, bounds[:, 0] - tol), np.greater(X, bounds[:, 1] + tol)
    if np.any(low | high):
        row, col = np.argwhere(low | high)[0]
        raise DesignError(
            f"X[{row}, {col}] = {X[row, col]:g} lies outside the bounds of {names[col]!r} "
            f"({bounds[col, 0]:g}, {bounds[col, 1]:g}): X and bounds do not describe one design"
        )


def _same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    scale = np.maximum(np.abs(a), np.abs(b))
    return np.abs(a - b) <= _STRUCTURE_RTOL * np.where(scale > 0, scale, 1.0)


def _variance_ok(column: np.ndarray, name: str, kind: str) -> bool:
    if np.ptp(column) > 1e-12 * max(float(np.max(np.abs(column))), np.finfo(float).tiny):
        return True
    warnings.warn(
        f"output {name!r} is the same in every row of the design: its {kind} are 0/0, "
        "reported as NaN",
        UndefinedVarianceWarning,
        stacklevel=3,
    )
    return False


def _output_names(output_names, k: int) -> list[str]:
    if output_names is None:
        return [f"y{i}" for i in range(k)]
    names = [str(n) for n in output_names]
    if len(names) != k:
        raise ParameterError(f"output_names must name the {k} outputs, got {len(names)} names")
    return names


class SobolIndices(BaseEstimator):
    """First-order and total Sobol' indices with bootstrap confidence intervals.

    Wraps ``SALib.analyze.sobol.analyze`` (``calc_second_order=False``) for each
    output column. The design X must be SALib's Sobol' sample without second-order
    terms (``SALib.sample.sobol.sample(problem, N, calc_second_order=False)``): N
    blocks of D + 2 rows, A, AB_1 ... AB_D, B, where AB_j is A with column j from B.
    ``fit`` checks that structure (the estimators rely on it, and a design read back in
    another order would give wrong indices without any error).

    Parameters
    ----------
    names : sequence of str, length D
        Parameter names, in the order of X's columns.
    bounds : array-like of shape (D, 2)
        (low, high) of each parameter; X must lie within them.
    num_resamples : int, default=1000
        Bootstrap resamples of the N base rows for the confidence intervals.
    conf_level : float, default=0.95
        Confidence level of the intervals.
    seed : int or None, default=0
        Seed of the bootstrap (a fresh generator per output column).

    Attributes
    ----------
    first_order_ : ndarray of shape (k, D)
        S1 of each output (rows) and parameter (columns).
    first_order_conf_ : ndarray of shape (k, D)
        Half-width of S1's confidence interval at ``conf_level``.
    total_order_ : ndarray of shape (k, D)
        ST, the total-effect indices.
    total_order_conf_ : ndarray of shape (k, D)
        Half-width of ST's confidence interval.
    n_base_samples_ : int
        N, the base sample size (rows / (D + 2)).
    n_outputs_ : int
        k, the number of output columns of y.
    problem_ : dict
        The SALib problem (``num_vars``, ``names``, ``bounds``).
    swapped_rows_ : ndarray of shape (D,)
        Base rows whose A -> AB_j swap changes parameter j (N for a continuous one).
    estimable_ : ndarray of shape (D,), bool
        ``swapped_rows_ >= MIN_SWAPPED_ROWS``; the indices of the others are NaN and
        fit raises a :class:`~analysis.errors.DegenerateDesignWarning`.

    Outputs without variance over the design have NaN indices and raise an
    :class:`~analysis.errors.UndefinedVarianceWarning` (their indices are 0/0).

    Examples
    --------
    >>> from SALib.sample import sobol as sobol_sample
    >>> from SALib.test_functions import Ishigami
    >>> problem = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[-3.1416, 3.1416]] * 3}
    >>> X = sobol_sample.sample(problem, 1024, calc_second_order=False, seed=1)
    >>> est = SobolIndices(problem["names"], problem["bounds"]).fit(X, Ishigami.evaluate(X))
    >>> est.first_order_.shape
    (1, 3)
    """

    def __init__(self, names, bounds, num_resamples=1000, conf_level=0.95, seed=0):
        self.names = names
        self.bounds = bounds
        self.num_resamples = num_resamples
        self.conf_level = conf_level
        self.seed = seed

    def fit(self, X, y):
        """Compute the indices.

        Parameters
        ----------
        X : array-like of shape (N * (D + 2), D)
            The design, in SALib's Sobol' sample order (see the class docstring).
        y : array-like of shape (N * (D + 2),) or (N * (D + 2), k)
            Outputs of each row; every column is analysed on its own.

        Returns
        -------
        self

        Raises
        ------
        ParameterError
            Bad parameters or shapes.
        DesignError
            The row count is not a multiple of D + 2, fewer than 2 base rows, X leaves
            its bounds, or the rows are not in SALib's A, AB_1..AB_D, B order.
        NonFiniteError
            NaN or inf in X or y (a Sobol' design cannot drop rows).
        """
        from SALib.analyze import sobol

        names, bounds = _check_problem(self.names, self.bounds)
        _check_common(self)
        D = len(names)
        X, Y, _ = _check_xy(X, y, D)
        n_base = self._check_structure(X, names)
        _check_bounds(X, names, bounds)
        self.problem_ = {"num_vars": D, "names": list(names), "bounds": bounds.tolist()}
        k = Y.shape[1]
        out = {key: np.full((k, D), np.nan) for key in ("S1", "S1_conf", "ST", "ST_conf")}
        swapped = self._swapped(X, D)
        estimable = swapped >= MIN_SWAPPED_ROWS
        if not estimable.all():
            warnings.warn(
                "; ".join(f"{names[j]!r} is changed by its A -> AB_{j + 1} swap in "
                          f"{swapped[j]} of {n_base} base rows" for j in np.flatnonzero(~estimable))
                + f": Sobol' indices need at least {MIN_SWAPPED_ROWS} (rows whose swap changes "
                "nothing add 0 to every estimator): reported as NaN, not estimable; the design "
                "never varied it (a two-level parameter from the first digit of a Sobol' "
                "coordinate): sample another seed or a larger N",
                DegenerateDesignWarning, stacklevel=2,
            )
        for j in range(k):
            if not _variance_ok(Y[:, j], f"y[:, {j}]", "Sobol indices"):
                continue
            with np.errstate(divide="ignore", invalid="ignore"):
                res = sobol.analyze(
                    self.problem_, Y[:, j], calc_second_order=False,
                    num_resamples=self.num_resamples, conf_level=self.conf_level,
                    seed=np.random.default_rng(self.seed),
                )
            for key in out:
                out[key][j] = np.where(estimable, res[key], np.nan)
        self.swapped_rows_, self.estimable_ = swapped, estimable
        self.first_order_, self.first_order_conf_ = out["S1"], out["S1_conf"]
        self.total_order_, self.total_order_conf_ = out["ST"], out["ST_conf"]
        self.n_base_samples_, self.n_outputs_ = n_base, k
        self.n_features_in_ = D
        return self

    @staticmethod
    def _swapped(X: np.ndarray, D: int) -> np.ndarray:
        """Base rows whose A -> AB_j swap changes parameter j, shape (D,)."""
        blocks = X.reshape(-1, D + 2, D)
        return np.array([int(np.sum(~_same(blocks[:, 0, j], blocks[:, 1 + j, j])))
                         for j in range(D)])

    @staticmethod
    def _check_structure(X: np.ndarray, names: tuple[str, ...]) -> int:
        D = len(names)
        rows = X.shape[0]
        if rows % (D + 2) or rows // (D + 2) < 2:
            raise DesignError(
                f"a Sobol' design of {D} parameters (calc_second_order=False) has "
                f"N * (D + 2) = N * {D + 2} rows with N >= 2 base samples; got {rows} rows "
                f"(nearest: {max(2, round(rows / (D + 2))) * (D + 2)})"
            )
        blocks = X.reshape(rows // (D + 2), D + 2, D)
        A, B = blocks[:, 0], blocks[:, -1]
        for j in range(D):
            expected = A.copy()
            expected[:, j] = B[:, j]
            ok = np.all(_same(blocks[:, 1 + j], expected), axis=1)
            if not ok.all():
                n = int(np.flatnonzero(~ok)[0])
                raise DesignError(
                    f"row {n * (D + 2) + 1 + j} of X (base sample {n}, block AB_{j + 1}) is "
                    f"not row {n * (D + 2)} (A) with {names[j]!r} taken from row "
                    f"{n * (D + 2) + D + 1} (B): X must be in SALib's Sobol' sample order "
                    "(SALib.sample.sobol.sample with calc_second_order=False), rows unsorted"
                )
        return rows // (D + 2)

    def to_frame(self, output_names=None) -> pd.DataFrame:
        """Long table: one row per (output, parameter).

        Parameters
        ----------
        output_names : sequence of str of length k, optional
            Names of y's columns [default: y0, y1, ...].

        Returns
        -------
        pandas.DataFrame
            Columns output, parameter, S1, S1_conf, ST, ST_conf, swapped_rows (base
            rows whose swap changes the parameter) and note (:data:`NOT_ESTIMABLE` for
            a parameter with fewer than :data:`MIN_SWAPPED_ROWS`, else empty).
        """
        check_is_fitted(self, "first_order_")
        outs = _output_names(output_names, self.n_outputs_)
        D = self.n_features_in_
        note = np.where(self.estimable_, "", NOT_ESTIMABLE)
        return pd.DataFrame({
            "output": np.repeat(outs, D),
            "parameter": np.tile(self.problem_["names"], self.n_outputs_),
            "S1": self.first_order_.ravel(),
            "S1_conf": self.first_order_conf_.ravel(),
            "ST": self.total_order_.ravel(),
            "ST_conf": self.total_order_conf_.ravel(),
            "swapped_rows": np.tile(self.swapped_rows_, self.n_outputs_),
            "note": np.tile(note, self.n_outputs_),
        })


class MorrisScreening(BaseEstimator):
    """Morris elementary effects (mu, mu*, sigma) with bootstrap CIs of mu*.

    Wraps ``SALib.analyze.morris.analyze`` for each output column. The design X must
    be r trajectories of D + 1 rows, as ``SALib.sample.morris.sample`` makes them:
    each row of a trajectory differs from the one before in exactly one parameter.
    SALib divides each output step by the unit-cube step Δ = p / (2 (p - 1)) of
    ``num_levels`` p, so mu* is in units of the output per "fraction of the range"
    and ``num_levels`` must be the one the design was sampled with.

    Parameters
    ----------
    names : sequence of str, length D
    bounds : array-like of shape (D, 2)
    num_levels : int, default=4
        Grid levels p of the design.
    num_resamples : int, default=1000
        Bootstrap resamples of the trajectories for mu*'s confidence interval.
    conf_level : float, default=0.95
    seed : int or None, default=0

    Attributes
    ----------
    mu_ : ndarray of shape (k, D)
        Mean elementary effect (signed: effects of opposite sign cancel).
    mu_star_ : ndarray of shape (k, D)
        Mean absolute elementary effect, the screening measure.
    mu_star_conf_ : ndarray of shape (k, D)
        Half-width of mu*'s bootstrap confidence interval.
    sigma_ : ndarray of shape (k, D)
        Standard deviation of the elementary effects (non-linearity, interactions).
    n_trajectories_ : int
    n_outputs_ : int
    problem_ : dict
    """

    def __init__(self, names, bounds, num_levels=4, num_resamples=1000, conf_level=0.95,
                 seed=0):
        self.names = names
        self.bounds = bounds
        self.num_levels = num_levels
        self.num_resamples = num_resamples
        self.conf_level = conf_level
        self.seed = seed

    def fit(self, X, y):
        """Compute the elementary-effect statistics.

        Parameters
        ----------
        X : array-like of shape (r * (D + 1), D)
            The design: r Morris trajectories, rows in sample order.
        y : array-like of shape (r * (D + 1),) or (r * (D + 1), k)

        Returns
        -------
        self

        Raises
        ------
        ParameterError, DesignError, NonFiniteError
            As for :meth:`SobolIndices.fit`; a trajectory step that changes no
            parameter or several is a :class:`DesignError`.
        """
        from SALib.analyze import morris

        names, bounds = _check_problem(self.names, self.bounds)
        _check_common(self)
        p = self.num_levels
        if isinstance(p, bool) or not isinstance(p, Integral) or p < 2:
            raise ParameterError(f"num_levels must be an integer >= 2, got {p!r}")
        D = len(names)
        X, Y, _ = _check_xy(X, y, D)
        n_traj = self._check_structure(X, names)
        _check_bounds(X, names, bounds)
        self.problem_ = {"num_vars": D, "names": list(names), "bounds": bounds.tolist()}
        k = Y.shape[1]
        out = {key: np.full((k, D), np.nan) for key in ("mu", "mu_star", "mu_star_conf", "sigma")}
        for j in range(k):
            if not _variance_ok(Y[:, j], f"y[:, {j}]", "elementary effects"):
                continue
            res = morris.analyze(
                self.problem_, X, Y[:, j], num_resamples=self.num_resamples,
                conf_level=self.conf_level, num_levels=p,
                seed=np.random.default_rng(self.seed),
            )
            for key in out:
                out[key][j] = np.asarray(res[key], dtype=float)
        self.mu_, self.mu_star_ = out["mu"], out["mu_star"]
        self.mu_star_conf_, self.sigma_ = out["mu_star_conf"], out["sigma"]
        self.n_trajectories_, self.n_outputs_ = n_traj, k
        self.n_features_in_ = D
        return self

    @staticmethod
    def _check_structure(X: np.ndarray, names: tuple[str, ...]) -> int:
        D = len(names)
        rows = X.shape[0]
        if rows % (D + 1) or rows // (D + 1) < 2:
            raise DesignError(
                f"a Morris design of {D} parameters has r * (D + 1) = r * {D + 1} rows with "
                f"r >= 2 trajectories; got {rows} rows"
            )
        traj = X.reshape(rows // (D + 1), D + 1, D)
        moved = ~_same(traj[:, 1:], traj[:, :-1])  # (r, D, D): which parameter each step moves
        count = moved.sum(axis=2)
        if np.any(count != 1):
            t, s = np.argwhere(count != 1)[0]
            raise DesignError(
                f"step {s + 1} of Morris trajectory {t} (rows {t * (D + 1) + s}->"
                f"{t * (D + 1) + s + 1}) changes {count[t, s]} parameters, not 1: X must be "
                "in SALib's Morris sample order (SALib.sample.morris.sample), rows unsorted"
            )
        if np.any(moved.sum(axis=1) != 1):
            t = int(np.flatnonzero(np.any(moved.sum(axis=1) != 1, axis=1))[0])
            raise DesignError(
                f"Morris trajectory {t} does not move every parameter exactly once"
            )
        return rows // (D + 1)

    def to_frame(self, output_names=None) -> pd.DataFrame:
        """Long table with columns output, parameter, mu, mu_star, mu_star_conf, sigma."""
        check_is_fitted(self, "mu_star_")
        outs = _output_names(output_names, self.n_outputs_)
        D = self.n_features_in_
        return pd.DataFrame({
            "output": np.repeat(outs, D),
            "parameter": np.tile(self.problem_["names"], self.n_outputs_),
            "mu": self.mu_.ravel(),
            "mu_star": self.mu_star_.ravel(),
            "mu_star_conf": self.mu_star_conf_.ravel(),
            "sigma": self.sigma_.ravel(),
        })


def ci_width(est: SobolIndices) -> dict[str, float]:
    """Mean full width (2 x half-width) of the S1 and ST confidence intervals."""
    check_is_fitted(est, "first_order_")
    return {
        "S1": float(2 * np.nanmean(est.first_order_conf_)),
        "ST": float(2 * np.nanmean(est.total_order_conf_)),
    }
