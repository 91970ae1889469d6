"""Inverse study files: the virtual inverse problems of thesis chapter 4, as TOML.

::

    [study]
    name = "thesis-ch4"
    store = "results/inverse.zarr"       # results go to group "inverse-<name>"
    cache = "results/inverse-evaluations" # optional: default "<store>.evaluations"
    seed = 0

    [study.storage_options]               # optional, URL stores only (as in sweep studies)
    endpoint_url = "http://minio:9000"

    [model]                               # the reduced model, as in sweep studies
    kind = "reduced"
    materials = "thesis-calibrated"

    [reference]
    deflection_mm = 30                    # the virtual experiment (iterative road)

    [noise]                               # §4.4: 1 mm on U, 0.04 % on strain
    displacement_mm = 1.0
    strain = 4e-4

    [optimizers.nelder-mead]              # the thesis' optimiser
    max_evaluations = 600
    noise_draw = "per_evaluation"         # §4.4: a new draw at every evaluation

    [optimizers.least-squares]            # TRF, Jacobian columns solved in parallel
    max_evaluations = 200
    fd_step_n = 0.25
    regularisation = "none"               # or "tikhonov", "smoothness", "guess" (towards x0)
    weight = 0.0                          # λ, or "discrepancy": each loop picks its own
    discrepancy = 1.0                     # τ: residual norm = τ x expected noise norm
    jacobian = "shared"                   # or "broyden", "full" (docs/inverse.md)
    jacobian_radius = 0.1                 # "shared": reuse within 10 % of ||x||
    jacobian_patience = 0                 # damped retries on a stale Jacobian before a new one
    warm_starts = true                    # solves continue from the loop's solved points
    columns_per_run = 8                   # Jacobian columns a ccx run solves one after another

    [mask]                                # optional: keep informative nodes only
    eigen_vectors = "pca/eigen_vectors.csv"   # from `farm analyse pca --out pca`
    keep = 0.5

    [distribution]                        # for initial = "distribution" (§6.2) or "surrogate"
    store = "results/thesis.zarr"         # a sweep group of the same mesh
    group = "reduced-table-3.1-default"
    components = 3                        # PCA modes of the normalised force maps
    degree = 2                            # polynomial in the load parameters
    exclude_within_mm = 0.5               # leave out training loads this near the reference

    [[conditions]]                        # default: the thesis' four (§4.3-4.5)
    name = "ideal"
    methods = ["displacement", "strain"]  # eq. 4.1, eq. 4.2, or "combined"
    noise = false
    initial = "scaled"                    # or "uniform", "offset", "distribution", "surrogate"
    scale = 0.9
    guess_sigma_n = 0.0
    repeats = 1

Everything is validated here, once: a bad key or value is one
:class:`~jobs.errors.StudyError` naming it, before anything is submitted. Counts and
sizes have bounds (docs/limits.md): repeats, evaluations, loops, noise levels, scales.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import storage
from farm.errors import SpecError
from farm.specs import LoadPath, ModelSpec, SolverSettings
from jobs.identity import value_key
from jobs.validate import limits, locations, reading, scalars, spec_tables
from jobs.validate.messages import fail, located, shown
from storage.paths import describe

METHODS = ("displacement", "strain", "combined")
OPTIMIZERS = ("nelder-mead", "least-squares")
INITIALS = ("scaled", "uniform", "offset", "distribution", "surrogate")
# weight = λ, or "discrepancy": the loop chooses λ (jobs/inverse/regularisation.py)
WEIGHT_RULES = ("fixed", "discrepancy")
NOISE_DRAWS = ("per_evaluation", "per_solve")
REGULARISATIONS = ("none", "tikhonov", "smoothness", "guess")  # guess: towards x0
# full: a finite-difference Jacobian at every accepted point (scipy's TRF); broyden:
# secant updates between full ones; shared: broyden + full ones shared between loops
JACOBIANS = ("full", "broyden", "shared")
# Bounds of the chapter-4 settings (docs/limits.md): far beyond the thesis' values (1 mm,
# 4e-4, a 0.9 guess, 4 N), short of numbers no measurement or optimiser could mean.
MAX_NOISE_MM = 100.0
MAX_NOISE_STRAIN = 1.0
MAX_SCALE = 10.0
MAX_FORCE_N = 1e4  # guess_sigma_n and fd_step_n: nodal forces are tens of newtons
MAX_TOLERANCE = 1e3
MAX_WEIGHT = 1e12
MAX_PATIENCE = 100  # damped retries on a stale Jacobian (each costs one evaluation)
# Jacobian columns one ccx run continues through (jobs/inverse/warm.py): a run of 8 on
# the default reduced mesh takes ~3 s; past a few hundred a run would outlast the timeout
MAX_COLUMNS_PER_RUN = 256


@dataclass(frozen=True)
class NoiseSettings:
    """Standard deviations of the measurement noise (thesis §4.4): mm and strain (1)."""

    displacement: float = 1.0
    strain: float = 4e-4


@dataclass(frozen=True)
class OptimizerSettings:
    """One optimiser and its budget.

    ``noise_draw``: ``per_evaluation`` compares every evaluation with a new noisy copy
    of the reference, as the thesis did (§4.4: "at each iteration"); ``per_solve`` draws
    the noise once per solve (a fixed noisy measurement, as a real one is). The
    least-squares optimiser needs ``per_solve``: a finite-difference Jacobian of a
    target that is redrawn between its columns would be noise over the step.
    ``fd_step`` (N) is the forward-difference step; ``weight`` the regularisation
    weight λ (see :mod:`jobs.inverse.objective`), or, with ``weight_rule =
    "discrepancy"``, chosen by each loop so that its linearised data residual matches
    ``discrepancy`` x the expected noise norm (:mod:`jobs.inverse.regularisation`).
    """

    name: str
    max_evaluations: int
    noise_draw: str
    xatol: float = 1e-3
    fatol: float = 1e-7
    fd_step: float = 0.25
    regularisation: str = "none"
    weight: float = 0.0
    tolerance: float = 1e-8
    jacobian: str = "shared"
    jacobian_radius: float = 0.1
    weight_rule: str = "fixed"
    discrepancy: float = 1.0
    jacobian_patience: int = 0  # jobs.loops.secant: poor steps on a stale Jacobian tolerated
    # jobs.inverse.warm: continue from solved states (the study files' default for least
    # squares; False: every point from rest, as before warm starts existed)
    warm_starts: bool = False
    columns_per_run: int = 8


@dataclass(frozen=True)
class Condition:
    """One row group of Tables 4.1-4.4: noise on/off and how the guess is made."""

    name: str
    methods: tuple[str, ...]
    optimizers: tuple[str, ...]
    noise: bool
    initial: str
    scale: float
    guess_sigma: float
    repeats: int


@dataclass(frozen=True)
class MaskSpec:
    """Keep the ``keep`` fraction of inner nodes with the largest |W| of ``mode``."""

    eigen_vectors: str
    keep: float
    mode: int = 1


@dataclass(frozen=True)
class DistributionSpec:
    """The training group of the "tyre distribution" guess (§6.2; jobs/inverse/distribution)."""

    store: str
    group: str
    components: int = 3
    degree: int = 2
    exclude_within: float = 0.5


@dataclass(frozen=True)
class InverseStudy:
    """A validated inverse study (units: mm, N, MPa).

    ``store`` is what storage calls get: the location, or the store opened with
    ``storage_options`` (as :attr:`jobs.study.Study.store`); :attr:`location` is text.
    """

    name: str
    store: storage.StoreLike
    group: str
    cache: str
    seed: int
    model: ModelSpec
    deflection: float
    noise: NoiseSettings
    optimizers: tuple[OptimizerSettings, ...]
    conditions: tuple[Condition, ...]
    mask: MaskSpec | None
    settings: SolverSettings
    source: str
    storage_options: dict[str, Any] | None = field(default=None, hash=False)
    distribution: DistributionSpec | None = None

    @property
    def location(self) -> str:
        """Where the store is, as text (a path or URL)."""
        if isinstance(self.store, str | os.PathLike):
            return os.fspath(self.store)
        return describe(self.store)

    def optimizer(self, name: str) -> OptimizerSettings:
        return next(o for o in self.optimizers if o.name == name)

    def problem_hash(self) -> str:
        """What every loop of the study shares: model, reference load, noise, mask."""
        return value_key({"model": self.model.to_dict(), "deflection": self.deflection,
                          "noise": [self.noise.displacement, self.noise.strain],
                          "mask": None if self.mask is None else
                          [self.mask.eigen_vectors, self.mask.keep, self.mask.mode]})


def thesis_conditions(repeats: int = 10, optimizers: tuple[str, ...] = ("nelder-mead",)
                      ) -> tuple[Condition, ...]:
    """The thesis' four conditions (§4.3 ideal, §4.4 noise, §4.5 two poor guesses).

    The ideal case is deterministic, so one repeat is all ten.
    """
    both = ("displacement", "strain")
    return (
        Condition("ideal", both, optimizers, False, "scaled", 0.9, 0.0, 1),
        Condition("noise", both, optimizers, True, "scaled", 0.9, 0.0, repeats),
        Condition("guess-90", both, optimizers, True, "scaled", 0.9, 4.0, repeats),
        Condition("guess-uniform", both, optimizers, True, "uniform", 1.0, 4.0, repeats),
    )


def _positive(t: dict, key: str, where: str, default: float, high: float | None = None
              ) -> float:
    return scalars.number(t.get(key, default), f"{where}.{key}", low=0, high=high, strict=True)


def _count(t: dict, key: str, where: str, default: int, low: int = 1,
           high: int | None = None) -> int:
    return scalars.integer(t.get(key, default), f"{where}.{key}", low=low, high=high)


def _optimizer(name: str, data: Any) -> OptimizerSettings:
    where = f"optimizers.{name}"
    if name not in OPTIMIZERS:
        raise fail(where, f"unknown optimiser; choose {', '.join(OPTIMIZERS)}")
    lsq = name == "least-squares"
    keys = {"max_evaluations", "noise_draw"} | ({"fd_step_n", "regularisation", "weight",
                                                 "tolerance", "jacobian", "jacobian_radius",
                                                 "jacobian_patience", "discrepancy",
                                                 "warm_starts", "columns_per_run"}
                                                if lsq else {"xatol", "fatol"})
    t = scalars.table(data, where, keys)
    draw = scalars.choice(t.get("noise_draw", "per_solve" if lsq else "per_evaluation"),
                          f"{where}.noise_draw", NOISE_DRAWS)
    if lsq and draw != "per_solve":
        raise fail(f"{where}.noise_draw", "least squares needs 'per_solve': a finite-"
                   "difference Jacobian of a target redrawn between columns is noise")
    budget = _count(t, "max_evaluations", where, 200 if lsq else 600, 2, limits.MAX_EVALUATIONS)
    if not lsq:
        return OptimizerSettings(name=name, noise_draw=draw, max_evaluations=budget,
                                 xatol=_positive(t, "xatol", where, 1e-3, MAX_TOLERANCE),
                                 fatol=_positive(t, "fatol", where, 1e-7, MAX_TOLERANCE))
    reg = scalars.choice(t.get("regularisation", "none"), f"{where}.regularisation",
                         REGULARISATIONS)
    rule, weight = _weight(t.get("weight", 0.0), f"{where}.weight")
    if reg != "none" and weight == 0 and rule == "fixed":
        raise fail(f"{where}.weight", f"give a weight > 0 or \"discrepancy\" for {reg} "
                   "regularisation")
    if rule == "discrepancy" and reg == "none":
        raise fail(f"{where}.weight", "\"discrepancy\" chooses a regularisation weight: "
                   "set regularisation = \"tikhonov\", \"smoothness\" or \"guess\"")
    tau = _positive(t, "discrepancy", where, 1.0, MAX_SCALE)
    if t.get("jacobian") == "full" and t.get("jacobian_patience", 0) != 0:
        raise fail(f"{where}.jacobian_patience", "applies to Jacobian reuse only: leave it "
                   "out with jacobian = \"full\" (a new Jacobian at every accepted point)")
    return OptimizerSettings(name=name, noise_draw=draw, max_evaluations=budget,
                             fd_step=_positive(t, "fd_step_n", where, 0.25, MAX_FORCE_N),
                             regularisation=reg, weight=weight,
                             tolerance=_positive(t, "tolerance", where, 1e-8, MAX_TOLERANCE),
                             jacobian=scalars.choice(t.get("jacobian", "shared"),
                                                     f"{where}.jacobian", JACOBIANS),
                             jacobian_radius=scalars.number(t.get("jacobian_radius", 0.1),
                                                            f"{where}.jacobian_radius", low=0,
                                                            high=1),
                             jacobian_patience=_count(t, "jacobian_patience", where, 0, 0,
                                                      MAX_PATIENCE),
                             weight_rule=rule, discrepancy=tau,
                             warm_starts=scalars.boolean(t.get("warm_starts", True),
                                                         f"{where}.warm_starts"),
                             columns_per_run=_count(t, "columns_per_run", where, 8, 1,
                                                    MAX_COLUMNS_PER_RUN))


def _weight(value: Any, where: str) -> tuple[str, float]:
    """``weight``: a number λ >= 0, or "discrepancy" (the loop chooses λ)."""
    if isinstance(value, str):
        if value != "discrepancy":
            raise fail(where, f"got {shown(value)}: give a number >= 0 or \"discrepancy\"")
        return "discrepancy", 0.0
    return "fixed", scalars.number(value, where, low=0, high=MAX_WEIGHT)


def _distribution(data: Any, base: Path) -> DistributionSpec:
    t = scalars.table(data, "distribution", {"store", "group", "components", "degree",
                                             "exclude_within_mm"}, {"store", "group"})
    return DistributionSpec(
        store=locations.store_location(t["store"], "distribution.store", base),
        group=scalars.identifier(t["group"], "distribution.group"),
        components=_count(t, "components", "distribution", 3, high=50),
        degree=_count(t, "degree", "distribution", 2, high=4),
        exclude_within=scalars.number(t.get("exclude_within_mm", 0.5),
                                      "distribution.exclude_within_mm", low=0,
                                      high=MAX_NOISE_MM))


def _condition(data: Any, k: int, optimizers: tuple[str, ...]) -> Condition:
    where = f"conditions[{k}]"
    t = scalars.table(data, where, {"name", "methods", "optimizers", "noise", "initial", "scale",
                                    "guess_sigma_n", "repeats"}, {"name"})
    return Condition(
        name=scalars.identifier(t["name"], f"{where}.name"),
        methods=scalars.choices(t.get("methods", ["displacement", "strain"]), f"{where}.methods",
                                METHODS),
        optimizers=scalars.choices(t.get("optimizers", list(optimizers)), f"{where}.optimizers",
                                   optimizers),
        noise=scalars.boolean(t.get("noise", True), f"{where}.noise"),
        initial=scalars.choice(t.get("initial", "scaled"), f"{where}.initial", INITIALS),
        scale=_positive(t, "scale", where, 0.9, MAX_SCALE),
        guess_sigma=scalars.number(t.get("guess_sigma_n", 0.0), f"{where}.guess_sigma_n", low=0,
                                   high=MAX_FORCE_N),
        repeats=_count(t, "repeats", where, 1, high=limits.MAX_REPEATS))


def _mask(data: Any, base: Path) -> MaskSpec:
    t = scalars.table(data, "mask", {"eigen_vectors", "keep", "mode"}, {"eigen_vectors"})
    path = locations.location(t["eigen_vectors"], "mask.eigen_vectors", "a path", base)
    keep = scalars.number(t.get("keep", 0.5), "mask.keep", low=0, high=1, strict=True)
    mask = MaskSpec(path, keep, _count(t, "mode", "mask", 1, high=1000))
    if Path(path).exists():  # a FIFO or a device would be read for ever at run time
        reading.regular_file(Path(path), "mask.eigen_vectors")
    return mask


def parse_inverse_study(text: str, source: str = "<study>", base: Path | None = None
                        ) -> InverseStudy:
    """Validate the TOML text of an inverse study (raises :class:`StudyError`)."""
    data = reading.parse_toml(text, source)
    with located(source):
        return _parse(data, source, base or Path.cwd())


def _paths(head: dict, base: Path) -> tuple[str, str]:
    """The store and the evaluation cache, relative paths taken from ``base``."""
    store = locations.store_location(head["store"], "study.store", base)
    cache = head.get("cache")
    if cache is None:
        if "://" in store:
            raise fail("study.cache", "give a local cache directory for a URL store")
        return store, store.rstrip("/") + ".evaluations"
    return store, locations.location(cache, "study.cache", "a directory path", base)


def _optimizers_and_conditions(data: dict) -> tuple[tuple, tuple]:
    """``[optimizers]`` (default: Nelder-Mead) and ``[[conditions]]`` (default: the
    thesis' conditions), within the study's loop limit."""
    opt_t = scalars.table(data.get("optimizers", {"nelder-mead": {}}), "optimizers",
                          set(OPTIMIZERS))
    if not opt_t:
        raise fail("optimizers", "name at least one optimiser")
    optimizers = tuple(_optimizer(k, x) for k, x in opt_t.items())
    names = tuple(o.name for o in optimizers)
    conds = data.get("conditions")
    if conds is None:
        conditions = thesis_conditions(optimizers=names)
    elif not isinstance(conds, list) or not conds:
        raise fail("conditions", "must be a non-empty array of tables ([[conditions]])")
    else:
        conditions = tuple(_condition(c, k, names) for k, c in enumerate(conds))
    if len({c.name for c in conditions}) != len(conditions):
        raise fail("conditions", "condition names must be distinct")
    loops = sum(len(c.methods) * len(c.optimizers) * c.repeats for c in conditions)
    if loops > limits.MAX_LOOPS:
        raise fail("conditions", f"methods x optimisers x repeats is {loops} loops, above "
                   f"the limit of {limits.MAX_LOOPS}")
    return optimizers, conditions


def _parse(data: dict, source: str, base: Path) -> InverseStudy:
    scalars.table(data, "study file", {"study", "model", "reference", "noise", "optimizers",
                                       "mask", "conditions", "solver", "distribution"},
                  {"study", "model"})
    head = scalars.table(data["study"], "study",
                         {"name", "store", "group", "cache", "seed", "storage_options"}, {"store"})
    name = scalars.identifier(head.get("name", Path(source).stem), "study.name")
    group = scalars.identifier(head.get("group", f"inverse-{name}"), "study.group")
    store, cache = _paths(head, base)
    model = spec_tables.model(data["model"])
    if model.kind != "reduced" or model.road != "iterative":
        raise fail("model", "the inverse problem uses the reduced model with the iterative "
                   f"road (thesis §4.1); got kind={model.kind!r}, road={model.road!r}")
    ref = scalars.table(data.get("reference", {}), "reference", {"deflection_mm"})
    deflection = _positive(ref, "deflection_mm", "reference", 30.0)
    noise_t = scalars.table(data.get("noise", {}), "noise", {"displacement_mm", "strain"})
    noise = NoiseSettings(_positive(noise_t, "displacement_mm", "noise", 1.0, MAX_NOISE_MM),
                          _positive(noise_t, "strain", "noise", 4e-4, MAX_NOISE_STRAIN))
    optimizers, conditions = _optimizers_and_conditions(data)
    settings = spec_tables.solver(data.get("solver", {})).settings
    seed = scalars.integer(head.get("seed", 0), "study.seed", low=0, high=limits.MAX_SEED)
    mask = _mask(data["mask"], base) if "mask" in data else None
    distribution = _distribution(data["distribution"], base) if "distribution" in data else None
    for k, c in enumerate(conditions):
        if c.initial in ("distribution", "surrogate") and distribution is None:
            raise fail(f"conditions[{k}].initial", f"\"{c.initial}\" needs a [distribution] "
                       "table naming the sweep group it is trained from (store, group)")
    options = (locations.storage_options(head["storage_options"], "study.storage_options", store)
               if "storage_options" in head else None)
    study = InverseStudy(name, store, group, cache, seed, model, deflection, noise, optimizers,
                         conditions, mask, settings, source, options, distribution)
    _check_deflection(study)
    if options:  # the results group is written by the client only: one store object
        study = replace(study, store=_opened(store, options))
    return study


def _opened(url: str, options: dict[str, Any]) -> storage.StoreLike:
    try:
        return storage.open_store(url, storage_options=options)
    except storage.StoreError as e:
        raise fail("study.storage_options", str(e)) from e


def _check_deflection(study: InverseStudy) -> None:
    try:
        LoadPath((study.deflection,)).check_against(study.model)
    except SpecError as e:
        raise fail("reference.deflection_mm", str(e)) from e


def load_inverse_study(path: str | Path) -> InverseStudy:
    """Read and validate an inverse study file; relative paths are taken from the
    current directory, like any path on the command line."""
    path = Path(path)
    return parse_inverse_study(reading.read_text(path), str(path))


def with_repeats(study: InverseStudy, repeats: int) -> InverseStudy:
    """The study with every condition's repeats capped at ``repeats`` (quick runs)."""
    return replace(study, conditions=tuple(replace(c, repeats=min(c.repeats, repeats))
                                           for c in study.conditions))
