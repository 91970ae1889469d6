"""to_layout: measured clouds whose points are not the sensor's, onto the sensor's grid."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.camera.sensor import PRESETS, SensorSpec, VirtualSensor
from analysis.camera.sensor.layout import face_weights
from analysis.camera.sensor.resample import surface_coordinates, to_layout
from analysis.errors import CloudError


def _smooth(theta, s):
    """A smooth displacement field (mm): a bump under the contact, a lateral shear."""
    bump = np.exp(-(theta**2) / 0.05) * np.cos(s / 100.0)
    return np.stack([2.0 * np.sin(3.0 * theta), 0.01 * s, -5.0 * bump], -1)


def _scattered(surface, m, deg, seed):
    """m random points on the FE surface within ±deg and the whole meridian."""
    rng = np.random.default_rng(seed)
    theta = np.radians(rng.uniform(-deg, deg, m))
    s = rng.uniform(surface.s[0], surface.s[-1], m)
    return theta, s, face_weights(surface, theta, s) @ surface.node_xyz


def test_surface_coordinates_invert_the_faces(torus):
    """A point of an FE face gets back the (theta, s) that put it there, although it
    sits a chord's sag inside the revolve and its angle is not linear along the chord."""
    theta, s, xyz = _scattered(torus, 400, 180.0, 0)
    t, m = surface_coordinates(torus, xyz)
    assert np.allclose(np.angle(np.exp(1j * (t - theta))), 0.0, atol=1e-12)
    assert np.allclose(m, s, rtol=0, atol=1e-9)
    geometric = np.arctan2(xyz[:, 0], -xyz[:, 2])
    assert np.abs(np.angle(np.exp(1j * (geometric - theta)))).max() > 1e-5
    # off the surface by its normal: the same s
    out = xyz * [1.01, 1.0, 1.01]
    assert np.abs(surface_coordinates(torus, out)[1] - s)[np.abs(s) < 20].max() < 0.5


def test_a_smooth_displacement_on_scattered_points_is_recovered(torus):
    sensor = VirtualSensor(PRESETS["t2cam-2017"], torus)
    theta, s, ref = _scattered(torus, 3000, 26.0, 1)
    u = _smooth(theta, s)
    ref_cloud, cloud = to_layout(torus, sensor.layout, ref, ref + u)
    T, S = np.meshgrid(sensor.layout.theta, sensor.layout.s)
    truth = _smooth(T, S)
    assert np.isfinite(cloud).all() and ref_cloud.shape == cloud.shape == (21, 23, 3)
    assert np.abs(ref_cloud - sensor.layout.xyz).max() < 0.02
    err = cloud - ref_cloud - truth
    assert np.abs(err).max() < 0.05 and np.sqrt(np.mean(err**2)) < 0.01


def test_clouds_on_the_layout_come_back_unchanged(torus):
    sensor = VirtualSensor(PRESETS["t2cam-2017"], torus)
    u = sensor.clean(np.random.default_rng(2).normal(0, 1, (1, torus.n_nodes, 3)))
    ref, cur = sensor.measure(u)
    back_ref, back = to_layout(torus, sensor.layout, ref[0].reshape(-1, 3),
                               cur[0].reshape(-1, 3))
    assert np.allclose(back_ref, ref[0], rtol=0, atol=1e-9)
    assert np.allclose(back, cur[0], rtol=0, atol=1e-9)


def test_a_full_window_is_filled_across_the_seam(torus):
    spacing = 2 * np.pi * torus.crown_radius / 90
    sensor = VirtualSensor(SensorSpec(window_deg=360.0, width_mm=None, spacing_mm=spacing),
                           torus)
    assert sensor.layout.periodic
    theta, s, ref = _scattered(torus, 6000, 180.0, 4)
    ref_cloud, cloud = to_layout(torus, sensor.layout, ref, ref + _smooth(theta, s))
    T, S = np.meshgrid(sensor.layout.theta, sensor.layout.s)
    assert np.isfinite(cloud).all()
    seam = np.abs(T) > np.radians(170)
    assert np.abs((cloud - ref_cloud - _smooth(T, S))[seam]).max() < 0.1


@pytest.mark.parametrize(("ref", "cur", "needle"), [
    (np.zeros((5, 3)), np.zeros((4, 3)), "same M"),
    (np.zeros((2, 3)), np.zeros((2, 3)), "at least 3"),
    (np.full((5, 3), np.nan), np.zeros((5, 3)), "finite"),
    (np.zeros((5, 2)), np.zeros((5, 2)), "(M, 3)"),
])
def test_unusable_clouds_are_refused_in_one_line(torus, ref, cur, needle):
    sensor = VirtualSensor(PRESETS["t2cam-2017"], torus)
    with pytest.raises(CloudError) as info:
        to_layout(torus, sensor.layout, ref, cur)
    assert needle in str(info.value) and "\n" not in str(info.value)
