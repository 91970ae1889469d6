"""Worker side: a per-process cache of a group's open arrays and of its id -> index map.

Opening a dozen arrays costs more than writing an experiment (about 0.5 ms each), and a
worker writes many experiments into one group, so the opened arrays are kept. The cache
is sound because of the schema's rules: an id keeps its index forever, and a client's
resize only grows arrays, so a cached array (with a stale, smaller shape) still writes
the right chunk for every index it knows. A cached index is nevertheless checked on
every write against the stored id (one small read), which also catches a store deleted
and made anew at the same path; a miss or a mismatch reloads everything.

The handle also keeps the load-case parameters of every id it knows, which the
worker's checksum covers (:mod:`storage.checksum`): read after the ids, so every id in
the handle has its parameters (a client writes them before the id), and an id's
parameters never change.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from zarr.abc.store import Store
from zarr.storage import FsspecStore, LocalStore

from storage._zarr import AsyncArray, array, async_arrays, read, read_item
from storage.errors import NotReservedError, reading
from storage.paths import describe, open_group
from storage.reserve import read_ids
from storage.schema import COMBINED_NAMES, EXPERIMENT, OPTIONAL_NAMES, WORKER_VARIABLES

_MAX_HANDLES = 16
_HANDLES: OrderedDict[tuple[object, ...], Handle] = OrderedDict()
_LOCK = threading.Lock()  # a Dask worker may run tasks in several threads


@dataclass
class Handle:
    """The open arrays of one group, as a worker needs them.

    Attributes
    ----------
    arrays : dict of str to zarr.AsyncArray
        ``experiment`` and every worker-written variable the group has (``checksum``
        is missing from groups written before checksums, the patch variables from
        groups written before issue 24, the combined-load variables from groups that
        are not combined-load ones).
    index : dict of str to int
        Experiment id -> index, as far as known when loaded.
    params : dict of str to (K,) float64
        Load-case parameters of the first K >= len(index) slots, by name.
    inner_node : (N,) int64, tread_node : (M,) int64
        The group's node ids.
    mesh_key : str
        The group's mesh key.
    """

    arrays: dict[str, AsyncArray]
    index: dict[str, int]
    params: dict[str, np.ndarray]
    inner_node: np.ndarray
    tread_node: np.ndarray
    mesh_key: str


def _key(store: Store, group: str) -> tuple[object, ...]:
    if isinstance(store, LocalStore):  # a new LocalStore per call for the same path
        return ("local", type(store), str(Path(store.root).resolve()), group)
    if isinstance(store, FsspecStore):  # Dask hands each task its own unpickled copy
        options = repr(sorted(store.fs.storage_options.items()))
        return ("fsspec", type(store.fs).__name__, store.path, options, group)
    # Other stores (in memory) are one object each; the handle holds a reference to the
    # store, so its id cannot be reused while the entry lives.
    return ("object", id(store), group)


def _load(store: Store, group: str) -> Handle:
    with reading(f"group {group!r}", describe(store)):
        g = open_group(store, group)
        # Ids first: a client creates and writes an id's parameters before the id, so
        # the arrays listed after it hold the parameters of every id read.
        ids = read_ids(g)
        members = dict(g.arrays())
        names = [EXPERIMENT.name,
                 *(v.name for v in WORKER_VARIABLES
                   if v.name not in OPTIONAL_NAMES or v.name in members),
                 *(n for n in COMBINED_NAMES if n in members)]  # combined-load groups only
        params = {name: np.asarray(a[...], dtype=np.float64) for name, a in members.items()
                  if a.attrs.get("role") == "parameter"}
        return Handle(
            arrays=async_arrays(g, names),
            index={e: i for i, e in enumerate(ids)},
            params=params,
            inner_node=read(array(g, "inner_node")),
            tread_node=read(array(g, "tread_node")),
            mesh_key=str(g.attrs.get("mesh_key")),
        )


def _verified(h: Handle, experiment_id: str, i: int) -> bool:
    ids = h.arrays[EXPERIMENT.name]
    return i < ids.shape[0] and str(read_item(ids, i)) == experiment_id


def locate(store: Store, group: str, experiment_id: str, *, fresh: bool = False
           ) -> tuple[Handle, int]:
    """The group's handle and the index of ``experiment_id`` in it (``fresh``: reload
    the group even if a cached handle knows the id, e.g. to see arrays created since).

    Raises
    ------
    NotReservedError
        The id was never reserved in this group.
    """
    key = _key(store, group)
    with _LOCK:
        h = _HANDLES.get(key)
        if h is not None:
            _HANDLES.move_to_end(key)
    if h is not None and not fresh:
        i = h.index.get(experiment_id)
        if i is not None and _verified(h, experiment_id, i):
            return h, i
    h = _load(store, group)
    with _LOCK:
        _HANDLES[key] = h
        while len(_HANDLES) > _MAX_HANDLES:
            _HANDLES.popitem(last=False)
    i = h.index.get(experiment_id)
    if i is None:
        raise NotReservedError(
            f"experiment {experiment_id!r} is not reserved in group {group!r} of "
            f"{describe(store)}: the client must storage.reserve(...) it before a worker "
            "writes it"
        )
    return h, i


def forget() -> None:
    """Drop every cached handle (tests; a worker never needs to)."""
    with _LOCK:
        _HANDLES.clear()
