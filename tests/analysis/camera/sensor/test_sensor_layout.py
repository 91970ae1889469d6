"""The sensor's points and the bilinear face interpolation of FE fields to them."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.camera.sensor import PRESETS, SensorSpec, layout, sensor_spec
from analysis.camera.sensor.layout import face_weights, interpolate
from analysis.errors import ParameterError
from tests.analysis.camera.sensor.sensor_helpers import COLS, ROWS


def _bilinear(theta, s, cut=0.0):
    """A field bilinear in (theta, s) on every face that does not span the angle ``cut``
    (where the branch of theta jumps by 2 pi)."""
    t = cut + np.mod(theta - cut, 2 * np.pi)
    return np.stack([(1.0 + 0.7 * t) * (2.0 - 0.01 * s), 3.0 + 0.2 * t + 0.05 * s], -1)


def _nodal(surface, cut=0.0):
    T, S = np.meshgrid(surface.angles, surface.s)
    field = np.empty((surface.n_nodes, 2))
    field[surface.node_index.ravel()] = _bilinear(T.ravel(), S.ravel(), cut)
    return field


@pytest.mark.parametrize("degrees", [(95.0, 100.0), (170.0, 190.0), (30.0, 150.0)],
                         ids=["index-seam", "pi-seam", "faces"])
def test_interpolation_is_exact_for_bilinear_fields(torus, degrees):
    """Inside the cell from the last column to the first (index seam), across ±pi and
    on ordinary faces: weights reproduce a field bilinear on each face."""
    rng = np.random.default_rng(1)
    theta = np.radians(rng.uniform(*degrees, 500))
    s = rng.uniform(torus.s[0], torus.s[-1], 500)
    w = face_weights(torus, theta, s)
    assert w.shape == (500, torus.n_nodes) and np.allclose(w.sum(axis=1), 1.0)
    assert np.allclose(w @ _nodal(torus), _bilinear(theta, s), rtol=0, atol=1e-10)
    # the same points named by another branch of the angle
    assert np.allclose((face_weights(torus, theta - 2 * np.pi, s) - w).toarray(), 0.0)


def test_interpolation_at_nodes_returns_node_values(torus):
    T, S = np.meshgrid(torus.angles, torus.s)
    w = face_weights(torus, T.ravel(), S.ravel())
    assert np.allclose(w.toarray(), np.eye(torus.n_nodes)[torus.node_index.ravel()])
    field = np.random.default_rng(2).standard_normal((torus.n_nodes, 3))
    assert np.allclose(w @ field, field[torus.node_index.ravel()], rtol=0, atol=1e-12)


def test_layout_points_interpolate_bilinear_fields_exactly(torus):
    lay = layout(torus, PRESETS["t2cam-2017"])
    field = np.stack([_nodal(torus, np.pi), 2 * _nodal(torus, np.pi)])  # (K=2, N, 2)
    T, S = np.meshgrid(lay.theta, lay.s)
    out = interpolate(lay, field)
    assert out.shape == (2, *lay.shape, 2)
    assert np.allclose(out[1], 2 * _bilinear(T, S, np.pi), atol=1e-10)
    assert np.allclose(interpolate(lay, field[0]), out[0])
    with pytest.raises(ParameterError, match=f"\\(K, {torus.n_nodes}, c\\)"):
        interpolate(lay, field[:, :-1])


def test_t2cam_window_and_grid(torus):
    lay = layout(torus, PRESETS["t2cam-2017"])
    R = torus.crown_radius
    half_arc = np.radians(20.0) * R  # 115 mm: 11 steps of 10 mm each side
    assert lay.shape == (21, 2 * int(half_arc // 10) + 1) == (21, 23)
    assert np.allclose(np.diff(lay.theta) * R, 10.0) and np.allclose(np.diff(lay.s), 10.0)
    assert lay.theta[11] == 0.0 and lay.s[10] == 0.0 and not lay.periodic
    assert lay.weights.shape == (21 * 23, torus.n_nodes) and lay.n_points == 483
    # points lie on the FE faces (flat across a column step: chords of the revolve)
    r = np.hypot(lay.xyz[..., 0], lay.xyz[..., 2])
    assert np.all(r <= torus.profile[:, 0].max() + 1e-9) and np.all(r > 300.0)
    assert np.allclose(np.arctan2(lay.xyz[..., 0], -lay.xyz[..., 2]), lay.theta, atol=1e-4)


@pytest.mark.parametrize(("text", "shape", "periodic"), [
    ("ideal-full", (ROWS, COLS), True),
    ("t2cam-2017,spacing_mm=none", (8, 9), False),  # nodes within ±20°, |s| <= 100 mm
    ("t2cam-2017,window_deg=90,width_mm=none,spacing_mm=20", (13, 25), False),
    ("t2cam-2017,window_deg=360", (21, 207), False),  # 2 pi R / 10 mm is no integer
])
def test_layout_sizes(torus, text, shape, periodic):
    lay = layout(torus, sensor_spec(text))
    assert lay.shape == shape and lay.periodic is periodic
    assert np.all(np.diff(lay.theta) > 0) and np.all(np.diff(lay.s) > 0)


def test_a_spacing_that_divides_the_circle_gives_a_periodic_layout(torus):
    spacing = 2 * np.pi * torus.crown_radius / 120
    lay = layout(torus, SensorSpec(window_deg=360.0, spacing_mm=spacing))
    assert lay.periodic and lay.shape[1] == 120
    assert lay.theta[-1] == pytest.approx(np.pi) and lay.theta[0] > -np.pi


def test_the_ideal_sensor_selects_every_node_in_angle_order(torus):
    lay = layout(torus, PRESETS["ideal-full"])
    w = lay.weights.toarray()
    assert set(np.unique(w)) == {0.0, 1.0} and (w.sum(axis=0) == 1).all()
    assert np.allclose(np.degrees(lay.theta), np.arange(-175, 181, 5))
    assert np.array_equal(lay.xyz, np.roll(torus.xyz, -17, axis=1))  # column 17: 185°


def test_a_sector_clips_the_window(cylinder):
    lay = layout(cylinder, sensor_spec("t2cam-2017,window_deg=360"))
    assert not lay.periodic
    assert np.degrees(lay.theta[[0, -1]]) == pytest.approx([-60, 60], abs=2.0)
    assert np.all(np.abs(lay.theta) <= np.radians(60) + 1e-12)
    lay = layout(cylinder, sensor_spec("t2cam-2017,spacing_mm=20"))
    assert lay.shape == (11, 11)


def test_a_window_with_fewer_than_3x3_points_is_refused(torus):
    with pytest.raises(ParameterError, match="at least 3 x 3") as info:
        layout(torus, SensorSpec(window_deg=2.0))
    assert "\n" not in str(info.value)
    with pytest.raises(ParameterError, match="3 x 3"):
        layout(torus, SensorSpec(width_mm=15.0))


@pytest.mark.parametrize("spacing", ["10", "none"])
@pytest.mark.parametrize(("centre_deg", "centre_mm"), [(20.0, 0.0), (-170.0, 0.0),
                                                       (0.0, 60.0), (25.0, -40.0)])
def test_a_window_looks_where_its_centre_says(torus, spacing, centre_deg, centre_mm):
    """centre_deg / centre_mm (issue 46: where to look): the window's points lie within
    its half-extents of its centre - ahead of the patch, across the +-180° seam, on a
    shoulder - and a grid of points is the centred grid moved there."""
    from analysis.camera.sensor.surface import wrap_angle

    spec = sensor_spec(f"t2cam-2017,window_deg=30,width_mm=120,spacing_mm={spacing},"
                       f"centre_deg={centre_deg},centre_mm={centre_mm}")
    lay = layout(torus, spec)
    off = np.degrees(wrap_angle(lay.theta - np.radians(centre_deg)))
    assert np.all(np.abs(off) <= 15.0 + 1e-9) and np.all(np.abs(lay.s - centre_mm) <= 60 + 1e-9)
    # the points are on the surface where their angles and arc lengths say
    theta = np.arctan2(lay.xyz[..., 0], -lay.xyz[..., 2])
    assert np.allclose(wrap_angle(theta - lay.theta[None, :]), 0.0, atol=1e-4)  # chords
    if spacing == "10":
        centred = layout(torus, sensor_spec("t2cam-2017,window_deg=30,width_mm=120"))
        assert lay.shape == centred.shape
        assert np.allclose(lay.theta - np.radians(centre_deg), centred.theta)
        assert np.allclose(lay.s - centre_mm, centred.s)
    with pytest.raises(ParameterError, match="centre_deg must be in"):
        sensor_spec("t2cam-2017,centre_deg=200")
