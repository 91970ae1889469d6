"""What a mesh depends on besides its spec: the mesher's own code and gmsh's version.

Cached meshes (and everything derived from them: inflation pre-runs, a store group's
``mesh_key``) are keyed by :func:`mesh_key`. Before this existed the key was the spec
alone, and a fix of the shoulder contour in ``farm/geometry.py`` was answered for hours
by meshes cached from the old code (nodes up to 3.8 mm off, the reduced model's force
at 30 mm 5 % off). Hashing the source of the modules that build a mesh makes any such
change a new key: caches fill again, and a store refuses to mix the two meshes.
"""

from __future__ import annotations

import hashlib
from functools import cache
from pathlib import Path

from farm.specs import ModelSpec, content_hash

_FARM = Path(__file__).resolve().parents[1]
SOURCES = ("geometry.py", "mesh/build.py", "mesh/session.py", "mesh/tyremesh.py")


LAYERS = "mesh/layers.py"
"""The wall splitter (:mod:`farm.mesh.layers`): part of a mesh's key only when the wall
is layered (``mesh.through > 1``), so that no one-element mesh changes key with it."""


@cache
def mesher_fingerprint() -> str:
    """SHA-256 of the mesher's source files and gmsh's version."""
    import gmsh

    digest = hashlib.sha256(str(getattr(gmsh, "__version__", "?")).encode())
    for name in SOURCES:
        digest.update((_FARM / name).read_bytes())
    return digest.hexdigest()


@cache
def layers_fingerprint() -> str:
    """SHA-256 of the wall splitter's source."""
    return hashlib.sha256((_FARM / LAYERS).read_bytes()).hexdigest()


def mesh_key(spec: ModelSpec) -> str:
    """Content hash of a mesh: the spec's geometry, density and sector, and the mesher
    (with the wall splitter for a wall of several elements)."""
    body = {"spec": spec.mesh_key(), "mesher": mesher_fingerprint()}
    if spec.mesh.through > 1:
        body["layers"] = layers_fingerprint()
    return content_hash(body)
