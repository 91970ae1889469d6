"""Client side: reserve gives each id one index forever, and checks parameters."""

from __future__ import annotations

import numpy as np
import pytest
import zarr
from store_helpers import GROUP, make_params

import storage
from storage import ParameterConflictError, SchemaError
from storage.paths import open_store


def _group(store):
    return zarr.open_group(open_store(store), path=GROUP, mode="r", use_consolidated=False)


def test_reserve_appends_and_keeps_indices_forever(store, group):
    ids = [f"e{i}" for i in range(5)]
    first = storage.reserve(store, group, ids[:3], make_params(ids[:3]))
    assert first == {"e0": 0, "e1": 1, "e2": 2}
    again = storage.reserve(store, group, ids[::-1], make_params(ids[::-1]))
    assert again == {"e4": 3, "e3": 4, "e2": 2, "e1": 1, "e0": 0}
    g = _group(store)
    assert g["experiment"][...].tolist() == ["e0", "e1", "e2", "e4", "e3"]
    assert all(g[n].shape[0] == 5 for n in ("displacement", "status", "error", "pressure"))
    want = make_params(["e4", "e3"])["deflection"]
    np.testing.assert_array_equal(g["deflection"][...][[3, 4]], want)


def test_new_slots_read_as_pending(store, group, mesh):
    storage.reserve(store, group, ["e1"], {"deflection": 5.0, "pressure": 0.2})
    ds = storage.open_dataset(store, group).load()
    assert ds["status"].item() == storage.PENDING and ds["error"].item() == ""
    assert np.isnan(ds["displacement"]).all() and np.isnan(ds["solve_seconds"]).all()
    assert ds["increments"].item() == -1
    assert ds["deflection"].item() == 5.0 and ds["pressure"].item() == 0.2


def test_reserve_with_other_parameters_for_a_known_id_is_refused(store, group):
    storage.reserve(store, group, ["e1"], {"deflection": 5.0, "pressure": 0.2})
    with pytest.raises(ParameterConflictError, match=r"'e1'.*deflection=5\.0, not 6\.0"):
        storage.reserve(store, group, ["e2", "e1"], {"deflection": [1.0, 6.0], "pressure": 0.2})
    assert list(storage.statuses(store, group)) == ["e1"]  # nothing reserved on a conflict


def test_new_parameters_need_units_unless_known(store, group):
    with pytest.raises(SchemaError, match="new parameter 'slip' needs units"):
        storage.reserve(store, group, ["e1"], {"deflection": 1.0, "pressure": 0.0, "slip": 0.1})
    storage.reserve(store, group, ["e1"], {"deflection": 1.0, "pressure": 0.0, "slip": 0.1},
                    units={"slip": "1"})
    storage.reserve(store, group, ["e2"], {"deflection": 1.0, "pressure": 0.0, "friction": 0.8})
    ds = storage.open_dataset(store, group)
    assert ds["slip"].attrs["units"] == "1" and ds["friction"].attrs["units"] == "1"
    assert np.isnan(ds["friction"].values[0]) and ds["friction"].values[1] == 0.8
    assert storage.parameters(ds) == ["deflection", "friction", "pressure", "slip"]


@pytest.mark.parametrize(
    ("ids", "params", "match"),
    [
        (["e1", "e1"], {"deflection": 1.0, "pressure": 0.0}, "given twice"),
        (["bad id"], {"deflection": 1.0, "pressure": 0.0}, "experiment id must be"),
        ("e1", {"deflection": 1.0, "pressure": 0.0}, "sequence of ids"),
        (["e1"], {"deflection": 1.0}, "'pressure' is missing"),
        (["e1"], {"deflection": np.nan, "pressure": 0.0}, "NaN or inf"),
        (["e1", "e2"], {"deflection": [1.0, 2.0, 3.0], "pressure": 0.0}, "one per id"),
        (["e1"], {"deflection": "deep", "pressure": 0.0}, "must be a number"),
        (["e1"], {"deflection": 1.0, "pressure": 0.0, "status": 1.0}, "variable of the schema"),
        (["e1"], {"deflection": 1.0, "pressure": 0.0, "Bad-Name": 1.0}, "parameter name"),
    ],
)
def test_reserve_rejects_bad_input(store, group, ids, params, match):
    with pytest.raises(SchemaError, match=match):
        storage.reserve(store, group, ids, params)


def test_reserve_repairs_slots_left_by_a_killed_client(store, group):
    storage.reserve(store, group, ["e0", "e1"], make_params(["e0", "e1"]))
    g = zarr.open_group(open_store(store), path=GROUP, mode="r+", use_consolidated=False)
    # A client killed after resizing some arrays but before writing the new ids:
    g["experiment"].resize((4,))
    g["status"].resize((5,))
    assert storage.statuses(store, group) == {"e0": 0, "e1": 0}
    assert storage.reserve(store, group, ["e2"], make_params(["e2"])) == {"e2": 2}
    assert all(g[n].shape[0] == 3 for n in ("experiment", "status", "displacement"))


@pytest.mark.parametrize(
    ("units", "match"),
    [
        ({"deflection": "m"}, "'deflection' is in 'mm'"),
        ({"friction": "N"}, "'friction' is in '1'"),
        ({"slip": "1"}, "no such parameter given"),
    ],
)
def test_units_must_agree_with_the_schema(store, group, units, match):
    params = {"deflection": 1.0, "pressure": 0.0, "friction": 0.5}
    with pytest.raises(SchemaError, match=match):
        storage.reserve(store, group, ["e1"], params, units=units)
