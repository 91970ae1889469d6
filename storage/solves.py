"""The inverse-solves group: every solve of one inverse study (thesis ch. 4), client-written.

One group per study sits beside the experiment groups of a store. It has no
``schema_version`` (so :func:`storage.list_groups`, which lists experiment groups, skips
it) but ``kind = "inverse-solves"``; it opens with ``xarray.open_zarr(store,
group=...)`` or, with checks and clear errors, :func:`open_solves`. Its variables are
:data:`VARIABLES` (``docs/schema.md``, "Inverse-solves groups"); everything the
chapter-4 tables need is in it, so reports read the group, never the loops.

The client is the only writer: :func:`write_solves` replaces the whole group (loops
are deterministic, so a re-run writes the same values) and then refreshes the root's
consolidated metadata, as every client write of this package does. Callers hand plain
values: :class:`Unknowns`, one :class:`SolveRecord` per solve and :class:`SolvesAttrs`.

Layout versions (group attribute ``solves_version``): 1 (no attribute) lacks the
reference experiment's ``reference_total_force`` and ``reference_moment``; such groups
still open, with those two variables NaN.
"""

from __future__ import annotations

import json
import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import xarray as xr
import zarr

from storage.errors import SchemaError, StoreError
from storage.lock import client_lock
from storage.paths import (
    StoreLike,
    check_group_name,
    describe,
    open_existing,
    open_store,
    publish,
    root_group,
)
from storage.schema import COMPONENTS

KIND = "inverse-solves"
SOLVES_VERSION = 2
#: The field directions of the RMSE (Tables 4.2/4.4): displacements, then strains.
DIRECTIONS = ("Ux", "Uy", "Uz", "exx", "eyy", "exy")
#: ``units`` of ``objective`` and ``objective_history``: the group's methods' units, sorted,
#: joined with "/" (displacement: mm; strain and combined: dimensionless).
PER_GROUP = None

#: name: (dims, units, long_name); text variables have units "-".
VARIABLES: dict[str, tuple[tuple[str, ...], str | None, str]] = {
    "x_true": (("unknown",), "N", "reference vertical force per unknown"),
    "unknown_xyz": (("unknown", "component"), "mm", "reference coordinates of the unknown nodes"),
    "reference_total_force": (("component",), "N", "Fx, Fy, Fz of the reference experiment"),
    "reference_moment": (("component",), "N mm",
                         "Mx, My, Mz of the reference experiment about the contact centre"),
    "x0": (("solve", "unknown"), "N", "initial guess"),
    "x_final": (("solve", "unknown"), "N", "identified forces"),
    "x_history": (("solve", "evaluation", "unknown"), "N", "forces of every evaluation, in order"),
    "objective_history": (("solve", "evaluation"), PER_GROUP,
                          "objective of every evaluation as the optimiser saw it"),
    "objective": (("solve",), PER_GROUP, "final objective"),
    "total_force": (("solve", "component"), "N", "Fx, Fy, Fz"),
    "moment": (("solve", "component"), "N mm", "Mx, My, Mz about the contact centre"),
    "rmse": (("solve", "direction"), "mm (U*), 1 (e*)",
             "field RMSE against the noise-free reference"),
    **{name: (("solve",), "-", name)
       for name in ("status", "message", "condition", "method", "optimizer")},
    **{name: (("solve",), "1", name) for name in ("repeat", "evaluations", "solved", "rounds")},
    "wall_seconds": (("solve",), "s", "wall time of the loop"),
    "solver_seconds": (("solve",), "s", "ccx seconds of the evaluations this loop solved"),
}
TEXT = ("status", "message", "condition", "method", "optimizer")
#: Added in layout version 2 (NaN when a version-1 group is opened).
ADDED_IN_2 = ("reference_total_force", "reference_moment")


@dataclass(frozen=True, eq=False)
class Unknowns:
    """What every solve of a study shares: the unknowns and the reference experiment.

    ``nodes`` (n,) tread node ids; ``x_true`` (n,) their reference vertical forces, N;
    ``xyz`` (n, 3) their reference coordinates, mm; ``reference_force`` (3,) N and
    ``reference_moment`` (3,) N mm: the reference experiment's totals.
    """

    nodes: np.ndarray
    x_true: np.ndarray
    xyz: np.ndarray
    reference_force: np.ndarray
    reference_moment: np.ndarray


@dataclass(frozen=True, eq=False)
class SolveRecord:
    """One finished solve.

    ``x_history`` (k, n) and ``objective_history`` (k,) hold every evaluation in order;
    ``total_force`` (3,) N, ``moment`` (3,) N mm and ``rmse`` (one value per name of
    :data:`DIRECTIONS`: mm, dimensionless) come from the forward evaluation at
    ``x_final``, and are all None when that evaluation failed. ``objective_units`` is
    the unit of the solve's objective (``"mm"`` or ``"1"``).
    """

    id: str
    condition: str
    method: str
    optimizer: str
    repeat: int
    status: str
    message: str
    objective_units: str
    x0: np.ndarray
    x_final: np.ndarray
    x_history: np.ndarray
    objective_history: np.ndarray
    objective: float
    total_force: np.ndarray | None
    moment: np.ndarray | None
    rmse: Mapping[str, float] | None
    solved: int
    rounds: int
    wall_seconds: float
    solver_seconds: float


@dataclass(frozen=True)
class SolvesAttrs:
    """The study behind a group: ``model_spec`` and ``noise`` are JSON text."""

    study: str
    model_spec: str
    solver: str
    deflection_mm: float
    road_z_mm: float
    noise: str
    problem_hash: str


# ---------------------------------------------------------------- validation


def _fail(where: str, message: str) -> SchemaError:
    return SchemaError(f"{where}: {message}")


def _array(where: str, name: str, value, shape: tuple[int, ...], *, finite: bool = True,
           integer: bool = False) -> np.ndarray:
    a = np.asarray(value)
    kinds = "iu" if integer else "iuf"
    if a.dtype.kind not in kinds or a.shape != shape:
        raise _fail(where, f"{name} must be a {'integer' if integer else 'real'} array of "
                           f"shape {shape}, got {a.dtype} array of shape {a.shape}")
    if finite and not integer and not np.isfinite(a).all():
        raise _fail(where, f"{name} holds NaN or inf")
    return a.astype(np.int64 if integer else np.float64)


def _text(where: str, name: str, value, *, empty: bool = False) -> str:
    if not isinstance(value, str) or not (empty or value):
        raise _fail(where, f"{name} must be {'' if empty else 'non-empty '}text, got {value!r}")
    return value


def _number(where: str, name: str, value, *, integer: bool = False, minimum: float | None = 0,
            finite: bool = True) -> float:
    kind = numbers.Integral if integer else numbers.Real
    ok = isinstance(value, kind) and not isinstance(value, bool)
    if ok and finite:
        ok = math.isfinite(value)
    if ok and minimum is not None:
        ok = value >= minimum
    if not ok:
        bound = f" >= {minimum}" if minimum is not None else ""
        raise _fail(where, f"{name} must be {'an integer' if integer else 'a number'}{bound}, "
                           f"got {value!r}")
    return value


def check_unknowns(u: Unknowns) -> int:
    """Validate the unknowns; returns their number n."""
    if not isinstance(u, Unknowns):
        raise SchemaError(f"unknowns must be a storage.solves.Unknowns, got {type(u).__name__}")
    n = np.shape(u.nodes)[0] if np.ndim(u.nodes) == 1 else -1
    if n < 1:
        raise SchemaError(f"unknowns: nodes must be a non-empty 1-d array of node ids, got shape "
                          f"{np.shape(u.nodes)}")
    nodes = _array("unknowns", "nodes", u.nodes, (n,), integer=True)
    if np.unique(nodes).size != n:
        raise SchemaError("unknowns: node ids must be distinct")
    _array("unknowns", "x_true", u.x_true, (n,))
    _array("unknowns", "xyz", u.xyz, (n, 3))
    _array("unknowns", "reference_force", u.reference_force, (3,))
    _array("unknowns", "reference_moment", u.reference_moment, (3,))
    return n


def check_solve(s: SolveRecord, n: int) -> None:
    """Validate one solve against n unknowns (shapes, text, counts, its final evaluation)."""
    if not isinstance(s, SolveRecord):
        raise SchemaError(f"solves must be storage.solves.SolveRecord, got {type(s).__name__}")
    where = f"solve {_text('a solve', 'id', s.id)!r}"
    for name in ("condition", "method", "optimizer", "status", "objective_units"):
        _text(where, name, getattr(s, name))
    _text(where, "message", s.message, empty=True)
    _number(where, "repeat", s.repeat, integer=True)
    for name in ("solved", "rounds"):
        _number(where, name, getattr(s, name), integer=True)
    for name in ("wall_seconds", "solver_seconds"):
        _number(where, name, getattr(s, name))
    _number(where, "objective", s.objective, minimum=None, finite=False)
    _array(where, "x0", s.x0, (n,))
    _array(where, "x_final", s.x_final, (n,))
    k = np.shape(s.objective_history)[0] if np.ndim(s.objective_history) == 1 else -1
    _array(where, "objective_history", s.objective_history, (max(k, 0),), finite=False)
    _array(where, "x_history", s.x_history, (k, n))
    _check_final(where, s)


def _check_final(where: str, s: SolveRecord) -> None:
    given = [v is not None for v in (s.total_force, s.moment, s.rmse)]
    if any(given) and not all(given):
        raise _fail(where, "total_force, moment and rmse come from the final forward "
                           "evaluation: give all three, or none when it failed")
    if not all(given):
        return
    _array(where, "total_force", s.total_force, (3,))
    _array(where, "moment", s.moment, (3,))
    if not isinstance(s.rmse, Mapping) or set(s.rmse) != set(DIRECTIONS):
        raise _fail(where, f"rmse must map each of {', '.join(DIRECTIONS)} to a value, got "
                           f"{sorted(s.rmse) if isinstance(s.rmse, Mapping) else s.rmse!r}")
    for d in DIRECTIONS:
        _number(where, f"rmse[{d!r}]", s.rmse[d])


def check_attrs(a: SolvesAttrs) -> None:
    if not isinstance(a, SolvesAttrs):
        raise SchemaError(f"attrs must be a storage.solves.SolvesAttrs, got {type(a).__name__}")
    _text("attrs", "study", a.study)
    for name in ("solver", "problem_hash"):
        _text("attrs", name, getattr(a, name), empty=True)
    for name in ("deflection_mm", "road_z_mm"):
        _number("attrs", name, getattr(a, name), minimum=None)
    for name in ("model_spec", "noise"):
        try:
            json.loads(_text("attrs", name, getattr(a, name)))
        except json.JSONDecodeError as e:
            raise SchemaError(f"attrs: {name} must be JSON text ({e})") from e


def _check(unknowns: Unknowns, solves: Sequence[SolveRecord]) -> None:
    n = check_unknowns(unknowns)
    if isinstance(solves, SolveRecord) or not len(solves):
        raise SchemaError("solves must be a non-empty sequence of SolveRecord: a group "
                          "holds at least one solve")
    for s in solves:
        check_solve(s, n)
    ids = [s.id for s in solves]
    if len(set(ids)) != len(ids):
        dup = next(i for i in ids if ids.count(i) > 1)
        raise SchemaError(f"solve id {dup!r} is given twice: each solve once")


# ---------------------------------------------------------------- the Dataset


def _history(solves: Sequence[SolveRecord], n: int) -> tuple[np.ndarray, np.ndarray]:
    k = max(len(s.objective_history) for s in solves)
    xs = np.full((len(solves), k, n), np.nan)
    fs = np.full((len(solves), k), np.nan)
    for i, s in enumerate(solves):
        xs[i, : len(s.objective_history)] = s.x_history
        fs[i, : len(s.objective_history)] = s.objective_history
    return xs, fs


def _final(solves: Sequence[SolveRecord], name: str) -> np.ndarray:
    if name == "rmse":
        return np.array([[s.rmse[d] if s.rmse is not None else np.nan for d in DIRECTIONS]
                         for s in solves], dtype=np.float64)
    return np.array([getattr(s, name) if getattr(s, name) is not None else np.full(3, np.nan)
                     for s in solves], dtype=np.float64)


def _values(unknowns: Unknowns, solves: Sequence[SolveRecord]) -> dict[str, np.ndarray]:
    xs, fs = _history(solves, np.size(unknowns.nodes))
    per_solve = {name: [getattr(s, name) for s in solves]
                 for name in ("x0", "x_final", "objective", "repeat", "solved", "rounds",
                              "wall_seconds", "solver_seconds", *TEXT)}
    return {
        "x_true": unknowns.x_true, "unknown_xyz": unknowns.xyz,
        "reference_total_force": unknowns.reference_force,
        "reference_moment": unknowns.reference_moment,
        "x_history": xs, "objective_history": fs,
        **{name: np.array(per_solve[name], dtype=np.float64)
           for name in ("x0", "x_final", "objective", "wall_seconds", "solver_seconds")},
        **{name: _final(solves, name) for name in ("total_force", "moment", "rmse")},
        **{name: np.array(per_solve[name], dtype=object) for name in TEXT},
        **{name: np.array(per_solve[name], dtype=np.int64)
           for name in ("repeat", "solved", "rounds")},
        "evaluations": np.array([len(s.objective_history) for s in solves], dtype=np.int64),
    }


def solves_dataset(unknowns: Unknowns, solves: Sequence[SolveRecord],
                   attrs: SolvesAttrs | None = None) -> xr.Dataset:
    """The group's contents in memory, validated: what :func:`write_solves` writes and
    :func:`open_solves` gives back (``attrs`` may be omitted for a Dataset never written).
    """
    _check(unknowns, solves)
    if attrs is not None:
        check_attrs(attrs)
    objective_units = "/".join(sorted({s.objective_units for s in solves}))
    data = {}
    for name, value in _values(unknowns, solves).items():
        dims, units, long_name = VARIABLES[name]
        units = objective_units if units is PER_GROUP else units
        attrs_ = {} if name in TEXT else {"units": units, "long_name": long_name}
        data[name] = xr.Variable(dims, np.asarray(value), attrs=attrs_)
    coords = {"solve": np.array([s.id for s in solves], dtype=object),
              "unknown": np.asarray(unknowns.nodes, dtype=np.int64),
              "component": np.array(COMPONENTS, dtype=object),
              "direction": np.array(DIRECTIONS, dtype=object)}
    group_attrs = {"kind": KIND, "solves_version": SOLVES_VERSION}
    if attrs is not None:
        group_attrs |= {"study": attrs.study, "model_spec": attrs.model_spec,
                        "solver": attrs.solver, "deflection_mm": float(attrs.deflection_mm),
                        "road_z_mm": float(attrs.road_z_mm), "noise": attrs.noise,
                        "problem_hash": attrs.problem_hash}
    return xr.Dataset(data, coords=coords, attrs=group_attrs)


# ---------------------------------------------------------------- write and read


def write_solves(store: StoreLike, group: str, unknowns: Unknowns,
                 solves: Sequence[SolveRecord], attrs: SolvesAttrs) -> None:
    """(Re)write the inverse-solves group ``group`` of ``store``. Client only.

    Everything is validated before anything is written. The store is created when it
    does not exist yet; other groups of it are left alone.

    Raises
    ------
    SchemaError
        Values that do not fit the schema, or ``group`` holds something other than
        inverse solves (an experiment group, say): it is never overwritten.
    StoreError
        The write failed (the group may be incomplete: write again).
    """
    check_group_name(group)
    ds = solves_dataset(unknowns, solves, attrs)
    zs = open_store(store)
    with client_lock(zs, create=True):  # metadata has one writer at a time
        root = root_group(zs, create=True)
        _check_replaceable(root, group, describe(zs))
        try:
            ds.to_zarr(zs, group=group, mode="w", zarr_format=3, consolidated=False)
            publish(zs)
        except (OSError, ValueError, TypeError) as e:
            raise StoreError(f"writing the inverse solves into group {group!r} of "
                             f"{describe(zs)} failed ({type(e).__name__}: {e}): write "
                             "again") from e


def _check_replaceable(root: zarr.Group, group: str, where: str) -> None:
    if group not in root:
        return
    node = root[group]
    kind = node.attrs.get("kind") if isinstance(node, zarr.Group) else "an array"
    if kind != KIND:
        what = ("an experiment group" if "schema_version" in node.attrs else f"kind={kind!r}") \
            if isinstance(node, zarr.Group) else "an array"
        raise SchemaError(
            f"group {group!r} of {where} holds {what}, not inverse solves: not overwriting "
            "it; give the study another name (its group is inverse-<name>)"
        )


def open_solves(store: StoreLike, group: str) -> xr.Dataset:
    """Read an inverse-solves group into memory, labelled, with units.

    Text variables and coordinates come as object arrays of ``str``. A group of layout
    version 1 gets NaN ``reference_total_force`` and ``reference_moment``.

    Raises
    ------
    NotAStoreError, GroupNotFoundError
        No store, or no group of that name.
    SchemaError
        The group is not an inverse-solves group, or lacks a variable.
    """
    zs = open_store(store, read_only=True)
    g = open_existing(zs, group, "run the inverse study (farm invert) to write it")
    if g.attrs.get("kind") != KIND:
        what = "an experiment group" if "schema_version" in g.attrs else \
            f"kind={g.attrs.get('kind')!r}"
        raise SchemaError(f"group {group!r} of {describe(zs)} is {what}, not inverse solves "
                          f"(kind={KIND!r}): give the group of an inverse study")
    try:
        ds = xr.open_zarr(zs, group=group, consolidated=True)
    except (KeyError, ValueError):  # no (or stale) consolidated metadata: read it fresh
        ds = xr.open_zarr(zs, group=group, consolidated=False)
    ds = _upgraded(ds.load(), group)
    text = [name for name, v in ds.variables.items() if v.dtype.kind in "TU"]
    return ds.assign({name: ds[name].astype(object) for name in text if name in ds.data_vars}) \
        .assign_coords({name: ds[name].astype(object) for name in text if name in ds.coords})


def _upgraded(ds: xr.Dataset, group: str) -> xr.Dataset:
    version = ds.attrs.get("solves_version", 1)
    for name in ADDED_IN_2 if version < 2 else ():
        dims, units, long_name = VARIABLES[name]
        ds[name] = xr.Variable(dims, np.full(3, np.nan),
                               attrs={"units": units, "long_name": long_name})
    missing = [name for name in VARIABLES if name not in ds]
    if missing:
        raise SchemaError(f"inverse-solves group {group!r} lacks {missing[0]!r} (it holds "
                          f"{', '.join(sorted(map(str, ds.data_vars)))}): write it again")
    return ds
