"""`farm sweep list` shows the resultant road forces of done experiments (issue 25):
Fz in every group, Fx and Fy in combined-load groups; failed and pending rows stay
readable, without forces."""

from __future__ import annotations

import json

import numpy as np
import pytest
import zarr

import storage
from tests.synthetic import make_combined_store, make_store
from tests.tyre_farm_cli.cli_helpers import run_cli
from tyre_farm_cli.listing import experiments, header

SMALL = {"rows": 3, "cols": 4, "tread_rows": 8, "tread_cols": 20}  # a tread in contact


@pytest.fixture(scope="module")
def vertical(tmp_path_factory):
    """4 done experiments, one failed whose slot holds a stray force, one pending."""
    path = tmp_path_factory.mktemp("stores") / "v.zarr"
    group = make_store(path, n_experiments=4, n_failed=1, n_pending=1, **SMALL)
    status = zarr.open_array(str(path / group / "status"), mode="r")[:]
    failed = int(np.flatnonzero(status == storage.FAILED)[0])
    # a writer that died after its forces: only the status says the numbers are not valid
    zarr.open_array(str(path / group / "total_force"), mode="r+")[failed] = [1.0, 2.0, 3.0]
    return path


def _forces(path) -> dict[str, np.ndarray]:
    ds = storage.open_dataset(path, storage.list_groups(path)[0])
    return dict(zip(ds["experiment"].values.tolist(), ds["total_force"].values, strict=True))


def test_done_rows_carry_fz_and_the_others_none(vertical):
    rows = experiments(str(vertical), None)
    assert len(rows) == 6
    forces = _forces(vertical)
    done = [r for r in rows if r["status"] == "done"]
    assert len(done) == 4
    for r in done:  # forces rounded to 9 decimals, like the load case
        assert r["fz_n"] == pytest.approx(forces[r["experiment"]][2], abs=1e-9)
        assert r["fz_n"] > 0  # the road pushes up: a real number, not a placeholder
    others = [r for r in rows if r["status"] != "done"]
    assert {r["status"] for r in others} == {"failed", "pending"}
    assert all(r["fz_n"] is None for r in others)  # not the stray 3.0 of the failed slot
    assert all(r["deflection_mm"] is not None for r in others)  # the load case still shows
    assert not any("fx_n" in r or "fy_n" in r for r in rows)  # vertical: Fz only
    assert list(rows[0]) == ["group", "experiment", "deflection_mm", "pressure_kpa", "fz_n",
                             "status", "error"]


def test_a_combined_group_lists_all_three_forces(tmp_path):
    path = tmp_path / "c.zarr"
    make_combined_store(path, n_experiments=5, **SMALL)
    rows = experiments(str(path), None, "done")
    forces = _forces(path)
    assert len(rows) == 5
    for r in rows:
        got = [r["fx_n"], r["fy_n"], r["fz_n"]]
        assert got == pytest.approx(forces[r["experiment"]].tolist(), abs=1e-9)
        assert {"friction", "shift_x", "shift_y", "tilt"} <= set(r)
    assert any(abs(r["fy_n"]) > 1.0 for r in rows)  # lateral loads: Fy is no noise here


def test_json_and_table(vertical, capsys):
    code, out, err = run_cli(["sweep", "list", str(vertical), "--json"], capsys)
    assert code == 0 and err == ""
    rows = json.loads(out)["experiments"]
    assert sum(r["fz_n"] is None for r in rows) == 2  # null in JSON
    code, out, err = run_cli(["sweep", "list", str(vertical)], capsys)
    assert code == 0 and err == ""
    assert "fz N" in out and "deflection mm" in out and "pressure kPa" in out
    failed = next(r for r in rows if r["status"] == "failed")
    line = next(ln for ln in out.splitlines() if failed["experiment"][:12] in ln)
    assert "-" in line.split("│")[5] and "synthetic failure" in line  # no force, the reason
    code, out, _ = run_cli(["sweep", "list", str(vertical), "--status", "failed", "--json"],
                           capsys)
    (only,) = json.loads(out)["experiments"]
    assert only["fz_n"] is None and only["error"] == "synthetic failure"


@pytest.mark.parametrize(("key", "shown"), [("deflection_mm", "deflection mm"),
                                            ("pressure_kpa", "pressure kPa"),
                                            ("fz_n", "fz N"), ("shift_x", "shift_x"),
                                            ("status", "status")])
def test_headers_carry_units(key, shown):
    assert header(key) == shown


def test_a_group_with_contact_patches_lists_their_area(tmp_path):
    """Issue 24: groups created since store each experiment's patch area; the table
    shows it for done experiments (older groups, above, list without it)."""
    path = tmp_path / "p.zarr"
    nodes = storage.MeshNodes(
        inner_ids=np.arange(4) + 1, inner_xyz=np.zeros((4, 3)), inner_row=np.arange(4),
        inner_col=np.zeros(4, int), tread_ids=np.arange(2) + 10, tread_xyz=np.zeros((2, 3)),
        tread_row=np.arange(2), tread_col=np.zeros(2, int))
    attrs = storage.GroupAttrs(model_spec="{}", mesh_key="k", solver="CalculiX 2.20",
                               package_versions={})
    storage.create_group(path, "g", nodes, attrs)
    storage.reserve(path, "g", ["a", "b"], {"deflection": [10.0, 20.0], "pressure": 0.2})
    result = {"displacement": np.zeros((4, 3)), "strain": np.zeros((4, 3)),
              "surface_strain": np.zeros((4, 3)), "reaction_force": np.ones((2, 3)),
              "total_force": np.array([0.0, 0.0, 2.0]), "moment": np.zeros(3)}
    info = {"solve_seconds": 1.0, "increments": 1, "ccx_runs": 1, "contact_nodes": 2,
            "patch_area": 123.5}
    storage.write_experiment(path, "g", "a", result, info)
    storage.write_failure(path, "g", "b", "boom", {})
    rows = {r["experiment"]: r for r in experiments(str(path), None)}
    assert rows["a"]["patch_area_mm2"] == 123.5 and rows["b"]["patch_area_mm2"] is None
    assert header("patch_area_mm2") == "patch_area mm2"
