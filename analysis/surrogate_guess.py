"""A surrogate-first start for the inverse loops (issue 28): invert a surrogate of the
farm's own experiments instead of the finite element model.

Trained on a sweep group of the inverse study's mesh (its ``[distribution]`` group), two
:class:`~analysis.surrogate.FieldSurrogate` map the group's load parameters to the
inner-surface displacement field and to the vertical tread force map. Given a measured
displacement field, :class:`SurrogateGuess` finds the load parameters whose predicted
field is nearest (bounded least squares over the training ranges: GP predictions cost
microseconds, so this is cheap beside one ccx run), and returns the predicted force map
at them on the loop's unknown nodes. Unlike the "tyre distribution" (thesis §6.2,
:mod:`jobs.inverse.distribution`), which is told the reference load, this guess reads
the load from the measurement itself, noise included.

jobs may not import analysis (tests/test_layering.py): ``farm invert`` builds the guess
here and hands it to :func:`jobs.inverse.run.run_inverse`, which calls it as a
:class:`jobs.inverse.guesses.FieldGuess`.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from scipy.optimize import minimize
from sklearn.exceptions import ConvergenceWarning

from analysis import data
from analysis.errors import ParameterError, TooFewExperimentsError
from analysis.studies.combined import varying_parameters
from analysis.surrogate import FieldSurrogate

MIN_EXPERIMENTS = 3


class SurrogateGuess:
    """Measured inner displacement -> load parameters -> tread force map.

    Parameters
    ----------
    restarts : int, default=2
        Kernel optimiser restarts of each GP.
    seed : int, default=0

    Attributes
    ----------
    names_ : list of str
        The load parameters that vary in the training set (the inputs).
    loads_ : ndarray of shape (K, n_parameters)
        The training experiments' load parameters.
    fields_ : ndarray of shape (K, N * 3)
        Their displacement fields (the search starts from the nearest one).
    bounds_ : ndarray of shape (n_parameters, 2)
        Their training ranges: the search stays inside.
    inner_nodes_, tread_nodes_ : ndarray of int, shapes (N,), (M,)
        Node ids of the field's rows and of the force map's columns.
    field_, forces_ : FieldSurrogate
        Parameters -> displacement (N x 3, node-major), -> vertical tread forces (M).
    p_ : ndarray of shape (n_parameters,)
        The load parameters the last call found.
    """

    def __init__(self, restarts: int = 2, seed: int = 0) -> None:
        self.restarts, self.seed = restarts, seed

    def fit(self, P, U, F, names, inner_nodes, tread_nodes) -> SurrogateGuess:
        """Fit on load parameters P (K, p), displacement fields U (K, N, 3) and vertical
        tread forces F (K, M) of K experiments."""
        P, U, F = (np.asarray(a, dtype=float) for a in (P, U, F))
        if len(P) < MIN_EXPERIMENTS:
            raise TooFewExperimentsError(f"{len(P)} training experiments; the surrogate guess "
                                         f"needs {MIN_EXPERIMENTS}")
        self.names_ = list(names)
        self.bounds_ = np.column_stack([P.min(axis=0), P.max(axis=0)])
        self.inner_nodes_ = np.asarray(inner_nodes)
        self.tread_nodes_ = np.asarray(tread_nodes)
        self.fields_ = U.reshape(len(U), -1)
        self.loads_ = P
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.field_ = FieldSurrogate(restarts=self.restarts, seed=self.seed).fit(
                P, self.fields_)
            self.forces_ = FieldSurrogate(restarts=self.restarts, seed=self.seed).fit(P, F)
        return self

    def parameters(self, measured) -> np.ndarray:
        """The load parameters whose predicted field is nearest ``measured`` (N, 3)."""
        u = np.asarray(measured, dtype=float).ravel()
        if u.size != self.fields_.shape[1]:
            raise ParameterError(f"the measured field has {u.size // 3} nodes; the surrogate "
                                 f"was trained on {self.fields_.shape[1] // 3}: same mesh needed")
        start = self.loads_[np.argmin(((self.fields_ - u) ** 2).sum(axis=1))]  # nearest experiment

        def misfit(p):
            return float(((self.field_.predict(p[None, :])[0] - u) ** 2).sum())

        found = minimize(misfit, start, method="L-BFGS-B", bounds=self.bounds_)
        self.p_ = found.x
        return self.p_

    def __call__(self, measured, nodes) -> np.ndarray:
        """Vertical force guesses (n,) on the unknown tread ``nodes`` (ids) for the
        measured inner displacement (N, 3).

        The predicted map's total is put on the unknowns (the nodes in contact), in the
        map's proportions there: a GP smooths the patch's edge across the training loads
        (its neighbours may touch with more or fewer nodes), so part of the map falls
        outside the contact set, where no force can be; the total is smooth in the load.
        """
        forces = self.forces_.predict(self.parameters(measured)[None, :])[0]
        where = {int(n): k for k, n in enumerate(self.tread_nodes_)}
        missing = [int(n) for n in nodes if int(n) not in where]
        if missing:
            raise ParameterError(f"tread node {missing[0]} is not in the training group's "
                                 "mesh: train on a sweep of the study's mesh")
        x = np.clip([forces[where[int(n)]] for n in nodes], 0.0, None)
        total, inside = float(forces.sum()), float(x.sum())
        if inside <= 0:  # the map misses the contact set altogether: spread evenly
            return np.full(len(x), total / max(len(x), 1))
        return x * (total / inside)


def from_group(store: Any, group: str, *, exclude: dict[str, float] | None = None,
               within: float = 0.0, restarts: int = 2, seed: int = 0) -> SurrogateGuess:
    """A :class:`SurrogateGuess` fitted on a sweep group's done experiments, leaving out
    those whose parameters all lie within ``within`` of ``exclude`` (the reference load:
    the guess must not look it up, as for the tyre distribution)."""
    ds = data.load(store, group)
    names = varying_parameters(ds)
    P = np.column_stack([np.asarray(ds[n].values, dtype=float) for n in names])
    keep = np.ones(len(P), bool)
    if exclude:
        near = np.ones_like(keep)
        for name, value in exclude.items():
            if name in names:
                near &= np.abs(P[:, names.index(name)] - value) <= within
        keep &= ~near
    U = np.asarray(ds["displacement"].transpose("experiment", "inner_node", "component")
                   .sel(component=["x", "y", "z"]).values, dtype=float)
    F = np.asarray(ds["reaction_force"].sel(component="z")
                   .transpose("experiment", "tread_node").values, dtype=float)
    return SurrogateGuess(restarts, seed).fit(
        P[keep], U[keep], F[keep], names, np.asarray(ds["inner_node"].values),
        np.asarray(ds["tread_node"].values))
