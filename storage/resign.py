"""Experiments whose checksum alone was lost: proven intact by their chunks' CRC32C.

A worker variable's chunk (one experiment) ends in its CRC32C in groups made since
issue 50 (:func:`storage.group.create_array`). When an experiment's ``checksum`` chunk
is lost or does not decode, its data are not suspect on that account: each of its
chunks proves its own bytes. Repair then signs the checksum again from what is stored,
instead of marking the experiment pending for a re-solve (issue 50: checksum-only damage
cost six re-solves in one fuzz case; an experiment may take an hour of ccx).

What is proven, and what is not: the slot's data and status are those the worker wrote
(every chunk present and its CRC32C right). Its id and load case are client arrays,
guarded by the checksum's label, which is what was lost; ``farm sweep resume STUDY``
checks every stored id against the study's load case before it trusts one
(:func:`storage.reserve`). A slot is only signed again when it is done, every variable
the checksum covers is CRC-guarded, and every chunk the checksum would cover is there:
an optional variable's chunk may be absent because the worker recorded nothing, or
because it was deleted - which the store cannot tell apart, so such a slot is not
signed again (it goes pending, as before).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import zarr
from zarr.abc.store import Store

from storage._zarr import delete_key, key_exists, read
from storage.checksum import checksum
from storage.group import crc_guarded
from storage.schema import DONE, checked_names


def chunk_key(group: str, name: str, a: zarr.Array, i: int) -> str:
    """The key of slot ``i``'s chunk of a worker variable (one experiment per chunk)."""
    return f"{group}/{name}/c/{i}" + "/0" * (a.ndim - 1)


def signed_again(zs: Store, group: str, arrays: Mapping[str, zarr.Array], experiment: str,
                 params: Mapping[str, np.ndarray], i: int, state: int) -> str | None:
    """The checksum slot ``i`` gets when its data are proven intact, else None."""
    names = checked_names(arrays)
    if state != DONE or not all(crc_guarded(arrays[n]) for n in (*names, "status", "checksum")):
        return None
    values: dict[str, np.ndarray] = {}
    for name in names:
        a = arrays[name]
        if name != "error" and not key_exists(zs, chunk_key(group, name, a, i)):
            return None  # lost, or never written: not proven either way
        try:
            values[name] = np.asarray(read(a, slice(i, i + 1)))[0]
        except Exception:  # its CRC32C (or its codec) refused it: damaged
            return None
    mine = {n: float(a[i]) for n, a in params.items()}
    return checksum(experiment, mine, DONE, values)


def drop_unreadable(zs: Store, group: str, arrays: Mapping[str, zarr.Array],
                    slots: list[int]) -> list[str]:
    """Delete the CRC-guarded chunks of ``slots`` (marked pending) that do not decode:
    their values are void either way, and a chunk that raises stops every read of a
    range holding it, the done experiments beside it included. Returns the keys."""
    dropped = []
    for name, a in sorted(arrays.items()):
        if name == "status" or not (a.ndim and crc_guarded(a)):
            continue
        for i in slots:
            try:
                read(a, slice(i, i + 1))
            except Exception:  # the chunk is damaged: void, since the slot is pending
                key = chunk_key(group, name, a, i)
                delete_key(zs, key)
                dropped.append(key)
    return dropped
