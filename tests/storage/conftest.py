"""Fixtures of the store's tests: stores of every kind, and a group with a small mesh."""

from __future__ import annotations

import pytest
from store_helpers import GROUP, make_attrs, make_mesh
from zarr.storage import MemoryStore

import storage
from storage import handles


@pytest.fixture(autouse=True)
def _fresh_handles():
    """Each test starts without cached worker handles (as a fresh worker would)."""
    handles.forget()
    yield
    handles.forget()


@pytest.fixture(params=["directory", "memory"])
def store(request, tmp_path):
    """A store location: a local directory path, or an in-memory zarr store object."""
    if request.param == "directory":
        return tmp_path / "farm.zarr"
    return MemoryStore()


@pytest.fixture
def mesh() -> storage.MeshNodes:
    return make_mesh()


@pytest.fixture
def group(store, mesh) -> str:
    """A created group named ``GROUP`` in ``store``, no experiments yet."""
    storage.create_group(store, GROUP, mesh, make_attrs())
    return GROUP

