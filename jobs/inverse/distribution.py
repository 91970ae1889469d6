"""The statistical "tyre distribution" (thesis §6.2): tread force maps from simple parameters.

§6.2: "the methods presented in this study could be used to develop a crude statistical
'tyre distribution'. Such a distribution could be developed such that it depends on
relatively simple parameters and produces a normalized distribution of external forces,
which can be used as a model in its own right or as an initial guess to a non-linear
physical model". :class:`TyreDistribution` is that model:

- each training map (vertical tread forces of one experiment, shape (M,)) is normalised
  by its total, s = f / sum(f), so that the shape is learnt apart from the load level;
- the normalised maps are reduced by PCA (chapter 5's tool: §5.3 found that a few modes
  carry the force fields, three for 91 % of the output variance, §5.4);
- the PCA scores and the total force are regressed by least squares on a polynomial of
  the standardised load parameters (deflection, and pressure when the training store
  varies it; the combined-load parameters when the store holds them); §5.4 found one
  latent variable but a nonlinear map from it, hence the polynomial.

Why here (jobs/) and in numpy, not an estimator in analysis/: its main use is the
initial guess of the inverse loops, which jobs/ runs, and jobs/ may not import
analysis/ (layering). It is small (an SVD and two lstsq solves) and follows the
scikit-learn conventions anyway (parameters in ``__init__``, ``fit`` returns self,
learned attributes end in ``_``).

The training data come from a sweep group of the farm's own store (read through
:mod:`storage`), e.g. the chapter-3 force-deflection sweep that ``farm reproduce``
writes on the same reduced mesh. :func:`training_set` validates it: a missing store or
group, a group of another mesh, or too few done experiments is one
:class:`~jobs.errors.StudyError` naming the study key.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

import storage
from jobs.errors import StudyError

#: Relative tolerance under which a load parameter counts as constant over the training set.
CONSTANT_RTOL = 1e-9


def _features(z: np.ndarray, degree: int) -> np.ndarray:
    """[1, z, z², ...] per column of standardised parameters z (K, p) -> (K, 1 + p*degree).

    No cross terms: with one or two load parameters and a handful of experiments the
    pure powers are what the data can carry.
    """
    cols = [np.ones((z.shape[0], 1))]
    for d in range(1, degree + 1):
        cols.append(z**d)
    return np.hstack(cols)


class TyreDistribution:
    """Tread force distribution as a function of load parameters (thesis §6.2).

    Parameters
    ----------
    n_components : int, default 3
        PCA modes of the normalised force maps kept (capped at the training size - 1).
    degree : int, default 2
        Degree of the polynomial in each standardised load parameter.

    Attributes
    ----------
    parameters_ : tuple of str
        The load parameters the model depends on (those that vary in the training set).
    constants_ : dict of str to float
        Parameters constant over the training set, with their value.
    mean_shape_ : ndarray, shape (M,)
        Mean normalised map.
    components_ : ndarray, shape (n_components_, M)
        PCA modes of the normalised maps.
    score_coef_ : ndarray, shape (n_features, n_components_)
    total_coef_ : ndarray, shape (n_features,)
        Regression coefficients of the scores and of the total force.
    center_, scale_ : ndarray, shape (p,)
        Standardisation of the parameters.
    """

    def __init__(self, n_components: int = 3, degree: int = 2) -> None:
        self.n_components = n_components
        self.degree = degree

    def fit(self, params: Mapping[str, np.ndarray], forces: np.ndarray) -> TyreDistribution:
        """Learn from K experiments.

        Parameters
        ----------
        params : mapping of name to ndarray, shape (K,)
            Load parameters of each experiment (deflection mm, pressure MPa, ...).
        forces : ndarray, shape (K, M)
            Vertical tread force of each node, N (positive in contact).
        """
        forces = np.asarray(forces, dtype=float)
        totals = forces.sum(axis=1)
        if forces.ndim != 2 or np.any(totals <= 0):
            raise ValueError("every training map needs a positive total force (in contact)")
        names = sorted(params)
        values = {n: np.asarray(params[n], dtype=float) for n in names}
        varying = [n for n in names if np.ptp(values[n]) > CONSTANT_RTOL * max(
            1.0, float(np.max(np.abs(values[n]))))]
        if not varying:
            raise ValueError("no load parameter varies over the training set")
        self.parameters_ = tuple(varying)
        self.constants_ = {n: float(values[n][0]) for n in names if n not in varying}
        p = np.column_stack([values[n] for n in varying])
        self.center_, self.scale_ = p.mean(axis=0), p.std(axis=0)
        phi = _features((p - self.center_) / self.scale_, self.degree)
        if phi.shape[0] < phi.shape[1]:
            raise ValueError(f"{phi.shape[0]} experiments cannot fit {phi.shape[1]} "
                             "coefficients: give more experiments or a lower degree")
        shapes = forces / totals[:, None]
        self.mean_shape_ = shapes.mean(axis=0)
        _, _, vt = np.linalg.svd(shapes - self.mean_shape_, full_matrices=False)
        k = max(1, min(self.n_components, shapes.shape[0] - 1))
        self.components_ = vt[:k]
        self.n_components_ = k
        scores = (shapes - self.mean_shape_) @ self.components_.T
        self.score_coef_ = np.linalg.lstsq(phi, scores, rcond=None)[0]
        self.total_coef_ = np.linalg.lstsq(phi, totals, rcond=None)[0]
        return self

    def _phi(self, params: Mapping[str, float | np.ndarray]) -> np.ndarray:
        missing = [n for n in self.parameters_ if n not in params]
        if missing:
            raise ValueError(f"the distribution depends on {missing[0]!r}: give its value")
        p = np.column_stack([np.atleast_1d(np.asarray(params[n], dtype=float))
                             for n in self.parameters_])
        return _features((p - self.center_) / self.scale_, self.degree)

    def predict_shape(self, params: Mapping[str, float | np.ndarray]) -> np.ndarray:
        """Normalised force maps, shape (K, M): non-negative, each summing to 1."""
        s = self.mean_shape_ + (self._phi(params) @ self.score_coef_) @ self.components_
        s = np.clip(s, 0.0, None)  # a road only pushes
        return s / s.sum(axis=1, keepdims=True)

    def predict_total(self, params: Mapping[str, float | np.ndarray]) -> np.ndarray:
        """Total vertical force, shape (K,), N."""
        return self._phi(params) @ self.total_coef_

    def predict(self, params: Mapping[str, float | np.ndarray]) -> np.ndarray:
        """Nodal force maps, shape (K, M), N: the shape times the predicted total."""
        return self.predict_shape(params) * self.predict_total(params)[:, None]


@dataclass(frozen=True, eq=False)
class TrainingSet:
    """Done experiments of a sweep group: parameters (K,) each, forces (K, M) N."""

    params: dict[str, np.ndarray]
    forces: np.ndarray
    tread_nodes: np.ndarray
    tread_xyz: np.ndarray


def training_set(store: storage.StoreLike, group: str, where: str = "distribution"
                 ) -> TrainingSet:
    """Read the vertical tread forces and load parameters of a sweep group's done
    experiments (raises :class:`StudyError` naming ``where``)."""
    try:
        ds = storage.done(storage.open_dataset(store, group))
        names = [n for n in storage.parameters(ds)]
        missing = [n for n in ("reaction_force", "tread_xyz") if n not in ds]
        if missing:
            raise StudyError(f"{where}.group: group {group!r} has no {missing[0]!r}: give a "
                             "sweep group (e.g. the chapter-3 sweep of `farm reproduce`)")
        forces = np.asarray(ds["reaction_force"].sel(component="z").values, dtype=float)
        params = {n: np.asarray(ds[n].values, dtype=float) for n in names}
        nodes = np.asarray(ds["tread_node"].values, dtype=np.int64)
        xyz = np.asarray(ds["tread_xyz"].values, dtype=float)
    except storage.StoreError as e:
        raise StudyError(f"{where}: cannot read group {group!r}: {e}") from e
    return TrainingSet(params, forces, nodes, xyz)


def fit_distribution(data: TrainingSet, *, n_components: int, degree: int,
                     exclude: Mapping[str, float] | None = None, within: float = 0.0,
                     where: str = "distribution") -> TyreDistribution:
    """Fit on ``data``, leaving out the experiments whose parameters all lie within
    ``within`` of ``exclude`` (the reference load: the guess must not look it up).
    Raises :class:`StudyError` when too few experiments remain or they do not touch."""
    keep = np.ones(data.forces.shape[0], bool)
    if exclude:
        near = np.ones_like(keep)
        for name, value in exclude.items():
            if name in data.params:
                near &= np.abs(data.params[name] - value) <= within
        keep &= ~near
    contact = data.forces.sum(axis=1) > 0
    keep &= contact
    if keep.sum() < degree + 1:
        raise StudyError(f"{where}: {int(keep.sum())} usable experiments (done, in contact, "
                         f"not within {within:g} of the reference load), need at least "
                         f"{degree + 1} for degree {degree}")
    try:
        return TyreDistribution(n_components, degree).fit(
            {n: v[keep] for n, v in data.params.items()}, data.forces[keep])
    except ValueError as e:
        raise StudyError(f"{where}: {e}") from e


def check_mesh(data: TrainingSet, tread_nodes: np.ndarray, tread_xyz: np.ndarray,
               where: str = "distribution", tolerance: float = 1e-6) -> None:
    """The training group must be of the study's mesh (same tread nodes and coordinates)."""
    same = (data.tread_nodes.shape == np.shape(tread_nodes)
            and np.array_equal(data.tread_nodes, tread_nodes)
            and np.allclose(data.tread_xyz, tread_xyz, atol=tolerance, rtol=0))
    if not same:
        raise StudyError(f"{where}.group: its tread nodes are not this model's mesh "
                         f"({data.tread_nodes.size} nodes vs {np.size(tread_nodes)}); train "
                         "on a sweep of the same [model.mesh]")


def guess_from(model: TyreDistribution, tread_nodes: np.ndarray,
               unknowns: Sequence[int] | np.ndarray,
               params: Mapping[str, float], total: float) -> np.ndarray:
    """The distribution's shape on the unknown nodes, scaled to ``total`` N, shape (n,).

    The unknowns are the nodes in contact in the reference; the model's map may put
    force on nodes outside them (its contact patch is an interpolation), so the shape
    is renormalised over the unknowns. ``total`` is the total force the guess carries
    (the uniform guess' Fz_ref, §4.5), so that guesses differ in shape only.
    """
    shape = model.predict_shape(params)[0]
    where = {int(n): k for k, n in enumerate(tread_nodes)}
    s = np.array([shape[where[int(n)]] for n in unknowns])
    if s.sum() <= 0:  # the model puts no force on the unknowns: fall back to uniform
        s = np.ones(len(s))
    return total * s / s.sum()
