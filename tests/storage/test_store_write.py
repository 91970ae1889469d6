"""Worker side: write_experiment / write_failure round-trip, idempotency, validation."""

from __future__ import annotations

import hashlib
import shutil

import numpy as np
import pytest
import zarr
from store_helpers import GROUP, make_attrs, make_info, make_params, make_result

import storage
from storage import (
    AlreadyDoneError,
    MeshMismatchError,
    NotReservedError,
    SchemaError,
)
from storage.paths import CLAIMS_DIR, LOCK_NAME, open_store
from storage.schema import MAX_ERROR_CHARS, RESULT_NAMES

IDS = ["e0", "e1", "e2"]


@pytest.fixture
def reserved(store, group):
    storage.reserve(store, group, IDS, make_params(IDS))
    return IDS


def _write(store, eid, mesh, **kw):
    storage.write_experiment(store, GROUP, eid, make_result(eid, mesh.n_inner, mesh.n_tread),
                             make_info(eid), **kw)


def test_round_trip_of_every_variable(store, reserved, mesh):
    _write(store, "e1", mesh)
    storage.write_failure(store, GROUP, "e2", "ccx failed (too_many_cutbacks)", {"ccx_runs": 3})
    ds = storage.open_dataset(store, GROUP).load()
    assert ds["experiment"].values.tolist() == IDS
    want = make_result("e1", mesh.n_inner, mesh.n_tread)
    for name in RESULT_NAMES:
        got = ds[name].sel(experiment="e1").values
        assert got.dtype == np.float64 and np.array_equal(got, want[name]), name
        assert np.isnan(ds[name].sel(experiment=["e0", "e2"]).values).all(), name
    for name, value in make_info("e1").items():
        assert ds[name].sel(experiment="e1").item() == value, name
    np.testing.assert_array_equal(ds["deflection"].values, make_params(IDS)["deflection"])
    np.testing.assert_array_equal(ds["pressure"].values, make_params(IDS)["pressure"])
    assert ds["status"].values.tolist() == [storage.PENDING, storage.DONE, storage.FAILED]
    assert ds["status"].dtype == np.int8
    assert ds["error"].values.tolist() == ["", "", "ccx failed (too_many_cutbacks)"]
    assert ds["ccx_runs"].values.tolist() == [-1, make_info("e1")["ccx_runs"], 3]
    assert np.isnan(ds["solve_seconds"].values[[0, 2]]).all()
    for name, value in mesh.arrays().items():
        np.testing.assert_array_equal(ds[name].values, value)
    assert ds["inner_xyz"].dims == ("inner_node", "component")


def _tree_digest(path) -> dict[str, str]:
    # The client lock records its last holder (pid, host): coordination, not data.
    return {str(p.relative_to(path)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(path.rglob("*"))
            if p.is_file() and p.name != LOCK_NAME and CLAIMS_DIR not in p.parts}


def test_writing_the_same_experiment_twice_gives_the_same_store(tmp_path, mesh):
    path = tmp_path / "s.zarr"
    storage.create_group(path, GROUP, mesh, make_attrs())
    storage.reserve(path, GROUP, IDS, make_params(IDS))
    _write(path, "e1", mesh)
    storage.write_failure(path, GROUP, "e2", "boom", {})
    before = _tree_digest(path)
    _write(path, "e1", mesh)
    storage.write_failure(path, GROUP, "e2", "boom", {})
    storage.reserve(path, GROUP, IDS, make_params(IDS))
    storage.create_group(path, GROUP, mesh, make_attrs())
    assert _tree_digest(path) == before


def test_write_touches_only_its_own_chunks(tmp_path, mesh):
    path = tmp_path / "s.zarr"
    storage.create_group(path, GROUP, mesh, make_attrs())
    storage.reserve(path, GROUP, IDS, make_params(IDS))
    before = _tree_digest(path)
    _write(path, "e1", mesh)
    storage.write_failure(path, GROUP, "e2", "boom", {})
    after = _tree_digest(path)
    changed = {k for k in before.keys() | after.keys() if before.get(k) != after.get(k)}
    assert len(changed) >= len(storage.schema.WORKER_VARIABLES)
    for key in changed:  # e.g. "mesh-a/displacement/c/1/0/0": variable, then chunk index
        _, chunk, coords = key.partition("/c/")
        assert chunk and coords.split("/")[0] in ("1", "2"), key  # never metadata


def test_a_failure_records_reason_and_timings(store, reserved):
    storage.write_failure(store, GROUP, "e0", "timeout after 1800 s", {"solve_seconds": 1800.0})
    ds = storage.open_dataset(store, GROUP)
    assert storage.statuses(store, GROUP, ["e0"]) == {"e0": storage.FAILED}
    assert ds["error"].values[0] == "timeout after 1800 s"
    assert ds["solve_seconds"].values[0] == 1800.0 and ds["increments"].values[0] == -1


def test_a_long_reason_is_cut_to_the_limit(store, reserved):
    reason = "ccx failed (crash): " + "x" * 5000 + " *ERROR in e_c3d: nonpositive jacobian"
    storage.write_failure(store, GROUP, "e0", reason, {})
    stored = storage.open_dataset(store, GROUP)["error"].values[0]
    assert len(stored) <= MAX_ERROR_CHARS
    assert stored.startswith("ccx failed (crash)") and stored.endswith("nonpositive jacobian")


def test_a_failure_never_overwrites_a_done_experiment(store, reserved, mesh):
    _write(store, "e1", mesh)
    with pytest.raises(AlreadyDoneError, match=r"'e1'.*is done"):
        storage.write_failure(store, GROUP, "e1", "late failure", {})
    ds = storage.done(storage.open_dataset(store, GROUP))
    assert ds["experiment"].values.tolist() == ["e1"]


def test_a_retry_after_a_failure_is_done_and_clears_the_reason(store, reserved, mesh):
    storage.write_failure(store, GROUP, "e1", "boom", {"ccx_runs": 1})
    _write(store, "e1", mesh)
    ds = storage.open_dataset(store, GROUP)
    assert ds["status"].values[1] == storage.DONE and ds["error"].values[1] == ""
    assert ds["ccx_runs"].values[1] == make_info("e1")["ccx_runs"]


def test_a_failure_resets_results_to_nan(store, reserved, mesh):
    # What a writer killed after its data chunks (before its status) leaves behind:
    g = zarr.open_group(open_store(store), path=GROUP, mode="r+", use_consolidated=False)
    g["displacement"][1] = np.ones((mesh.n_inner, 3))
    storage.write_failure(store, GROUP, "e1", "retry failed", {})
    ds = storage.open_dataset(store, GROUP)
    assert np.isnan(ds["displacement"].values[1]).all()
    assert ds["status"].values[1] == storage.FAILED


def _bad(mesh, **change):
    result = make_result("e0", mesh.n_inner, mesh.n_tread)
    result.update(change)
    return {k: v for k, v in result.items() if v is not None}


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"displacement": np.zeros((11, 3))}, SchemaError,
         r"'displacement' must be a real array of shape \(12, 3\)"),
        ({"reaction_force": np.zeros((5, 2))}, SchemaError, r"shape \(5, 3\)"),
        ({"total_force": np.zeros(3, dtype=complex)}, SchemaError, "real array"),
        ({"strain": np.full((12, 3), np.nan)}, SchemaError, "36 NaN/inf"),
        ({"moment": np.array([0.0, np.inf, 1.0])}, SchemaError, "1 NaN/inf"),
        ({"displacment": np.zeros((12, 3))}, SchemaError, "unknown result variable 'displacment'"),
        ({"surface_strain": None}, SchemaError, "'surface_strain' is missing"),
        ({"inner_node": np.arange(12)}, MeshMismatchError, "inner_node ids of the result differ"),
    ],
)
def test_write_rejects_results_that_do_not_fit(store, reserved, mesh, change, error, match):
    with pytest.raises(error, match=match):
        storage.write_experiment(store, GROUP, "e0", _bad(mesh, **change), make_info("e0"))
    assert storage.statuses(store, GROUP, ["e0"]) == {"e0": storage.PENDING}


def test_matching_node_ids_are_accepted(store, reserved, mesh):
    result = _bad(mesh, inner_node=mesh.inner_ids, tread_node=mesh.tread_ids)
    storage.write_experiment(store, GROUP, "e0", result, make_info("e0"))
    assert storage.statuses(store, GROUP, ["e0"]) == {"e0": storage.DONE}


@pytest.mark.parametrize(
    ("info", "match"),
    [
        ({"solve_seconds": 1.0, "increments": 2, "ccx_runs": 1}, "'contact_nodes' is missing"),
        ({"solve_seconds": -1.0, "increments": 2, "ccx_runs": 1, "contact_nodes": 0},
         "seconds >= 0"),
        ({"solve_seconds": 1.0, "increments": 2.5, "ccx_runs": 1, "contact_nodes": 0}, "integer"),
        ({"solve_seconds": 1.0, "increments": True, "ccx_runs": 1, "contact_nodes": 0}, "integer"),
        ({"solve_seconds": 1.0, "increments": 2, "ccx_runs": 1, "contact_nodes": 0, "x": 1},
         "unknown info key 'x'"),
    ],
)
def test_write_rejects_bad_info(store, reserved, mesh, info, match):
    with pytest.raises(SchemaError, match=match):
        storage.write_experiment(store, GROUP, "e0", _bad(mesh), info)


def test_writing_an_unreserved_id_is_refused(store, reserved, mesh):
    with pytest.raises(NotReservedError, match=r"'e9' is not reserved.*reserve"):
        _write(store, "e9", mesh)
    with pytest.raises(NotReservedError):
        storage.write_failure(store, GROUP, "e9", "boom", {})


def test_mesh_key_is_checked_when_given(store, reserved, mesh):
    _write(store, "e0", mesh, mesh_key="mesh-a")
    with pytest.raises(MeshMismatchError, match=r"holds mesh 'mesh-a'.*'mesh-b'"):
        _write(store, "e1", mesh, mesh_key="mesh-b")


def test_a_failure_needs_a_reason(store, reserved):
    with pytest.raises(SchemaError, match="needs a reason"):
        storage.write_failure(store, GROUP, "e0", "  ", {})


def test_ids_reserved_after_a_worker_opened_the_group_are_found(store, reserved, mesh):
    _write(store, "e0", mesh)  # the worker now caches the group with 3 slots
    storage.reserve(store, GROUP, ["e3"], make_params(["e3"]))
    _write(store, "e3", mesh)
    _write(store, "e2", mesh)  # cached arrays still write old slots after the resize
    assert storage.statuses(store, GROUP) == {"e0": 1, "e1": 0, "e2": 1, "e3": 1}


def test_a_store_made_anew_at_the_same_path_is_not_confused(tmp_path, mesh):
    path = tmp_path / "s.zarr"
    storage.create_group(path, GROUP, mesh, make_attrs())
    storage.reserve(path, GROUP, ["a", "b"], make_params(["a", "b"]))
    _write(path, "a", mesh)  # cached: a -> 0
    shutil.rmtree(path)
    storage.create_group(path, GROUP, mesh, make_attrs())
    storage.reserve(path, GROUP, ["b", "a"], make_params(["b", "a"]))
    _write(path, "a", mesh)  # must land at index 1 now
    assert storage.statuses(path, GROUP) == {"b": 0, "a": 1}
    ds = storage.open_dataset(path, GROUP)
    want = make_result("a", mesh.n_inner, mesh.n_tread)["displacement"]
    np.testing.assert_array_equal(ds["displacement"].values[1], want)
