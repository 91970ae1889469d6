"""Contact-patch metrics, inflation growth and window RMS against geometry oracles."""

import numpy as np
import pytest

from farm.measure.patch import (
    grid_areas,
    inflation_growth,
    patch_metrics,
    tread_areas,
    window_rms,
)
from farm.mesh import build_mesh
from farm.presets import default_model
from farm.solve.states import SolvedState
from farm.specs import MeshDensity

MESHES = {
    "uniform": MeshDensity(tread=4, sidewall=2, bead=1, circumferential=16),
    "window": MeshDensity(tread=4, sidewall=2, bead=1, circumferential=38, window=32.0,
                          window_elements=8),
}


@pytest.fixture(scope="module", params=sorted(MESHES))
def mesh(request):
    return build_mesh(default_model("full", mesh=MESHES[request.param]))


def _state(mesh, tread_force=None, displacement=None):
    n_tread = len(mesh.tread_nodes)
    return SolvedState(
        deflection=10.0, road_z=mesh.bottom_z + 10.0,
        displacement=np.zeros((mesh.n_nodes, 3)) if displacement is None else displacement,
        strain=np.zeros((len(mesh.inner_nodes), 6)),
        tread_force=np.zeros((n_tread, 3)) if tread_force is None else tread_force,
        road_reaction=np.zeros(3))


def test_areas_tile_the_chordal_surface_pappus(mesh):
    """The tributary areas add up to the area of the revolved polygon of the node rows:
    sum over columns of 2 sin(dphi/2) x (the first moment of each meridional chord)."""
    areas = grid_areas(mesh, mesh.outer_grid)
    xyz = mesh.xyz(mesh.outer_grid[:, 0])
    y, r = xyz[:, 1], np.hypot(xyz[:, 0], xyz[:, 2])
    dphi = np.diff(np.append(mesh.angles, mesh.angles[0] + 2 * np.pi))
    # a chord (y1, r1)-(y2, r2) swept by dphi between two straight generators: a planar
    # trapezoid of parallel sides 2 r sin(dphi/2) and height the chord's length projected
    chord = np.hypot(np.diff(y), np.diff(r) * np.cos(dphi[:, None] / 2))
    expected = np.sum(2 * np.sin(dphi[:, None] / 2) * 0.5 * (r[:-1] + r[1:]) * chord)
    assert areas.sum() == pytest.approx(expected, rel=1e-9)
    assert np.all(areas > 0)
    first, stop = mesh.tread_rows
    assert tread_areas(mesh).sum() == pytest.approx(areas[first:stop].sum())


def test_patch_of_two_loaded_nodes(mesh):
    force = np.zeros((len(mesh.tread_nodes), 3))
    cols = mesh.outer_grid.shape[1]
    centre = int(np.argmin(np.abs(mesh.angles)))
    row = (mesh.tread_rows[1] - mesh.tread_rows[0]) // 2
    a, b = row * cols + centre, row * cols + centre + 1
    force[[a, b], 2] = [300.0, 100.0]
    force[a, 0] = 40.0  # friction does not count as pressure
    m = patch_metrics(mesh, _state(mesh, force))
    area = tread_areas(mesh)
    assert (m.nodes, m.columns) == (2, 2)
    assert m.area == pytest.approx(area[a] + area[b])
    assert m.mean_pressure == pytest.approx(400.0 / m.area)
    assert m.peak_pressure == pytest.approx(max(300 / area[a], 100 / area[b]))
    assert (m.nodal_mean, m.nodal_std) == pytest.approx((200.0, 100.0))
    xyz = mesh.xyz(mesh.tread_nodes[[a, b]])
    assert m.length == pytest.approx(abs(xyz[1, 0] - xyz[0, 0])) and m.width < 1e-9


def test_an_unloaded_state_has_an_empty_patch(mesh):
    assert patch_metrics(mesh, _state(mesh)).nodes == 0


def test_growth_is_the_radial_displacement_of_the_crown(mesh):
    xyz = mesh.nodes
    radial = np.column_stack([xyz[:, 0], 0 * xyz[:, 1], xyz[:, 2]])
    u = 3.0 * radial / np.linalg.norm(radial, axis=1, keepdims=True)
    u[:, 1] = 5.0  # a lateral shift is no growth
    assert inflation_growth(mesh, _state(mesh, displacement=u)) == pytest.approx(3.0)


def test_window_rms_of_a_uniform_field_is_its_size(mesh):
    field = np.tile([3.0, 4.0, 0.0], (len(mesh.inner_nodes), 1))
    assert window_rms(mesh, field, 20.0) == pytest.approx(5.0)
    # a field that is 0 inside the window and large outside has RMS 0
    outside = np.abs(np.degrees(mesh.angles)) > 20.0 + 1e-9
    field = np.zeros((*mesh.inner_grid.shape, 3))
    field[:, outside] = 7.0
    assert window_rms(mesh, field.reshape(-1, 3), 20.0) == 0.0


def test_a_tilted_road_s_pressure_is_along_its_own_normal(mesh):
    """The normal comes from the state's motion: a force along the tilted normal is all
    pressure, the same force read along z would be cos(tilt) of it."""
    import dataclasses

    from farm.specs import RoadMotion

    motion = RoadMotion(tilt=6.0)
    force = np.zeros((len(mesh.tread_nodes), 3))
    force[len(force) // 2] = 500.0 * np.array(motion.normal)
    tilted = dataclasses.replace(_state(mesh, force), motion=motion)
    assert patch_metrics(mesh, tilted).nodal_mean == pytest.approx(500.0)
    assert patch_metrics(mesh, _state(mesh, force)).nodal_mean == pytest.approx(
        500.0 * np.cos(np.radians(6.0)))
