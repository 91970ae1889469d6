"""What a mesh depends on besides its spec: the mesher's version and gmsh's version.

Cached meshes (and everything derived from them: inflation pre-runs, a store group's
``mesh_key``, every experiment id) are keyed by :func:`mesh_key`. The key must change
whenever the mesher would place a node differently: a fix of the shoulder contour in
``farm/geometry.py`` was once answered for hours by meshes cached from the old code
(nodes up to 3.8 mm off, the reduced model's force at 30 mm 5 % off).

How that is enforced: :data:`MESHER_VERSION` is an explicit number, bumped by hand when
a change moves a node of an existing mesh, and ``tests/farm/test_mesh_golden.py`` holds
the geometry of canonical meshes and fails when their nodes or elements change while
the version stays. Until 2026-11-26 the fingerprint was a SHA-256 of the mesher's source
bytes, so a comment edit changed every id; version 1 is that last digest, kept verbatim
per gmsh release (:data:`_SOURCE_DIGESTS`), so every key and id made before stays valid
and old stores keep resuming.
"""

from __future__ import annotations

from functools import cache

from farm.specs import ModelSpec, content_hash

MESHER_VERSION = 1
"""Bump when :mod:`farm.geometry` or :mod:`farm.mesh.build` moves a node of a mesh
whose spec existed before (new spec fields at their defaults must not move any)."""

LAYERS_VERSION = 1
"""The wall splitter's (:mod:`farm.mesh.layers`) version: part of a mesh's key only
when the wall is layered (``mesh.through > 1``)."""

# Version 1 = SHA-256(gmsh version + the bytes of geometry.py, mesh/build.py,
# mesh/session.py, mesh/tyremesh.py) as of commit 31ef7f1, for each gmsh release the
# project's `gmsh>=4.11` admitted that day. A gmsh release not listed gets a new key.
_SOURCE_DIGESTS = {
    "4.15.2": "3c140f002e57bcbfdfe69a292e862bd26d03d790f82b6a6d4194d75b033b35b6",
    "4.15.1": "74df3beb1336f7adcaa50677f85320cb2eb8fc5246fb83ef6d51144a63eac73e",
    "4.15.0": "0cbf2eb292f3edd6787e61e07bcb02b8bb719afebe1b0861e451c57d878653c3",
    "4.14.1": "995f56af55ac137aeb9ecc0b6aec2382ec62ecabbda4271da9fce4e0eb0c358c",
    "4.14.0": "6a2e858c8ee5748134a1e11168e83d355707a6461e78056e579b9f8277b81f77",
    "4.13.1": "a3bfdeffd7d15661e2185fb1cc5481ac170efccaf5791dc6e67420f4c279aa36",
    "4.13.0": "a9884d71ebea839fb7981e44357089fde30c45b6984c742d4150d079054dae55",
    "4.12.2": "586090a896c79fe1e803aeaaf571608b1d87cdcef1a764341572e301b630ef69",
    "4.12.1": "3d191b9bd3782bf056a6ce2b88f460bd5defb87c42328b7a4b9ad702b079fd36",
    "4.12.0": "7b21904c8a1c3fab6835b5fb50ffc1e4583fa4591f3fcad1372c04dbce7b9b67",
    "4.11.1": "545f77d4cfc488b2f346f81a614b9548005b65d2e4c951cc179ad40409129416",
    "4.11.0": "40d6a50cf2c15ecbab6348fc98664d7197705e0f99fbcef6eebc9024c7ef5c25",
}
# Layers version 1 = SHA-256 of mesh/layers.py as of commit 31ef7f1.
_LAYERS_DIGEST = "ac7ab7e3650be8735f46b182d2fbf9bd49c6f38019e351fcf852be8c215559f0"


def gmsh_version() -> str:
    import gmsh

    return str(getattr(gmsh, "__version__", "?"))


@cache
def mesher_fingerprint() -> str:
    """The mesher's identity: :data:`MESHER_VERSION` with gmsh's version."""
    version = gmsh_version()
    if MESHER_VERSION == 1 and version in _SOURCE_DIGESTS:
        return _SOURCE_DIGESTS[version]
    return content_hash({"mesher": MESHER_VERSION, "gmsh": version})


@cache
def layers_fingerprint() -> str:
    """The wall splitter's identity (:data:`LAYERS_VERSION`)."""
    if LAYERS_VERSION == 1:
        return _LAYERS_DIGEST
    return content_hash({"layers": LAYERS_VERSION})


def mesh_key(spec: ModelSpec) -> str:
    """Content hash of a mesh: the spec's geometry, density and sector, and the mesher
    (with the wall splitter for a wall of several elements)."""
    body = {"spec": spec.mesh_key(), "mesher": mesher_fingerprint()}
    if spec.mesh.through > 1:
        body["layers"] = layers_fingerprint()
    return content_hash(body)
