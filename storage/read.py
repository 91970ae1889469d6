"""Read side: a group as an ``xarray.Dataset``, and cheap status look-ups for the client.

Only ``status == 1`` means done: a slot that is pending or failed may hold NaN, or the
partial chunks of a writer that died, so analyses go through :func:`done`.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
import xarray as xr

from storage.errors import NotReservedError, SchemaError
from storage.paths import StoreLike, open_group, open_store
from storage.reserve import read_ids
from storage.schema import CLIENT_CHUNK, DONE, STATUS_NAMES

#: Relative tolerance of :func:`select` on parameter values.
SELECT_RTOL = 1e-9
# One dask chunk per 4096 experiments (98 MB of a full model's
# displacement), a multiple of every stored chunk, so dask graphs stay small.
_DEFAULT_CHUNKS = {"experiment": 4 * CLIENT_CHUNK}


def open_dataset(store: StoreLike, group: str, *, chunks: Any = _DEFAULT_CHUNKS) -> xr.Dataset:
    """Open a group lazily as an ``xarray.Dataset`` (dask arrays, labelled, with units).

    Uses the consolidated metadata the client published (one consistent snapshot of
    all shapes), or fresh metadata when there is none. Text variables (``error``) come
    as object arrays, so that ``ds.where(..., drop=True)`` works on the whole dataset.

    Parameters
    ----------
    store, group : the store and the group (see :func:`storage.list_groups`).
    chunks : passed to ``xarray.open_zarr``; the default makes dask chunks of 4096
        experiments (the one-experiment chunks of the store, merged).
    """
    zs = open_store(store, read_only=True)
    open_group(zs, group)  # clear errors for a missing store, group or schema
    chunks = dict(chunks) if isinstance(chunks, dict) else chunks  # never share the default
    try:
        ds = xr.open_zarr(zs, group=group, consolidated=True, chunks=chunks)
    except (KeyError, ValueError):  # no (or stale) consolidated metadata: read it fresh
        ds = xr.open_zarr(zs, group=group, consolidated=False, chunks=chunks)
    text = [name for name, var in ds.data_vars.items() if var.dtype.kind == "T"]
    return ds.assign({name: ds[name].astype(object) for name in text})


def done(ds: xr.Dataset) -> xr.Dataset:
    """The experiments of ``ds`` that are done (``status == 1``)."""
    return ds.isel(experiment=np.flatnonzero(np.asarray(ds["status"]) == DONE))


def parameters(ds: xr.Dataset) -> list[str]:
    """Names of the load-case parameter variables of ``ds``."""
    return sorted(n for n, v in ds.data_vars.items() if v.attrs.get("role") == "parameter")


def _matches(values: np.ndarray, want: Any, name: str) -> np.ndarray:
    def close(target: float) -> np.ndarray:
        return np.isclose(values, target, rtol=SELECT_RTOL, atol=0.0)

    if isinstance(want, slice):
        if want.step is not None:
            raise SchemaError(f"select {name}=slice(...) takes no step, got {want!r}")
        lo = -np.inf if want.start is None else float(want.start)
        hi = np.inf if want.stop is None else float(want.stop)
        return ((values >= lo) | close(lo)) & ((values <= hi) | close(hi))
    try:
        targets = np.atleast_1d(np.asarray(want, dtype=np.float64))
    except (TypeError, ValueError) as e:
        raise SchemaError(
            f"select {name}= takes a number, a list of numbers or a slice, got {want!r}"
        ) from e
    return np.logical_or.reduce([close(t) for t in targets.ravel()], axis=0)


def select(ds: xr.Dataset, **params: Any) -> xr.Dataset:
    """Experiments whose load-case parameters match, e.g. ``select(ds, pressure=0.2)``.

    Each keyword is a parameter name and a number (equal within a relative 1e-9), a
    list of numbers (any of them) or a ``slice(lo, hi)`` (inclusive, open ends allowed).
    """
    known = parameters(ds)
    keep = np.ones(ds.sizes["experiment"], dtype=bool)
    for name, want in params.items():
        if name not in known:
            raise SchemaError(
                f"unknown parameter {name!r}; this group's parameters: {', '.join(known)}"
            )
        keep &= _matches(np.asarray(ds[name], dtype=np.float64), want, name)
    return ds.isel(experiment=np.flatnonzero(keep))


def statuses(
    store: StoreLike, group: str, experiment_ids: Iterable[str] | None = None
) -> dict[str, int]:
    """Status (0 pending, 1 done, 2 failed) of reserved experiments, from fresh metadata.

    Reads only the status chunks of the ids asked for (all when ``None``); this is what
    the client uses to skip experiments that are done.

    Raises
    ------
    NotReservedError
        An id asked for was never reserved in the group.
    """
    g = open_group(open_store(store, read_only=True), group)
    ids = read_ids(g)
    index = {e: i for i, e in enumerate(ids)}
    wanted = ids if experiment_ids is None else list(experiment_ids)
    missing = [e for e in wanted if e not in index]
    if missing:
        raise NotReservedError(
            f"experiment {missing[0]!r} is not reserved in group {group!r} "
            f"({len(missing)} of {len(wanted)} ids are not): reserve them first"
        )
    status = g["status"]
    # A client resizing right now may have grown ``experiment`` before ``status``: the
    # slots beyond the status array are brand new, hence pending.
    slots = np.array([index[e] for e in wanted], dtype=np.int64)
    inside = slots < status.shape[0]
    values = np.zeros(slots.size, dtype=np.int8)
    if experiment_ids is None:
        values[inside] = status[...][slots[inside]]
    elif inside.any():
        values[inside] = status.get_coordinate_selection(slots[inside])
    return {e: int(v) for e, v in zip(wanted, values, strict=True)}


def status_counts(store: StoreLike, group: str) -> dict[str, int]:
    """Number of experiments per status: ``{"pending": ..., "done": ..., "failed": ...}``."""
    values = np.fromiter(statuses(store, group).values(), dtype=np.int8)
    return {name: int(np.count_nonzero(values == code)) for code, name in STATUS_NAMES.items()}
