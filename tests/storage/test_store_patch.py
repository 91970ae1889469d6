"""Contact patch and inflation growth in the store (issue 24, item 5): the variables of
every new group, and groups created before them staying readable, writable, resumable
and verifiable with the checksums they had."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from store_helpers import GROUP, make_attrs, make_info, make_patch, make_result
from test_store_combined import _head_checksum_module

import storage
import tyre_farm_cli as cli
from storage import checksum as current_checksum
from storage.paths import publish
from storage.schema import CHECKED_NAMES, FIXED_VARIABLES, PATCH_NAMES, PATCH_VARIABLES
from storage.verify import REQUIRED_ARRAYS, verify

N_INNER, N_TREAD = 12, 5  # make_mesh()
IDS = ["e0", "e1", "e2"]


def _reserve(store, ids=IDS) -> None:
    storage.reserve(store, GROUP, ids, {"deflection": [10.0 + k for k in range(len(ids))],
                                        "pressure": 0.2})


def _write(store, e: str, info=None) -> None:
    storage.write_experiment(store, GROUP, e, make_result(e, N_INNER, N_TREAD),
                             make_info(e) if info is None else info)


def _cli(*args: str) -> int:
    try:
        cli.main(list(args))
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def test_patch_variables_are_optional_worker_variables():
    assert [v.dims for v in PATCH_VARIABLES] == [("experiment",)] * len(PATCH_VARIABLES)
    assert {v.dtype for v in PATCH_VARIABLES} == {"float64"}
    assert all(v.writer == "worker" and np.isnan(v.fill) for v in PATCH_VARIABLES)
    assert not set(PATCH_NAMES) & set(REQUIRED_ARRAYS)  # older groups lack them
    assert not set(PATCH_NAMES) & set(CHECKED_NAMES)  # only where a group has them
    units = {"patch_area": "mm2", "patch_length": "mm", "patch_width": "mm",
             "peak_pressure": "MPa", "mean_pressure": "MPa", "nodal_force_mean": "N",
             "nodal_force_std": "N", "inflation_growth": "mm", "loaded_radius": "mm",
             "rolling_radius": "mm"}
    assert {n: FIXED_VARIABLES[n].units for n in PATCH_NAMES} == units


def test_farm_measurement_names_are_the_schema_s():
    from farm.measure.measurement import Measurement
    assert (*Measurement.PATCH_FIELDS, "inflation_growth", "loaded_radius",
            "rolling_radius") == PATCH_NAMES
    assert {n: FIXED_VARIABLES[n].units for n in PATCH_NAMES} == Measurement.PATCH_UNITS


def test_new_group_stores_reads_and_verifies_them(store, group):
    _reserve(store)
    _write(store, "e0")
    no_growth = {**make_info("e1"), "inflation_growth": float("nan")}  # a reduced model
    _write(store, "e1", no_growth)
    storage.write_failure(store, GROUP, "e2", "boom", {})
    ds = storage.open_dataset(store, GROUP)
    for name in PATCH_NAMES:
        assert ds[name].attrs["units"] == FIXED_VARIABLES[name].units
        assert ds[name].values[0] == make_patch("e0")[name]
        assert np.isnan(ds[name].values[2])  # a failure records no patch
    assert np.isnan(ds["inflation_growth"].values[1])
    assert ds["patch_area"].values[1] == make_patch("e1")["patch_area"]
    assert verify(store).ok
    assert storage.done(ds).sizes["experiment"] == 2


def test_a_changed_patch_value_is_damage(tmp_path, mesh):
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, mesh, make_attrs())
    _reserve(path)
    for e in IDS:
        _write(path, e)
    chunk = path / GROUP / "peak_pressure" / "c" / "1"
    chunk.write_bytes(np.float64(1.5).tobytes())  # raw chunks: a silently changed value
    report = verify(path)
    assert not report.ok and report.damaged_ids == {"e1"}
    with pytest.raises(storage.DamagedStoreError, match="e1"):
        storage.done(storage.open_dataset(path, GROUP))


def test_a_lost_patch_array_of_a_new_group_is_damage(tmp_path, mesh):
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, mesh, make_attrs())
    _reserve(path)
    for e in IDS:
        _write(path, e)
    shutil.rmtree(path / GROUP / "patch_width")  # the consolidated metadata still lists it
    report = verify(path)
    assert not report.ok
    assert "patch_width" in "\n".join(report.lines())


# --- groups created before issue 24 -------------------------------------------------------


@pytest.fixture
def old_group(tmp_path, mesh):
    """A group as created before issue 24: no patch arrays, two experiments done."""
    path = tmp_path / "old.zarr"
    storage.create_group(path, GROUP, mesh, make_attrs())
    for name in PATCH_NAMES:
        shutil.rmtree(path / GROUP / name)
    publish(storage.open_store(path))  # its consolidated metadata never listed them
    _reserve(path, IDS[:2])
    for e in IDS[:2]:
        _write(path, e, {k: v for k, v in make_info(e).items() if k not in PATCH_NAMES})
    return path


def test_old_group_checksums_are_those_of_before(old_group):
    try:
        before = _head_checksum_module()
    except (subprocess.CalledProcessError, FileNotFoundError):
        pytest.skip("no git history here")
    ds = storage.open_dataset(old_group, GROUP)
    assert not set(ds.variables) & set(PATCH_NAMES)
    for k, e in enumerate(IDS[:2]):
        values = {n: ds[n].values[k] for n in CHECKED_NAMES}
        params = {"deflection": ds["deflection"].values[k], "pressure": 0.2}
        want = before.checksum(e, params, storage.DONE, values)
        assert str(ds["checksum"].values[k]) == want == current_checksum.checksum(
            e, params, storage.DONE, values)


def test_old_group_opens_verifies_and_resumes(old_group, capsys):
    assert verify(old_group).ok
    assert _cli("sweep", "verify", str(old_group)) == 0
    capsys.readouterr()
    # a resume: one more experiment reserved, a worker of today writes it with its patch
    _reserve(old_group, [*IDS, "e3"])
    _write(old_group, "e2")  # the patch values are skipped: the group has no arrays
    storage.write_failure(old_group, GROUP, "e3", "boom", {})
    assert storage.statuses(old_group, GROUP) == {**dict.fromkeys(IDS, storage.DONE),
                                                  "e3": storage.FAILED}
    ds = storage.done(storage.open_dataset(old_group, GROUP))
    assert ds.sizes["experiment"] == 3 and not set(ds.variables) & set(PATCH_NAMES)
    assert verify(old_group).ok
    assert _cli("sweep", "verify", str(old_group)) == 0
    np.testing.assert_array_equal(ds.sel(experiment="e2")["displacement"].values,
                                  make_result("e2", N_INNER, N_TREAD)["displacement"])


def test_bad_patch_info_is_refused(store, group):
    _reserve(store)
    with pytest.raises(storage.SchemaError, match="'patch_area' must be a finite number"):
        _write(store, "e0", {**make_info("e0"), "patch_area": float("inf")})
    with pytest.raises(storage.SchemaError, match="'mean_pressure' must be a finite number"):
        _write(store, "e0", {**make_info("e0"), "mean_pressure": "high"})
    with pytest.raises(storage.SchemaError, match="unknown info key 'patch_depth'"):
        _write(store, "e0", {**make_info("e0"), "patch_depth": 1.0})
