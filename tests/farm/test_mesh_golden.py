"""The mesher's version guards every id: a canonical mesh that changes without a bump
of :data:`farm.mesh.version.MESHER_VERSION` fails here.

The digests are of the geometry, not of gmsh's numbering: nodes rounded to 1e-6 mm and
sorted, each element as the sorted set of its nodes' places in that order, each named
set likewise. They were taken from the mesher of commit 31ef7f1 (version 1), the last
one whose source bytes were the fingerprint, so they also prove that the version
constant replaced the source hash without moving a node.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from farm.mesh.build import build_mesh
from farm.mesh.tyremesh import TyreMesh
from farm.mesh.version import LAYERS_VERSION, MESHER_VERSION, gmsh_version, mesh_key
from farm.presets import default_model
from farm.specs import MeshDensity

COARSE = MeshDensity(tread=4, sidewall=2, bead=1, circumferential=16)

GOLDEN_GMSH = "4.15.2"
# (spec, mesh key, geometry digest) as made by mesher version 1 with gmsh 4.15.2
GOLDEN = {
    "reduced": (
        lambda: default_model("reduced"),
        "d3b7814ce78bff0c737677d1fb370de4801db808fd6c5648b4953d725ed55727",
        "bbce06e5d21416382c629406be67f6728238f1a8ad2edb731c3a3111a9b2ca49"),
    "full-coarse": (
        lambda: default_model("full", mesh=COARSE),
        "d1e4bc5e01743f143f42072ef9bd558e7379f8e64d49fd3a33a1086789c9792e",
        "b8511fb9387ee3afb922535f53b7f2c9344474970a52d646d5a3b664b25c4421"),
    "reduced-through-2": (
        lambda: default_model("reduced", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                          circumferential=8, through=2)),
        "0b16158ee7e6103e81a3599438e803ca736349337414a798d985bc2c36378041",
        "d48fe9216e4e1cc4bf63c6702f51474ef5b61a777aa4ca791722fe0a2821876e"),
}


def geometry_digest(mesh: TyreMesh) -> str:
    """SHA-256 of a mesh's geometry and sets, independent of node and element numbering."""
    rounded = np.round(mesh.nodes, 6) + 0.0  # + 0.0: no -0.0
    order = np.lexsort(rounded.T[::-1])
    place = np.empty(len(order), dtype=np.int64)
    place[order] = np.arange(len(order))
    digest = hashlib.sha256(rounded[order].tobytes())
    elements = np.sort(place[mesh.elements - 1], axis=1)
    digest.update(elements[np.lexsort(elements.T[::-1])].tobytes())
    digest.update(np.sort(mesh.element_region[np.lexsort(elements.T[::-1])]).tobytes())
    for name in sorted(mesh.node_sets):
        digest.update(name.encode() + np.sort(place[mesh.node_sets[name] - 1]).tobytes())
    return digest.hexdigest()


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_canonical_meshes_are_unchanged_at_this_mesher_version(name):
    make, key, digest = GOLDEN[name]
    spec = make()
    assert (MESHER_VERSION, LAYERS_VERSION) == (1, 1), (
        "the mesher's version was bumped: take new digests and keys for GOLDEN")
    assert geometry_digest(build_mesh(spec)) == digest, (
        f"mesh {name!r} changed while MESHER_VERSION stayed {MESHER_VERSION}: if the change "
        "is meant, bump farm.mesh.version.MESHER_VERSION (every id changes) and the digests")
    if gmsh_version() == GOLDEN_GMSH:  # the key names gmsh's release too
        assert mesh_key(spec) == key
