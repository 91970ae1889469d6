"""Validation of user input, one rule per kind of value: study files and the CLI.

Every study kind (sweeps in :mod:`jobs.study`, inverse studies in
:mod:`jobs.inverse.study`) and the command line (:mod:`cli.params`) check their input
with these functions, so a range, a model table or a solver table means the same
wherever it is written. Each function takes the value and ``where``, the key path it
came from (``loads.deflection_mm.step``, ``conditions[1].repeats``), and raises one
:class:`~jobs.errors.StudyError` whose message names the key path, the value given and
what is allowed::

    loads.deflection_mm.step: must be > 0, got -5

Ranges have one rule (:func:`inclusive_range`): ``start`` to ``stop`` inclusive in
steps of ``step``, at most :data:`MAX_VALUES` values, each rounded to
:data:`DECIMALS` decimals so that 0.1 steps do not leave 0.30000000000000004 in a
store coordinate. A study writes it ``{ start = 10, stop = 40, step = 5 }``, the CLI
``10:40:5``; a list is ``[10, 20, 30]`` or ``10,20,30`` (:func:`values`,
:func:`values_from_text`).

Why not pydantic. Pydantic v2 (``extra="forbid"``, a JSON Schema for editors) was
considered and not adopted, because it would add code rather than delete it. It would
replace the primitive checks here (``table`` to ``identifier``: about 65 lines) with
about 14 model classes for the two study kinds (about 90 lines with their field
constraints) plus a formatter (about 20 lines) that turns its multi-line
``ValidationError`` into the one-line, key-naming message the CLI prints. Nothing else
goes: the three forms of a value list and the range rule need a custom validator; the
preset-plus-overrides merge onto ``ModelSpec`` (a frozen dataclass of ``farm``, which
must not depend on pydantic) stays; so do the cross-field rules (sampled and listed
loads, an inflated model needs a pressure, least squares needs ``per_solve``, distinct
condition names, deflections the tyre can take, paths relative to the study). That is
about 45 more lines and a new hard dependency of every worker; the editor schema, the
one real gain, can be written by hand for the two tables if it is ever wanted.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from farm.errors import SpecError
from farm.presets import MATERIAL_PRESETS, default_model
from farm.specs import ModelSpec, SolverSettings
from jobs.errors import StudyError
from storage.schema import GROUP_NAME

MAX_VALUES = 100_000  # values one list or range may expand to
DECIMALS = 9  # rounding of range values (a nanometre in mm)
IDENTIFIER = GROUP_NAME  # names of store groups, studies and conditions: the store's rule
MODEL_KINDS = ("reduced", "full")
MODEL_KEYS = {"kind", "materials", "road", "cut_faces", "geometry", "mesh", "contact",
              "sector_angle"}
SOLVER_KEYS = {"timeout_s", "threads", "initial_increment", "min_increment", "max_increment",
               "max_increments", "max_path_length", "retry_smaller_increments"}
RANGE_KEYS = {"start", "stop", "step"}
RANGE_HINT = "give start:stop:step (e.g. 10:40:5) or a list (10,20,30)"


# ------------------------------------------------------------------- errors and files


def fail(where: str, message: str) -> StudyError:
    """The error for the value at key path ``where``: ``"<where>: <message>"``."""
    return StudyError(f"{where}: {message}")


@contextmanager
def located(source: str) -> Iterator[None]:
    """Prefix every :class:`StudyError` raised inside with ``source`` (the file name)."""
    try:
        yield
    except StudyError as e:
        raise StudyError(f"{source}: {e}") from e.__cause__


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """The TOML document ``text`` as a dict (raises :class:`StudyError` naming ``source``)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{source} is not valid TOML: {e}") from e


def read_text(path: Path, what: str = "study file") -> str:
    """The text of ``path`` (raises :class:`StudyError` saying why it cannot be read)."""
    try:
        return path.read_text()
    except OSError as e:
        raise StudyError(f"cannot read {what} {path}: {e.strerror or e}") from e


# ------------------------------------------------------------------ tables and scalars


def table(data: Any, where: str, allowed: set[str], required: set[str] = frozenset()
          ) -> dict[str, Any]:
    """``data`` if it is a table with only ``allowed`` keys and every ``required`` one."""
    if not isinstance(data, dict):
        raise fail(where, f"must be a table, got {type(data).__name__} {data!r}")
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise fail(f"{where}.{unknown[0]}", f"unknown key; allowed: {', '.join(sorted(allowed))}")
    missing = sorted(required - set(data))
    if missing:
        raise fail(f"{where}.{missing[0]}", "is required")
    return data


def _bounds(low: float | None, high: float | None, strict: bool) -> str:
    if low is not None and high is not None:
        return f"in {'(' if strict else '['}{low:g}, {high:g}]"
    if low is not None:
        return f"{'>' if strict else '>='} {low:g}"
    return f"<= {high:g}"


def number(value: Any, where: str, *, low: float | None = None, high: float | None = None,
           strict: bool = False) -> float:
    """A finite number (not a boolean), ``>= low`` (``> low`` if ``strict``), ``<= high``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise fail(where, f"must be a number, got {value!r}")
    if ((low is not None and (value < low or (strict and value == low)))
            or (high is not None and value > high)):
        raise fail(where, f"must be {_bounds(low, high, strict)}, got {value!r}")
    return float(value)


def integer(value: Any, where: str, *, low: int | None = None, high: int | None = None) -> int:
    """An integer (not a boolean) in ``[low, high]`` (either bound optional)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise fail(where, f"must be an integer, got {value!r}")
    if (low is not None and value < low) or (high is not None and value > high):
        raise fail(where, f"must be an integer {_bounds(low, high, False)}, got {value!r}")
    return value


def boolean(value: Any, where: str) -> bool:
    """``true`` or ``false`` (not 0 or 1)."""
    if not isinstance(value, bool):
        raise fail(where, f"must be true or false, got {value!r}")
    return value


def choice(value: Any, where: str, allowed: tuple[str, ...]) -> str:
    """One of ``allowed``."""
    if not isinstance(value, str) or value not in allowed:
        raise fail(where, f"must be one of {', '.join(allowed)}, got {value!r}")
    return value


def choices(value: Any, where: str, allowed: tuple[str, ...]) -> tuple[str, ...]:
    """A non-empty list of ``allowed`` strings, repeats dropped, order kept."""
    if not isinstance(value, list) or not value:
        raise fail(where, f"must be a non-empty list, got {value!r}")
    for item in value:
        if not isinstance(item, str) or item not in allowed:
            raise fail(where, f"must list {', '.join(allowed)}; got {item!r}")
    return tuple(dict.fromkeys(value))


def string(value: Any, where: str, what: str = "a string", *, blank: bool = True) -> str:
    """A string (a non-blank one unless ``blank``); ``what`` says what it should be."""
    if not isinstance(value, str) or (not blank and not value.strip()):
        raise fail(where, f"must be {what}, got {value!r}")
    return value


def identifier(value: Any, where: str) -> str:
    """A name usable as a store group or a file name (:data:`IDENTIFIER`)."""
    if not (isinstance(value, str) and IDENTIFIER.fullmatch(value)):
        raise fail(where, f"must be letters, digits, '_', '.', '-' (at most 128), got {value!r}")
    return value


# ------------------------------------------------------------------- values and ranges


def inclusive_range(start: float, stop: float, step: float, where: str) -> tuple[float, ...]:
    """``start, start + step, ...`` up to ``stop`` inclusive, rounded to :data:`DECIMALS`.

    The one range rule of study files and the CLI. ``stop`` is included when it is
    within 1e-9 steps of the grid (so 0.1 steps reach 0.3); at most :data:`MAX_VALUES`.
    """
    if not (math.isfinite(step) and step > 0):
        raise fail(f"{where}.step", f"must be > 0, got {step!r}")
    if stop < start:
        raise fail(where, f"stop ({stop:g}) must not be below start ({start:g})")
    n = math.floor((stop - start) / step + 1e-9) + 1
    if n > MAX_VALUES:
        raise fail(where, f"{n} values is too many (at most {MAX_VALUES})")
    return tuple(round(start + k * step, DECIMALS) for k in range(n))


def values(value: Any, where: str, *, low: float | None = None, strict: bool = False
           ) -> tuple[float, ...]:
    """A number, a non-empty list of numbers or a ``{start, stop, step}`` range table ->
    the sorted distinct values, each ``>= low`` (``> low`` if ``strict``)."""
    if isinstance(value, dict):
        r = table(value, where, RANGE_KEYS, RANGE_KEYS)
        start, stop = (number(r[k], f"{where}.{k}", low=low, strict=strict)
                       for k in ("start", "stop"))
        out = inclusive_range(start, stop, number(r["step"], f"{where}.step", low=0,
                                                  strict=True), where)
    elif isinstance(value, list):
        if not value:
            raise fail(where, "must not be empty")
        if len(value) > MAX_VALUES:
            raise fail(where, f"{len(value)} values is too many (at most {MAX_VALUES})")
        out = [number(v, f"{where}[{k}]", low=low, strict=strict) for k, v in enumerate(value)]
    else:
        out = [number(value, where, low=low, strict=strict)]
    return tuple(sorted({round(v, DECIMALS) for v in out}))


def values_from_text(text: str, where: str, *, low: float | None = None, strict: bool = False
                     ) -> tuple[float, ...]:
    """The command line's form of :func:`values`: ``"10:40:5"`` (the range
    ``{start = 10, stop = 40, step = 5}``), ``"10,20,30"`` or ``"30"``."""
    parts = text.split(":") if ":" in text else text.split(",")
    try:
        numbers = [float(p) for p in parts]
    except ValueError as e:
        raise StudyError(f"cannot read {where} {text!r}: {RANGE_HINT}") from e
    if ":" not in text:
        return values(numbers, where, low=low, strict=strict)
    if len(numbers) != 3:
        raise StudyError(f"{where} range {text!r} needs three numbers: start:stop:step")
    return values(dict(zip(("start", "stop", "step"), numbers, strict=True)), where, low=low,
                  strict=strict)


# ------------------------------------------------------------------------ model, solver


def model(data: Any, where: str = "model") -> ModelSpec:
    """A ``[model]`` table -> :class:`ModelSpec`: ``kind``, a ``materials`` preset name (or
    a table per region over ``table-3.1``) and overrides of the preset's other keys."""
    t = table(data, where, MODEL_KEYS, {"kind"})
    kind = t["kind"]
    if kind not in MODEL_KINDS:
        raise fail(f"{where}.kind", f"unknown model {kind!r}: choose 'reduced' or 'full'")
    materials = t.get("materials", "table-3.1")
    if isinstance(materials, str) and materials not in MATERIAL_PRESETS:
        raise fail(f"{where}.materials", f"unknown preset {materials!r}; presets: "
                   f"{', '.join(MATERIAL_PRESETS)} (or give a table per region)")
    base = default_model(kind, materials if isinstance(materials, str) else "table-3.1")
    overrides = {k: v for k, v in t.items()
                 if k != "kind" and not (k == "materials" and isinstance(v, str))}
    return override_model(base, overrides, where)


def override_model(base: ModelSpec, overrides: dict[str, Any], where: str = "model"
                   ) -> ModelSpec:
    """``base`` with ``overrides`` (nested tables merged key by key, unknown keys named)."""
    try:
        return ModelSpec.from_dict(_merge(base.to_dict(), overrides, where))
    except SpecError as e:  # its messages name the key (model.mesh.tread ...)
        raise StudyError(str(e)) from e


def _merge(base: dict, override: dict, where: str) -> dict:
    out = dict(table(override, where, set(base)))
    for key, value in override.items():
        if isinstance(base[key], dict):
            out[key] = _merge(base[key], value, f"{where}.{key}")
    return {**base, **out}


@dataclass(frozen=True)
class SolverTable:
    """A ``[solver]`` table: ccx settings and how the sweep splits and retries paths."""

    settings: SolverSettings
    max_path_length: int = 0  # split load paths longer than this (0: never)
    retry_smaller_increments: bool = True


def solver(data: Any, where: str = "solver") -> SolverTable:
    """A ``[solver]`` table (keys :data:`SOLVER_KEYS`; ``timeout_s`` in seconds)."""
    t = table(data, where, SOLVER_KEYS)
    kwargs: dict[str, Any] = {}
    if "timeout_s" in t:
        kwargs["timeout"] = number(t["timeout_s"], f"{where}.timeout_s", low=0, strict=True)
    for k in ("threads", "max_increments"):
        if k in t:
            kwargs[k] = integer(t[k], f"{where}.{k}", low=1)
    for k in ("initial_increment", "min_increment", "max_increment"):
        if k in t:
            kwargs[k] = number(t[k], f"{where}.{k}", low=0, strict=True)
    try:
        settings = SolverSettings(**kwargs)
    except SpecError as e:
        raise StudyError(str(e)) from e
    return SolverTable(settings,
                       integer(t.get("max_path_length", 0), f"{where}.max_path_length", low=0),
                       boolean(t.get("retry_smaller_increments", True),
                               f"{where}.retry_smaller_increments"))
