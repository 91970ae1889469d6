"""Data assembly: from a store group to the matrices of thesis section 5.3.

The store schema is in ``docs/schema.md``. This module is the only place in
:mod:`analysis` that opens a group, and it reads through :mod:`storage`'s readers
(``open_dataset``, ``done``, ``verify_done``, ``select``, ``status_counts``); everything
else works on the :class:`xarray.Dataset` that :func:`load` returns: done experiments
only, optionally filtered by load case, each checked against its checksum (a damaged
one is refused by name, never analysed), with the per-experiment variables as dask
arrays chunked along ``experiment`` so that a store larger than memory streams through
the reductions.

Matrices follow the thesis' notation: ``X`` is K experiments by N inner nodes for one
*direction* (Ux, Uy, Uz, exx, eyy, exy, or a CST surface strain), ``Y`` is K by M tread
forces of one component (vertical by default); :func:`totals` gives the six totals of
each experiment (Fx, Fy, Fz, Mx, My, Mz).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import dask
import dask.array as da
import numpy as np
import pandas as pd
import xarray as xr

import storage
from analysis.errors import (
    AmbiguousGroupError,
    EmptySelectionError,
    MissingVariableError,
    NoVarianceError,
    TooFewExperimentsError,
)
from storage.errors import reading
from storage.read import verify_done

#: direction name -> (store variable, component dimension, component label)
DIRECTIONS: dict[str, tuple[str, str, str]] = {
    "Ux": ("displacement", "component", "x"),
    "Uy": ("displacement", "component", "y"),
    "Uz": ("displacement", "component", "z"),
    "exx": ("strain", "strain_component", "xx"),
    "eyy": ("strain", "strain_component", "yy"),
    "exy": ("strain", "strain_component", "xy"),
    "cst_exx": ("surface_strain", "strain_component", "xx"),
    "cst_eyy": ("surface_strain", "strain_component", "yy"),
    "cst_exy": ("surface_strain", "strain_component", "xy"),
}

#: input-set name -> directions; a set is one "method" of the thesis (displacement-based,
#: strain-based) and shares one unit, so its directions may be concatenated into one X.
INPUT_SETS: dict[str, tuple[str, ...]] = {
    "displacement": ("Ux", "Uy", "Uz"),
    "strain": ("exx", "eyy", "exy"),
    "surface_strain": ("cst_exx", "cst_eyy", "cst_exy"),
}

#: the six totals of an experiment, in the order of :func:`totals`
TOTALS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")

_CHUNK_BYTES = 32 * 2**20  # target size of one dask chunk along `experiment`


def family(direction: str) -> str:
    """Store variable (hence unit family) of a direction, e.g. ``"Uz" -> "displacement"``."""
    return DIRECTIONS[check_direction(direction)][0]


def check_direction(direction: str) -> str:
    """Return ``direction`` if known, else raise :class:`MissingVariableError`."""
    if direction not in DIRECTIONS:
        known = ", ".join(DIRECTIONS)
        raise MissingVariableError(f"unknown input direction {direction!r}; known: {known}")
    return direction


def expand_inputs(spec: str | Sequence[str]) -> tuple[str, ...]:
    """Expand a comma list of set names and directions, e.g. ``"displacement,exx"``."""
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    out: list[str] = []
    for item in (s.strip() for s in items):
        for d in INPUT_SETS.get(item, (item,)):
            if check_direction(d) not in out:
                out.append(d)
    if not out:
        raise MissingVariableError("no input direction given")
    return tuple(out)


def open_group(store: Any, group: str) -> xr.Dataset:
    """Open one group lazily through :func:`storage.open_dataset` (the store's reader).

    Storage's errors (:class:`storage.NotAStoreError`, :class:`storage.GroupNotFoundError`)
    pass through unchanged: they already say what is missing and how to fix it.
    """
    return storage.open_dataset(store, group, chunks=None)


def list_groups(store: Any) -> list[str]:
    """Names of the experiment groups of ``store`` (one per model)."""
    with reading("the store's list of groups (its root zarr.json)", str(store)):
        return storage.list_groups(store)


def resolve_group(store: Any, group: str | None) -> str:
    """``group`` if given, else the store's only group; ambiguity is an error."""
    if group is not None:
        return group
    groups = list_groups(store)
    if len(groups) != 1:
        names = ", ".join(groups) or "none"
        raise AmbiguousGroupError(
            f"store {store!s} has {len(groups)} groups ({names}); pass --group"
        )
    return groups[0]


def load(
    store: Any,
    group: str | None = None,
    *,
    pressure: float | None = None,
    deflection: float | None = None,
) -> xr.Dataset:
    """Done experiments of one group, optionally at one pressure and/or deflection.

    Reads through :mod:`storage` (:func:`storage.open_dataset`, :func:`storage.done`,
    :func:`storage.select`), so "done" and "matches" mean what they mean for every
    other reader of the store. Every done experiment's id and load case, and the data
    of the selected ones, are checked against their checksums first
    (:func:`storage.read.verify_done`).

    Parameters
    ----------
    store : str, path or zarr store
        The Zarr store (directory or fsspec URL).
    group : str, optional
        Group (mesh) name; may be omitted when the store has exactly one group.
    pressure, deflection : float, optional
        Keep only experiments at this inflation pressure (MPa) / deflection (mm).

    Returns
    -------
    xarray.Dataset
        Variables with an ``experiment`` dimension are dask arrays chunked along it.
        Attributes ``store``, ``group`` and ``filters`` describe the selection (for
        error messages, see :func:`require_experiments`).
    """
    name = resolve_group(store, group)
    ds = open_group(store, name)
    if "status" not in ds:
        raise MissingVariableError(f"group {name!r} has no 'status' variable: not a farm store")
    asked = (("pressure", pressure), ("deflection", deflection))
    filters = {k: v for k, v in asked if v is not None}
    done = storage.done(ds, verify=False)
    verify_done(done, data=False)  # ids and load cases, which the selection relies on
    sel = storage.select(done, **filters)
    if sel.sizes["experiment"] == 0:
        raise EmptySelectionError(_empty_message(store, name, done, filters))
    sel = verify_done(sel)  # the data of what is analysed (in memory, if it fits)
    attrs = {"store": str(store), "group": name, "filters": _filter_text(filters)}
    return _chunk(sel.assign_attrs(attrs))


def _filter_text(filters: dict[str, float]) -> str:
    return ", ".join(f"{k}={v:g}" for k, v in filters.items())


def _empty_message(store, group: str, done: xr.Dataset, filters: dict[str, float]) -> str:
    counts = storage.status_counts(store, group)
    msg = f"no done experiment in group {group!r}"
    if filters:
        msg += " with " + _filter_text(filters)
        for var in ("pressure", "deflection"):
            if var in done and done.sizes["experiment"]:
                vals = np.unique(np.asarray(done[var].values))
                msg += f"; done {var} values: {', '.join(f'{v:g}' for v in vals)}"
    parts = ", ".join(f"{n} {flag}" for flag, n in counts.items())
    return msg + f" (group holds {sum(counts.values())} experiments: {parts})"


def selection_text(ds: xr.Dataset) -> str:
    """The selection in words: store, group and filters (from :func:`load`'s attributes)."""
    parts = [f"store {ds.attrs.get('store', '?')}", f"group {ds.attrs.get('group', '?')!r}"]
    if ds.attrs.get("filters"):
        parts.append(ds.attrs["filters"])
    if ds.attrs.get("axes") == "road":  # analysis.axes: forces in the road's axes
        parts.append("forces and moments in the road's axes")
    return ", ".join(parts)


def require_experiments(ds: xr.Dataset, needed: int, what: str, why: str) -> None:
    """Raise :class:`TooFewExperimentsError` unless ``ds`` holds ``needed`` experiments.

    ``what`` names the analysis ("PCR"), ``why`` says why it needs that many.
    """
    k = ds.sizes["experiment"]
    if k >= needed:
        return
    raise TooFewExperimentsError(
        f"{what} needs at least {needed} done experiments ({why}), but the selection "
        f"({selection_text(ds)}) has {k} done experiment{'' if k == 1 else 's'}: widen it "
        "(drop or change --pressure / --deflection) or run more load cases"
    )


def require_variance(Y, ds: xr.Dataset, component: str) -> None:
    """Raise :class:`NoVarianceError` if the outputs ``Y`` (K, M; numpy or dask) are the
    same in every experiment: every fraction of variance explained would be 0/0."""
    lo, hi = Y.min(axis=0), Y.max(axis=0)
    if isinstance(Y, da.Array):
        lo, hi = dask.compute(lo, hi)
    spread = float(np.max(hi - lo, initial=0.0))
    if spread > 1e-12 * float(np.max(np.abs([lo, hi]), initial=0.0)):
        return
    raise NoVarianceError(
        f"the tread forces (force component {component}) have no variance over the "
        f"{Y.shape[0]} experiments of the selection ({selection_text(ds)}): variance "
        "explained is 0/0 and there is nothing to model; choose another --force-component "
        "or a selection whose loads differ"
    )


def _chunk(ds: xr.Dataset) -> xr.Dataset:
    """Dask-chunk the per-experiment variables to ~32 MiB blocks along ``experiment``."""
    per_exp = max(
        (
            v.dtype.itemsize * v.size // max(v.sizes["experiment"], 1)
            for v in ds.data_vars.values()
            if "experiment" in v.dims
        ),
        default=8,
    )
    rows = int(max(1, _CHUNK_BYTES // max(per_exp, 1)))
    return ds.chunk({"experiment": rows})


def _variable(ds: xr.Dataset, var: str) -> xr.DataArray:
    if var not in ds:
        group = ds.attrs.get("group", "?")
        have = ", ".join(sorted(str(v) for v in ds.data_vars))
        raise MissingVariableError(f"group {group!r} has no variable {var!r} (it has: {have})")
    return ds[var]


def inputs(ds: xr.Dataset, directions: str | Sequence[str]) -> da.Array:
    """Input matrix X, shape (K, N * len(directions)): directions side by side.

    One direction gives the thesis' K x N matrix (eq. 5.3's X); a set such as
    ``"displacement"`` concatenates Ux, Uy, Uz column-wise (K x 3N).
    """
    blocks = []
    for d in expand_inputs(directions):
        var, dim, label = DIRECTIONS[d]
        arr = _variable(ds, var).sel({dim: label}).transpose("experiment", "inner_node")
        blocks.append(_as_dask(arr))
    return da.concatenate(blocks, axis=1) if len(blocks) > 1 else blocks[0]


def outputs(ds: xr.Dataset, component: str = "z") -> da.Array:
    """Output matrix Y, shape (K, M): tread-node reaction forces of one component (N)."""
    if component not in ("x", "y", "z"):
        raise MissingVariableError(f"force component must be x, y or z, got {component!r}")
    arr = _variable(ds, "reaction_force").sel(component=component)
    return _as_dask(arr.transpose("experiment", "tread_node"))


def totals(ds: xr.Dataset) -> np.ndarray:
    """(K, 6): Fx, Fy, Fz (N) from total_force, Mx, My, Mz (N mm) from moment."""
    for var in ("total_force", "moment"):
        if var not in ds:
            raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no {var!r}")
    f = np.asarray(ds["total_force"].sel(component=["x", "y", "z"]).values, dtype=float)
    m = np.asarray(ds["moment"].sel(component=["x", "y", "z"]).values, dtype=float)
    return np.concatenate([f, m], axis=1)


def _as_dask(arr: xr.DataArray) -> da.Array:
    data = arr.data
    return data if isinstance(data, da.Array) else da.from_array(np.asarray(data))


def input_index(ds: xr.Dataset, directions: str | Sequence[str]) -> pd.DataFrame:
    """One row per column of :func:`inputs`: direction, inner_node, row, col, x, y, z."""
    frames = []
    for d in expand_inputs(directions):
        frames.append(_node_frame(ds, "inner").assign(direction=d))
    out = pd.concat(frames, ignore_index=True)
    return out[["direction", *[c for c in out.columns if c != "direction"]]]


def tread_index(ds: xr.Dataset) -> pd.DataFrame:
    """One row per column of :func:`outputs`: tread_node, row, col, x, y, z (mm)."""
    return _node_frame(ds, "tread")


def _node_frame(ds: xr.Dataset, kind: str) -> pd.DataFrame:
    node = f"{kind}_node"
    frame = pd.DataFrame({node: np.asarray(ds[node].values)})
    for part in ("row", "col"):
        name = f"{kind}_{part}"
        frame[part] = np.asarray(ds[name].values) if name in ds else -1
    xyz = f"{kind}_xyz"
    if xyz not in ds:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no {xyz!r}")
    coords = np.asarray(ds[xyz].transpose(node, "component").values, dtype=float)
    frame[["x", "y", "z"]] = coords
    return frame


def reference_index(ds: xr.Dataset, deflection: float | None = None) -> int:
    """Position of the reference experiment (thesis §5.4-5.6 use 30 mm at 200 kPa).

    The experiment whose deflection is nearest ``deflection``; by default nearest the
    median deflection of the selection.
    """
    values = np.asarray(_variable(ds, "deflection").values, dtype=float)
    target = float(np.median(values)) if deflection is None else float(deflection)
    return int(np.argmin(np.abs(values - target)))
