"""Data assembly from the store, the synthetic store's schema, and bad-input errors."""

from __future__ import annotations

import dask.array as da
import numpy as np
import pytest
import xarray as xr
import zarr

import storage
from analysis import data
from analysis.errors import (
    AnalysisError,
    ComponentsError,
    EmptySelectionError,
    MissingVariableError,
    NonFiniteError,
    StoreError,
)
from analysis.moments import compute_moments
from analysis.pls import SIMPLSRegression
from tests.synthetic import make_store

SCHEMA_DIMS = {
    "inner_xyz": ("inner_node", "component"),
    "tread_xyz": ("tread_node", "component"),
    "inner_row": ("inner_node",),
    "tread_col": ("tread_node",),
    "displacement": ("experiment", "inner_node", "component"),
    "strain": ("experiment", "inner_node", "strain_component"),
    "surface_strain": ("experiment", "inner_node", "strain_component"),
    "reaction_force": ("experiment", "tread_node", "component"),
    "total_force": ("experiment", "component"),
    "moment": ("experiment", "component"),
    "deflection": ("experiment",),
    "pressure": ("experiment",),
    "status": ("experiment",),
    "error": ("experiment",),
}


def test_synthetic_store_follows_the_schema(thesis_store):
    raw = xr.open_zarr(thesis_store, group="synthetic", consolidated=False)
    for name, dims in SCHEMA_DIMS.items():
        assert raw[name].dims == dims, name
        assert "units" in raw[name].attrs, name
    assert (
        raw["status"].dtype == np.int8
        and raw["status"].attrs["flag_meanings"] == "pending done failed"
    )
    assert list(raw["component"].values) == ["x", "y", "z"]
    assert list(raw["strain_component"].values) == ["xx", "yy", "xy"]
    group = zarr.open_group(thesis_store, mode="r")["synthetic"]
    for name in ("displacement", "strain", "reaction_force", "status", "moment"):
        assert group[name].chunks[0] == 1, f"{name}: one chunk per experiment"
    assert raw.attrs["schema_version"] == 1
    # stored totals are the sums of the nodal forces (done experiments)
    done = raw["status"].values == 1
    np.testing.assert_allclose(
        raw["total_force"].values[done], raw["reaction_force"].values[done].sum(1)
    )


def test_load_keeps_done_experiments_only(thesis_store, thesis_ds):
    raw = xr.open_zarr(thesis_store, group="synthetic", consolidated=False)
    assert raw.sizes["experiment"] == 9 and thesis_ds.sizes["experiment"] == 7
    assert set(np.asarray(thesis_ds["status"].values)) == {1}
    X = data.inputs(thesis_ds, "displacement")
    assert isinstance(X, da.Array) and X.shape == (7, 3 * thesis_ds.sizes["inner_node"])
    assert np.isfinite(X.compute()).all()


def test_input_columns_follow_the_index(thesis_ds):
    X = np.asarray(data.inputs(thesis_ds, ["Uy", "exx"]).compute())
    index = data.input_index(thesis_ds, ["Uy", "exx"])
    assert len(index) == X.shape[1]
    k = int(np.flatnonzero((index["direction"] == "exx").to_numpy())[5])
    node = index["inner_node"].iloc[k]
    expected = thesis_ds["strain"].sel(inner_node=node, strain_component="xx").values
    np.testing.assert_array_equal(X[:, k], expected)


@pytest.mark.parametrize(
    ("pressure", "deflection", "k"),
    [(0.2, None, 5), (0.25, None, 5), (None, 25.0, 2), (0.25, 40.0, 1)],
)
def test_filters(two_pressure_store, pressure, deflection, k):
    ds = data.load(two_pressure_store, "mesh_a", pressure=pressure, deflection=deflection)
    assert ds.sizes["experiment"] == k
    if pressure is not None:
        np.testing.assert_allclose(ds["pressure"].values, pressure)


def test_empty_selection_is_one_clear_line(two_pressure_store):
    with pytest.raises(EmptySelectionError) as info:
        data.load(two_pressure_store, "mesh_a", pressure=0.3)
    msg = str(info.value)
    assert "\n" not in msg and "no done experiment" in msg and "0.2, 0.25" in msg


def test_group_must_be_named_when_ambiguous(two_pressure_store, thesis_store):
    with pytest.raises(StoreError, match="2 groups"):
        data.load(two_pressure_store)
    assert data.load(thesis_store).attrs["group"] == "synthetic"  # the only group
    with pytest.raises(StoreError):
        data.load(two_pressure_store, "nope")


def test_missing_variable(two_pressure_store):
    ds = data.load(two_pressure_store, "mesh_b")  # written without strains
    with pytest.raises(MissingVariableError, match="'strain'"):
        data.inputs(ds, "exx")
    with pytest.raises(MissingVariableError, match="unknown input direction"):
        data.inputs(ds, "Uq")


def test_missing_store(tmp_path):
    with pytest.raises(storage.NotAStoreError):
        data.load(tmp_path / "absent.zarr")


def test_one_store_error_class(two_pressure_store):
    """analysis reads through storage and re-exports its StoreError: one class, so one
    ``except StoreError`` catches the store's errors whichever layer found them."""
    assert StoreError is storage.StoreError
    with pytest.raises(storage.GroupNotFoundError):
        data.load(two_pressure_store, "nope")
    with pytest.raises(storage.StoreError) as info:
        data.load(two_pressure_store)
    assert isinstance(info.value, AnalysisError)  # found by the analysis: both


def test_load_selects_like_storage(two_pressure_store):
    """`load` = storage's done + select (same tolerance, same done rule)."""
    raw = storage.open_dataset(two_pressure_store, "mesh_a")
    expected = storage.select(storage.done(raw), pressure=0.25, deflection=40.0)
    ds = data.load(two_pressure_store, "mesh_a", pressure=0.25 * (1 + 1e-12), deflection=40.0)
    assert list(ds["experiment"].values) == list(expected["experiment"].values)
    assert ds.attrs["filters"] == "pressure=0.25, deflection=40"


def test_non_finite_values_are_named(tmp_path):
    path = tmp_path / "nan.zarr"
    make_store(path, n_experiments=5, rows=4, cols=6, tread_rows=3, tread_cols=5)
    arr = zarr.open_group(path, mode="r+")["synthetic"]["displacement"]
    arr[2, 3, 2] = np.nan  # a "done" experiment with a corrupt value
    ds = data.load(path)
    X, Y = data.inputs(ds, "Uz"), data.outputs(ds)
    with pytest.raises(NonFiniteError, match=r"1 of 5 samples \(rows 2\)"):
        compute_moments(X, Y)
    with pytest.raises(NonFiniteError, match="NaN"):
        SIMPLSRegression(1).fit(np.asarray(X.compute()), np.asarray(Y.compute()))
    tall = da.from_array(np.repeat(np.asarray(X.compute()), 10, axis=0), chunks=(7, 24))
    with pytest.raises(NonFiniteError):
        compute_moments(tall, da.from_array(np.repeat(np.asarray(Y.compute()), 10, axis=0)))


def test_fewer_experiments_than_components(tmp_path):
    path = tmp_path / "few.zarr"
    make_store(path, n_experiments=3, rows=4, cols=6, tread_rows=3, tread_cols=5)
    ds = data.load(path)
    X, Y = data.inputs(ds, "Uz"), data.outputs(ds)
    with pytest.raises(ComponentsError, match="3 experiments support at most 2") as info:
        SIMPLSRegression(3).fit(X, Y)
    assert isinstance(info.value, AnalysisError) and isinstance(info.value, ValueError)


def test_reference_index(thesis_ds):
    d = np.asarray(thesis_ds["deflection"].values)
    assert d[data.reference_index(thesis_ds, 30.0)] == 30.0
    assert d[data.reference_index(thesis_ds)] == 25.0  # median of 10..40 mm
