"""Saved solver states that several tasks continue from: opaque bytes beside the data.

A load-path tree's trunk (:mod:`jobs.trees`) is solved once and continued by its slides;
its states lived in one worker's memory, so a lost worker, a resumed study or a second
client solved the trunk again (issue 50). The worker now saves them here, under
``.states/<group>/<key>`` of the store (a farm entry beside ``.claims``, not a zarr
node: readers and ``verify`` never see it), and whoever holds the trunk's claim next
reads them back instead of solving. The bytes are the caller's (no format here); each
file starts with the BLAKE2b digest of the rest, so that a half-written or damaged
file reads as absent (solved again), never as a wrong state. Deleted when the tree is
finished (:func:`drop`).
"""

from __future__ import annotations

import hashlib

from storage._zarr import delete_key, get_bytes, set_bytes
from storage.errors import SchemaError
from storage.paths import STATES_DIR, StoreLike, check_group_name, names_the_store, open_store
from storage.schema import GROUP_NAME

_DIGEST = 32


def _key(group: str, key: str) -> str:
    check_group_name(group)
    if not (isinstance(key, str) and GROUP_NAME.fullmatch(key)):
        raise SchemaError(f"a saved state's key is 1-128 letters, digits, '_', '.' or '-', "
                          f"got {key!r}")
    return f"{STATES_DIR}/{group}/{key}"


@names_the_store
def save(store: StoreLike, group: str, key: str, data: bytes) -> None:
    """Keep ``data`` as the saved state ``key`` of ``group`` (replacing one there)."""
    digest = hashlib.blake2b(data, digest_size=_DIGEST).digest()
    set_bytes(open_store(store), _key(group, key), digest + data)


@names_the_store
def load(store: StoreLike, group: str, key: str) -> bytes | None:
    """The saved state ``key`` of ``group``; None when there is none, or when what is
    there does not match its digest (cut short or damaged: it is removed)."""
    zs = open_store(store)
    raw = get_bytes(zs, _key(group, key))
    if raw is None:
        return None
    data = raw[_DIGEST:]
    if hashlib.blake2b(data, digest_size=_DIGEST).digest() != raw[:_DIGEST]:
        delete_key(zs, _key(group, key))
        return None
    return data


@names_the_store
def drop(store: StoreLike, group: str, key: str) -> None:
    """Remove the saved state ``key`` of ``group`` (none there: nothing happens)."""
    delete_key(open_store(store), _key(group, key))
