"""Validation of user input, one rule per kind of value: study files and the CLI.

Every study kind (sweeps in :mod:`jobs.study`, inverse studies in
:mod:`jobs.inverse.study`) and the command line (:mod:`tyre_farm_cli.params`) check their input
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

Limits (docs/limits.md is their one table). Files are read only when they are regular
files of at most :data:`MAX_FILE_BYTES`, as UTF-8, nested at most :data:`MAX_DEPTH`
deep (:func:`read_text`, :func:`parse_toml`): a FIFO, a device or a directory is refused
before it is opened for reading, so nothing waits for ever. Counts are computed before
anything is expanded: a study has at most :data:`EXPERIMENTS` experiments and a model at
most :data:`MESH_NODES` mesh nodes, practical limits that a researcher may raise through
their environment variables (:class:`Limit`); physical bounds of the specs (moduli,
pressures, threads, timeouts) live in :mod:`farm.specs`. Paths, URLs, output files and
folders, scheduler addresses and worker counts given on the command line are checked
here too (:func:`location`, :func:`output_file`, :func:`output_folder`,
:func:`scheduler_address`, :func:`workers`), before anything is solved.

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

import ipaddress
import math
import os
import re
import reprlib
import stat
import tomllib
import unicodedata
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from farm.errors import SpecError
from farm.presets import MATERIAL_PRESETS, default_model, mesh_presets
from farm.specs import TIMEOUT_S, ModelSpec, SolverSettings
from jobs.errors import StudyError
from storage import open_store
from storage.errors import StoreError
from storage.schema import GROUP_NAME

MAX_VALUES = 100_000  # values one list or range may expand to
DECIMALS = 9  # rounding of range values (a nanometre in mm)
MAX_FILE_BYTES = 1 << 20  # study files and reference tables: 1 MiB (the thesis' are < 2 KiB)
MAX_DEPTH = 8  # tables and lists in a study nest at most this deep (the deepest needs 4)
MAX_PATH_CHARS = 4096  # a path or URL (Linux' PATH_MAX)
MAX_WORKERS = 1024  # --workers: processes of the embedded cluster, or workers to wait for
MAX_SEED = 2 ** 32 - 1  # seeds of designs and noise draws (numpy's legacy range)
MAX_EVALUATIONS = 100_000  # evaluations of one optimisation loop
MAX_REPEATS = 1_000  # repeats of one inverse condition
MAX_LOOPS = 10_000  # optimisation loops of one inverse study
IDENTIFIER = GROUP_NAME  # names of store groups, studies and conditions: the store's rule
RESERVED_NAMES = frozenset({"zarr.json"})  # Zarr v3's metadata file in every group
WINDOWS_PATH = re.compile(r"[A-Za-z]:[\\/]")  # C:\farm or C:/farm
MODEL_KINDS = ("reduced", "full")
MODEL_KEYS = {"kind", "materials", "road", "cut_faces", "geometry", "mesh", "contact",
              "sector_angle"}
SOLVER_KEYS = {"timeout_s", "threads", "initial_increment", "min_increment", "max_increment",
               "max_increments", "max_path_length", "retry_smaller_increments"}
RANGE_KEYS = {"start", "stop", "step"}
RANGE_HINT = "give start:stop:step (e.g. 10:40:5) or a list (10,20,30)"
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "inproc")
# ucx:// needs ucx-py and RDMA hardware that the farm does not install or test; it was
# accepted here and then failed deep in distributed with a TypeError (issue 26)
UNSUPPORTED_SCHEMES = {"ucx": "UCX (ucx://) is not supported by the farm: its workers talk "
                              "tcp:// or tls://"}
HOSTNAME = re.compile(r"(?=.{1,253}$)[A-Za-z0-9_]([A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?"
                      r"(\.[A-Za-z0-9_]([A-Za-z0-9_-]{0,61}[A-Za-z0-9_])?)*")

_SHORT = reprlib.Repr()
_SHORT.maxstring = _SHORT.maxother = 60
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxdict = 2, 6, 4


def shown(value: Any) -> str:
    """``repr(value)`` cut short: an error line names a 1 MiB list, it does not print it."""
    return _SHORT.repr(value)


# ------------------------------------------------------------------------------ limits


@dataclass(frozen=True)
class Limit:
    """A practical limit (not a physical one) that a researcher may raise: the
    environment variable ``env`` overrides ``default`` (docs/limits.md)."""

    name: str  # what is counted, plural ("experiments")
    env: str
    default: int

    def value(self) -> int:
        text = os.environ.get(self.env)
        if text is None or not text.strip():
            return self.default
        try:
            value = int(text)
        except ValueError:
            value = 0
        if not 1 <= value <= 10 ** 12:
            raise StudyError(f"{self.env} must be a whole number of {self.name} in [1, 1e12], "
                             f"got {shown(text)}")
        return value

    def check(self, count: int, where: str, what: str) -> int:
        """``count`` if within the limit, else one error naming ``where`` and ``what``."""
        limit = self.value()
        if count > limit:
            raise fail(where, f"{what} is {count} {self.name}, above the limit of {limit} "
                       f"(set {self.env} to raise it; docs/limits.md)")
        return count


# Mesh nodes: the default full model has 1760; 200 000 nodes is a day of ccx per load path
# on one core (ccx's time grows faster than linearly in the node count).
EXPERIMENTS = Limit("experiments", "FARM_MAX_EXPERIMENTS", 10_000)
MESH_NODES = Limit("mesh nodes", "FARM_MAX_MESH_NODES", 200_000)


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
    """The TOML document ``text`` as a dict, nested at most :data:`MAX_DEPTH` deep
    (raises :class:`StudyError` naming ``source``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{source} is not valid TOML: {e}") from e
    except RecursionError as e:  # tomllib recurses once per level of [ or {
        raise StudyError(f"{source} is nested too deeply to read (lists or tables inside "
                         f"each other hundreds of levels deep; a study needs {MAX_DEPTH} "
                         "at most)") from e
    with located(source):
        _check_depth(data)
    return data


def _check_depth(data: dict) -> None:
    """Walk the document without recursion: too deep a value is refused before any
    check (or error message) recurses into it."""
    stack: list[tuple[Any, str, int]] = [(data, "", 0)]
    while stack:
        value, where, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise fail(where[:80] + ("..." if len(where) > 80 else ""),
                       f"nested more than {MAX_DEPTH} tables or lists deep")
        if isinstance(value, dict):
            stack += [(v, f"{where}.{k}" if where else str(k), depth + 1)
                      for k, v in value.items()]
        elif isinstance(value, list):
            stack += [(v, f"{where}[{k}]", depth + 1) for k, v in enumerate(value)]


_FILE_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
               (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
               (stat.S_ISSOCK, "a socket"))


def _file_kind(mode: int) -> str:
    return next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")


def read_text(path: Path, what: str = "study file") -> str:
    """The UTF-8 text of the regular file ``path``, at most :data:`MAX_FILE_BYTES`.

    A FIFO, a device or a directory is refused from its ``stat`` before it is opened
    for reading (opening a FIFO waits for a writer; ``/dev/urandom`` never ends), and
    the file is opened non-blocking and checked again, in case it was swapped in
    between. Raises :class:`StudyError` saying what is wrong and what to give instead.
    """
    try:
        data = _read_regular(path)
    except OSError as e:
        raise StudyError(f"cannot read {what} {path}: {e.strerror or e}") from e
    except ValueError as e:  # a NUL byte in the path
        raise StudyError(f"cannot read {what} {shown(str(path))}: {e}") from e
    if isinstance(data, str):
        raise StudyError(f"cannot read {what} {path}: it is {data}, not a regular file")
    if len(data) > MAX_FILE_BYTES:
        raise StudyError(f"cannot read {what} {path}: it is larger than "
                         f"{MAX_FILE_BYTES >> 20} MiB")
    try:
        return data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise StudyError(f"cannot read {what} {path}: it is not UTF-8 text (byte "
                         f"0x{data[e.start]:02x} on line {line}): save it as UTF-8") from e


def regular_file(path: Path, what: str) -> Path:
    """``path`` if it is a regular file, judged from its ``stat`` alone (a table that
    another module reads later, and may be large): a FIFO or a device is refused."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError) as e:
        raise StudyError(f"cannot read {what} {shown(str(path))}: "
                         f"{getattr(e, 'strerror', None) or e}") from e
    if not stat.S_ISREG(mode):
        raise StudyError(f"cannot read {what} {path}: it is {_file_kind(mode)}, not a "
                         "regular file")
    return path


def _read_regular(path: Path) -> bytes | str:
    """The first ``MAX_FILE_BYTES + 1`` bytes of ``path``, or what kind of file it is
    when it is not a regular one."""
    mode = os.stat(path).st_mode
    if not stat.S_ISREG(mode):
        return _file_kind(mode)
    with os.fdopen(os.open(path, os.O_RDONLY | os.O_NONBLOCK), "rb") as f:
        mode = os.fstat(f.fileno()).st_mode
        if not stat.S_ISREG(mode):
            return _file_kind(mode)
        return f.read(MAX_FILE_BYTES + 1)


# ------------------------------------------------------------------ tables and scalars


def table(data: Any, where: str, allowed: set[str], required: set[str] = frozenset()
          ) -> dict[str, Any]:
    """``data`` if it is a table with only ``allowed`` keys and every ``required`` one."""
    if not isinstance(data, dict):
        raise fail(where, f"must be a table, got {type(data).__name__} {shown(data)}")
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
        raise fail(where, f"must be a number, got {shown(value)}")
    if ((low is not None and (value < low or (strict and value == low)))
            or (high is not None and value > high)):
        raise fail(where, f"must be {_bounds(low, high, strict)}, got {shown(value)}")
    return float(value)


def integer(value: Any, where: str, *, low: int | None = None, high: int | None = None) -> int:
    """An integer (not a boolean) in ``[low, high]`` (either bound optional)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise fail(where, f"must be an integer, got {shown(value)}")
    if (low is not None and value < low) or (high is not None and value > high):
        raise fail(where, f"must be an integer {_bounds(low, high, False)}, got {shown(value)}")
    return value


def boolean(value: Any, where: str) -> bool:
    """``true`` or ``false`` (not 0 or 1)."""
    if not isinstance(value, bool):
        raise fail(where, f"must be true or false, got {shown(value)}")
    return value


def choice(value: Any, where: str, allowed: tuple[str, ...]) -> str:
    """One of ``allowed``."""
    if not isinstance(value, str) or value not in allowed:
        raise fail(where, f"must be one of {', '.join(allowed)}, got {shown(value)}")
    return value


def choices(value: Any, where: str, allowed: tuple[str, ...]) -> tuple[str, ...]:
    """A non-empty list of ``allowed`` strings, repeats dropped, order kept."""
    if not isinstance(value, list) or not value:
        raise fail(where, f"must be a non-empty list, got {shown(value)}")
    for item in value:
        if not isinstance(item, str) or item not in allowed:
            raise fail(where, f"must list {', '.join(allowed)}; got {shown(item)}")
    return tuple(dict.fromkeys(value))


def string(value: Any, where: str, what: str = "a string", *, blank: bool = True) -> str:
    """A string (a non-blank one unless ``blank``); ``what`` says what it should be."""
    if not isinstance(value, str) or (not blank and not value.strip()):
        raise fail(where, f"must be {what}, got {shown(value)}")
    return value


def identifier(value: Any, where: str) -> str:
    """A name usable as a store group or a file name (:data:`IDENTIFIER`)."""
    if not (isinstance(value, str) and IDENTIFIER.fullmatch(value)):
        raise fail(where, f"must be letters, digits, '_', '.', '-' (at most 128), "
                   f"got {shown(value)}")
    if value in RESERVED_NAMES:  # issue 26: passed here, then failed in create_group
        raise fail(where, f"{shown(value)} is the name of Zarr's own metadata file in every "
                   "group: choose another name")
    return value


# ------------------------------------------------------------------- values and ranges


def inclusive_range(start: float, stop: float, step: float, where: str) -> tuple[float, ...]:
    """``start, start + step, ...`` up to ``stop`` inclusive, rounded to :data:`DECIMALS`.

    The one range rule of study files and the CLI. ``stop`` is included when it is
    within 1e-9 steps of the grid (so 0.1 steps reach 0.3); at most :data:`MAX_VALUES`,
    counted before anything is made (a step of 1e-308 is a count, not an allocation).
    """
    if not (math.isfinite(step) and step > 0):
        raise fail(f"{where}.step", f"must be > 0, got {shown(step)}")
    if stop < start:
        raise fail(where, f"stop ({stop:g}) must not be below start ({start:g})")
    steps = (stop - start) / step
    if not steps < MAX_VALUES:  # also an infinite count, which has no integer
        n = f"{math.floor(steps + 1e-9) + 1}" if math.isfinite(steps) else "too many:"
        raise fail(where, f"{n} values is too many (at most {MAX_VALUES}): step {step:g} "
                   f"over {start:g} to {stop:g}")
    n = math.floor(steps + 1e-9) + 1
    return tuple(round(start + k * step, DECIMALS) for k in range(n))


def values(value: Any, where: str, *, low: float | None = None, high: float | None = None,
           strict: bool = False) -> tuple[float, ...]:
    """A number, a non-empty list of numbers or a ``{start, stop, step}`` range table ->
    the sorted distinct values, each ``>= low`` (``> low`` if ``strict``) and ``<= high``,
    also once rounded to :data:`DECIMALS` (5e-324 is not a deflection > 0)."""
    bounds = {"low": low, "high": high, "strict": strict}
    if isinstance(value, dict):
        r = table(value, where, RANGE_KEYS, RANGE_KEYS)
        start, stop = (number(r[k], f"{where}.{k}", **bounds) for k in ("start", "stop"))
        out = inclusive_range(start, stop, number(r["step"], f"{where}.step", low=0,
                                                  strict=True), where)
        smallest = start
    elif isinstance(value, list):
        if not value:
            raise fail(where, "must not be empty")
        if len(value) > MAX_VALUES:
            raise fail(where, f"{len(value)} values is too many (at most {MAX_VALUES})")
        out = [number(v, f"{where}[{k}]", **bounds) for k, v in enumerate(value)]
        smallest = min(out)
    else:
        out = [smallest := number(value, where, **bounds)]
    rounded = sorted({round(v, DECIMALS) for v in out})
    if low is not None and strict and rounded[0] <= low:
        raise fail(where, f"must be > {low:g}, got {shown(smallest)} (rounds to "
                   f"{rounded[0]:g} at {DECIMALS} decimals)")
    return tuple(rounded)


def values_from_text(text: str, where: str, *, low: float | None = None,
                     high: float | None = None, strict: bool = False) -> tuple[float, ...]:
    """The command line's form of :func:`values`: ``"10:40:5"`` (the range
    ``{start = 10, stop = 40, step = 5}``), ``"10,20,30"`` or ``"30"``."""
    parts = text.split(":") if ":" in text else text.split(",")
    try:
        numbers = [float(p) for p in parts]
    except ValueError as e:
        raise StudyError(f"cannot read {where} {shown(text)}: {RANGE_HINT}") from e
    if ":" not in text:
        return values(numbers, where, low=low, high=high, strict=strict)
    if len(numbers) != 3:
        raise StudyError(f"{where} range {shown(text)} needs three numbers: start:stop:step")
    return values(dict(zip(("start", "stop", "step"), numbers, strict=True)), where, low=low,
                  high=high, strict=strict)


# ------------------------------------------------------------------------ model, solver


def model(data: Any, where: str = "model") -> ModelSpec:
    """A ``[model]`` table -> :class:`ModelSpec`: ``kind``, a ``materials`` preset name (or
    a table per region over ``table-3.1``) and overrides of the preset's other keys."""
    t = table(data, where, MODEL_KEYS, {"kind"})
    kind = t["kind"]
    if kind not in MODEL_KINDS:
        raise fail(f"{where}.kind", f"unknown model {shown(kind)}: choose 'reduced' or 'full'")
    materials = t.get("materials", "table-3.1")
    if isinstance(materials, str) and materials not in MATERIAL_PRESETS:
        raise fail(f"{where}.materials", f"unknown preset {shown(materials)}; presets: "
                   f"{', '.join(MATERIAL_PRESETS)} (or give a table per region)")
    mesh = t.get("mesh", "thesis")
    if isinstance(mesh, str) and mesh not in mesh_presets(kind):
        raise fail(f"{where}.mesh", f"unknown mesh preset {shown(mesh)} for the {kind} model; "
                   f"presets: {', '.join(mesh_presets(kind))} (or give a table of counts)")
    base = default_model(kind, materials if isinstance(materials, str) else "table-3.1",
                         mesh if isinstance(mesh, str) else "thesis")
    overrides = {k: v for k, v in t.items()
                 if k != "kind" and not (k in ("materials", "mesh") and isinstance(v, str))}
    return override_model(base, overrides, where)


def override_model(base: ModelSpec, overrides: dict[str, Any], where: str = "model"
                   ) -> ModelSpec:
    """``base`` with ``overrides`` (nested tables merged key by key, unknown keys named),
    a mesh of at most :data:`MESH_NODES` nodes."""
    try:
        spec = ModelSpec.from_dict(_merge(base.editable_dict(), overrides, where))
    except SpecError as e:  # its messages name the key (model.mesh.tread ...)
        raise StudyError(str(e)) from e
    m = spec.mesh
    MESH_NODES.check(spec.node_estimate, f"{where}.mesh",
                     f"{m.meridional} x {m.circumferential} elements (tread={m.tread}, "
                     f"sidewall={m.sidewall}, bead={m.bead}, circumferential="
                     f"{m.circumferential})")
    return spec


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
        kwargs["timeout"] = number(t["timeout_s"], f"{where}.timeout_s", low=TIMEOUT_S[0],
                                   high=TIMEOUT_S[1])
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


# ------------------------------------------------------------ paths, addresses, workers


def location(value: Any, where: str, what: str = "a path or URL", base: Path | None = None
             ) -> str:
    """A store or cache location: a URL (``scheme://...``) as given, or a local path made
    absolute (``~`` expanded, a relative one taken from ``base``, default the current
    folder). Control characters, over-long names and a ``~user`` that does not exist are
    refused here, where the key can still be named."""
    text = string(value, where, what, blank=False)
    if len(text) > MAX_PATH_CHARS or any(ord(c) < 32 or ord(c) == 127 for c in text):
        raise fail(where, f"must be {what} of at most {MAX_PATH_CHARS} printable characters, "
                   f"got {shown(text)}")
    invisible = [c for c in text if unicodedata.category(c) == "Cf"]
    if invisible:  # a U+202E makes a path read differently from what it is (issue 26)
        raise fail(where, f"contains the invisible formatting character "
                   f"U+{ord(invisible[0]):04X} ({unicodedata.name(invisible[0], '?')}): "
                   "type the path again")
    if "://" in text:
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9+.-]*://\S+", text):
            raise fail(where, f"is not a URL (scheme://location), got {shown(text)}")
        return text
    if any(len(part.encode()) > 255 for part in Path(text).parts):
        raise fail(where, f"has a path component longer than 255 bytes: {shown(text)}")
    if os.name == "posix" and (WINDOWS_PATH.match(text) or "\\" in text):
        raise fail(where, f"{shown(text)} looks like a Windows path; on this system paths "
                   "use '/' (e.g. /data/farm.zarr)")
    try:
        path = Path(text).expanduser()
        path = path if base is None else base / path
        _check_links(path, where)
        return str(path.resolve())
    except (RuntimeError, KeyError, OSError) as e:  # ~nobody: no such user
        raise fail(where, f"cannot resolve the path {shown(text)}: {e}") from e


def _check_links(path: Path, where: str) -> None:
    """Refuse a path through a symbolic link whose target does not exist: the store would
    be created at the link's target, somewhere the user did not name (issue 26)."""
    for part in (path, *path.parents):
        if part.is_symlink() and not part.exists():
            raise fail(where, f"{part} is a symbolic link to {os.readlink(part)}, which does "
                       "not exist: create the target or give another path")


def store_location(value: Any, where: str, base: Path | None = None) -> str:
    """A store: :func:`location`, then what the storage layer accepts as a store
    (:func:`storage.open_store`, no I/O: schemes, buckets, control characters), so that
    a store no worker can write is refused before a cluster starts."""
    text = location(value, where, "a directory path or URL", base)
    try:
        open_store(value)  # as written: "s3:/bucket" is a typo, not a folder "s3:"
    except StoreError as e:
        raise fail(where, str(e)) from e
    return text


#: Keys of fsspec/s3fs/gcsfs/adlfs options that hold secrets: refused in study files,
#: which get copied, committed and shared. Credentials come from the environment
#: (``AWS_ACCESS_KEY_ID``/``AWS_SECRET_ACCESS_KEY``, a profile, an instance role).
SECRET_OPTIONS = frozenset({"key", "secret", "token", "password", "session_token",
                            "aws_access_key_id", "aws_secret_access_key", "aws_session_token",
                            "account_key", "sas_token", "client_secret", "connection_string"})
MAX_OPTIONS_DEPTH = 3  # client_kwargs.config.x: deeper tables are no fsspec option


def storage_options(data: Any, where: str, store: str) -> dict[str, Any]:
    """fsspec options of a URL store (``[study.storage_options]``): endpoint, region,
    ``anon``, ``client_kwargs``... as strings, numbers, booleans and nested tables.
    Refused: options for a local directory (they would be ignored), and secrets
    (:data:`SECRET_OPTIONS`: credentials stay in environment variables)."""
    if "://" not in store:
        raise fail(where, f"are for object-store URLs (s3://...), but the store is the "
                   f"local path {shown(store)}: drop the table")
    return _options(data, where, 1)


def _options(data: Any, where: str, depth: int) -> dict[str, Any]:
    if not isinstance(data, dict):
        raise fail(where, f"must be a table, got {type(data).__name__} {shown(data)}")
    if depth > MAX_OPTIONS_DEPTH:
        raise fail(where, f"nests deeper than {MAX_OPTIONS_DEPTH} tables")
    out: dict[str, Any] = {}
    for name, value in data.items():
        at = f"{where}.{name}"
        if name.lower() in SECRET_OPTIONS:
            raise fail(at, "credentials do not belong in a study file: set them in the "
                       "environment (AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY for S3, "
                       "or a profile) on the client and on every worker")
        if isinstance(value, dict):
            out[name] = _options(value, at, depth + 1)
        elif isinstance(value, str | bool | int | float):
            if isinstance(value, float) and not math.isfinite(value):
                raise fail(at, f"must be finite, got {shown(value)}")
            out[name] = value
        else:
            raise fail(at, f"must be a string, number, boolean or table, got {shown(value)}")
    return out


def output_file(path: Path, where: str) -> Path:
    """A file to write later: not a directory, in an existing, writable folder.
    Checked before any work, so that a finished solve is never lost to a bad path."""
    path = Path(path).expanduser()
    if path.is_dir():
        raise fail(where, f"{path} is a directory: give a file name")
    folder = path.parent
    if not folder.is_dir():
        raise fail(where, f"the folder {folder} of {path} does not exist (create it first)")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise fail(where, f"the folder {folder} of {path} is not writable")
    return path


def output_folder(path: Path, where: str) -> Path:
    """A folder to write into later (made if missing): not a file, and its nearest
    existing ancestor a writable folder."""
    path = Path(path).expanduser()
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        what = "is" if existing == path else f"would be made under {existing}, which is"
        raise fail(where, f"{path} {what} a file, not a folder: give a folder path")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise fail(where, f"{existing} is not writable: give a folder you can write to")
    return path


def scheduler_address(value: str | None, where: str = "--scheduler") -> str | None:
    """A Dask scheduler address: ``[scheme://]host:port`` with a scheme of
    :data:`SCHEDULER_SCHEMES` (tcp when none is given), a host name, IPv4 or [IPv6]
    address and a port in 1-65535; or ``inproc://...``. ``None`` (embedded) passes."""
    if value is None:
        return None
    hint = "give host:port or tcp://host:port (e.g. tcp://127.0.0.1:8786)"
    scheme, sep, rest = value.partition("://")
    if not sep:
        scheme, rest = "tcp", value
    if scheme in UNSUPPORTED_SCHEMES:
        raise fail(where, f"{UNSUPPORTED_SCHEMES[scheme]}: {hint}")
    if scheme not in SCHEDULER_SCHEMES:
        raise fail(where, f"unknown protocol {shown(scheme)} in {shown(value)}; use one of "
                   f"{', '.join(SCHEDULER_SCHEMES)}: {hint}")
    if scheme == "inproc":
        if not re.fullmatch(r"[\w.:/-]{1,256}", rest):
            raise fail(where, f"{shown(value)} is not an inproc address (inproc://host/pid/n)")
        return value
    host, colon, port = rest.rpartition(":")
    if not colon or not _is_host(host) or not (port.isdigit() and 1 <= int(port) <= 65535):
        raise fail(where, f"{shown(value)} is not a scheduler address: {hint}")
    return value


def _is_host(host: str) -> bool:
    if host.startswith("[") and host.endswith("]"):
        try:
            ipaddress.IPv6Address(host[1:-1])
        except ValueError:
            return False
        return True
    return bool(HOSTNAME.fullmatch(host))


def workers(value: int | None, where: str = "--workers") -> int | None:
    """A worker count in [1, :data:`MAX_WORKERS`]; ``None`` (one per core) passes."""
    return None if value is None else integer(value, where, low=1, high=MAX_WORKERS)
