"""MeshNodes and GroupAttrs: validated once, canonical dtypes, read-only arrays."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from store_helpers import make_attrs, make_mesh

from storage import GroupAttrs, MeshNodes, SchemaError


def _fields(mesh: MeshNodes) -> dict:
    return {f.name: getattr(mesh, f.name) for f in dataclasses.fields(mesh)}


def test_mesh_arrays_are_canonical_and_read_only():
    mesh = make_mesh()
    assert mesh.inner_ids.dtype == np.int64 and mesh.inner_xyz.dtype == np.float64
    assert mesh.tread_row.dtype == np.int32
    with pytest.raises(ValueError, match="read-only"):
        mesh.inner_xyz[0, 0] = 1.0


def test_mesh_copies_its_input():
    ids = np.arange(4)
    mesh = MeshNodes(ids, np.zeros((4, 3)), ids, ids, ids, np.zeros((4, 3)), ids, ids)
    ids[0] = 99
    assert mesh.inner_ids[0] == 0


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("inner_ids", np.array([1, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]), "repeated node ids"),
        ("inner_ids", np.arange(12.0), "integer node ids"),
        ("tread_ids", np.arange(0), "non-empty"),
        ("inner_xyz", np.zeros((12, 2)), r"\(12, 3\) array"),
        ("tread_xyz", np.full((5, 3), np.nan), "NaN or inf"),
        ("inner_row", np.arange(11), r"\(12,\) array"),
        ("tread_col", -np.ones(5, dtype=int), "grid positions"),
    ],
)
def test_mesh_rejects_bad_arrays(field, value, match):
    kwargs = _fields(make_mesh())
    kwargs[field] = value
    with pytest.raises(SchemaError, match=match):
        MeshNodes(**kwargs)


def test_difference_names_what_differs():
    mesh = make_mesh()
    stored = mesh.arrays()
    assert mesh.difference(stored) is None
    moved = dict(stored, tread_xyz=stored["tread_xyz"] + 1e-3)
    assert "tread_xyz" in mesh.difference(moved)
    close = dict(stored, tread_xyz=stored["tread_xyz"] + 1e-9)
    assert mesh.difference(close) is None


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"model_spec": "{not json"}, "JSON text"),
        ({"model_spec": "[1, 2]"}, "JSON object"),
        ({"mesh_key": ""}, "mesh_key"),
        ({"solver": None}, "solver"),
        ({"package_versions": {"numpy": 2}}, "version strings"),
    ],
)
def test_group_attrs_rejects_bad_values(change, match):
    base = make_attrs()
    with pytest.raises(SchemaError, match=match):
        dataclasses.replace(base, **change)


def test_group_attrs_default_versions_name_the_stack():
    attrs = GroupAttrs("{}", "k", "CalculiX 2.20")
    assert {"numpy", "zarr", "xarray"} <= set(attrs.package_versions)
