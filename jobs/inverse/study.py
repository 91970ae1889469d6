"""Inverse study files: the virtual inverse problems of thesis chapter 4, as TOML.

::

    [study]
    name = "thesis-ch4"
    store = "results/inverse.zarr"       # results go to group "inverse-<name>"
    cache = "results/inverse-evaluations" # optional: default "<store>.evaluations"
    seed = 0

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
    regularisation = "none"               # or "tikhonov", "smoothness"
    weight = 0.0

    [mask]                                # optional: keep informative nodes only
    eigen_vectors = "pca/eigen_vectors.csv"   # from `farm analyse pca --out pca`
    keep = 0.5

    [[conditions]]                        # default: the thesis' four (§4.3-4.5)
    name = "ideal"
    methods = ["displacement", "strain"]  # eq. 4.1, eq. 4.2, or "combined"
    noise = false
    initial = "scaled"                    # or "uniform", "offset"
    scale = 0.9
    guess_sigma_n = 0.0
    repeats = 1

Everything is validated here, once: a bad key or value is one
:class:`~jobs.errors.StudyError` naming it, before anything is submitted.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from farm.specs import ModelSpec, SolverSettings, content_hash
from jobs.errors import StudyError
from jobs.study import GROUP_NAME, _fail, _model, _solver, _table

METHODS = ("displacement", "strain", "combined")
OPTIMIZERS = ("nelder-mead", "least-squares")
INITIALS = ("scaled", "uniform", "offset")
NOISE_DRAWS = ("per_evaluation", "per_solve")
REGULARISATIONS = ("none", "tikhonov", "smoothness")


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
    weight λ (see :mod:`jobs.inverse.objective`).
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
class InverseStudy:
    """A validated inverse study (units: mm, N, MPa)."""

    name: str
    store: str
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

    def optimizer(self, name: str) -> OptimizerSettings:
        return next(o for o in self.optimizers if o.name == name)

    def problem_hash(self) -> str:
        """What every loop of the study shares: model, reference load, noise, mask."""
        return content_hash({"model": self.model.to_dict(), "deflection": self.deflection,
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


def _number(t: dict, key: str, where: str, default: float, *, low: float = 0.0,
            strict: bool = False) -> float:
    v = t.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise _fail(f"{where}.{key}", f"must be a number, got {v!r}")
    if v < low or (strict and v == low):
        raise _fail(f"{where}.{key}", f"must be {'>' if strict else '>='} {low:g}, got {v!r}")
    return float(v)


def _integer(t: dict, key: str, where: str, default: int, low: int = 1) -> int:
    v = t.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int) or v < low:
        raise _fail(f"{where}.{key}", f"must be an integer >= {low}, got {v!r}")
    return v


def _choice(t: dict, key: str, where: str, default: str, allowed: tuple[str, ...]) -> str:
    v = t.get(key, default)
    if v not in allowed:
        raise _fail(f"{where}.{key}", f"must be one of {', '.join(allowed)}, got {v!r}")
    return v


def _choices(t: dict, key: str, where: str, default: tuple[str, ...],
             allowed: tuple[str, ...]) -> tuple[str, ...]:
    v = t.get(key, list(default))
    if not isinstance(v, list) or not v:
        raise _fail(f"{where}.{key}", f"must be a non-empty list, got {v!r}")
    for item in v:
        if item not in allowed:
            raise _fail(f"{where}.{key}", f"must list {', '.join(allowed)}; got {item!r}")
    return tuple(dict.fromkeys(v))


def _optimizer(name: str, data: Any) -> OptimizerSettings:
    where = f"optimizers.{name}"
    if name not in OPTIMIZERS:
        raise _fail(where, f"unknown optimiser; choose {', '.join(OPTIMIZERS)}")
    lsq = name == "least-squares"
    keys = {"max_evaluations", "noise_draw"} | ({"fd_step_n", "regularisation", "weight",
                                                 "tolerance"} if lsq else {"xatol", "fatol"})
    t = _table(data, where, keys)
    draw = _choice(t, "noise_draw", where, "per_solve" if lsq else "per_evaluation",
                   NOISE_DRAWS)
    if lsq and draw != "per_solve":
        raise _fail(f"{where}.noise_draw", "least squares needs 'per_solve': a finite-"
                    "difference Jacobian of a target redrawn between columns is noise")
    common = {"name": name, "noise_draw": draw,
              "max_evaluations": _integer(t, "max_evaluations", where, 200 if lsq else 600, 2)}
    if not lsq:
        return OptimizerSettings(**common, xatol=_number(t, "xatol", where, 1e-3, strict=True),
                                 fatol=_number(t, "fatol", where, 1e-7, strict=True))
    reg = _choice(t, "regularisation", where, "none", REGULARISATIONS)
    weight = _number(t, "weight", where, 0.0)
    if reg != "none" and weight == 0:
        raise _fail(f"{where}.weight", f"give a weight > 0 for {reg} regularisation")
    return OptimizerSettings(**common, fd_step=_number(t, "fd_step_n", where, 0.25, strict=True),
                             regularisation=reg, weight=weight,
                             tolerance=_number(t, "tolerance", where, 1e-8, strict=True))


def _condition(data: Any, k: int, optimizers: tuple[str, ...]) -> Condition:
    where = f"conditions[{k}]"
    t = _table(data, where, {"name", "methods", "optimizers", "noise", "initial", "scale",
                             "guess_sigma_n", "repeats"}, {"name"})
    name = t["name"]
    if not (isinstance(name, str) and GROUP_NAME.fullmatch(name)):
        raise _fail(f"{where}.name", f"must be letters, digits, '_', '.', '-', got {name!r}")
    noise = t.get("noise", True)
    if not isinstance(noise, bool):
        raise _fail(f"{where}.noise", f"must be true or false, got {noise!r}")
    opts = _choices(t, "optimizers", where, optimizers, optimizers)
    return Condition(
        name=name, methods=_choices(t, "methods", where, ("displacement", "strain"), METHODS),
        optimizers=opts, noise=noise, initial=_choice(t, "initial", where, "scaled", INITIALS),
        scale=_number(t, "scale", where, 0.9, strict=True),
        guess_sigma=_number(t, "guess_sigma_n", where, 0.0),
        repeats=_integer(t, "repeats", where, 1))


def _mask(data: Any, base: Path) -> MaskSpec:
    t = _table(data, "mask", {"eigen_vectors", "keep", "mode"}, {"eigen_vectors"})
    path = t["eigen_vectors"]
    if not isinstance(path, str):
        raise _fail("mask.eigen_vectors", f"must be a path, got {path!r}")
    keep = _number(t, "keep", "mask", 0.5, strict=True)
    if keep > 1:
        raise _fail("mask.keep", f"must be a fraction in (0, 1], got {keep!r}")
    return MaskSpec(str((base / path).expanduser().resolve()) if not Path(path).is_absolute()
                    else path, keep, _integer(t, "mode", "mask", 1))


def parse_inverse_study(text: str, source: str = "<study>", base: Path | None = None
                        ) -> InverseStudy:
    """Validate the TOML text of an inverse study (raises :class:`StudyError`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{source} is not valid TOML: {e}") from e
    try:
        return _parse(data, source, base or Path.cwd())
    except StudyError as e:
        raise StudyError(f"{source}: {e}") from e.__cause__


def _parse(data: dict, source: str, base: Path) -> InverseStudy:
    _table(data, "study file", {"study", "model", "reference", "noise", "optimizers", "mask",
                                "conditions", "solver"}, {"study", "model"})
    head = _table(data["study"], "study", {"name", "store", "group", "cache", "seed"},
                  {"store"})
    store = head["store"]
    if not isinstance(store, str) or not store.strip():
        raise _fail("study.store", f"must be a path or URL string, got {store!r}")
    name = head.get("name", Path(source).stem)
    if not (isinstance(name, str) and GROUP_NAME.fullmatch(name)):
        raise _fail("study.name", f"must be letters, digits, '_', '.', '-', got {name!r}")
    group = head.get("group", f"inverse-{name}")
    if not (isinstance(group, str) and GROUP_NAME.fullmatch(group)):
        raise _fail("study.group", f"must be letters, digits, '_', '.', '-', got {group!r}")
    if "://" not in store:
        store = str((base / store).expanduser().resolve())
    cache = head.get("cache")
    if cache is None:
        if "://" in store:
            raise _fail("study.cache", "give a local cache directory for a URL store")
        cache = store.rstrip("/") + ".evaluations"
    elif not isinstance(cache, str):
        raise _fail("study.cache", f"must be a directory path, got {cache!r}")
    else:
        cache = str((base / cache).expanduser().resolve())
    model = _model(data["model"])
    if model.kind != "reduced" or model.road != "iterative":
        raise _fail("model", "the inverse problem uses the reduced model with the iterative "
                    f"road (thesis §4.1); got kind={model.kind!r}, road={model.road!r}")
    ref = _table(data.get("reference", {}), "reference", {"deflection_mm"})
    deflection = _number(ref, "deflection_mm", "reference", 30.0, strict=True)
    noise_t = _table(data.get("noise", {}), "noise", {"displacement_mm", "strain"})
    noise = NoiseSettings(_number(noise_t, "displacement_mm", "noise", 1.0, strict=True),
                          _number(noise_t, "strain", "noise", 4e-4, strict=True))
    opt_t = _table(data.get("optimizers", {"nelder-mead": {}}), "optimizers", set(OPTIMIZERS))
    if not opt_t:
        raise _fail("optimizers", "name at least one optimiser")
    optimizers = tuple(_optimizer(k, v) for k, v in opt_t.items())
    names = tuple(o.name for o in optimizers)
    conds = data.get("conditions")
    if conds is None:
        conditions = thesis_conditions(optimizers=names)
    elif not isinstance(conds, list) or not conds:
        raise _fail("conditions", "must be a non-empty array of tables ([[conditions]])")
    else:
        conditions = tuple(_condition(c, k, names) for k, c in enumerate(conds))
    if len({c.name for c in conditions}) != len(conditions):
        raise _fail("conditions", "condition names must be distinct")
    settings, _, _ = _solver(data.get("solver", {}))
    seed = head.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise _fail("study.seed", f"must be an integer >= 0, got {seed!r}")
    mask = _mask(data["mask"], base) if "mask" in data else None
    study = InverseStudy(name, store, group, cache, seed, model, deflection, noise, optimizers,
                         conditions, mask, settings, source)
    _check_deflection(study)
    return study


def _check_deflection(study: InverseStudy) -> None:
    from farm.errors import SpecError
    from farm.specs import LoadPath

    try:
        LoadPath((study.deflection,)).check_against(study.model)
    except SpecError as e:
        raise _fail("reference.deflection_mm", str(e)) from e


def load_inverse_study(path: str | Path) -> InverseStudy:
    """Read and validate an inverse study file; relative paths are taken from the
    current directory, like any path on the command line."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise StudyError(f"cannot read study file {path}: {e.strerror or e}") from e
    return parse_inverse_study(text, str(path))


def with_repeats(study: InverseStudy, repeats: int) -> InverseStudy:
    """The study with every condition's repeats capped at ``repeats`` (quick runs)."""
    return replace(study, conditions=tuple(replace(c, repeats=min(c.repeats, repeats))
                                           for c in study.conditions))
