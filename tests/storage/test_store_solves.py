"""The inverse-solves group: schema, validation, write (client only), read back, errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import xarray as xr
from store_helpers import GROUP, make_info, make_result

import storage
from storage.solves import (
    DIRECTIONS,
    KIND,
    SOLVES_VERSION,
    VARIABLES,
    SolveRecord,
    SolvesAttrs,
    Unknowns,
    open_solves,
    write_solves,
)

SOLVES_GROUP = "inverse-t"
N = 3
UNKNOWNS = Unknowns(np.array([4, 5, 6]), np.array([10.0, 20.0, 30.0]),
                    np.arange(9.0).reshape(3, 3), np.array([1.0, 2.0, 60.0]),
                    np.array([-800.0, 30.0, 0.0]))
ATTRS = SolvesAttrs("t", '{"kind": "reduced"}', "CalculiX 2.20", 30.0, -369.2,
                    '{"displacement_mm": 1.0, "strain": 0.0004}', "abc")


def record(i: int = 0, k: int = 3, ok: bool = True, method: str = "displacement",
           **fields) -> SolveRecord:
    rng = np.random.default_rng(i)
    values = dict(
        id=f"{i:064x}", condition="noise", method=method, optimizer="least-squares",
        repeat=i, status="converged" if ok else "failed", message="" if ok else "diverged",
        objective_units="mm" if method == "displacement" else "1",
        x0=np.full(N, 9.0), x_final=rng.normal(20, 1, N), x_history=rng.normal(20, 1, (k, N)),
        objective_history=rng.uniform(0, 1, k), objective=0.5,
        total_force=rng.normal(0, 1, 3) if ok else None,
        moment=rng.normal(0, 100, 3) if ok else None,
        rmse=dict(zip(DIRECTIONS, rng.uniform(0, 1, 6), strict=True)) if ok else None,
        solved=k, rounds=2, wall_seconds=3.5, solver_seconds=1.25)
    return SolveRecord(**(values | fields))


def test_a_group_round_trips_with_units_and_labels(store):
    solves = [record(0, k=3), record(1, k=5, method="strain"), record(2, k=2, ok=False)]
    write_solves(store, SOLVES_GROUP, UNKNOWNS, solves, ATTRS)
    ds = open_solves(store, SOLVES_GROUP)
    assert set(VARIABLES) <= set(ds.data_vars)
    assert list(ds["solve"].values) == [s.id for s in solves]
    assert list(ds["direction"].values) == list(DIRECTIONS)
    np.testing.assert_array_equal(ds["unknown"].values, UNKNOWNS.nodes)
    np.testing.assert_array_equal(ds["x_final"].values[1], solves[1].x_final)
    np.testing.assert_array_equal(ds["x_history"].values[1], solves[1].x_history)
    assert np.isnan(ds["x_history"].values[0, 3:]).all()  # NaN past a solve's end
    np.testing.assert_array_equal(ds["reference_moment"].values, UNKNOWNS.reference_moment)
    assert list(ds["evaluations"].values) == [3, 5, 2]
    assert np.isnan(ds["rmse"].values[2]).all() and np.isnan(ds["total_force"].values[2]).all()
    assert ds["rmse"].sel(direction="Uz").values[0] == solves[0].rmse["Uz"]
    assert ds["moment"].attrs["units"] == "N mm" and ds["x_history"].attrs["units"] == "N"
    assert ds["objective"].attrs["units"] == "1/mm"  # both methods' units
    assert ds["status"].values.dtype == object and ds["status"].values[2] == "failed"
    assert ds["solve"].values.dtype == object
    assert ds.attrs["kind"] == KIND and ds.attrs["solves_version"] == SOLVES_VERSION
    assert ds.attrs["study"] == "t" and ds.attrs["road_z_mm"] == -369.2


def test_the_group_opens_with_plain_xarray_and_is_not_an_experiment_group(tmp_path):
    path = tmp_path / "s.zarr"
    write_solves(path, SOLVES_GROUP, UNKNOWNS, [record()], ATTRS)
    ds = xr.open_zarr(path, group=SOLVES_GROUP)
    assert ds.sizes["solve"] == 1 and ds["x_true"].attrs["units"] == "N"
    assert storage.list_groups(path) == []


def test_rewriting_replaces_the_group_and_leaves_other_groups_alone(store, group):
    storage.reserve(store, group, ["e1"], {"deflection": 30.0, "pressure": 0.0})
    storage.write_experiment(store, group, "e1", make_result("e1", 12, 5), make_info("e1"))
    write_solves(store, SOLVES_GROUP, UNKNOWNS, [record(0), record(1)], ATTRS)
    write_solves(store, SOLVES_GROUP, UNKNOWNS, [record(2)], ATTRS)
    assert list(open_solves(store, SOLVES_GROUP)["repeat"].values) == [2]
    assert storage.statuses(store, group) == {"e1": storage.DONE}
    assert storage.list_groups(store) == [GROUP]


def test_an_experiment_group_is_never_overwritten(store, group):
    storage.reserve(store, group, ["e1"], {"deflection": 30.0, "pressure": 0.0})
    with pytest.raises(storage.SchemaError, match="experiment group, not inverse solves"):
        write_solves(store, group, UNKNOWNS, [record()], ATTRS)
    assert storage.statuses(store, group) == {"e1": storage.PENDING}


def _bad(**fields):
    return [record(**fields)]


@pytest.mark.parametrize(("unknowns", "solves", "match"), [
    (UNKNOWNS, _bad(x_final=np.zeros(2)), r"x_final must be a real array of shape \(3,\)"),
    (UNKNOWNS, _bad(x_history=np.zeros((2, 3))), r"x_history must be .* shape \(3, 3\)"),
    (UNKNOWNS, _bad(x0=np.array([1.0, np.nan, 2.0])), "x0 holds NaN"),
    (UNKNOWNS, _bad(rmse=None), "give all three, or none"),
    (UNKNOWNS, _bad(rmse={"Ux": 1.0}), "rmse must map each of Ux"),
    (UNKNOWNS, _bad(rmse=dict.fromkeys(DIRECTIONS, -1.0)), r"rmse\['Ux'\] must be a number"),
    (UNKNOWNS, _bad(solved=-1), "solved must be an integer >= 0"),
    (UNKNOWNS, _bad(repeat=True), "repeat must be an integer"),
    (UNKNOWNS, _bad(wall_seconds=float("inf")), "wall_seconds must be a number"),
    (UNKNOWNS, _bad(method=""), "method must be non-empty text"),
    (UNKNOWNS, [record(0), record(0)], "given twice"),
    (UNKNOWNS, [], "non-empty sequence"),
    (dataclasses.replace(UNKNOWNS, nodes=np.array([4, 4, 6])), [record()], "distinct"),
    (dataclasses.replace(UNKNOWNS, x_true=np.array([1.0, np.inf, 2.0])), [record()],
     "x_true holds NaN or inf"),
    (dataclasses.replace(UNKNOWNS, reference_force=np.zeros(2)), [record()],
     "reference_force must be"),
])
def test_what_does_not_fit_is_refused_before_anything_is_written(tmp_path, unknowns, solves,
                                                                 match):
    path = tmp_path / "s.zarr"
    with pytest.raises(storage.SchemaError, match=match):
        write_solves(path, SOLVES_GROUP, unknowns, solves, ATTRS)
    assert not path.exists()


def test_attrs_are_validated(tmp_path):
    with pytest.raises(storage.SchemaError, match="model_spec must be JSON"):
        write_solves(tmp_path / "s.zarr", SOLVES_GROUP, UNKNOWNS, [record()],
                     dataclasses.replace(ATTRS, model_spec="{kind"))


def test_reading_a_missing_store_or_group_is_one_clear_error(tmp_path, store, group):
    with pytest.raises(storage.NotAStoreError, match="no store at"):
        open_solves(tmp_path / "missing.zarr", SOLVES_GROUP)
    with pytest.raises(storage.GroupNotFoundError,
                       match=f"no group 'inverse-x' .*groups: {GROUP}.*farm invert"):
        open_solves(store, "inverse-x")
    with pytest.raises(storage.SchemaError, match="is an experiment group, not inverse solves"):
        open_solves(store, group)


def test_a_group_that_lost_a_variable_is_refused(tmp_path):
    path = tmp_path / "s.zarr"
    write_solves(path, SOLVES_GROUP, UNKNOWNS, [record()], ATTRS)
    ds = xr.open_zarr(path, group=SOLVES_GROUP).load().drop_vars("x_final")
    ds.to_zarr(path, group=SOLVES_GROUP, mode="w", zarr_format=3, consolidated=False)
    storage.paths.publish(storage.open_store(path))
    with pytest.raises(storage.SchemaError, match="lacks 'x_final'"):
        open_solves(path, SOLVES_GROUP)
