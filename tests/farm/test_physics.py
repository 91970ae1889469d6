"""Physics of the virtual experiments, with the real solver (thesis ch. 3).

The solved paths are session fixtures shared by several checks: equilibrium, symmetry,
monotonicity, the inflated reference state, a path point against a separate run, mesh
refinement, and the iterative road against rigid-plane contact.
"""

import dataclasses

import numpy as np
import pytest

from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.contact import inflate
from farm.specs import LoadPath, MeshDensity, SolverSettings

pytestmark = pytest.mark.ccx

FULL = default_model("full")
REDUCED = default_model("reduced")
SETTINGS = SolverSettings()


@pytest.fixture(scope="module")
def full_200():
    return run_load_path(FULL, LoadPath((10.0, 20.0, 30.0), 0.2), SETTINGS)


@pytest.fixture(scope="module")
def full_80():
    return run_load_path(FULL, LoadPath((10.0, 20.0), 0.08), SETTINGS)


@pytest.fixture(scope="module")
def reduced():
    return run_load_path(REDUCED, LoadPath((10.0, 20.0, 30.0)), SETTINGS)


def _contact_extent(mesh, m):
    """Largest distance of a loaded tread node from the contact centre's vertical."""
    xy = mesh.xyz(mesh.tread_nodes)[:, :2]
    return np.hypot(*xy[np.abs(m.reaction_force).sum(axis=1) > 0].T).max()


@pytest.mark.parametrize("name", ["full_200", "reduced"])
def test_tread_forces_balance_the_road(name, request):
    result = request.getfixturevalue(name)
    for m in result.measurements:
        assert m.total_force[2] > 0
        assert m.total_force[2] == pytest.approx(m.road_reaction[2], rel=5e-3)
        # frictionless road: no horizontal force
        assert np.abs(m.total_force[:2]).max() < 1e-6 * m.total_force[2]


@pytest.mark.parametrize("name", ["full_200", "reduced"])
def test_symmetric_load_gives_no_moment(name, request):
    result = request.getfixturevalue(name)
    mesh = mesh_for(result.model)
    for m in result.measurements:
        lever = m.total_force[2] * _contact_extent(mesh, m)
        assert abs(m.moment[0]) < 1e-3 * lever
        assert abs(m.moment[1]) < 1e-3 * lever


@pytest.mark.parametrize("name", ["full_200", "reduced"])
def test_force_increases_with_deflection(name, request):
    fz = [m.total_force[2] for m in request.getfixturevalue(name).measurements]
    assert np.all(np.diff(fz) > 0)


def test_force_increases_with_pressure(full_80, full_200):
    low, high = full_80.measurements[1], full_200.measurements[1]
    assert low.deflection == high.deflection == 20.0
    assert high.total_force[2] > low.total_force[2]


def test_inflation_alone_gives_no_road_force_and_grows_the_tyre(full_200):
    mesh = mesh_for(FULL)
    _, lowest = inflate(FULL, mesh, 0.2, SETTINGS)
    assert lowest < mesh.bottom_z - 1.0  # pressure on the cavity faces pushes outward
    ref = full_200.reference  # the path's state at the end of inflation
    assert np.all(ref.tread_force == 0) and np.abs(ref.road_reaction).max() < 1e-6
    assert np.nanmin(ref.displacement[mesh.tread_nodes - 1, 2]) == pytest.approx(
        lowest - mesh.bottom_z, abs=1e-3)


def test_path_point_equals_separate_run(full_80):
    alone = run_load_path(FULL, LoadPath((10.0,), 0.08), SETTINGS).measurements[0]
    in_path = full_80.measurements[0]
    assert in_path.deflection == alone.deflection == 10.0
    assert in_path.total_force[2] == pytest.approx(alone.total_force[2], rel=5e-3)
    scale = np.abs(alone.displacement).max()
    assert np.abs(in_path.displacement - alone.displacement).max() < 5e-3 * scale


def test_measurements_have_the_store_shapes(full_200):
    mesh = mesh_for(FULL)
    n, m = mesh.inner_nodes.size, mesh.tread_nodes.size
    for x in full_200.measurements:
        shapes = {k: v.shape for k, v in x.arrays().items()}
        assert shapes == {"displacement": (n, 3), "strain": (n, 3), "surface_strain": (n, 3),
                          "reaction_force": (m, 3), "total_force": (3,), "moment": (3,)}
        assert all(np.isfinite(v).all() for v in x.arrays().values())
    # the inner surface under the road moves up by about the deflection
    last = full_200.measurements[-1]
    assert last.displacement[:, 2].max() == pytest.approx(30.0, rel=0.1)


def test_solver_and_surface_strains_agree(full_200):
    """Two independent routes to the circumferential strain of the cavity wall."""
    last = full_200.measurements[-1]
    a, b = last.strain[:, 0], last.surface_strain[:, 0]
    assert np.corrcoef(a, b)[0, 1] > 0.9


def test_reduced_iterative_contact_is_settled(reduced):
    mesh = mesh_for(REDUCED)
    for m in reduced.measurements:
        fz = m.reaction_force[:, 2]
        assert np.all(fz >= 0)  # no node pulls the road down
        assert m.contact_nodes >= 2
    assert reduced.ccx_runs >= len(reduced.measurements)
    # thesis §3.3.1: the uninflated section bulges in the middle and loses contact there
    grid = reduced.measurements[-1].reaction_force[:, 2].reshape(
        mesh.tread_rows[1] - mesh.tread_rows[0], -1)
    centre = grid[grid.shape[0] // 2, grid.shape[1] // 2]
    edges = grid[[0, -1]].sum()
    assert centre == 0 and edges > 0.5 * grid.sum()


def test_iterative_road_agrees_with_rigid_plane_contact(reduced):
    contact = run_load_path(dataclasses.replace(REDUCED, road="contact"),
                            LoadPath((10.0,)), SETTINGS).measurements[0]
    iterative = reduced.measurements[0]
    assert contact.total_force[2] == pytest.approx(iterative.total_force[2], rel=0.05)


@pytest.mark.slow
def test_refined_mesh_changes_force_little():
    coarse = run_load_path(FULL, LoadPath((20.0,), 0.2), SETTINGS).measurements[0]
    fine_spec = dataclasses.replace(FULL, mesh=MeshDensity(tread=16, sidewall=10, bead=4,
                                                           circumferential=80))
    fine = run_load_path(fine_spec, LoadPath((20.0,), 0.2), SETTINGS).measurements[0]
    assert fine.total_force[2] == pytest.approx(coarse.total_force[2], rel=0.02)


def test_contact_patch_and_growth_of_every_state(full_200):
    """Issue 24: the patch and the inflation growth the worker stores, from the real
    solver. ``mean_pressure`` is the loaded nodes' road-normal force over ``patch_area``
    (farm.measure.patch), so on a level road their product is Fz less the force of the
    nodes below ``LOADED_N`` (at most 1e-6 N each), up to rounding."""
    from farm.measure.patch import LOADED_N

    mesh = mesh_for(FULL)
    growth = full_200.growth(mesh)
    assert np.isfinite(growth) and growth > 0  # inflation pushes the tread outward
    slack = mesh.tread_nodes.size * LOADED_N
    for m in full_200.measurements:
        v = m.patch_values()
        fz = m.total_force[2]
        assert fz > 0 and v["patch_area"] > 0
        assert v["mean_pressure"] * v["patch_area"] == pytest.approx(fz, rel=1e-9, abs=slack)
        assert v["patch_length"] > 0 and v["patch_width"] > 0
        assert v["peak_pressure"] >= v["mean_pressure"] > 0
        assert v["nodal_force_mean"] > 0 and v["nodal_force_std"] >= 0
        assert v["inflation_growth"] == growth  # one reference per path
    areas = [m.patch_values()["patch_area"] for m in full_200.measurements]
    assert areas == sorted(areas)  # the patch grows with the deflection
    # issue 30's radii: the road comes up by the deflection; no roll, no rolling radius
    loaded = np.array([m.loaded_radius for m in full_200.measurements])
    deflections = np.array([m.deflection for m in full_200.measurements])
    np.testing.assert_allclose(loaded + deflections, loaded[0] + deflections[0], atol=1e-9)
    assert 350.0 < loaded[0] < 420.0  # mm: the TM700's outer radius is about 400
    assert all(np.isnan(m.patch_values()["rolling_radius"]) for m in full_200.measurements)


def test_growth_is_not_recorded_without_inflation(reduced):
    for m in reduced.measurements:
        v = m.patch_values()
        assert np.isnan(v["inflation_growth"]) and np.isnan(v["rolling_radius"])
        measured = [x for k, x in v.items() if k not in ("inflation_growth", "rolling_radius")]
        assert v["patch_area"] > 0 and np.isfinite(measured).all()
