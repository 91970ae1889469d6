"""Read side: labelled xarray datasets with units, done/select helpers, status look-ups."""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest
from store_helpers import GROUP, make_attrs, make_info, make_mesh, make_result, run_python
from zarr.storage import MemoryStore

import storage
from storage import NotReservedError, SchemaError
from storage.schema import COMBINED_NAMES, FIXED_VARIABLES, KNOWN_PARAMETER_UNITS

IDS = [f"e{i}" for i in range(6)]
DEFLECTION = [10.0, 20.0, 30.0, 40.0, 10.0, 20.0000000001]
PRESSURE = [0.2, 0.2, 0.2, 0.2, 0.3, 0.3]


def _fill(store, group, mesh):
    storage.reserve(store, group, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    for e in IDS[:4]:
        storage.write_experiment(store, group, e, make_result(e, mesh.n_inner, mesh.n_tread),
                                 make_info(e))
    storage.write_failure(store, group, "e4", "boom", {})
    return store


@pytest.fixture
def filled(store, group, mesh):
    """Six experiments: e0-e3 done, e4 failed, e5 pending; in each kind of store."""
    return _fill(store, group, mesh)


@pytest.fixture(scope="module")
def shared():
    """The same six experiments in one in-memory store, for read-only tests."""
    store = MemoryStore()
    storage.create_group(store, GROUP, make_mesh(), make_attrs())
    return _fill(store, GROUP, make_mesh())


def test_dataset_is_labelled_with_units(filled):
    ds = storage.open_dataset(filled, GROUP)
    assert ds["displacement"].dims == ("experiment", "inner_node", "component")
    assert ds["strain"].dims == ("experiment", "inner_node", "strain_component")
    assert ds["reaction_force"].dims == ("experiment", "tread_node", "component")
    # the load case: one index over both parameters (issue 25, test_store_index.py)
    assert set(ds.indexes) == {"experiment", "inner_node", "component", "tread_node",
                               "strain_component", "deflection", "pressure"}
    units = {**{n: v.units for n, v in FIXED_VARIABLES.items()}, **KNOWN_PARAMETER_UNITS}
    # a vertical group: no combined-load variables (those are created by reserve only
    # for combined-load studies, tests/storage/test_store_combined.py)
    assert set(ds.variables) == (set(FIXED_VARIABLES) - set(COMBINED_NAMES)
                                 | {"deflection", "pressure"})
    for name, var in ds.variables.items():
        assert var.attrs["units"] == units[name], name
    assert ds["moment"].attrs["units"] == "N mm" and ds["strain"].attrs["units"] == "1"
    assert ds.attrs["solver"] == "CalculiX 2.20" and ds.attrs["schema_version"] == 1
    assert ds["component"].values.tolist() == ["x", "y", "z"]


def test_dataset_is_lazy_and_text_is_object(filled):
    ds = storage.open_dataset(filled, GROUP)
    assert ds["displacement"].chunks is not None
    assert ds["error"].dtype == object
    kept = ds.where((ds["status"] == storage.DONE).compute(), drop=True)
    assert kept["experiment"].values.tolist() == IDS[:4]


def test_done_keeps_only_status_one(filled):
    ds = storage.done(storage.open_dataset(filled, GROUP))
    assert ds["experiment"].values.tolist() == IDS[:4]
    assert np.isfinite(ds["displacement"].values).all()


@pytest.mark.parametrize(
    ("query", "want"),
    [
        ({"pressure": 0.2}, ["e0", "e1", "e2", "e3"]),
        ({"pressure": 0.3, "deflection": 20.0}, ["e5"]),  # 20.0000000001 within tolerance
        ({"deflection": slice(15, 30)}, ["e1", "e2", "e5"]),
        ({"deflection": slice(None, 10)}, ["e0", "e4"]),
        ({"deflection": slice(30.0, None), "pressure": 0.2}, ["e2", "e3"]),
        ({"deflection": [10, 40]}, ["e0", "e3", "e4"]),
        ({"pressure": 0.25}, []),
    ],
)
def test_select_by_parameters(shared, query, want):
    ds = storage.select(storage.open_dataset(shared, GROUP), **query)
    assert ds["experiment"].values.tolist() == want


@pytest.mark.parametrize(
    ("query", "match"),
    [
        ({"speed": 1.0}, "unknown parameter 'speed'.*deflection, pressure"),
        ({"status": 1}, "unknown parameter 'status'"),
        ({"deflection": slice(0, 10, 2)}, "no step"),
        ({"deflection": "deep"}, "a number, a list of numbers or a slice"),
    ],
)
def test_select_rejects_unknown_parameters(shared, query, match):
    with pytest.raises(SchemaError, match=match):
        storage.select(storage.open_dataset(shared, GROUP), **query)


def test_statuses_and_counts(filled):
    assert storage.statuses(filled, GROUP) == {"e0": 1, "e1": 1, "e2": 1, "e3": 1, "e4": 2,
                                               "e5": 0}
    assert storage.statuses(filled, GROUP, ["e5", "e4"]) == {"e5": 0, "e4": 2}
    assert storage.statuses(filled, GROUP, []) == {}
    assert storage.status_counts(filled, GROUP) == {"pending": 1, "done": 4, "failed": 1}
    with pytest.raises(NotReservedError, match="'nope' is not reserved"):
        storage.statuses(filled, GROUP, ["e1", "nope"])


def test_xarray_open_zarr_in_a_fresh_process(tmp_path):
    path = tmp_path / "farm.zarr"
    mesh = make_mesh()
    storage.create_group(path, GROUP, mesh, make_attrs())
    storage.reserve(path, GROUP, ["e0", "e1"], {"deflection": [5.0, 9.0], "pressure": 0.2})
    storage.write_experiment(path, GROUP, "e1", make_result("e1", mesh.n_inner, mesh.n_tread),
                             make_info("e1"))
    script = textwrap.dedent(f"""
        import json, sys, warnings
        warnings.simplefilter("error")  # e.g. xarray's "consolidated metadata" warning
        import xarray as xr
        ds = xr.open_zarr({str(path)!r}, group={GROUP!r})
        done = ds.isel(experiment=(ds.status == 1).values)  # the README's third line
        print(json.dumps({{
            "done": done["experiment"].values.tolist(),
            "dims": {{k: list(v.dims) for k, v in ds.variables.items()}},
            "units": {{k: v.attrs.get("units") for k, v in ds.variables.items()}},
            "experiment": ds["experiment"].values.tolist(),
            "status": ds["status"].values.tolist(),
            "u": ds["displacement"].sel(experiment="e1", component="z").values.tolist(),
        }}))
    """)
    out = json.loads(run_python("-c", script).stdout)
    assert out["dims"]["displacement"] == ["experiment", "inner_node", "component"]
    assert out["dims"]["inner_node"] == ["inner_node"]
    assert all(u is not None for u in out["units"].values()), out["units"]
    assert out["units"]["reaction_force"] == "N" and out["units"]["deflection"] == "mm"
    assert out["experiment"] == ["e0", "e1"] and out["status"] == [0, 1]
    assert out["done"] == ["e1"]
    want = make_result("e1", mesh.n_inner, mesh.n_tread)["displacement"][:, 2]
    assert out["u"] == want.tolist()


def test_a_store_without_consolidated_metadata_still_opens(tmp_path):
    # e.g. written by a client that died before publishing, or by another tool
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, make_mesh(), make_attrs())
    storage.reserve(path, GROUP, ["e0", "e1"], {"deflection": [1.0, 2.0], "pressure": 0.0})
    root = json.loads((path / "zarr.json").read_text())
    del root["consolidated_metadata"]
    (path / "zarr.json").write_text(json.dumps(root))
    ds = storage.open_dataset(path, GROUP)
    assert ds["experiment"].values.tolist() == ["e0", "e1"]
