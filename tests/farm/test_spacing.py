"""Circumferential spacing: uniform, or fine over a window about the road (issue 24)."""

import numpy as np
import pytest

from farm.errors import SpecError
from farm.presets import default_model
from farm.spacing import MAX_GROWTH, column_angles, half_steps
from farm.specs import MeshDensity, ModelSpec


@pytest.mark.parametrize(("half", "n", "window", "k"), [
    (180.0, 33, 32.0, 16), (180.0, 54, 32.0, 32), (45.0, 10, 10.0, 4), (180.0, 12, 30.0, 3)])
def test_steps_fill_the_half_sector_fine_inside_and_grow_outside(half, n, window, k):
    steps = half_steps(half, n, window, k)
    assert steps.shape == (n,) and steps.sum() == pytest.approx(half, rel=1e-12)
    np.testing.assert_allclose(steps[:k], window / k)
    growth = steps[k:] / np.append(window / k, steps[k:-1])
    np.testing.assert_allclose(growth, growth[0], rtol=1e-9)  # one geometric ratio
    assert 1.0 < growth[0] <= MAX_GROWTH


def test_uniform_columns_are_the_formula_of_the_uniform_mesh_bit_for_bit():
    for full, n, sector in ((True, 40, 360.0), (False, 20, 90.0)):
        step = np.radians(sector) / n
        expected = (np.arange(n if full else n + 1) - n // 2) * step
        assert np.array_equal(column_angles(sector, n, full), expected)


def test_windowed_columns_are_symmetric_and_end_at_the_seam_or_cut():
    full = column_angles(360.0, 66, True, 32.0, 16)
    assert len(full) == 66 and full[0] == pytest.approx(-np.pi) and full[33] == 0.0
    np.testing.assert_allclose(full[1:33], -full[65:33:-1], atol=1e-12)
    sector = column_angles(90.0, 20, False, 10.0, 4)
    assert len(sector) == 21 and sector[-1] == pytest.approx(np.radians(45.0))
    np.testing.assert_allclose(sector, -sector[::-1], atol=1e-12)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"window": 32.0}, "go together"),
    ({"window_elements": 4}, "go together"),
    ({"window": -1.0, "window_elements": 4}, "mesh.window must be"),
    ({"window": 200.0, "window_elements": 4}, "mesh.window must be"),
    ({"window": "wide", "window_elements": 4}, "mesh.window must be"),
    ({"window": 30.0, "window_elements": 2.5}, "mesh.window_elements must be"),
    ({"window": 30.0, "window_elements": True}, "mesh.window_elements must be"),
])
def test_bad_window_fields_are_refused(kwargs, match):
    with pytest.raises(SpecError, match=match):
        MeshDensity(**kwargs)


@pytest.mark.parametrize(("mesh", "match"), [
    (dict(circumferential=48, window=32.0, window_elements=4), "not finer"),  # 8 deg each
    (dict(circumferential=30, window=32.0, window_elements=8), "grow by"),
    (dict(circumferential=40, window=32.0, window_elements=20), "less than half"),
])
def test_windows_that_do_not_grade_are_refused_naming_what_to_change(mesh, match):
    with pytest.raises(SpecError, match=match):
        default_model("full", mesh=MeshDensity(**mesh))


def test_a_window_wider_than_the_sector_is_refused():
    with pytest.raises(SpecError, match=r"mesh.window must lie in \(0, 45\)"):
        default_model("reduced", mesh=MeshDensity(circumferential=20, window=50.0,
                                                  window_elements=4))


def test_ids_of_uniform_meshes_predate_the_window_and_30_is_30_0():
    plain = default_model("full")
    assert "window" not in plain.to_dict()["mesh"]
    assert plain.editable_dict()["mesh"]["window"] == 0.0
    a = MeshDensity(circumferential=66, window=32, window_elements=16)
    b = MeshDensity(circumferential=66, window=32.0, window_elements=16)
    assert a.canonical() == b.canonical() and isinstance(a.window, float)
    windowed = default_model("full", mesh=a)
    assert windowed.to_dict()["mesh"]["window"] == 32.0
    assert windowed.mesh_key() != default_model("full", mesh=MeshDensity(
        circumferential=68)).mesh_key()
    assert ModelSpec.from_dict(windowed.to_dict()) == windowed


def test_a_full_windowed_mesh_need_not_be_a_multiple_of_four():
    default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1, circumferential=66,
                                           window=32.0, window_elements=16))
    with pytest.raises(SpecError, match="multiple of 4"):
        default_model("full", mesh=MeshDensity(circumferential=42))
