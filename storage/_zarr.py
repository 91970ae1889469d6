"""Every use of zarr-python beyond its public API, in one place.

Why these are needed (zarr-python 3.1; checked against 3.1.6):

- zarr v3's public :class:`zarr.Array` API is synchronous and writes one array per
  call. A worker writes a dozen arrays of one experiment, and doing them one after the
  other costs several times writing them together; there is no public way to run
  several arrays' reads or writes concurrently. So the worker keeps each array's
  :class:`zarr.AsyncArray` (``Array.async_array``, undocumented) and drives its
  coroutines (``getitem``/``setitem``) on zarr's own event loop with
  ``zarr.core.sync.sync`` (internal).
- :class:`zarr.abc.store.Store` exposes only coroutines (``exists``); the same
  ``sync`` runs them from synchronous code.
- Reading and writing one key's raw bytes (``Store.get``/``Store.set``) needs a
  buffer prototype (``zarr.core.buffer``, internal); ``farm sweep verify`` uses them to
  read metadata documents as bytes and to restore a damaged ``zarr.json`` from the
  root's consolidated copy (``storage.verify``).
- zarr's type hints are wider than what the farm's stores hold: ``group[name]`` is an
  array or a group, ``array[selection]`` any array-like or a scalar, and an array's
  metadata v2 or v3. :func:`array`, :func:`read` and :func:`dimension_names` narrow them
  once (the selection types come from ``zarr.core.indexing``, internal).
- :func:`zarr.consolidate_metadata` warns on every call that consolidated metadata is
  not part of the v3 specification; the warning's text is matched to silence it.

What to check on a zarr upgrade (``tests/storage`` exercises every function here; the
concurrency and crash tests depend on the write order of :func:`write_in_order`):

- ``zarr.core.sync.sync`` still exists and runs a coroutine on zarr's loop;
- ``zarr.core.buffer.default_buffer_prototype()`` still exists, with
  ``.buffer.from_bytes``;
- ``zarr.Array.async_array`` still returns the array's ``AsyncArray``, whose
  ``getitem(selection)`` and ``setitem(selection, value)`` are coroutines;
- the consolidated-metadata warning still starts with ``Consolidated metadata is
  currently not`` (otherwise it merely shows again: harmless).
"""

from __future__ import annotations

import asyncio
import warnings
from collections.abc import Coroutine, Iterable, Sequence
from typing import Any, TypeVar

import numpy as np
import zarr
from zarr import AsyncArray
from zarr.abc.store import Store
from zarr.core.buffer import default_buffer_prototype
from zarr.core.indexing import CoordinateSelection, Selection
from zarr.core.metadata import ArrayV3Metadata
from zarr.core.sync import sync as _sync

from storage.errors import DamagedStoreError, verify_hint

T = TypeVar("T")

#: One write: an array, the selection along its first axis, the values.
Write = tuple[AsyncArray, slice, np.ndarray]

__all__ = ["AsyncArray", "Write", "array", "async_arrays", "consolidate", "dimension_names",
           "get_bytes", "key_exists", "list_dir", "read", "read_coordinates", "read_item",
           "run", "set_bytes", "write_in_order"]


def run(coroutine: Coroutine[Any, Any, T]) -> T:
    """Run a zarr coroutine to its end from synchronous code (on zarr's event loop)."""
    return _sync(coroutine)


def key_exists(store: Store, key: str) -> bool:
    """Whether ``key`` (e.g. ``"zarr.json"``) exists in ``store``."""
    return bool(run(store.exists(key)))


def get_bytes(store: Store, key: str) -> bytes | None:
    """The raw bytes stored under ``key``, or None when there are none."""
    buf = run(store.get(key, prototype=default_buffer_prototype()))
    return None if buf is None else buf.to_bytes()


def set_bytes(store: Store, key: str, data: bytes) -> None:
    """Store ``data`` under ``key`` as it is (no codec)."""
    run(store.set(key, default_buffer_prototype().buffer.from_bytes(data)))


def delete_key(store: Store, key: str) -> None:
    """Remove ``key`` (a chunk reads as the array's fill value then)."""
    run(store.delete(key))


def list_dir(store: Store, prefix: str) -> list[str]:
    """Names directly under ``prefix`` (``""``: the root), keys and "folders" alike."""

    async def collect() -> list[str]:
        return [name async for name in store.list_dir(prefix)]

    return sorted(run(collect()))


def array(group: zarr.Group, name: str) -> zarr.Array:
    """The array ``name`` of ``group`` (KeyError when there is none).

    Raises
    ------
    DamagedStoreError
        ``name`` is a group: the farm never makes one there, so the store was edited.
    """
    node = group[name]
    if not isinstance(node, zarr.Array):
        where = f"{group.path}/{name}" if group.path else name
        raise DamagedStoreError(
            f"{where} is a group where the farm keeps an array: the store was modified by "
            f"hand; {verify_hint()}"
        )
    return node


def read(arr: zarr.Array, selection: Selection = ...) -> np.ndarray:
    """``arr[selection]`` as a numpy array (a 0-d one for a single element).

    zarr types the result as any array-like or a scalar; with zarr's default (numpy)
    buffers it already is an ndarray, which ``np.asarray`` returns as it is (no copy).
    """
    return np.asarray(arr[selection])


def read_coordinates(arr: zarr.Array, coordinates: CoordinateSelection) -> np.ndarray:
    """``arr.get_coordinate_selection(coordinates)`` as a numpy array."""
    return np.asarray(arr.get_coordinate_selection(coordinates))


def dimension_names(arr: zarr.Array) -> tuple[str | None, ...]:
    """The array's dimension names; () when it has none (or is a Zarr v2 array, whose
    metadata cannot hold them)."""
    meta = arr.metadata
    if not isinstance(meta, ArrayV3Metadata):
        return ()
    return tuple(meta.dimension_names or ())


def async_arrays(group: zarr.Group, names: Iterable[str]) -> dict[str, AsyncArray]:
    """The asynchronous views of arrays of ``group``, by name."""
    return {name: array(group, name).async_array for name in names}


def read_item(array: AsyncArray, index: int) -> Any:
    """One element of a one-dimensional array."""
    return run(array.getitem(index))


def write_in_order(steps: Sequence[Sequence[Write]]) -> None:
    """Run ``steps`` one after the other; the writes of one step run concurrently.

    A step ends only when all of its writes have, so whatever a later step writes (a
    status flag) is never stored before what an earlier step wrote (the data it marks).
    """
    run(_write_steps(steps))


async def _write_steps(steps: Sequence[Sequence[Write]]) -> None:
    for step in steps:
        await asyncio.gather(*(array.setitem(region, values) for array, region, values in step))


def consolidate(store: Store) -> None:
    """Refresh the consolidated metadata at the root of ``store``."""
    with warnings.catch_warnings():
        # Consolidated metadata is a zarr-python extension of v3 ("must_understand":
        # false), which other readers ignore; nothing in storage/ depends on it.
        warnings.filterwarnings("ignore", message="Consolidated metadata is currently not")
        zarr.consolidate_metadata(store)


_CRC_MISMATCH = "Stored and computed checksum do not match"  # zarr's Crc32cCodec


def short_error(e: BaseException) -> str:
    """``Type: message`` of a read or decode error on one line (at most 160 characters
    of message); a chunk whose CRC32C fails is said so, not as zarr's "checksum" (the
    farm's checksums are the experiments', :mod:`storage.checksum`)."""
    text = " ".join(str(e).split())
    if text.startswith(_CRC_MISMATCH):
        return "its CRC32C does not match: a byte of the chunk changed"
    return f"{type(e).__name__}: {text[:160]}"
