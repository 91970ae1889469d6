"""Client side: create_group is idempotent for one mesh and refuses another; list_groups."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import zarr
from store_helpers import GROUP, make_attrs, make_mesh

import storage
from storage import MeshMismatchError
from storage.paths import open_store


def _group(store):
    return zarr.open_group(open_store(store), path=GROUP, mode="r", use_consolidated=False)


def test_create_group_writes_mesh_and_attributes(store, group, mesh):
    g = _group(store)
    np.testing.assert_array_equal(g["inner_node"][...], mesh.inner_ids)
    np.testing.assert_array_equal(g["tread_xyz"][...], mesh.tread_xyz)
    assert g["component"][...].tolist() == ["x", "y", "z"]
    assert g["strain_component"][...].tolist() == ["xx", "yy", "xy"]
    assert g["displacement"].shape == (0, mesh.n_inner, 3)
    assert g.attrs["schema_version"] == 1 and g.attrs["mesh_key"] == "mesh-a"
    assert json.loads(g.attrs["model_spec"])["kind"] == "reduced"
    assert json.loads(g.attrs["package_versions"])["tyre-farm"] == "0.1.0"


def test_worker_arrays_have_one_experiment_per_chunk(store, group, mesh):
    g = _group(store)
    assert g["displacement"].chunks == (1, mesh.n_inner, 3)
    assert g["reaction_force"].chunks == (1, mesh.n_tread, 3)
    assert g["status"].chunks == (1,) and g["error"].chunks == (1,)


def test_create_group_again_with_the_same_mesh_changes_nothing(store, group, mesh):
    storage.reserve(store, group, ["e1"], {"deflection": 5.0, "pressure": 0.0})
    storage.create_group(store, group, make_mesh(), make_attrs())
    assert storage.statuses(store, group) == {"e1": storage.PENDING}


@pytest.mark.parametrize(
    ("mesh_change", "key", "match"),
    [
        ({}, "mesh-b", "holds mesh 'mesh-a', not 'mesh-b'"),
        ({"tread_ids": np.arange(5) + 6000}, "mesh-a", "tread_node differs"),
        ({"inner_xyz": make_mesh().inner_xyz + 0.01}, "mesh-a", "inner_xyz differs"),
        ({"inner_row": np.zeros(12, dtype=int)}, "mesh-a", "inner_row differs"),
    ],
)
def test_create_group_with_another_mesh_is_refused(store, group, mesh_change, key, match):
    other = dataclasses.replace(make_mesh(), **mesh_change)
    with pytest.raises(MeshMismatchError, match=match):
        storage.create_group(store, group, other, make_attrs(key))


def test_other_node_count_is_a_mismatch(store, group):
    with pytest.raises(MeshMismatchError, match="shape"):
        storage.create_group(store, group, make_mesh(n_inner=13), make_attrs())


def test_a_half_made_group_is_rebuilt(store, mesh):
    storage.create_group(store, GROUP, mesh, make_attrs())
    g = zarr.open_group(open_store(store), path=GROUP, mode="r+", use_consolidated=False)
    g.attrs.clear()  # what a client killed before its last step leaves
    del g["status"]
    storage.create_group(store, GROUP, mesh, make_attrs())
    assert storage.status_counts(store, GROUP) == {"pending": 0, "done": 0, "failed": 0}


def test_list_groups(store, group, mesh):
    other = dataclasses.replace(mesh, tread_ids=mesh.tread_ids + 1)
    storage.create_group(store, "mesh-b", other, make_attrs("mesh-b"))
    assert storage.list_groups(store) == ["mesh-a", "mesh-b"]
