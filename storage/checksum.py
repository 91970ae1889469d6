"""Per-experiment checksums: what a worker signs, and the check of what a reader reads.

With every done or failed experiment a worker writes a checksum into its own slot
(variable ``checksum``, in the same step as the data, before the status that publishes
them), ``"<label>:<data>"``, two blake2b-128 digests in hex:

- label: the experiment id and its load-case parameters as the worker read them from
  the store, by name (NaN ones skipped: a parameter added to a group later is NaN in
  the slots reserved before it, and :func:`storage.reserve` never sets it there);
- data: the label, the status (done or failed) and every variable of
  :data:`~storage.schema.CHECKED_NAMES`, then those of
  :data:`~storage.schema.COMBINED_NAMES` the group has and the slot records
  (combined-load groups only, so the checksums of every other group are those of
  before), then those of :data:`~storage.schema.PATCH_NAMES` (contact patch, inflation
  growth: issue 24) the group has and the slot records (groups created before them have
  none, and their checksums stay those of before), each as its name, dtype,
  shape and C-order little-endian bytes (text as UTF-8, every NaN as the one canonical
  NaN).

Two parts, so that a reader can check the labels of every done experiment cheaply (ids
and parameters are small, and a selection by load case relies on them) and the data
only of what it loads, and so that a report can say which of the two was damaged. The
status is in the data digest: a flipped status byte (failed read as done) shows too.
This catches flipped, lost, truncated or mixed-up chunks; it is no defence against a
forger (the hash is keyless).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from storage._zarr import short_error
from storage.schema import (
    CHECKED_NAMES,
    COMBINED_NAMES,
    FIXED_VARIABLES,
    NOT_RECORDED,
    PATCH_NAMES,
    STATUS_NAMES,
)

ALGORITHM = "blake2b-128"
_DIGEST_BYTES = 16
_HEX = 2 * _DIGEST_BYTES
#: Target bytes of one block of experiments read at a time by :func:`check`.
BLOCK_BYTES = 64 * 2**20


def _hash() -> hashlib.blake2b:
    return hashlib.blake2b(digest_size=_DIGEST_BYTES)


def _feed(h: hashlib.blake2b, name: str, value: object) -> None:
    dtype = FIXED_VARIABLES[name].dtype if name in FIXED_VARIABLES else "float64"
    a = np.asarray(value)
    if dtype == "str":
        texts = [str(x).encode() for x in a.ravel().tolist()]
        body = b"".join(len(t).to_bytes(8, "little") + t for t in texts)
        head = f"{name}|utf-8|{a.shape}|"
    else:
        b = np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<"))
        if b.dtype.kind == "f":
            b = np.where(np.isnan(b), np.nan, b).astype(b.dtype)  # one NaN bit pattern
        body, head = b.tobytes(), f"{name}|{b.dtype.str}|{b.shape}|"
    h.update(head.encode())
    h.update(body)


def label_digest(experiment_id: str, params: Mapping[str, float]) -> str:
    """Digest of an experiment's id and its (finite) load-case parameters."""
    h = _hash()
    h.update(f"id|{experiment_id}|".encode())
    for name in sorted(params):
        v = float(params[name])
        if not np.isnan(v):
            _feed(h, name, np.float64(v))
    return h.hexdigest()


def data_digest(label: str, status: int, values: Mapping[str, np.ndarray]) -> str:
    """Digest of one slot's status and data (``values``: one experiment's slices)."""
    h = _hash()
    h.update(f"label|{label}|status|{int(status)}|".encode())
    for name in CHECKED_NAMES:
        _feed(h, name, values[name])
    # only in groups that have them (combined-load groups; groups created since issue
    # 24), and only where recorded
    for name in (*COMBINED_NAMES, *PATCH_NAMES):
        if name in values and not _unrecorded(name, values[name]):
            _feed(h, name, values[name])
    return h.hexdigest()


def _unrecorded(name: str, value: object) -> bool:
    """Whether a combined or patch variable's slot holds only its fill (NaN, -1 for the
    status): a vertical experiment of a combined group, a failure, a model without
    inflation, or one written by a worker whose open arrays predate the group's optional
    ones. Skipped in the digest, so both read back
    alike; a recorded slot later lost reads as fill and no longer matches."""
    a = np.asarray(value)
    if FIXED_VARIABLES[name].dtype == "int8":
        return bool(np.all(a == NOT_RECORDED))
    return bool(np.all(np.isnan(a.astype(np.float64))))


def checksum(experiment_id: str, params: Mapping[str, float], status: int,
             values: Mapping[str, np.ndarray]) -> str:
    """The checksum a worker stores with a done or failed experiment."""
    label = label_digest(experiment_id, params)
    return f"{label}:{data_digest(label, status, values)}"


def split(stored: str) -> tuple[str, str] | None:
    """``(label, data)`` of a stored checksum, or None if it is not one."""
    parts = str(stored).split(":")
    if len(parts) != 2 or any(len(p) != _HEX for p in parts):
        return None
    try:
        [bytes.fromhex(p) for p in parts]
    except ValueError:
        return None
    return parts[0], parts[1]


@dataclass(frozen=True)
class Slots:
    """Experiments to check, as read from a store or a dataset (positions 0..n-1).

    ``ids``, ``status``, ``checksums`` and every array of ``params`` have one entry per
    position; ``read(name, lo, hi)`` returns positions ``lo:hi`` of a variable of
    ``names`` (and may raise whatever a damaged chunk makes the store raise);
    ``sizes`` is the bytes per experiment of each of those variables; ``names`` are the
    checked variables of the group (:func:`storage.schema.checked_names`).
    """

    ids: Sequence[str]
    status: np.ndarray
    params: Mapping[str, np.ndarray]
    checksums: Sequence[str]
    read: Callable[[str, int, int], np.ndarray]
    sizes: Mapping[str, int]
    names: Sequence[str] = CHECKED_NAMES


def check(slots: Slots, positions: Sequence[int], *, data: bool = True) -> dict[int, str]:
    """Position -> reason for each of ``positions`` whose checksum does not match.

    Labels first (no data read); then, with ``data``, the data of the positions whose
    label matched, block by block (about :data:`BLOCK_BYTES` each), so that memory stays
    bounded however many experiments there are.
    """
    bad: dict[int, str] = {}
    labels: dict[int, str] = {}
    for k in positions:
        reason, label = _label_check(slots, k)
        if reason:
            bad[k] = reason
        else:
            labels[k] = label
    if data and labels:
        bad.update(_data_check(slots, labels))
    return dict(sorted(bad.items()))


def _label_check(slots: Slots, k: int) -> tuple[str | None, str]:
    stored = slots.checksums[k]
    if not stored:
        return "it has no checksum (its checksum chunk is missing)", ""
    parts = split(stored)
    if parts is None:
        return f"its checksum {str(stored)[:80]!r} is garbled", ""
    params = {n: a[k] for n, a in slots.params.items()}
    label = label_digest(str(slots.ids[k]), params)
    if label != parts[0]:
        shown = ", ".join(f"{n}={float(v):g}" for n, v in sorted(params.items())
                          if not np.isnan(v))
        return (f"its id or load case ({shown}) differs from what the worker recorded "
                "(a parameter or id chunk is damaged)"), ""
    return None, label


def _data_check(slots: Slots, labels: dict[int, str]) -> dict[int, str]:
    step = max(1, BLOCK_BYTES // max(sum(slots.sizes.values()), 1))
    todo = sorted(labels)
    bad: dict[int, str] = {}
    while todo:
        block = [k for k in todo if k < todo[0] + step]
        todo = todo[len(block):]
        rows, unreadable = _read_block(slots, block)
        bad.update(unreadable)
        for k, one in rows.items():
            if data_digest(labels[k], int(slots.status[k]), one) != slots.checksums[k][-_HEX:]:
                state = STATUS_NAMES.get(int(slots.status[k]), str(slots.status[k]))
                bad[k] = (f"its data or status ({state}) differ from what the worker wrote "
                          "(a chunk was changed or lost)")
    return bad


def _read_block(slots: Slots, block: list[int]):
    """The checked variables of ``block`` (positions, ascending), read in one go; a
    block that does not decode is read one experiment at a time, to name the ones whose
    chunks are damaged. Returns (position -> values, position -> reason)."""
    lo, hi = block[0], block[-1] + 1
    try:
        values = {n: np.asarray(slots.read(n, lo, hi)) for n in slots.names}
        return {k: {n: v[k - lo] for n, v in values.items()} for k in block}, {}
    except Exception:  # a damaged chunk raises whatever its codec raises
        pass
    rows: dict[int, dict[str, np.ndarray]] = {}
    unreadable: dict[int, str] = {}
    for k in block:
        one: dict[str, np.ndarray] = {}
        for n in slots.names:
            try:
                one[n] = np.asarray(slots.read(n, k, k + 1))[0]
            except Exception as e:  # any codec or I/O error of one chunk
                unreadable[k] = f"its {n!r} chunk does not decode ({short_error(e)})"
                break
        else:
            rows[k] = one
    return rows, unreadable
