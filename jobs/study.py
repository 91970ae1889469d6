"""Study files: a TOML description of a sweep, validated once into frozen values.

A study names a store, a model and its load cases::

    [study]
    name = "thesis-ch5"
    store = "results/thesis.zarr"     # a directory or an fsspec URL
    group = "full-table-3.1"          # optional: default "<kind>-<model hash>"

    [model]                           # as farm.specs.ModelSpec; units mm, MPa
    kind = "full"
    materials = "table-3.1"           # a preset, or a table per region
    [model.mesh]
    circumferential = 40

    [loads]                           # a grid: every pressure x every deflection
    pressure_kpa = [200]
    deflection_mm = { start = 10, stop = 40, step = 5 }

    # or, instead of the grid, a design over ranges (scipy.stats.qmc)
    # [loads.sample]
    # method = "lhs"                  # or "sobol"
    # n = 16
    # seed = 0
    # deflection_mm = [10, 40]
    # pressure_kpa = [80, 200]

    [solver]                          # optional, as farm.specs.SolverSettings
    timeout_s = 1800
    max_path_length = 0               # split load paths longer than this (0: never)

Every key is checked: an unknown key, a wrong type or an out-of-range value is one
:class:`~jobs.errors.StudyError` naming the key, the value given and what is allowed.
"""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from farm.errors import SpecError
from farm.presets import MATERIAL_PRESETS, default_model
from farm.specs import LoadPath, ModelSpec, SolverSettings, content_hash
from jobs.errors import StudyError

GROUP_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,127}")
SAMPLING_METHODS = ("lhs", "sobol")
LOAD_KEYS = {"pressure_kpa", "deflection_mm", "sample"}
SOLVER_KEYS = {"timeout_s", "threads", "initial_increment", "min_increment", "max_increment",
               "max_increments", "max_path_length", "retry_smaller_increments"}


@dataclass(frozen=True)
class Sampling:
    """A quasi-random design over load ranges (``scipy.stats.qmc``)."""

    method: str
    n: int
    seed: int
    ranges: tuple[tuple[str, float, float], ...]  # (parameter, low, high), internal units


@dataclass(frozen=True)
class Study:
    """A validated study: where results go, which model, which load cases, how to solve.

    Pressures are in MPa and deflections in mm (the file says kPa and mm).
    """

    name: str
    store: str
    group: str | None
    model: ModelSpec
    pressures: tuple[float, ...]
    deflections: tuple[float, ...]
    sampling: Sampling | None
    settings: SolverSettings
    max_path_length: int
    retry_smaller_increments: bool
    source: str

    @property
    def group_name(self) -> str:
        """The group the study writes to: given, else one per model (kind + spec hash)."""
        return self.group or f"{self.model.kind}-{self.model_hash()[:10]}"

    def model_hash(self) -> str:
        return content_hash(self.model.to_dict())


def _fail(where: str, message: str) -> StudyError:
    return StudyError(f"{where}: {message}")


def _table(data: Any, where: str, allowed: set[str], required: set[str] = frozenset()) -> dict:
    if not isinstance(data, dict):
        raise _fail(where, f"must be a table, got {type(data).__name__} {data!r}")
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise _fail(f"{where}.{unknown[0]}", f"unknown key; allowed: {', '.join(sorted(allowed))}")
    missing = sorted(required - set(data))
    if missing:
        raise _fail(f"{where}.{missing[0]}", "is required")
    return data


def _number(value: Any, where: str, *, positive: bool = False, allow_zero: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(where, f"must be a number, got {value!r}")
    if positive and (value < 0 or (value == 0 and not allow_zero)):
        raise _fail(where, f"must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return float(value)


def _integer(value: Any, where: str, low: int, high: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(where, f"must be an integer, got {value!r}")
    if value < low or (high is not None and value > high):
        bound = f">= {low}" if high is None else f"between {low} and {high}"
        raise _fail(where, f"must be {bound}, got {value!r}")
    return value


def _values(value: Any, where: str, *, allow_zero: bool) -> tuple[float, ...]:
    """A list of numbers, a single number, or {start, stop, step} (inclusive)."""
    if isinstance(value, dict):
        r = _table(value, where, {"start", "stop", "step"}, {"start", "stop", "step"})
        start, stop = (_number(r[k], f"{where}.{k}", positive=True) for k in ("start", "stop"))
        step = _number(r["step"], f"{where}.step", positive=True, allow_zero=False)
        if stop < start:
            raise _fail(where, f"stop ({stop:g}) must not be below start ({start:g})")
        n = math.floor((stop - start) / step + 1e-9) + 1
        if n > 100_000:
            raise _fail(where, f"{n} values is too many (at most 100000)")
        values = [start + k * step for k in range(n)]
    elif isinstance(value, list):
        if not value:
            raise _fail(where, "must not be empty")
        values = [_number(v, f"{where}[{k}]", positive=True) for k, v in enumerate(value)]
    else:
        values = [_number(value, where, positive=True)]
    if not allow_zero and any(v == 0 for v in values):
        raise _fail(where, "must be > 0")
    return tuple(sorted({round(v, 9) for v in values}))


def _sampling(data: Any, where: str) -> Sampling:
    t = _table(data, where, {"method", "n", "seed", "deflection_mm", "pressure_kpa"},
               {"method", "n"})
    method = t["method"]
    if method not in SAMPLING_METHODS:
        raise _fail(f"{where}.method", f"must be one of {', '.join(SAMPLING_METHODS)}, "
                    f"got {method!r}")
    n = _integer(t["n"], f"{where}.n", 1, 100_000)
    seed = _integer(t.get("seed", 0), f"{where}.seed", 0)
    ranges = []
    for key, name, scale in (("deflection_mm", "deflection", 1.0), ("pressure_kpa", "pressure",
                                                                   1e-3)):
        if key in t:
            r = t[key]
            if not (isinstance(r, list) and len(r) == 2):
                raise _fail(f"{where}.{key}", f"must be [low, high], got {r!r}")
            low, high = (_number(v, f"{where}.{key}", positive=True) for v in r)
            if not low < high:
                raise _fail(f"{where}.{key}", f"needs low < high, got {r!r}")
            ranges.append((name, low * scale, high * scale))
    if not ranges:
        raise _fail(where, "give a range for deflection_mm and/or pressure_kpa")
    return Sampling(method, n, seed, tuple(ranges))


def _model(data: Any) -> ModelSpec:
    t = _table(data, "model", {"kind", "materials", "road", "cut_faces", "geometry", "mesh",
                               "contact", "sector_angle"}, {"kind"})
    kind = t["kind"]
    if kind not in ("reduced", "full"):
        raise _fail("model.kind", f"must be 'reduced' or 'full', got {kind!r}")
    materials = t.get("materials", "table-3.1")
    spec = default_model(kind, materials) if isinstance(materials, str) and (
        materials in MATERIAL_PRESETS) else default_model(kind)
    if isinstance(materials, str) and materials not in MATERIAL_PRESETS:
        raise _fail("model.materials", f"unknown preset {materials!r}; presets: "
                    f"{', '.join(MATERIAL_PRESETS)} (or give a table per region)")
    overrides = {k: v for k, v in t.items()
                 if k != "kind" and not (k == "materials" and isinstance(v, str))}
    try:
        return ModelSpec.from_dict(_merge(spec.to_dict(), overrides, "model"))
    except SpecError as e:
        raise StudyError(str(e)) from e


def _merge(base: dict, override: dict, where: str) -> dict:
    """``base`` with ``override``'s values, nested tables merged key by key."""
    out = dict(base)
    for key, value in override.items():
        if isinstance(base.get(key), dict):
            if not isinstance(value, dict):
                raise _fail(f"{where}.{key}", f"must be a table, got {value!r}")
            out[key] = _merge(base[key], value, f"{where}.{key}")
        else:
            out[key] = value  # unknown keys are left for ModelSpec.from_dict to name
    return out


def _solver(data: Any) -> tuple[SolverSettings, int, bool]:
    t = _table(data, "solver", SOLVER_KEYS)
    kwargs = {k: t[k] for k in ("threads", "initial_increment", "min_increment", "max_increment",
                                "max_increments") if k in t}
    if "timeout_s" in t:
        kwargs["timeout"] = _number(t["timeout_s"], "solver.timeout_s", positive=True,
                                    allow_zero=False)
    for k in ("threads", "max_increments"):
        if k in kwargs:
            _integer(kwargs[k], f"solver.{k}", 1)
    for k in ("initial_increment", "min_increment", "max_increment"):
        if k in kwargs:
            _number(kwargs[k], f"solver.{k}", positive=True, allow_zero=False)
    retry = t.get("retry_smaller_increments", True)
    if not isinstance(retry, bool):
        raise _fail("solver.retry_smaller_increments", f"must be true or false, got {retry!r}")
    try:
        settings = SolverSettings(**kwargs)
    except SpecError as e:
        raise StudyError(str(e)) from e
    return settings, _integer(t.get("max_path_length", 0), "solver.max_path_length", 0), retry


def _loads(data: Any, model: ModelSpec):
    t = _table(data, "loads", LOAD_KEYS)
    sampling = _sampling(t["sample"], "loads.sample") if "sample" in t else None
    grid = {"pressure_kpa", "deflection_mm"} & set(t)
    if sampling is not None:
        sampled = {name for name, _, _ in sampling.ranges}
        clash = sorted(k for k in grid if k.split("_")[0] in sampled)
        if clash:
            raise _fail(f"loads.{clash[0]}", "is both sampled and listed; give it in one place")
    pressures = (tuple(v / 1000 for v in _values(t["pressure_kpa"], "loads.pressure_kpa",
                                                  allow_zero=not model.inflated))
                 if "pressure_kpa" in t else None)
    deflections = (_values(t["deflection_mm"], "loads.deflection_mm", allow_zero=False)
                   if "deflection_mm" in t else ())
    sampled = {name for name, _, _ in sampling.ranges} if sampling else set()
    if not deflections and "deflection" not in sampled:
        raise _fail("loads.deflection_mm", "is required (a list, a {start, stop, step} range, "
                    "or a range in [loads.sample])")
    if pressures is None and "pressure" not in sampled:
        if model.inflated:
            raise _fail("loads.pressure_kpa", "is required for the inflated full model")
        pressures = (0.0,)
    return pressures or (), deflections, sampling


def parse_study(text: str, source: str = "<study>") -> Study:
    """Validate the TOML text of a study (raises :class:`StudyError`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{source} is not valid TOML: {e}") from e
    try:
        _table(data, "study file", {"study", "model", "loads", "solver"},
               {"study", "model", "loads"})
        head = _table(data["study"], "study", {"name", "store", "group"}, {"store"})
        store = head["store"]
        if not isinstance(store, str) or not store.strip():
            raise _fail("study.store", f"must be a path or URL string, got {store!r}")
        group = head.get("group")
        if group is not None and not (isinstance(group, str) and GROUP_NAME.fullmatch(group)):
            raise _fail("study.group", "must be letters, digits, '_', '.', '-' (at most 128), "
                        f"got {group!r}")
        name = head.get("name", Path(source).stem)
        if not isinstance(name, str):
            raise _fail("study.name", f"must be a string, got {name!r}")
        model = _model(data["model"])
        pressures, deflections, sampling = _loads(data["loads"], model)
        settings, max_path, retry = _solver(data.get("solver", {}))
        study = Study(name, store, group, model, pressures, deflections, sampling, settings,
                      max_path, retry, source)
        _check_loads(study)
    except StudyError as e:
        raise StudyError(f"{source}: {e}") from e.__cause__
    return study


def _check_loads(study: Study) -> None:
    """Load cases the model cannot take are rejected before anything runs."""
    ranges = {name: (low, high) for name, low, high in (study.sampling.ranges
                                                          if study.sampling else ())}
    top = max([*study.deflections, ranges.get("deflection", (0, 0))[1]])
    for p in [*study.pressures, *ranges.get("pressure", ())]:
        try:
            LoadPath((top,), p).check_against(study.model)
        except SpecError as e:
            raise StudyError(f"loads: {e}") from e


def load_study(path: str | Path) -> Study:
    """Read and validate a study file; a relative store path is taken from the current
    directory, like any path given on the command line."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise StudyError(f"cannot read study file {path}: {e.strerror or e}") from e
    study = parse_study(text, str(path))
    if "://" not in study.store:
        study = replace(study, store=str(Path(study.store).expanduser().resolve()))
    return study
