"""What a group was made as: digests of its name, model, mesh key and mesh (issue 50).

A group's experiments carry checksums (:mod:`storage.checksum`), but what they are
experiments *of* did not: a hand that edited ``inner_xyz`` or the ``model_spec``
attribute, deleted a mesh chunk (it reads back as zeros), or renamed or copied the
group's folder left a store that ``verify`` called intact and the analyses read, with
wrong coordinates or under a name that no longer says what it holds. A group made
since then carries ``identity``: one SHA-256 per part, written with the group, so that
verify names the part that changed (the folder's name, an attribute, the mesh arrays).
Groups made before lack it and stay readable; verify counts them unverifiable here.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

import numpy as np

IDENTITY = "identity"
"""The group attribute holding the digests (a dict: part -> hex SHA-256)."""

MESH_ARRAYS = ("inner_node", "inner_xyz", "inner_row", "inner_col",
               "tread_node", "tread_xyz", "tread_row", "tread_col")
"""The mesh arrays digested, in this order (:meth:`storage.mesh.MeshNodes.arrays`)."""

VERSION = 1
"""How the digests are made. A group whose identity has another version is treated as
one made before identities (not checked), never as damaged: a change of this module
must not turn every existing store into a damaged one."""

PARTS = {
    "group": "the group's folder name",
    "model_spec": "the group attribute model_spec",
    "mesh_key": "the group attribute mesh_key",
    "mesh": "the mesh arrays (node ids, coordinates, grid rows and columns)",
}


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def name_digest(group: str) -> str:
    """The digest of a group's name, as :func:`digests` stores it."""
    return _sha(group.encode())


def mesh_digest(arrays: Mapping[str, Any]) -> str:
    """One digest of the mesh arrays: each one's name, shape and values, integers as
    int64 and reals as float64 (a reader that widens a dtype, as xarray may, reads the
    same values and so the same digest)."""
    h = hashlib.sha256()
    for name in MESH_ARRAYS:
        a = np.asarray(arrays[name])
        a = np.ascontiguousarray(a, dtype=np.int64 if a.dtype.kind in "iu" else np.float64)
        h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def digests(group: str, attrs: Mapping[str, Any], arrays: Mapping[str, Any]
            ) -> dict[str, Any]:
    """The digest of each part of :data:`PARTS` as the group stands, and the
    :data:`VERSION` they were made by."""
    return {
        "version": VERSION,
        "group": name_digest(group),
        "model_spec": _sha(json.dumps(attrs.get("model_spec")).encode()),
        "mesh_key": _sha(json.dumps(attrs.get("mesh_key")).encode()),
        "mesh": mesh_digest(arrays),
    }


def changed(group: str, attrs: Mapping[str, Any], arrays: Mapping[str, Any]) -> list[str] | None:
    """The parts whose digest no longer matches; ``None`` for a group made before
    identities (nothing to compare with)."""
    stored = attrs.get(IDENTITY)
    if stored is None:
        return None
    if not isinstance(stored, Mapping):
        return ["identity"]
    if stored.get("version") != VERSION:
        return None  # made by another revision of this module: not comparable
    now = digests(group, attrs, arrays)
    return [part for part in PARTS if stored.get(part) != now[part]]
