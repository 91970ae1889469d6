"""The meridional section honours the tyre's nominal dimensions (TM700 280/70R16)."""

import dataclasses

import numpy as np
import pytest

from farm.errors import SpecError
from farm.geometry import build_section, wall_thickness
from farm.presets import default_model
from farm.specs import TyreGeometry

SPEC = default_model("full")
SECTION = build_section(SPEC.geometry, SPEC.mesh)


def test_nominal_dimensions():
    g = SPEC.geometry
    y, r = SECTION.outer[:, 0], SECTION.outer[:, 1]
    assert r.max() == pytest.approx(g.rim_radius + g.section_height, abs=1e-6)  # 16 in + 196 mm
    assert np.abs(y).max() == pytest.approx(g.section_width / 2, abs=0.01)  # sampled
    assert r[0] == pytest.approx(g.rim_radius) and r[-1] == pytest.approx(g.rim_radius)
    assert y[0] == pytest.approx(-g.rim_width / 2) and y[-1] == pytest.approx(g.rim_width / 2)


def test_section_is_symmetric():
    mirrored = SECTION.outer[::-1] * [-1, 1]
    np.testing.assert_allclose(SECTION.outer, mirrored, atol=1e-9)
    np.testing.assert_allclose(SECTION.inner, SECTION.inner[::-1] * [-1, 1], atol=1e-9)


@pytest.mark.parametrize("region_index, attr", [(0, "bead_thickness"), (2, "tread_thickness"),
                                                (4, "bead_thickness")])
def test_wall_thickness_in_each_region(region_index, attr):
    sl = SECTION.region_slices[region_index]
    middle = (sl.start + sl.stop) // 2
    gap = np.linalg.norm(SECTION.outer[middle] - SECTION.inner[middle])
    assert gap == pytest.approx(getattr(SPEC.geometry, attr), rel=1e-6)


def test_sidewall_thickness_reached_between_blends():
    bounds = np.array([40.0, 200.0, 400.0, 560.0])
    t = wall_thickness(SPEC.geometry, np.array([120.0, 300.0]), bounds)
    assert t[0] == pytest.approx(SPEC.geometry.sidewall_thickness)
    assert t[1] == pytest.approx(SPEC.geometry.tread_thickness)


def test_inner_contour_inside_outer():
    # the cavity wall is closer to the section's centre than the outer contour
    centre = np.array([0.0, SPEC.geometry.rim_radius + 0.5 * SPEC.geometry.section_height])
    d_out = np.linalg.norm(SECTION.outer - centre, axis=1)
    d_in = np.linalg.norm(SECTION.inner - centre, axis=1)
    assert np.all(d_in[1:-1] < d_out[1:-1])


def test_too_thick_wall_is_rejected():
    g = dataclasses.replace(TyreGeometry(), tread_width=210.0, tread_thickness=45.0,
                            sidewall_thickness=30.0)
    with pytest.raises(SpecError):
        build_section(g, SPEC.mesh)
