"""Store resolution: paths, file:// URLs and store objects; clear errors for non-stores.

Hostile or odd input (issue 14) gets one line, never a traceback or a hang: URLs that no
worker could write to, malformed URLs, FIFOs, devices, stores nested in other stores.
"""

from __future__ import annotations

import os
import re
import warnings

import pytest
import xarray as xr
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


@pytest.mark.parametrize(("given", "match"), [
    ("memory://farm.zarr", "memory:// stores live inside one process"),
    ("MEMORY://farm.zarr", "memory:// stores live inside one process"),
    ("nosuchprotocol://bucket/x.zarr", "scheme 'nosuchprotocol://'.*not supported.*s3://"),
    ("http://example.org/farm.zarr", "scheme 'http://'.*not supported"),
    ("ftp://host/farm.zarr", "scheme 'ftp://'.*not supported"),
    ("simplecache::s3://bucket/x", "not a URL of the form scheme://bucket/path"),
    ("://bucket/x", "not a URL of the form"),
    ("not a url://x", "not a URL of the form"),
    ("s3://", "names no bucket"),
    ("s3:///farm.zarr", "names no bucket"),
    ("s3:/bucket/farm.zarr", "URL without the '//' after 's3:'"),
    ("", "store path is empty"),
    ("   ", "store path is empty"),
    ("a\x00b", "control character"),
    ("runs/\nfarm.zarr", "control character"),
])
def test_odd_store_strings_are_one_clear_line(given, match):
    for call in (lambda: open_store(given), lambda: storage.list_groups(given),
                 lambda: storage.create_group(given, GROUP, make_mesh(), make_attrs())):
        with pytest.raises(StoreError) as e:
            call()
        assert "\n" not in str(e.value) and len(str(e.value)) < 400, str(e.value)
        assert re.search(match, str(e.value)), str(e.value)


def test_url_without_backend_is_a_clear_error(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_gcsfs(name, *args, **kwargs):
        if name.startswith("gcsfs"):
            raise ImportError("No module named 'gcsfs'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_gcsfs)
    with pytest.raises(StoreError, match=r"cannot open store URL 'gs://bucket/x\.zarr'.*install"):
        open_store("gs://bucket/x.zarr")


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


# ---------------------------------------------------------------- local paths


def _all_calls(path):
    return (lambda: storage.create_group(path, GROUP, make_mesh(), make_attrs()),
            lambda: storage.list_groups(path),
            lambda: storage.open_dataset(path, GROUP),
            lambda: storage.reserve(path, GROUP, ["e1"], {"deflection": 1.0, "pressure": 0.0}))


def _refused(path, match, error=StoreError):
    for call in _all_calls(path):
        with pytest.raises(error) as e:
            call()
        assert "\n" not in str(e.value), str(e.value)
        assert re.search(match, str(e.value)), str(e.value)


@pytest.mark.timeout(60)  # a FIFO opened for reading would hang
def test_a_fifo_is_refused_without_hanging(tmp_path):
    fifo = tmp_path / "farm.zarr"
    os.mkfifo(fifo)
    _refused(fifo, "is a FIFO, not a Zarr store", NotAStoreError)


@pytest.mark.parametrize(("path", "match"), [
    ("/dev/null", "under /dev"),
    ("/dev/urandom", "under /dev"),
    ("/dev/farm.zarr", "under /dev"),
    ("/proc/self", "under /proc"),
    ("/sys/farm.zarr", "under /sys"),
])
def test_system_directories_are_refused(path, match):
    _refused(path, match)
    assert not os.path.exists("/dev/farm.zarr")


def test_a_path_below_a_file_is_refused(tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("not a directory")
    with pytest.raises(NotAStoreError, match=r"notes\.txt is a file, not a directory"):
        storage.create_group(f / "farm.zarr", GROUP, make_mesh(), make_attrs())


def test_a_name_too_long_is_one_line(tmp_path):
    _refused(tmp_path / ("x" * 300), "cannot use .* as a store: File name too long",
             NotAStoreError)


@pytest.mark.parametrize("inside", ["", "mesh-a", "mesh-a/displacement", "mesh-a/status/c"])
def test_a_store_inside_another_store_is_refused(tmp_path, inside):
    outer = tmp_path / "outer.zarr"
    storage.create_group(outer, GROUP, make_mesh(), make_attrs())
    storage.reserve(outer, GROUP, ["e1"], {"deflection": 1.0, "pressure": 0.0})
    nested = outer / inside / "inner.zarr"
    _refused(nested, "is inside the Zarr store or group at .*outer.zarr", NotAStoreError)
    assert not nested.exists()  # nothing made inside the other store
    assert storage.list_groups(outer) == [GROUP]


def test_a_store_inside_a_zarr_v2_hierarchy_is_refused(tmp_path):
    zarr.open_group(tmp_path / "v2.zarr", mode="w", zarr_format=2).create_group("g")
    with pytest.raises(NotAStoreError, match=r"inside the Zarr store or group at .*v2\.zarr/g"):
        storage.create_group(tmp_path / "v2.zarr" / "g" / "x.zarr", GROUP, make_mesh(),
                             make_attrs())


def test_the_farm_entries_are_invisible_to_zarr_and_xarray(tmp_path):
    path = tmp_path / "farm.zarr"
    path.mkdir()
    (path / ".farm.lock").write_text("left by a client")  # still an empty directory
    storage.create_group(path, GROUP, make_mesh(), make_attrs())
    storage.reserve(path, GROUP, ["e1"], {"deflection": 1.0, "pressure": 0.0})
    (path / ".claims" / GROUP).mkdir(parents=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        storage.reserve(path, GROUP, ["e2"], {"deflection": 2.0, "pressure": 0.0})
        assert storage.list_groups(path) == [GROUP]
        ds = xr.open_zarr(path, group=GROUP)
    assert ds["experiment"].values.tolist() == ["e1", "e2"]
    assert sorted(p.name for p in path.iterdir()) == [".claims", ".farm.lock", GROUP,
                                                       "zarr.json"]
