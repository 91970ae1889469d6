"""farm.measure.axes: the road's axes of a tilted road (issue 45)."""

from __future__ import annotations

import numpy as np
import pytest

from farm.measure.axes import in_road_axes, road_axes
from farm.specs import RoadMotion


@pytest.mark.parametrize("tilt", [-4.0, 0.0, 2.0, 3.0])
def test_the_road_axes_are_a_rotation_whose_z_is_the_road_normal(tilt):
    r = road_axes(tilt)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(r) == pytest.approx(1.0)
    np.testing.assert_allclose(r[2], RoadMotion(tilt=tilt).normal, atol=1e-15)


def test_a_tilted_road_s_normal_force_leaves_the_lateral_force():
    """docs/rolling.md: at 2 degrees the road's normal force put -90 N into the wheel's
    Fy (-44 N); in the road plane the camber force is the rest, +46 N."""
    normal, lateral = 2600.0, 46.0
    r = road_axes(2.0)
    wheel = lateral * r[1] + normal * r[2]  # the road's push, in the wheel's axes
    assert wheel[1] == pytest.approx(-44.7, abs=0.1)
    np.testing.assert_allclose(in_road_axes(wheel, 2.0), [0.0, lateral, normal], atol=1e-9)
    rows = in_road_axes(np.stack([wheel, wheel]), np.array([2.0, 0.0]))
    np.testing.assert_allclose(rows[0], [0.0, lateral, normal], atol=1e-9)
    np.testing.assert_allclose(rows[1], wheel)  # untilted: the wheel's axes
