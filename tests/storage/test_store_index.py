"""The load case as one index (issue 25): ``ds.sel(deflection=..., pressure=...)`` on every
group, old ones too (the index is made at read time), agreeing with select()/done()."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from store_helpers import GROUP, make_attrs, make_info, make_mesh, make_result
from zarr.storage import MemoryStore

import storage
from storage.load_case_index import LoadCaseIndex
from storage.read import index_parameters
from tests.synthetic import make_combined_store, make_store

IDS = [f"e{i}" for i in range(6)]
DEFLECTION = [10.0, 20.0, 30.0, 40.0, 10.0, 20.0]
PRESSURE = [0.2, 0.2, 0.2, 0.2, 0.3, 0.3]
MOTION = {"friction": [0.5, 0.5, 0.8, 0.8], "shift_x": [0.0, 1.0, 0.0, 1.0],
          "shift_y": [0.0, 0.0, -2.0, -2.0], "tilt": [0.0, 3.0, 3.0, 0.0]}
#: (sel keywords, ids) on the six experiments above
QUERIES = [
    ({"deflection": 30}, ["e2"]),  # one match: still a selection along `experiment`
    ({"deflection": 10.0}, ["e0", "e4"]),
    ({"deflection": 10, "pressure": 0.3}, ["e4"]),
    ({"pressure": 0.2, "deflection": 20.0}, ["e1"]),
    ({"deflection": [10, 40]}, ["e0", "e3", "e4"]),
    ({"deflection": np.array([20.0, 30.0]), "pressure": [0.3]}, ["e5"]),
    ({"deflection": slice(15, 30)}, ["e1", "e2", "e5"]),
    ({"deflection": slice(None, 10), "pressure": 0.2}, ["e0"]),
    ({"pressure": 0.2, "deflection": 40}, ["e3"]),
]


def _vertical(store, mesh=None):
    mesh = mesh or make_mesh()
    storage.create_group(store, GROUP, mesh, make_attrs())
    storage.reserve(store, GROUP, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    for e in IDS[:4]:
        storage.write_experiment(store, GROUP, e, make_result(e, mesh.n_inner, mesh.n_tread),
                                 make_info(e))
    storage.write_failure(store, GROUP, "e4", "boom", {})
    return store


@pytest.fixture(scope="module")
def fresh():
    """Six experiments (e0-e3 done, e4 failed, e5 pending) in an in-memory store."""
    return _vertical(MemoryStore())


def _ids(ds) -> list[str]:
    return [str(e) for e in ds["experiment"].values.tolist()]


@pytest.mark.parametrize(("query", "want"), QUERIES)
def test_sel_by_parameters_on_a_fresh_group(fresh, query, want):
    ds = storage.open_dataset(fresh, GROUP)
    got = ds.sel(**query)
    assert _ids(got) == want
    assert got["displacement"].dims[0] == "experiment"  # a selection, never a scalar
    assert _ids(storage.select(ds, **query)) == want  # select agrees (exact labels here)


def test_the_index_is_one_over_every_parameter(fresh):
    ds = storage.open_dataset(fresh, GROUP)
    index = ds.xindexes["deflection"]
    assert isinstance(index, LoadCaseIndex) and ds.xindexes["pressure"] is index
    assert isinstance(ds.xindexes["experiment"], xr.indexes.PandasIndex)  # the ids stay
    assert _ids(ds) == IDS and ds["deflection"].attrs["units"] == "mm"
    assert ds["pressure"].attrs["role"] == "parameter"
    assert storage.parameters(ds) == ["deflection", "pressure"]
    assert index_parameters(ds) is ds  # already indexed: nothing to do


def test_labels_are_exact_and_misses_say_what_to_do(fresh):
    ds = storage.open_dataset(fresh, GROUP)
    with pytest.raises(KeyError, match=r"deflection=25 .*storage\.select"):
        ds.sel(deflection=25)
    with pytest.raises(KeyError, match=r"pressure=0\.25"):
        ds.sel(pressure=[0.2, 0.25])  # every label of a list must occur
    with pytest.raises(KeyError):
        ds.sel(deflection=30.000001)  # exact: select() is the one with a tolerance
    assert _ids(storage.select(ds, deflection=30.0000000001)) == ["e2"]
    with pytest.raises(ValueError, match=r"exactly.*storage\.select"):
        ds.sel(deflection=29.0, method="nearest")
    with pytest.raises(ValueError, match="no step"):
        ds.sel(deflection=slice(10, 40, 10))
    assert _ids(ds.sel(deflection=slice(41, None))) == []  # a range may be empty


@pytest.mark.parametrize(("query", "want"), QUERIES)
def test_done_and_select_agree_with_sel(fresh, query, want):
    ds = storage.open_dataset(fresh, GROUP)
    done = storage.done(ds)
    assert isinstance(done.xindexes["pressure"], LoadCaseIndex)  # kept by done()
    expected = [e for e in want if e in IDS[:4]]
    if expected:
        assert _ids(done.sel(**query)) == expected
        assert _ids(storage.done(ds.sel(**query))) == expected  # either order
    assert _ids(storage.select(done, **query)) == expected
    assert _ids(storage.verify_done(ds.sel(**query))) == want


def test_the_store_on_disk_has_no_index(tmp_path):
    """Nothing is written: plain xarray reads the parameters as before issue 25."""
    path = _vertical(tmp_path / "farm.zarr")
    plain = xr.open_zarr(path, group=GROUP)
    assert "deflection" not in plain.xindexes and "deflection" in plain.variables
    assert _ids(index_parameters(plain).sel(deflection=10, pressure=0.2)) == ["e0"]


def test_an_old_group_written_by_xarray_gets_the_index(tmp_path):
    """A group as older writers made it (xarray's to_zarr, parameters data variables with
    role "parameter", no checksums): indexed when read."""
    path = tmp_path / "old.zarr"
    group = make_store(path, n_experiments=4, pressures=(0.2, 0.25), n_failed=1, n_pending=1,
                       rows=3, cols=4, tread_rows=2, tread_cols=3)
    stored = xr.open_zarr(path, group=group, consolidated=False)
    assert "deflection" in stored.data_vars  # stored as data, not as a coordinate
    ds = storage.open_dataset(path, group)
    assert isinstance(ds.xindexes["deflection"], LoadCaseIndex)
    d = float(ds["deflection"].values[1])
    assert ds.sel(deflection=d, pressure=0.25).sizes["experiment"] == 1
    done = storage.done(ds)
    assert done.sel(pressure=0.2).sizes["experiment"] == 4
    assert _ids(done.sel(pressure=0.25)) == _ids(storage.select(done, pressure=0.25))


def test_an_older_in_memory_index_is_replaced():
    """A dataset indexed the issue-12 way (``set_xindex("deflection")``) gets the one
    index: two indexes on ``experiment`` could not be queried together."""
    ds = xr.Dataset(
        {"status": ("experiment", np.ones(6, np.int8))},
        coords={"experiment": IDS,
                "deflection": ("experiment", DEFLECTION, {"role": "parameter"}),
                "pressure": ("experiment", PRESSURE, {"role": "parameter"})},
    ).set_xindex("deflection")
    out = index_parameters(ds)
    assert _ids(out.sel(deflection=20, pressure=0.3)) == ["e5"]
    assert out["deflection"].attrs == {"role": "parameter"}
    part = ds.drop_indexes("deflection").set_xindex("deflection", LoadCaseIndex)
    assert index_parameters(part).xindexes["deflection"].names == ("deflection", "pressure")


def _combined_group(store):
    mesh = make_mesh()
    storage.create_group(store, GROUP, mesh, make_attrs())
    ids = ["c0", "c1", "c2", "c3"]
    storage.reserve(store, GROUP, ids, {"deflection": [10.0, 10.0, 20.0, 20.0],
                                        "pressure": 0.2, **MOTION})
    return store


def test_sel_on_a_combined_group_with_six_parameters():
    ds = storage.open_dataset(_combined_group(MemoryStore()), GROUP)
    assert storage.parameters(ds) == ["deflection", "friction", "pressure", "shift_x",
                                      "shift_y", "tilt"]
    assert all(isinstance(ds.xindexes[n], LoadCaseIndex) for n in storage.parameters(ds))
    assert _ids(ds.sel(tilt=3.0)) == ["c1", "c2"]
    assert _ids(ds.sel(tilt=3.0, friction=0.8)) == ["c2"]
    assert _ids(ds.sel(deflection=10, shift_x=1.0, pressure=0.2)) == ["c1"]
    assert _ids(ds.sel(shift_y=slice(-3, -1), tilt=[0.0])) == ["c3"]
    for query in ({"tilt": 3.0, "friction": 0.8}, {"deflection": 20.0, "shift_y": -2.0}):
        assert _ids(ds.sel(**query)) == _ids(storage.select(ds, **query))


def test_a_vertical_group_turned_combined_has_nan_parameters(store, group, mesh):
    """Old vertical experiments have no motion parameters (NaN): they match no label."""
    storage.reserve(store, group, ["v0"], {"deflection": 10.0, "pressure": 0.2})
    storage.reserve(store, group, ["c0"], {"deflection": 10.0, "pressure": 0.2,
                                           **{k: v[1] for k, v in MOTION.items()}})
    ds = storage.open_dataset(store, group)
    assert np.isnan(ds["friction"].values[0])
    assert _ids(ds.sel(deflection=10)) == ["v0", "c0"]
    assert _ids(ds.sel(deflection=10, tilt=3.0)) == ["c0"]


def test_a_synthetic_combined_group(tmp_path):
    path = tmp_path / "combined.zarr"
    group = make_combined_store(path, n_experiments=8, rows=3, cols=4, tread_rows=2,
                                tread_cols=3, vary=("tilt",))
    ds = storage.done(storage.open_dataset(path, group))
    tilt = float(ds["tilt"].values[3])
    one = ds.sel(tilt=tilt, deflection=25.0, friction=0.8)
    assert _ids(one) == [_ids(ds)[3]]


def test_what_consumers_do_still_works(fresh, tmp_path):
    ds = storage.done(storage.open_dataset(fresh, GROUP))
    kept = ds.where(ds.deflection >= 20, drop=True)  # where(..., drop=True): an isel
    assert _ids(kept) == ["e1", "e2", "e3"] and _ids(kept.sel(pressure=0.2)) == _ids(kept)
    one = ds.isel(experiment=2)  # one experiment: parameters become scalars, no index
    assert float(one["deflection"]) == 30.0 and "deflection" not in one.xindexes
    assert float(ds.sel(experiment="e3")["deflection"]) == 40.0
    both = xr.concat([ds.isel(experiment=[3]), ds.isel(experiment=[0, 1])], "experiment",
                     data_vars="all")
    assert _ids(both.sel(pressure=0.2, deflection=[10, 40])) == ["e3", "e0"]
    total = ds["total_force"] + ds["total_force"]  # same experiments: aligned as before
    assert _ids(total.sel(deflection=20)) == ["e1"]
    other = ds.isel(experiment=[1, 2])  # different ones: a clear way out
    with pytest.raises(NotImplementedError, match=r"drop_indexes"):
        ds["status"] + other["status"]
    names = storage.parameters(ds)
    plain = ds.drop_indexes(names)
    assert _ids(plain["status"] + other.drop_indexes(names)["status"]) == ["e1", "e2"]
    # a DataFrame leaves indexed coordinates out; without the index they are columns
    frame = plain[["status", *names]].to_dataframe()
    assert frame["deflection"].tolist() == DEFLECTION[:4]
    # one parameter cannot be overwritten under the index (it would go stale)
    with pytest.raises(ValueError, match="corrupt"):
        ds.assign_coords(pressure=("experiment", np.zeros(4)))
    moved = plain.assign_coords(pressure=("experiment", np.zeros(4)))
    assert moved["pressure"].values.tolist() == [0.0] * 4
    with pytest.raises(ValueError, match="read-only"):
        ds["deflection"].values[0] = 99.0  # would leave the index stale
    # written back (e.g. an export) and read again: plain coordinates on disk
    ds[["status", "total_force"]].compute().drop_encoding().to_zarr(tmp_path / "copy.zarr",
                                                                  consolidated=False)
    back = xr.open_zarr(tmp_path / "copy.zarr", consolidated=False)
    assert back["deflection"].values.tolist() == DEFLECTION[:4]
    assert _ids(index_parameters(back).sel(deflection=30)) == ["e2"]


@pytest.mark.parametrize("select", ["sel", "select"])
@pytest.mark.parametrize(("kpa", "mpa"), [(200, 0.2), (300.0, 0.3), ([200], 0.2)])
def test_a_pressure_in_kpa_is_refused_with_the_unit_the_store_keeps(fresh, select, kpa, mpa):
    """Every command takes kPa, the store MPa (issue 48): ``sel(pressure=200)`` says so
    instead of a bare miss (sel) or a silently empty selection (select)."""
    ds = storage.open_dataset(fresh, GROUP)
    error = KeyError if select == "sel" else storage.SchemaError
    with pytest.raises(error, match=rf"keeps pressure in MPa: pressure={mpa:g} is"):
        ds.sel(pressure=kpa) if select == "sel" else storage.select(ds, pressure=kpa)


def test_no_unit_hint_where_the_value_is_no_pressure_in_kpa(fresh):
    ds = storage.open_dataset(fresh, GROUP)
    with pytest.raises(KeyError) as e:
        ds.sel(pressure=250)  # 0.25 MPa is no stored pressure either
    assert "MPa" not in str(e.value)
    assert storage.select(ds, pressure=0.25).sizes["experiment"] == 0
    with pytest.raises(KeyError) as e:
        ds.sel(deflection=20000)
    assert "MPa" not in str(e.value)
