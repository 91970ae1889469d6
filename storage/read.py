"""Read side: a group as an ``xarray.Dataset``, and cheap status look-ups for the client.

Only ``status == 1`` means done: a slot that is pending or failed may hold NaN, or the
partial chunks of a writer that died, so analyses go through :func:`done`, which also
checks every done experiment against its checksum (:mod:`storage.checksum`) and refuses
damaged ones by name. A store whose bytes do not decode gives one
:class:`DamagedStoreError` line that names what failed, never zarr's traceback.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from typing import Any

import numpy as np
import xarray as xr
import zarr

import storage.identity as identity
from storage._zarr import array, list_dir, read, read_coordinates
from storage.checksum import Slots, check
from storage.errors import DamagedStoreError, NotReservedError, SchemaError, reading, verify_hint
from storage.load_case_index import LoadCaseIndex, kpa_hint
from storage.paths import StoreLike, describe, open_group, open_store
from storage.reserve import read_ids
from storage.schema import (
    CHECKED_NAMES,
    CLIENT_CHUNK,
    DONE,
    FAILED,
    PENDING,
    STATUS_NAMES,
    checked_names,
)

#: Up to this size, the checked variables of the experiments that :func:`verify_done`
#: checks are read into memory once: what was hashed is then what the caller analyses,
#: without a second read. Larger selections are checked block by block and stay lazy.
IN_MEMORY_BYTES = 256 * 2**20
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
    where = describe(zs)
    with reading(f"group {group!r}", where):
        g = open_group(zs, group)  # clear errors for a missing store, group or schema
        arrays = _fresh_arrays(zs, group, where)
    chunks = dict(chunks) if isinstance(chunks, dict) else chunks  # never share the default
    with reading(f"group {group!r}", where):
        try:
            ds = xr.open_zarr(zs, group=group, consolidated=True, chunks=chunks)
        except (KeyError, ValueError):  # no (or stale) consolidated metadata: read it fresh
            ds = xr.open_zarr(zs, group=group, consolidated=False, chunks=chunks)
    gone = sorted(set(ds.variables) - arrays)
    if gone:  # listed in the consolidated copy, absent on disk: it would read as all fill
        raise DamagedStoreError(
            f"group {group!r} of {where} has lost array {gone[0]!r} (listed in the store's "
            f"metadata, absent from the group); {verify_hint(where)}"
        )
    _check_identity(ds, group, dict(g.attrs), where)
    text = [name for name, var in ds.data_vars.items() if var.dtype.kind == "T"]
    with reading(f"the text arrays ({', '.join(text)}) of group {group!r}", where):
        # decoded here: one flipped byte in a checksum chunk was a 145-line
        # UnicodeDecodeError from `farm analyse pca` (issue 26)
        ds = ds.assign({name: ds[name].astype(object) for name in text})
    # The load case labels the experiments: coordinates along ``experiment`` with one
    # index over all of them (issue 25), so ``ds.sel(deflection=30, pressure=0.2)`` and
    # ``ds.where(ds.deflection == 30, drop=True)`` work. Made here, at read time, so that
    # groups written before issue 25 get it too. Read now (8 bytes an experiment, which
    # done() reads anyway): a lazy label cannot index.
    with reading(f"the load cases of group {group!r}", where):
        ds = index_parameters(ds)
    ds.encoding.update(farm_store=where, farm_group=group)  # for the messages of done()
    return ds


def _check_identity(ds: xr.Dataset, group: str, attrs: dict, where: str) -> None:
    """Refuse a group that is no longer what it was made as (:mod:`storage.identity`):
    edited coordinates or model attributes, a lost mesh chunk, a renamed or copied
    folder would otherwise be analysed as if intact (issue 50)."""
    if identity.IDENTITY not in attrs or not set(identity.MESH_ARRAYS) <= set(ds.variables):
        return  # made before identities, or a lost array (named by the caller)
    with reading(f"the mesh arrays of group {group!r}", where):
        parts = identity.changed(group, attrs, {n: ds[n].values for n in identity.MESH_ARRAYS})
    if parts:
        raise DamagedStoreError(
            f"group {group!r} of {where}: {identity.PARTS.get(parts[0], parts[0])} differs from "
            f"what the group was made with (edited, a chunk lost, or the folder renamed or "
            f"copied); {verify_hint(where)}")


def index_parameters(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with its load-case parameters as coordinates along ``experiment``, in memory,
    under one :class:`~storage.load_case_index.LoadCaseIndex` (what :func:`open_dataset`
    returns; a no-op on such a dataset).

    Then ``ds.sel(deflection=30)``, ``ds.sel(deflection=30, pressure=0.2)``,
    ``ds.sel(deflection=[10, 30])`` and ``ds.sel(deflection=slice(10, 30))`` select
    experiments; the ``experiment`` dimension and its ids stay. Labels match exactly:
    the farm stores parameters rounded to 9 decimals, so the numbers of a study file
    match; :func:`select` matches within a relative 1e-9. The plain coordinates come
    back with ``ds.drop_indexes(parameters(ds))`` (to overwrite one of them, or to
    align datasets holding different experiments).
    """
    names = parameters(ds)
    index = ds.xindexes.get(names[0]) if names else None
    if not names or (isinstance(index, LoadCaseIndex) and index.names == tuple(names)):
        return ds
    ds = ds.set_coords([n for n in names if n in ds.data_vars])
    # an index already there (``set_xindex("deflection")`` of issue 12), with its coordinates
    held = {c for n in names if n in ds.xindexes for c in ds.xindexes.get_all_coords(n)}
    ds = ds.drop_indexes(sorted(held, key=str))  # names are str in the farm's datasets
    ds = ds.assign_coords({n: ds[n].load() for n in names})
    return ds.set_xindex(names, LoadCaseIndex)


def _fresh_arrays(zs, group: str, where: str) -> set[str]:
    """Names of the group's arrays, each one's metadata read fresh; the first that does
    not decode, or a missing ``experiment`` or ``status``, is a DamagedStoreError."""
    names = {n for n in list_dir(zs, group) if n != "zarr.json" and not n.startswith(".")}
    g = zarr.open_group(store=zs, path=group, mode="r", use_consolidated=False)
    for name in sorted(names):
        with reading(f"{group}/{name}/zarr.json", where):
            g[name]
    for name in ("experiment", "status"):
        if name not in names:
            raise DamagedStoreError(
                f"group {group!r} of {where} has no {name!r} array (deleted?); "
                f"{verify_hint(where)}"
            )
    return names


def done(ds: xr.Dataset, *, verify: bool = True) -> xr.Dataset:
    """The experiments of ``ds`` that are done (``status == 1``), checked.

    With ``verify`` (the default), every one of them is checked against its checksum
    (:func:`verify_done`): a damaged one raises :class:`DamagedStoreError` naming it.
    """
    with _reading_ds(ds, "the status"):
        sel = ds.isel(experiment=np.flatnonzero(np.asarray(ds["status"]) == DONE))
    return verify_done(sel) if verify else sel


def verify_done(ds: xr.Dataset, *, data: bool = True) -> xr.Dataset:
    """``ds``, checked: raise :class:`DamagedStoreError` naming its damaged experiments.

    Checks every done or failed experiment of ``ds``: it has an id, and (in groups with
    checksums) its id and load case match its checksum's label and, with ``data``, its
    status and data match the rest (:mod:`storage.checksum`). The labels alone are cheap
    (``data=False``: what a selection by load case relies on). The data cost one read of
    the checked variables: up to :data:`IN_MEMORY_BYTES` they are returned in memory
    (the caller analyses what was hashed, and reads nothing twice); beyond, they are
    read block by block and the returned variables stay lazy.
    """
    with _reading_ds(ds, "the ids, status and checksums"):
        status = np.asarray(ds["status"].values).astype(np.int64)
        ids = [str(e) for e in np.asarray(ds["experiment"].values).tolist()]
        sums = ([str(c) for c in np.asarray(ds["checksum"].values).tolist()]
                if "checksum" in ds else None)
        params = {n: np.asarray(ds[n].values, dtype=np.float64) for n in parameters(ds)}
    positions = np.flatnonzero(np.isin(status, (DONE, FAILED))).tolist()
    bad = {k: "it is done but has no id (the ids chunk is missing or damaged)"
           for k in positions if not ids[k]}
    if sums is not None:
        missing = [n for n in CHECKED_NAMES if n not in ds] if data else []
        if missing:
            raise SchemaError(
                f"cannot check the experiments against their checksums without {missing[0]!r}:"
                " call storage.done(...) on the whole dataset, before choosing variables"
            )
        if data:
            ds = _in_memory(ds)
        names = checked_names(ds.data_vars)  # with the combined ones of a combined group
        slots = Slots(ids, status, params, sums,
                      lambda n, lo, hi: ds[n].isel(experiment=slice(lo, hi)).values,
                      {n: _bytes_per_experiment(ds, n) for n in names if n in ds}, names)
        bad.update(check(slots, [k for k in positions if ids[k]], data=data))
    if bad:
        raise DamagedStoreError(_damage_message(ds, ids, bad))
    return ds


def _in_memory(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with its checked variables read into memory, if they fit the budget."""
    names = list(checked_names(ds.data_vars))
    size = sum(_bytes_per_experiment(ds, n) for n in names) * ds.sizes["experiment"]
    if size > IN_MEMORY_BYTES:
        return ds
    try:
        loaded = ds[names].compute()
    except Exception:  # a chunk that does not decode: the block-wise check names it
        return ds
    return ds.assign({n: loaded[n] for n in names})


def _bytes_per_experiment(ds: xr.Dataset, name: str) -> int:
    var = ds[name]
    return int(var.dtype.itemsize * var.size // max(var.sizes.get("experiment", 1), 1))


def _damage_message(ds: xr.Dataset, ids: list[str], bad: dict[int, str]) -> str:
    where = ds.encoding.get("farm_store", "STORE")
    group = ds.encoding.get("farm_group", "?")
    named = [f"{ids[k]} ({reason})" for k, reason in bad.items() if ids[k]]
    orphans = sum(1 for k in bad if not ids[k])
    parts = named[:5] + ([f"and {len(named) - 5} more"] if len(named) > 5 else [])
    if orphans:
        parts.append(f"{orphans} done slot(s) without an id (the ids chunk is missing or "
                     "damaged)")
    return (f"{len(bad)} damaged experiment(s) in group {group!r} of {where}: "
            f"{'; '.join(parts)}; refusing to use them: {verify_hint(where)} (marks them "
            "pending), then `farm sweep resume STUDY` re-solves them")


def _reading_ds(ds: xr.Dataset, what: str):
    return reading(f"{what} of group {ds.encoding.get('farm_group', '?')!r}",
                   ds.encoding.get("farm_store", "STORE"))


def parameters(ds: xr.Dataset) -> list[str]:
    """Names of the load-case parameters of ``ds`` (coordinates along ``experiment`` in
    what :func:`open_dataset` returns; data variables in older in-memory datasets)."""
    # isinstance: xarray names are any Hashable; a zarr store's (the farm's) are str
    return sorted(n for n, v in ds.variables.items()
                  if isinstance(n, str) and v.attrs.get("role") == "parameter")


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
        values = np.asarray(ds[name], dtype=np.float64)
        match = _matches(values, want, name)
        if not match.any() and not isinstance(want, slice):
            hint = kpa_hint(name, float(np.atleast_1d(want)[0]), values)
            if hint:  # an empty selection would pass silently for a kPa value
                raise SchemaError(f"no experiment has {name}={want!r}{hint}")
        keep &= match
    return ds.isel(experiment=np.flatnonzero(keep))


def held_ids(store: StoreLike, group: str) -> frozenset[str]:
    """Every id the group holds, damaged slots included (an empty id before reserved
    ones does not raise, as in :func:`statuses`): what a client resolving old ids
    against the group needs before :func:`storage.reserve` restores a lost id."""
    zs = open_store(store, read_only=True)
    where = describe(zs)
    with reading(f"the ids of group {group!r}", where):
        g = open_group(zs, group)
        return frozenset(str(e) for e in read(array(g, "experiment")).tolist() if e)


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
    zs = open_store(store, read_only=True)
    where = describe(zs)
    with reading(f"the ids of group {group!r}", where):
        g = open_group(zs, group)
        ids = read_ids(g)
    with reading(f"the 'status' array of group {group!r}", where):
        status = array(g, "status")
    index = {e: i for i, e in enumerate(ids)}
    wanted = ids if experiment_ids is None else list(experiment_ids)
    missing = [e for e in wanted if e not in index]
    if experiment_ids is None or missing:  # ids lost (a missing chunk reads as empty)?
        _check_orphans(status, len(ids), group, where)
    if missing:
        raise NotReservedError(
            f"experiment {missing[0]!r} is not reserved in group {group!r} "
            f"({len(missing)} of {len(wanted)} ids are not): reserve them first"
        )
    # A client resizing right now may have grown ``experiment`` before ``status``: the
    # slots beyond the status array are brand new, hence pending.
    slots = np.array([index[e] for e in wanted], dtype=np.int64)
    inside = slots < status.shape[0]
    values = np.zeros(slots.size, dtype=np.int8)
    with reading(f"the 'status' array of group {group!r}", where):
        if experiment_ids is None:
            values[inside] = read(status)[slots[inside]]
        elif inside.any():
            values[inside] = read_coordinates(status, slots[inside])
    return {e: int(v) for e, v in zip(wanted, values, strict=True)}


def _check_orphans(status: zarr.Array, n_ids: int, group: str, where: str) -> None:
    """Raise if a slot past the reserved ids is done or failed: its id was lost."""
    if status.shape[0] <= n_ids:
        return
    with reading(f"the 'status' array of group {group!r}", where):
        tail = read(status, slice(n_ids, None))
    orphans = np.flatnonzero(tail != PENDING) + n_ids
    if orphans.size:
        raise DamagedStoreError(
            f"group {group!r} of {where} has {orphans.size} done or failed slot(s) without an "
            f"experiment id (from slot {int(orphans[0])}): the ids chunk is missing or "
            f"damaged; {verify_hint(where)}"
        )


def status_counts(store: StoreLike, group: str) -> dict[str, int]:
    """Number of experiments per status: ``{"pending": ..., "done": ..., "failed": ...}``.

    Counts only what is valid (issue 50: a status of 7 or -1, or an id in two slots,
    once read "19 done, 0 failed, 0 pending" for 20 slots, exit 0): a slot whose status
    is outside pending/done/failed, or an id reserved twice, raises
    :class:`DamagedStoreError` naming it and saying to run verify.
    """
    zs = open_store(store, read_only=True)
    where = describe(zs)
    with reading(f"the ids of group {group!r}", where):
        ids = read_ids(open_group(zs, group))
    repeated = sorted({e for e, n in Counter(ids).items() if n > 1})
    if repeated:
        raise DamagedStoreError(
            f"group {group!r} of {where} holds experiment id {repeated[0]!r} in more than one "
            f"slot ({len(repeated)} id(s) repeated): its counts would be wrong; "
            f"{verify_hint(where)}")
    values = np.fromiter(statuses(store, group).values(), dtype=np.int8, count=len(ids))
    bad = np.flatnonzero(~np.isin(values, list(STATUS_NAMES)))
    if bad.size:
        raise DamagedStoreError(
            f"group {group!r} of {where} has {bad.size} slot(s) whose status is none of "
            f"pending, done, failed (experiment {ids[int(bad[0])]!r}: {int(values[bad[0]])}); "
            f"{verify_hint(where)}")
    return {name: int(np.count_nonzero(values == code)) for code, name in STATUS_NAMES.items()}
