"""Saved solver states (storage.saved, issue 50): kept beside the data, read back exactly
or not at all, invisible to readers and verify, removed when asked."""

from __future__ import annotations

import pytest
from store_helpers import GROUP, make_attrs, make_mesh

import storage
import storage.saved as saved
from storage.paths import STATES_DIR
from storage.verify import verify


@pytest.fixture
def store(tmp_path):
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, make_mesh(6, 3), make_attrs())
    return path


def test_a_saved_state_reads_back_and_is_removed(store):
    assert saved.load(store, GROUP, "tree-1") is None
    saved.save(store, GROUP, "tree-1", b"\x00state" * 1000)
    assert saved.load(store, GROUP, "tree-1") == b"\x00state" * 1000
    saved.save(store, GROUP, "tree-1", b"newer")
    assert saved.load(store, GROUP, "tree-1") == b"newer"
    saved.drop(store, GROUP, "tree-1")
    assert saved.load(store, GROUP, "tree-1") is None
    saved.drop(store, GROUP, "tree-1")  # nothing there: nothing happens


@pytest.mark.parametrize("damage", ["truncate", "flip"])
def test_a_damaged_state_reads_as_none_and_is_removed(store, damage):
    saved.save(store, GROUP, "tree-1", bytes(range(256)) * 10)
    path = store / STATES_DIR / GROUP / "tree-1"
    raw = bytearray(path.read_bytes())
    if damage == "truncate":
        raw = raw[: len(raw) // 2]
    else:
        raw[100] ^= 0xFF
    path.write_bytes(bytes(raw))
    assert saved.load(store, GROUP, "tree-1") is None
    assert not path.exists()


def test_saved_states_are_no_part_of_the_data(store):
    saved.save(store, GROUP, "tree-1", b"state")
    assert storage.list_groups(store) == [GROUP]
    assert verify(store).ok
    assert storage.open_dataset(store, GROUP).sizes["experiment"] == 0


@pytest.mark.parametrize("key", ["", "../x", "a/b", "x" * 200])
def test_a_bad_key_is_refused(store, key):
    with pytest.raises(storage.SchemaError, match="saved state's key"):
        saved.save(store, GROUP, key, b"x")
