"""Chapter 3 of the reproduction drawn from a synthetic store (no ccx): the force table,
the differences to the thesis' reference points, the nodal forces at the thesis' §3.3.1 and
§3.3.2 points, Table 3.1 from the groups' model specs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import storage
from analysis.report import ch3

N_INNER, N_TREAD = 4, 5


def _spec(kind: str, moduli: tuple[float, float, float], nu: float, mesh: dict) -> dict:
    """The parts of ``ModelSpec.to_dict()`` chapter 3 reads."""
    return {"kind": kind, "mesh": mesh, "road": "iterative" if kind == "reduced" else "contact",
            "materials": {r: {"youngs_modulus": e, "poisson_ratio": nu}
                          for r, e in zip(("tread", "sidewall", "bead"), moduli, strict=True)}}


def _group(store: Path, group: str, spec: dict, cases: list[tuple[float, float, float]],
           nodal_fz: np.ndarray | None = None) -> None:
    """Experiments (deflection mm, pressure MPa, Fz N); the first is left pending and the
    second fails, so neither must be read."""
    mesh = storage.MeshNodes(
        inner_ids=np.arange(N_INNER) + 1, inner_xyz=np.eye(N_INNER, 3) * 100,
        inner_row=np.zeros(N_INNER, int), inner_col=np.arange(N_INNER),
        tread_ids=np.arange(N_TREAD) + 100, tread_xyz=np.eye(N_TREAD, 3) * 200,
        tread_row=np.zeros(N_TREAD, int), tread_col=np.arange(N_TREAD))
    attrs = storage.GroupAttrs(model_spec=json.dumps(spec, sort_keys=True), mesh_key=group,
                               solver="CalculiX test")
    storage.create_group(store, group, mesh, attrs)
    cases = [(15.0, cases[0][1], 1e9), (20.0, cases[0][1], 1e9), *cases]
    ids = [f"{group}-{k}" for k in range(len(cases))]
    storage.reserve(store, group, ids, {"deflection": [c[0] for c in cases],
                                        "pressure": [c[1] for c in cases]})
    storage.write_failure(store, group, ids[1], "diverged", {})
    for eid, (d, _, fz) in zip(ids[2:], cases[2:], strict=True):
        reaction = np.zeros((N_TREAD, 3))
        reaction[:, 2] = nodal_fz if nodal_fz is not None and d == 30 else fz / N_TREAD
        storage.write_experiment(store, group, eid, {
            "displacement": np.zeros((N_INNER, 3)), "strain": np.zeros((N_INNER, 3)),
            "surface_strain": np.zeros((N_INNER, 3)), "reaction_force": reaction,
            "total_force": np.array([0.0, 0.0, fz]), "moment": np.zeros(3)},
            {"solve_seconds": 1.0, "increments": 1, "ccx_runs": 1, "contact_nodes": 1})


@pytest.fixture(scope="module")
def stage(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ch3")
    store = folder / "s.zarr"
    full = _spec("full", (60.0, 20.0, 5.0), 0.4,
                 {"tread": 8, "sidewall": 5, "bead": 2, "circumferential": 40})
    reduced = _spec("reduced", (10.0, 10.0, 10.0), 0.499,
                    {"tread": 4, "sidewall": 2, "bead": 1, "circumferential": 8})
    # thesis: 3933 N at 25 mm / 80 kPa, 4476 N at 30 mm / 200 kPa, 359 N reduced at 30 mm
    _group(store, "full", full, [(25.0, 0.08, 0.9 * 3933), (25.0, 0.2, 4000.0),
                                 (30.0, 0.2, 1.05 * 4476)])
    _group(store, "reduced", reduced, [(10.0, 0.0, 100.0), (30.0, 0.0, 1.1 * 359)],
           nodal_fz=np.array([10.0, 20.0, 30.0, 0.0, -5.0]))
    return ch3.validation(store, "full", "reduced", folder / "figures")


def test_force_table_has_one_curve_per_model_and_pressure(stage):
    table = stage.tables["force-deflection (thesis Fig. 3.3)"]
    assert list(table.columns) == ["deflection mm", "full 80 kPa: Fz N",
                                   "full 200 kPa: Fz N", "reduced: Fz N"]
    assert list(table["deflection mm"]) == [10.0, 25.0, 30.0]  # no pending/failed rows
    expected = [[np.nan, np.nan, 100.0], [0.9 * 3933, 4000.0, np.nan],
                [np.nan, 1.05 * 4476, 1.1 * 359]]
    np.testing.assert_allclose(table.iloc[:, 1:].to_numpy(), expected)


def test_reference_points_differ_from_the_thesis_in_percent(stage):
    points = stage.tables["thesis reference points (§3.3, §3.4)"]
    assert list(points["case"]) == ["full 80 kPa, 25 mm", "full 200 kPa, 30 mm",
                                    "reduced, 30 mm"]
    assert list(points["thesis Fz N"]) == [3933.0, 4476.0, 359.0]
    np.testing.assert_allclose(points["measured Fz N"], [0.9 * 3933, 1.05 * 4476, 1.1 * 359])
    np.testing.assert_allclose(points["difference %"], [-10.0, 5.0, 10.0])


def test_reduced_model_at_30_mm_counts_the_pushed_nodes(stage):
    table = stage.tables["reduced model at 30 mm (thesis §3.3.1)"].set_index("quantity")
    # nodal Fz 10, 20, 30, 0, -5: three nodes pushed by the road
    np.testing.assert_allclose(table["measured"], [55.0, 3, 20.0, np.sqrt(200 / 3)])
    assert list(table["thesis"]) == [359.0, 14, 25.68, 7.27]


def test_the_full_models_nodal_forces_at_30_mm_80_kpa_stand_beside_the_thesis():
    """§3.3.2: 263.3 N mean and 227.4 N std over the loaded nodes, at 30 mm / 80 kPa only
    (the 200 kPa experiment at 30 mm and the unloaded nodes must not be read)."""
    fz = np.array([[0.0, 1.0, 1.0, 1.0], [100.0, 300.0, 0.0, -4.0], [9.0, 9.0, 9.0, 9.0]])
    ds = xr.Dataset(
        {"reaction_force": (("experiment", "tread_node", "component"),
                            np.stack([np.zeros_like(fz), np.zeros_like(fz), fz], axis=-1))},
        coords={"deflection": ("experiment", [25.0, 30.0, 30.0]),
                "pressure": ("experiment", [0.08, 0.08, 0.2]),
                "component": ["x", "y", "z"]})
    table = ch3.full_30_80(ds).set_index("quantity")
    assert list(table.index) == ["mean nodal force N", "std nodal force N"]
    np.testing.assert_allclose(table["measured"], [200.0, 100.0])
    assert list(table["thesis"]) == [263.3, 227.4]
    assert ch3.full_30_80(ds.isel(experiment=[0, 2])).empty  # no such experiment: no table


def test_a_full_group_without_the_80_kpa_30_mm_point_has_no_nodal_table(stage):
    assert ch3.FULL_NODAL not in stage.tables
    assert next(iter(stage.tables)) == ch3.REDUCED_30  # the thesis' order: §3.3.1 first


def test_table_3_1_reads_the_groups_model_specs(stage):
    table = stage.tables["models (thesis Table 3.1)"].set_index("property")
    modulus = "Young's modulus tread / sidewall / bead (MPa)"
    assert table.loc[modulus, "here full"] == "60 / 20 / 5"  # region order, not JSON's
    assert table.loc[modulus, "here reduced"] == "10 / 10 / 10"
    assert table.loc["number of elements", "here full"] == str((8 + 2 * 7) * 40)
    assert table.loc["number of elements", "here reduced"] == str((4 + 2 * 3) * 8)
    assert table.loc["Poisson's ratio"].tolist()[2:] == ["0.499", "0.4"]
    assert table.loc["road boundary condition", "here reduced"] == "iterative"


def test_the_figure_is_a_png(stage):
    path = stage.figures["force-deflection"]
    assert path.name == "force_deflection.png"
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# That analysis/report imports neither farm nor jobs is tests/test_layering.py's check.


def test_groups_without_patches_have_no_patch_table(stage):
    assert ch3.CONTACT_PATCH not in stage.tables  # written without patches (NaN)


def test_the_contact_patch_table_lists_each_recorded_patch(tmp_path):
    """Issue 24: groups created since store each experiment's patch and growth."""
    store = tmp_path / "s.zarr"
    spec = _spec("full", (60.0, 20.0, 5.0), 0.4,
                 {"tread": 8, "sidewall": 5, "bead": 2, "circumferential": 40})
    _group(store, "g", spec, [(30.0, 0.2, 4000.0), (10.0, 0.2, 1000.0)])
    ds = storage.open_dataset(store, "g")
    storage.write_experiment(store, "g", "g-3", {
        "displacement": np.zeros((N_INNER, 3)), "strain": np.zeros((N_INNER, 3)),
        "surface_strain": np.zeros((N_INNER, 3)), "reaction_force": np.zeros((N_TREAD, 3)),
        "total_force": np.array([0.0, 0.0, 1000.0]), "moment": np.zeros(3)},
        {"solve_seconds": 1.0, "increments": 1, "ccx_runs": 1, "contact_nodes": 1,
         "patch_area": 5000.0, "mean_pressure": 0.2, "inflation_growth": 4.5})
    rows = ch3.patch_rows(storage.done(storage.open_dataset(store, "g")), spec)
    assert "patch_area" in ds
    (row,) = rows  # g-2 (30 mm) recorded no patch
    assert row["case"] == "full 200 kPa, 10 mm" and row["Fz N"] == 1000.0
    assert row["patch area mm2"] == 5000.0 and row["mean pressure kPa"] == 200.0
    assert row["inflation growth mm"] == 4.5 and np.isnan(row["width mm"])
