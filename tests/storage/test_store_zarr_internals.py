"""zarr-python internals are used in one module only (storage/_zarr.py), so that a zarr
upgrade is checked in one place."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import zarr

import storage
from storage._zarr import array, dimension_names, read, read_coordinates
from storage.errors import DamagedStoreError

# the internal modules, the async view of an array and its coroutines, zarr's loop runner
INTERNALS = re.compile(r"zarr\.core|\.async_array\b|\.(get|set)item\(|\bsync\(|from zarr import")


def test_only_the_wrapper_touches_zarr_internals():
    folder = Path(storage.__file__).parent
    offenders = [f"{path.name}:{n}" for path in sorted(folder.glob("*.py"))
                 if path.name != "_zarr.py"
                 for n, line in enumerate(path.read_text().splitlines(), start=1)
                 if INTERNALS.search(line.split("#")[0])
                 and "from storage._zarr import" not in line]
    assert offenders == []


def test_array_is_an_array_or_a_damaged_store(tmp_path):
    # zarr types group[name] as an array or a group: storage reads arrays through
    # storage._zarr.array, which refuses a group in an array's place (a hand-edited store)
    root = zarr.open_group(store=str(tmp_path / "s.zarr"), mode="w")
    root.create_array("status", shape=(3,), dtype="int8")
    sub = root.create_group("g")
    sub.create_group("experiment")
    assert isinstance(array(root, "status"), zarr.Array)
    with pytest.raises(DamagedStoreError, match=r"^g/experiment is a group where the farm"):
        array(sub, "experiment")
    with pytest.raises(KeyError):
        array(root, "missing")


def test_read_gives_numpy_arrays_and_dimension_names(tmp_path):
    root = zarr.open_group(store=str(tmp_path / "s.zarr"), mode="w")
    a = root.create_array("x", shape=(4,), dtype="float64", dimension_names=["experiment"])
    a[:] = [1.0, 2.0, 3.0, 4.0]
    part = read(a, slice(1, 3))
    assert isinstance(part, np.ndarray) and part.tolist() == [2.0, 3.0]
    assert read(a).tolist() == [1.0, 2.0, 3.0, 4.0]
    assert read(a, 0).shape == () and read(a, 0).tolist() == 1.0
    assert read_coordinates(a, np.array([3, 0])).tolist() == [4.0, 1.0]
    assert dimension_names(a) == ("experiment",)
    assert dimension_names(root.create_array("y", shape=(2,), dtype="int8")) == ()
