"""A force model for measured point clouds: train on a store, predict with intervals (issue 27).

:func:`fit` trains one learner of :mod:`analysis.camera.learners` on a group of a store, as a
virtual T2Cam (:mod:`analysis.camera.sensor`) measures it: the training experiments'
features from ``draws`` noisy measurements each (a model applied to measurements must
be trained on measurements). Its prediction intervals are split-conformal
(:class:`analysis.camera.predict.intervals.ConformalIntervals`) on out-of-fold residuals of
the training experiments (grouped k-fold: the draws of one experiment are never on both
sides), and are then *checked* on held-out experiments the model and the intervals never
saw: the fraction of held-out totals inside their nominal interval is reported beside
the nominal level.

:class:`ForceModel` is what ``farm fit`` saves and ``farm predict`` loads: the learner,
the intervals, the sensor and the reference inner surface it was trained on (to put a
measured cloud on the sensor's points).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
import xarray as xr
from sklearn.base import clone
from sklearn.model_selection import GroupKFold

import analysis.camera.learners as learners
from analysis.camera.features import MODEL_INPUTS, TARGETS, TPMS, UNITS, camera_inputs, with_tpms
from analysis.camera.population import Tyres, resampled_features
from analysis.camera.predict.domain import FeatureDomain, reference_checks
from analysis.camera.predict.intervals import ConformalIntervals
from analysis.camera.sensor import InnerSurface, SensorSpec, VirtualSensor
from analysis.errors import ModelFileError, ParameterError, TooFewExperimentsError
from analysis.splits import grouped_split

INPUTS = ("displacement", "surface_strain")
#: how a force model's intervals are calibrated (:func:`fit`)
INTERVALS = ("split", "adaptive")


@dataclass
class ForceModel:
    """A trained learner with its sensor, reference surface and intervals."""

    sensor: SensorSpec
    surface: InnerSurface
    learner: object
    intervals: ConformalIntervals
    inputs: tuple[str, ...] = INPUTS
    targets: tuple[str, ...] = TARGETS
    info: dict = field(default_factory=dict)
    # the training clouds' domain (issue 47); None for a model saved before it
    domain: FeatureDomain | None = None

    def __post_init__(self) -> None:
        # built once: its layout's interpolation matrix (and a correlated-noise factor)
        # would otherwise be rebuilt for every cloud predicted
        self.virtual = VirtualSensor(self.sensor, self.surface)

    @property
    def tpms(self) -> bool:
        """Whether the model reads the tyre's inflation pressure (a TPMS) beside the
        camera's clouds (issue 47)."""
        return TPMS in self.inputs

    def check_pressure(self, kpa: float | None) -> None:
        """Refuse a TPMS reading ``kpa`` this model cannot take: missing where it reads
        one, given where it does not, not a positive finite pressure."""
        if self.tpms and kpa is None:
            raise ParameterError("this force model reads the tyre's inflation pressure "
                                 "(fitted with --tpms): give the TPMS reading with "
                                 "--pressure-kpa")
        if not self.tpms and kpa is not None:
            raise ParameterError("this force model does not read a pressure (fitted "
                                 "without --tpms): drop --pressure-kpa, or fit a model "
                                 "with --tpms")
        if kpa is not None and not (np.isfinite(kpa) and kpa > 0):
            raise ParameterError(f"--pressure-kpa must be a positive pressure in kPa, "
                                 f"got {kpa}")

    def features(self, ref_points: np.ndarray, points: np.ndarray) -> np.ndarray:
        """The camera's features (1, F) of one measured cloud against its reference
        cloud, both (M, 3) in the model's frame (registered), resampled on the sensor's
        points."""
        return resampled_features(self.virtual, ref_points, points,
                                  camera_inputs(self.inputs))

    def predict_clouds(self, ref_points: np.ndarray, clouds: list[np.ndarray],
                       pressure_kpa: float | None = None) -> pd.DataFrame:
        """One row per cloud: each target, with the lower and upper interval bounds, and
        ``domain``: ``inside``, ``outside: <the measure over its limit>`` (its intervals
        are then unbounded: the model does not know), or ``not checked`` (a model saved
        before issue 47). ``pressure_kpa``: the TPMS reading, which a model trained with
        one (:attr:`tpms`) needs and any other refuses.

        Raises :class:`~analysis.errors.CloudError` when the reference cloud is not this
        tyre in the model's frame (:func:`analysis.camera.predict.domain.reference_checks`).
        """
        self.check_pressure(pressure_kpa)
        seen = np.isfinite(ref_points).all(axis=1)
        reference_checks(self.surface, self.virtual.layout, ref_points[seen])
        X = with_tpms(np.concatenate([self.features(ref_points, c) for c in clouds]),
                      pressure_kpa, self.inputs)
        with np.errstate(over="ignore", invalid="ignore"):
            table = self.predict_features(X)
        if self.domain is None:
            return table.assign(domain="not checked")
        why = self.domain.outside(X)
        out = np.array([bool(w) for w in why])
        for name in self.targets:
            table.loc[out, f"{name}_lower"], table.loc[out, f"{name}_upper"] = -np.inf, np.inf
        return table.assign(domain=["outside: " + w if w else "inside" for w in why])

    def predict_features(self, X: np.ndarray) -> pd.DataFrame:
        P = np.asarray(self.learner.predict(X)).reshape(X.shape[0], -1)  # type: ignore[attr-defined]
        scale = None
        if getattr(self.intervals, "scaled_", False) and self.domain is not None:
            scale = self.domain.difficulty(X)  # wider where a cloud is unlike the training
        lower, upper = self.intervals.interval(P, scale)
        frame = {}
        for j, name in enumerate(self.targets):
            frame[name] = P[:, j]
            frame[f"{name}_lower"] = lower[:, j]
            frame[f"{name}_upper"] = upper[:, j]
        return pd.DataFrame(frame)


def fit(ds: xr.Dataset | Sequence[xr.Dataset], sensor: SensorSpec, *, learner: str = "plsr",
        draws: int = 3, alpha: float = 0.1, test_fraction: float = 0.25, folds: int = 5,
        max_components: int = 10, seed: int = 0, inputs=INPUTS,
        intervals: str = "split") -> tuple[ForceModel, pd.DataFrame]:
    """Train on the training part of ``ds``, calibrate intervals, check them held out.

    ``ds`` is one store group, or several: a population of tyres
    (:class:`analysis.camera.population.Tyres`, issue 47), whose splits and folds hold out
    whole tyres and whose first group is the reference surface. ``intervals``: ``split``
    (one half-width per target) or ``adaptive`` (normalised by each cloud's difficulty,
    :meth:`FeatureDomain.difficulty <analysis.camera.predict.domain.FeatureDomain.difficulty>`,
    each out-of-fold row's from a domain of its fold's training rows: wider where a
    cloud is unlike the training clouds, issue 47).

    Returns
    -------
    model : ForceModel
    check : pandas.DataFrame
        Per target: held-out RMSE (and % of range), the interval half-width, nominal and
        held-out coverage.
    """
    return fit_intervals(ds, sensor, learner=learner, draws=draws, alpha=alpha,
                         test_fraction=test_fraction, folds=folds,
                         max_components=max_components, seed=seed, inputs=inputs,
                         intervals=(intervals,))[intervals]


def fit_intervals(ds: xr.Dataset | Sequence[xr.Dataset], sensor: SensorSpec, *,
                  learner: str = "plsr", draws: int = 3, alpha: float = 0.1,
                  test_fraction: float = 0.25, folds: int = 5, max_components: int = 10,
                  seed: int = 0, inputs=INPUTS, intervals: Sequence[str] = INTERVALS
                  ) -> dict[str, tuple[ForceModel, pd.DataFrame]]:
    """:func:`fit` once, its intervals calibrated each of the ``intervals`` ways on the
    same out-of-fold residuals: ``{kind: (model, check)}``, the models sharing one
    learner and domain (a comparison of interval kinds that differs in nothing else)."""
    for kind in intervals:
        if kind not in INTERVALS:
            raise ParameterError(f"intervals must be one of {', '.join(INTERVALS)}, got "
                                 f"{kind!r}")
    if not camera_inputs(inputs) or any(i not in MODEL_INPUTS for i in inputs):
        raise ParameterError(f"inputs must be camera fields of {', '.join(INPUTS)}, and "
                             f"optionally {TPMS}, got {list(inputs)}")
    tyres = Tyres.of(ds)
    Y = tyres.targets()
    _check_sizes(tyres, alpha, test_fraction, folds)
    surface = tyres.surface()
    virtual = VirtualSensor(sensor, surface)
    labels = tyres.groups()  # whole rolls (issue 45), whole tyres (issue 47)
    train, test = grouped_split(labels, test_fraction, seed)
    rng = np.random.default_rng(seed)
    Xf = tyres.features(virtual, train, draws, rng, inputs)
    reps = Xf.shape[0] // train.size
    # a fold keeps an experiment's noisy draws, a roll's states and a tyre together; a
    # learner's own CV keeps paths together (the same labels for one tyre)
    estimator = learners.learner(learner, max_components=max_components, folds=folds,
                                 x_blocks=_blocks(Xf.shape[1], inputs),
                                 y_blocks=[1] * len(TARGETS), seed=seed)
    calibrated = _train(estimator, Xf, np.tile(Y[train], (reps, 1)),
                        np.tile(labels[train], reps), np.tile(tyres.paths()[train], reps),
                        folds, alpha, intervals)
    Xt = tyres.features(virtual, test, draws, rng, inputs)
    Yt = np.tile(Y[test], (Xt.shape[0] // test.size, 1))
    info = {"train": train.tolist(), "test": test.tolist(), "learner": learner,
            "draws": draws, "seed": seed, "range": np.ptp(Y, axis=0).tolist(),
            **tyres.held_out(test)}
    domain = FeatureDomain().fit(Xf, Xt)
    out = {}
    for kind, conformal in calibrated.items():
        model = ForceModel(sensor, surface, estimator, conformal, tuple(inputs),
                           info=dict(info), domain=domain)
        out[kind] = (model, _check(model, Xt, Yt, np.ptp(Y, axis=0), alpha))
    return out


def _blocks(n_features: int, inputs) -> list[int]:
    """Column counts of the inputs' feature blocks: the camera's fields alike, a TPMS
    reading one column (a block of its own, so the block scaling weighs it as one
    input, not as one of thousands of columns)."""
    camera = camera_inputs(inputs)
    tpms = int(TPMS in inputs)
    return [(n_features - tpms) // len(camera)] * len(camera) + [1] * tpms


def _train(estimator, X, Y, groups, paths, folds: int, alpha: float,
           kinds: Sequence[str]) -> dict[str, ConformalIntervals]:
    """Fit ``estimator`` on all rows (its own CV keeping ``paths`` whole) and return the
    conformal intervals of its out-of-fold residuals (folds keeping ``groups`` whole) for
    each of ``kinds``: ``adaptive`` scales each row by its difficulty."""
    residuals, scale = _out_of_fold(estimator, X, Y, groups, folds, paths)
    intervals = {kind: ConformalIntervals(alpha=alpha).fit(
        residuals, scale=scale if kind == "adaptive" else None) for kind in kinds}
    estimator.fit(X, Y, paths)
    return intervals


def _check_sizes(tyres: Tyres, alpha: float, test_fraction: float, folds: int) -> None:
    """Enough experiments for the folds and the held-out check; a population holds out
    whole tyres: enough of them for the split and the folds."""
    if not 0.0 < alpha < 1.0:
        raise ParameterError(f"alpha must be in (0, 1), got {alpha}")
    K = int(tyres.sizes.sum())
    if 2 * folds > K:
        raise TooFewExperimentsError(f"fitting a force model needs at least {2 * folds} "
                                     f"done experiments ({folds} CV folds), the selection "
                                     f"has {K}")
    if round(K * test_fraction) < 1:
        raise ParameterError(f"test fraction {test_fraction:g} holds out none of the {K} "
                             f"experiments, and the model's check needs one: give at "
                             f"least {1 / K:.3g}")
    if not tyres.population:
        return
    n = len(tyres.datasets)
    held = min(max(1, round(n * test_fraction)), n - 1)
    if n - held < max(folds, 2):
        raise TooFewExperimentsError(
            f"a population's splits and CV folds hold out whole tyres: {n} tyres, "
            f"{held} held out, leave {n - held} to train on, and {folds} folds need "
            f"{folds}; lower --folds (at least 2) or add tyres")


def _out_of_fold(estimator, X, Y, groups, folds: int, paths) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (truth - prediction) of every row, each predicted by a model that never
    saw its group (its experiment's path, or its tyre), and each row's difficulty against
    its fold's training rows, relative to its fold's held-out rows (as a new cloud's is
    to the model's held-out rows); ``paths`` are what each fold's learner keeps whole in its
    own CV."""
    res, scale = np.empty_like(Y), np.empty(Y.shape[0])
    for train, test in GroupKFold(folds).split(X, groups=groups):
        model = clone(estimator).fit(X[train], Y[train], paths[train])
        res[test] = Y[test] - model.predict(X[test])
        scale[test] = FeatureDomain().fit(X[train], X[test]).difficulty(X[test])
    return res, scale


def _check(model: ForceModel, Xt, Yt, span, alpha: float) -> pd.DataFrame:
    P = model.predict_features(Xt)
    rows = []
    for j, name in enumerate(model.targets):
        pred = P[name].to_numpy()
        inside = (P[f"{name}_lower"] <= Yt[:, j]) & (Yt[:, j] <= P[f"{name}_upper"])
        rmse = float(np.sqrt(np.mean((pred - Yt[:, j]) ** 2)))
        rows.append({"target": name, "unit": UNITS[name], "rmse": rmse,
                     "rmse_pct_range": 100.0 * rmse / span[j] if span[j] > 0 else np.nan,
                     # the median over the rows: adaptive intervals differ row by row
                     "half_width": float(np.median(P[f"{name}_upper"] - P[f"{name}_lower"])
                                         / 2.0),
                     "nominal_coverage": 1.0 - alpha,
                     "heldout_coverage": float(np.mean(inside)), "heldout_rows": len(pred)})
    return pd.DataFrame(rows)


def save(model: ForceModel, path, *, store: str, group: str, ids: list[str],
         check: pd.DataFrame, provenance: dict[str, str] | None = None) -> object:
    """Write ``model`` with its manifest (:func:`analysis.camera.predict.persist.save_model`);
    ``provenance`` (the command, commit and load that trained it,
    :mod:`analysis.render.provenance`) goes into the manifest's ``extra`` as it is.

    The learner, the intervals and the reference surface's arrays go into the skops file
    (plain arrays and the farm's own estimators: nothing a safe loader must trust
    blindly); the sensor, inputs, targets, training ids and the held-out check into the
    manifest.
    """
    from analysis.camera.predict.persist import save_model

    s = model.surface
    payload = {"learner": model.learner, "intervals": model.intervals,
               "surface": {"xyz": s.xyz, "theta": s.theta, "s": s.s,
                           "node_index": s.node_index, "periodic": bool(s.periodic)}}
    if model.domain is not None:
        payload["domain"] = model.domain.to_dict()
    manifest = {"store": store, "group": group, "experiment_ids": list(ids),
                "sensor": model.sensor.to_dict(), "inputs": list(model.inputs),
                "targets": list(model.targets),
                "extra": {"info": model.info, "check": check.to_dict("records"),
                          **({"provenance": dict(provenance)} if provenance else {})}}
    return save_model(path, payload, manifest)


def load(path) -> tuple[ForceModel, dict]:
    """Read a model written by :func:`save`: checksum and types verified on the way, then
    the manifest and the payload checked as a whole (:mod:`analysis.camera.predict.validate`)
    before any part is used; a refusal is one :class:`ModelFileError` line."""
    from analysis.camera.predict import validate as v
    from analysis.camera.predict.persist import load_model

    payload, manifest = load_model(path)
    where = f"model {path}"
    targets_ = v.names(manifest, "targets", TARGETS, where)
    inputs = v.names(manifest, "inputs", MODEL_INPUTS, where)
    sensor = v.built(SensorSpec.from_dict, v.sensor_dict(manifest, where), "sensor", where)
    learner, intervals, s = v.payload_parts(payload, len(targets_), where)
    surface = v.built(lambda s: InnerSurface(
        xyz=np.asarray(s["xyz"], dtype=float), theta=np.asarray(s["theta"], dtype=float),
        s=np.asarray(s["s"], dtype=float), periodic=bool(s["periodic"]),
        node_index=np.asarray(s["node_index"])), s, "reference surface", where)
    extra = manifest.get("extra") or {}
    info = {**(extra.get("info") or {}), "check": extra.get("check") or []}
    domain = payload.get("domain")
    if domain is not None:
        domain = v.built(FeatureDomain.from_dict, domain, "feature domain", where)
    model = ForceModel(sensor, surface, learner, intervals, inputs, targets_, info, domain)
    features = (3 * model.virtual.layout.n_points * len(camera_inputs(inputs))
                + int(model.tpms))
    if domain is not None and domain.mean_.size != features:
        raise ModelFileError(f"{where}: its feature domain has {domain.mean_.size} features, "
                             f"its sensor and inputs give {features}; save the model again "
                             "with farm fit")
    return model, manifest
