"""The chooser of an adaptive study (issue 28): fit :class:`~analysis.surrogate.FieldSurrogate`
on a group's done experiments, report its held-out errors, pick the next batch.

:func:`jobs.adaptive.loop.run_adaptive` calls it after each round's sweep (the CLI passes
it in: jobs does not import analysis). The surrogate maps the sampled load parameters to
the inner-surface field and the six totals; its errors are the closed-form leave-one-out
RMSE in % of each output's range (:meth:`FieldSurrogate.loo_predict`), and its batch the
kriging-believer choice of :meth:`FieldSurrogate.next_batch` over the round's candidates,
with the group's failed experiments counted as observed: a round does not return to where
ccx just failed (measured: such neighbourhoods are the most uncertain, and an adaptive
design lost 2 of its 24 picks to failures there, docs/guide/surrogate.md, "Adaptive studies").
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sklearn.exceptions import ConvergenceWarning

import storage
from analysis import data
from analysis.errors import TooFewExperimentsError
from analysis.studies.combined import field_matrix, totals
from analysis.studies.surrogate import rmse_pct
from analysis.surrogate import FieldSurrogate

#: The study's name for the field among the outputs a target judges
#: (jobs.validate.adaptive).
FIELD = "field"
MIN_EXPERIMENTS = 3  # FieldSurrogate's minimum


@dataclass(frozen=True)
class Choice:
    """Rows of the candidates to run next, and the fit that chose them."""

    picks: tuple[int, ...]
    fitted_on: int
    errors: dict[str, float | None] = field(default_factory=dict)


def failed_points(store: Any, group: str, names: tuple[str, ...]) -> np.ndarray:
    """The load parameters ``names`` of the group's failed experiments: (J, len(names))."""
    ds = data.open_group(store, group)
    failed = np.asarray(ds["status"].values) == storage.FAILED
    return np.column_stack([np.asarray(ds[p].values, dtype=float)[failed] for p in names]
                           ).reshape(int(failed.sum()), len(names))


class SurrogateChooser:
    """Fit a surrogate of a group's done experiments and choose candidates.

    Parameters
    ----------
    restarts : int, default=2
        Restarts of each kernel optimiser (:class:`FieldSurrogate`).
    seed : int, default=0
    criterion : {"variance", "integrated"}, default="variance"
        The batch's acquisition (:meth:`FieldSurrogate.next_batch`).

    Attributes
    ----------
    model_ : FieldSurrogate
        The last surrogate fitted (a round's choice can be inspected afterwards).
    """

    def __init__(self, restarts: int = 2, seed: int = 0, criterion: str = "variance") -> None:
        self.restarts, self.seed, self.criterion = restarts, seed, criterion

    def __call__(self, store: Any, group: str, names: tuple[str, ...], field: str,
                 candidates: np.ndarray, size: int) -> Choice:
        """Fit on the done experiments of ``group``; pick ``size`` rows of ``candidates``
        (K, len(names)) in the store's units of the parameters ``names``."""
        ds = data.load(store, group)
        n = ds.sizes["experiment"]
        if n < MIN_EXPERIMENTS:
            raise TooFewExperimentsError(
                f"group {group!r}: {n} done experiments, a surrogate needs "
                f"{MIN_EXPERIMENTS}: raise [loads.sample] n, or resume with --retry-failed "
                "after fixing what failed")
        P = np.column_stack([np.asarray(ds[p].values, dtype=float) for p in names])
        F = field_matrix(ds, field)
        Y = np.hstack([F, totals(ds)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.model_ = FieldSurrogate(n_field=F.shape[1], restarts=self.restarts,
                                         seed=self.seed).fit(P, Y)
        errors = {(FIELD if name == field else name): (None if np.isnan(pct) else pct)
                  for name, (_, pct) in rmse_pct(Y, self.model_.loo_predict(), F.shape[1],
                                                 field).items()}
        picks = (tuple(int(k) for k in self.model_.next_batch(
            candidates, size, avoid=failed_points(store, group, names),
            criterion=self.criterion)) if size else ())
        return Choice(picks, n, errors)
