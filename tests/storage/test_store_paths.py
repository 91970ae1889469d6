"""Store resolution: paths, file:// URLs and store objects; clear errors for non-stores."""

from __future__ import annotations

import pytest
import zarr
from store_helpers import GROUP, make_attrs, make_mesh
from zarr.storage import LocalStore, MemoryStore

import storage
from storage import GroupNotFoundError, NotAStoreError, SchemaError, StoreError
from storage.paths import open_store


def test_paths_and_file_urls_are_local_stores(tmp_path):
    for given in (tmp_path / "a.zarr", str(tmp_path / "a.zarr"), f"file://{tmp_path}/a.zarr"):
        s = open_store(given)
        assert isinstance(s, LocalStore) and str(s.root) == str(tmp_path / "a.zarr")


def test_store_objects_are_used_as_given():
    s = MemoryStore()
    assert open_store(s) is s


def test_url_without_backend_is_a_clear_error():
    with pytest.raises(StoreError, match="cannot open store URL"):
        open_store("nosuchprotocol://bucket/x.zarr")


def test_not_a_store_argument():
    with pytest.raises(StoreError, match="path, an fsspec URL or a zarr store"):
        open_store(42)


def test_missing_store_is_not_a_store(tmp_path):
    with pytest.raises(NotAStoreError, match="no store at") as e:
        storage.open_dataset(tmp_path / "missing.zarr", GROUP)
    assert isinstance(e.value, FileNotFoundError)
    assert not (tmp_path / "missing.zarr").exists()  # reading never creates


def test_a_directory_of_other_files_is_not_a_store(tmp_path):
    (tmp_path / "notes.txt").write_text("not zarr")
    with pytest.raises(NotAStoreError, match="not a Zarr v3 store"):
        storage.create_group(tmp_path, GROUP, make_mesh(), make_attrs())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]  # left untouched


def test_a_file_is_not_a_store(tmp_path):
    f = tmp_path / "file.zarr"
    f.write_text("")
    with pytest.raises(NotAStoreError, match="is a file"):
        storage.list_groups(f)


def test_an_empty_directory_becomes_a_store(tmp_path):
    storage.create_group(tmp_path, GROUP, make_mesh(), make_attrs())
    assert storage.list_groups(tmp_path) == [GROUP]


def test_a_zarr_v2_store_is_refused(tmp_path):
    zarr.open_group(tmp_path / "v2.zarr", mode="w", zarr_format=2)
    with pytest.raises(SchemaError, match="Zarr v2 store"):
        storage.create_group(tmp_path / "v2.zarr", GROUP, make_mesh(), make_attrs())


def test_missing_group_names_the_groups(group, store):
    with pytest.raises(GroupNotFoundError, match=f"no group 'other'.*groups: {group}"):
        storage.open_dataset(store, "other")


@pytest.mark.parametrize("name", ["", "a/b", "../x", " x", "x" * 200])
def test_bad_group_names(store, name):
    with pytest.raises(SchemaError, match="group name"):
        storage.create_group(store, name, make_mesh(), make_attrs())


def test_group_of_another_tool_is_refused(tmp_path):
    root = zarr.open_group(tmp_path / "s.zarr", mode="w")
    root.create_group(GROUP).create_array("temperature", shape=(2,), dtype="f8")
    with pytest.raises(SchemaError, match="not a tyre-farm group"):
        storage.create_group(tmp_path / "s.zarr", GROUP, make_mesh(), make_attrs())
    with pytest.raises(SchemaError, match="schema version"):
        storage.reserve(tmp_path / "s.zarr", GROUP, ["e1"], {"deflection": 1.0, "pressure": 0.0})
    assert storage.list_groups(tmp_path / "s.zarr") == []


def test_an_array_is_not_a_group(tmp_path):
    root = zarr.open_group(tmp_path / "s.zarr", mode="w")
    root.create_array(GROUP, shape=(2,), dtype="f8")
    with pytest.raises(SchemaError, match="is an array"):
        storage.create_group(tmp_path / "s.zarr", GROUP, make_mesh(), make_attrs())


def test_writing_to_a_missing_store_creates_nothing(tmp_path):
    missing = tmp_path / "missing.zarr"
    with pytest.raises(NotAStoreError, match="no store at"):
        storage.reserve(missing, GROUP, ["e1"], {"deflection": 1.0, "pressure": 0.0})
    with pytest.raises(NotAStoreError, match="no store at"):
        storage.write_failure(missing, GROUP, "e1", "boom", {})
    assert not missing.exists()
