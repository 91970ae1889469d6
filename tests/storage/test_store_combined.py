"""Combined-load groups (issue 13): parameters with units, the optional worker variables,
and groups written without them staying readable, writable and verifiable as before."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import numpy as np
import pytest
from store_helpers import GROUP, ROOT, make_info, make_result

import storage
from storage import SchemaError, handles
from storage import checksum as current_checksum
from storage.schema import COMBINED_NAMES, COMBINED_PARAMETERS, PATCH_NAMES

N_INNER, N_TREAD = 12, 5  # make_mesh()


def _combined(experiment_id: str, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"contact_status": np.array([0, 1, 2, 2, 0], dtype=np.int8),
            "tread_slip": rng.normal(size=(N_TREAD, 3)),
            "road_reaction": rng.normal(scale=1e3, size=3),
            "road_moment": rng.normal(scale=1e4, size=3)}


def _motion(n: int, friction=0.5, shift_x=1.0, shift_y=-2.0, tilt=3.0) -> dict:
    return {"friction": [friction] * n, "shift_x": [shift_x] * n, "shift_y": [shift_y] * n,
            "tilt": [tilt] * n}


def _group_arrays(store, group=GROUP) -> set[str]:
    return set(storage.open_dataset(store, group).variables)


def test_vertical_group_has_no_combined_variables(store, group):
    storage.reserve(store, group, ["v1"], {"deflection": 10.0, "pressure": 0.2})
    assert not _group_arrays(store) & {*COMBINED_NAMES, *COMBINED_PARAMETERS}
    result = {**make_result("v1", N_INNER, N_TREAD), **_combined("v1")}
    with pytest.raises(SchemaError, match=r"'contact_status' is a combined-load one.*reserve"):
        storage.write_experiment(store, group, "v1", result, make_info("v1"))


def test_combined_group_round_trip_with_units(store, group):
    ids = ["c1", "c2", "v0"]
    params = {"deflection": [10.0, 20.0, 15.0], "pressure": 0.2,
              **{k: [*v[:2], 0.0] for k, v in _motion(3).items()}}
    storage.reserve(store, group, ids, params)
    for e in ids[:2]:
        storage.write_experiment(store, group, e, {**make_result(e, N_INNER, N_TREAD),
                                                   **_combined(e)}, make_info(e))
    # a vertical case of a combined study: the combined variables stay not recorded
    storage.write_experiment(store, group, "v0", make_result("v0", N_INNER, N_TREAD),
                             make_info("v0"))
    ds = storage.done(storage.open_dataset(store, group))
    units = {n: ds[n].attrs["units"] for n in (*COMBINED_NAMES, *COMBINED_PARAMETERS)}
    assert units == {"contact_status": "1", "tread_slip": "mm", "road_reaction": "N",
                     "road_moment": "N mm", "friction": "1", "shift_x": "mm", "shift_y": "mm",
                     "tilt": "deg"}
    assert ds["contact_status"].dtype == np.int8
    assert ds["contact_status"].dims == ("experiment", "tread_node")
    assert ds["tread_slip"].dims == ("experiment", "tread_node", "component")
    assert ds["road_moment"].dims == ("experiment", "component")
    assert ds["friction"].values.tolist() == [0.5, 0.5, 0.0]
    assert ds["tilt"].values.tolist() == [3.0, 3.0, 0.0]
    c1 = _combined("c1")
    for n in COMBINED_NAMES:
        assert np.array_equal(ds[n].values[0], c1[n])
    assert (ds["contact_status"].values[2] == -1).all()
    assert np.isnan(ds["road_reaction"].values[2]).all()
    assert storage.verify(store).ok


def test_combined_results_are_checked(store, group):
    storage.reserve(store, group, ["c1"], {"deflection": 10.0, "pressure": 0.2, **_motion(1)})
    base = make_result("c1", N_INNER, N_TREAD)
    partial = {**base, "contact_status": _combined("c1")["contact_status"]}
    with pytest.raises(SchemaError, match="'tread_slip' is missing: give all of"):
        storage.write_experiment(store, group, "c1", partial, make_info("c1"))
    bad = {**base, **_combined("c1"), "contact_status": np.array([0, 1, 3, 0, 0])}
    with pytest.raises(SchemaError, match=r"contact_status.*0 \(open\), 1 \(stick\)"):
        storage.write_experiment(store, group, "c1", bad, make_info("c1"))
    nan = {**base, **_combined("c1"), "road_moment": np.array([1.0, np.nan, 0.0])}
    with pytest.raises(SchemaError, match="'road_moment' holds 1 NaN"):
        storage.write_experiment(store, group, "c1", nan, make_info("c1"))


def test_damaged_combined_chunk_is_found(tmp_path, mesh):
    from store_helpers import make_attrs
    store = tmp_path / "farm.zarr"
    storage.create_group(store, GROUP, mesh, make_attrs())
    storage.reserve(store, GROUP, ["c1"], {"deflection": 10.0, "pressure": 0.2, **_motion(1)})
    storage.write_experiment(store, GROUP, "c1", {**make_result("c1", N_INNER, N_TREAD),
                                                  **_combined("c1")}, make_info("c1"))
    assert storage.verify(store).ok
    (store / GROUP / "road_reaction" / "c" / "0" / "0").unlink()  # a lost chunk
    report = storage.verify(store)
    assert not report.ok and report.damaged_ids == {"c1"}


def _head_checksum_module():
    """storage/checksum.py as committed before combined loads (8bc2bcb)."""
    text = subprocess.run(["git", "show", "8bc2bcb:storage/checksum.py"], cwd=ROOT,
                          capture_output=True, text=True, check=True).stdout
    spec = importlib.util.spec_from_loader("checksum_before", loader=None)
    module = importlib.util.module_from_spec(spec)
    sys.modules["checksum_before"] = module  # its dataclass looks itself up there
    try:
        exec(compile(text, "checksum_before", "exec"), module.__dict__)
    finally:
        del sys.modules["checksum_before"]
    return module


def test_old_groups_stay_byte_compatible_and_verify(store, group):
    """A vertical group as written before: same checksums as the code before issue 13;
    then combined experiments join it, and the old ones still read and verify."""
    try:
        before = _head_checksum_module()
    except (subprocess.CalledProcessError, FileNotFoundError):
        pytest.skip("no git history here")
    storage.reserve(store, group, ["old1", "old2"], {"deflection": [10.0, 20.0],
                                                     "pressure": 0.2})
    for e in ("old1", "old2"):  # as before issue 24 too: no patch recorded (NaN)
        info = {k: v for k, v in make_info(e).items() if k not in PATCH_NAMES}
        storage.write_experiment(store, group, e, make_result(e, N_INNER, N_TREAD), info)
    ds = storage.open_dataset(store, group)
    assert not set(ds.variables) & set(COMBINED_NAMES)
    for k, e in enumerate(("old1", "old2")):
        values = {n: ds[n].values[k] for n in before.CHECKED_NAMES}
        params = {"deflection": ds["deflection"].values[k], "pressure": 0.2}
        want = before.checksum(e, params, storage.DONE, values)
        assert str(ds["checksum"].values[k]) == want == current_checksum.checksum(
            e, params, storage.DONE, values)
    # the group becomes a combined one; re-reserving the old vertical case with all-0
    # motion parameters is no conflict (it is that case), the new slots get arrays
    storage.reserve(store, group, ["old1", "c1"],
                    {"deflection": [10.0, 12.0], "pressure": 0.2,
                     **{k: [0.0, v[0]] for k, v in _motion(1).items()}})
    storage.write_experiment(store, group, "c1", {**make_result("c1", N_INNER, N_TREAD),
                                                  **_combined("c1")}, make_info("c1"))
    storage.write_experiment(store, group, "old2", make_result("old2", N_INNER, N_TREAD),
                             make_info("old2"))  # an old one rewritten: still writable
    assert storage.verify(store).ok
    ds = storage.done(storage.open_dataset(store, group))
    assert ds.sizes["experiment"] == 3
    assert np.isnan(ds["friction"].values[:2]).all() and ds["friction"].values[2] == 0.5
    assert (ds["contact_status"].values[:2] == -1).all()


def test_worker_handle_opened_before_the_group_became_combined(store, group):
    """A worker that cached the group while it was vertical: its vertical rewrite (no
    combined arrays in its handle) and its combined write both verify."""
    storage.reserve(store, group, ["v1"], {"deflection": 10.0, "pressure": 0.2})
    storage.write_experiment(store, group, "v1", make_result("v1", N_INNER, N_TREAD),
                             make_info("v1"))  # the handle is cached now, vertical
    storage.reserve(store, group, ["c1"], {"deflection": 11.0, "pressure": 0.2,
                                           **_motion(1)})
    storage.write_experiment(store, group, "v1", make_result("v1", N_INNER, N_TREAD),
                             make_info("v1"))  # with the stale handle
    h, _ = handles.locate(storage.open_store(store), group, "v1")
    assert not set(h.arrays) & set(COMBINED_NAMES)  # the stale handle was used
    storage.write_experiment(store, group, "c1", {**make_result("c1", N_INNER, N_TREAD),
                                                  **_combined("c1")}, make_info("c1"))
    ds = storage.done(storage.open_dataset(store, group))
    assert ds.sizes["experiment"] == 2
    assert np.array_equal(ds["contact_status"].values[1], _combined("c1")["contact_status"])
    assert (ds["contact_status"].values[0] == -1).all()
    assert storage.verify(store).ok


def test_a_rolling_group_from_before_states_takes_travel_without_a_conflict(store, group):
    """Issue 45: a rolling group reserved before ``travel`` existed is resumed by a study
    that keeps a roll's states: its done slot keeps NaN travel and verifies as before, the
    new states get their travel, and a conflicting travel is still refused."""
    roll = {"deflection": 15.0, "pressure": 0.2, **_motion(1, shift_x=0.0, shift_y=0.0,
                                                             tilt=0.0),
            "slip_ratio": 0.01, "slip_angle": 2.0}
    storage.reserve(store, group, ["end"], roll)
    storage.write_experiment(store, group, "end", {**make_result("end", N_INNER, N_TREAD),
                                                   **_combined("end")}, make_info("end"))
    storage.reserve(store, group, ["half", "end"], {**roll, "travel": [80.0, 160.0]})
    ds = storage.open_dataset(store, group)
    travel = dict(zip(ds["experiment"].values.tolist(), ds["travel"].values.tolist(),
                      strict=True))
    assert travel["half"] == 80.0 and np.isnan(travel["end"])
    assert ds["travel"].attrs["units"] == "mm"
    assert storage.verify(store, group).ok
    storage.reserve(store, group, ["half"], {**roll, "travel": 80.0})  # as reserved
    with pytest.raises(storage.ParameterConflictError, match="travel"):
        storage.reserve(store, group, ["half"], {**roll, "travel": 60.0})
