"""InnerSurface: the store's inner nodes as a (theta, s) grid, across the ±pi seam."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.camera.sensor import InnerSurface
from analysis.errors import MissingVariableError, ParameterError
from tests.analysis.camera.sensor.sensor_helpers import COLS, CROWN, ROWS, dataset, torus_nodes


def test_a_full_revolve_is_a_periodic_grid_in_index_order(torus, torus_ds):
    assert torus.shape == (ROWS, COLS) and torus.periodic and torus.n_nodes == ROWS * COLS
    assert np.all((torus.theta > -np.pi) & (torus.theta <= np.pi))
    assert np.allclose(np.degrees(torus.theta[:3]), [100, 105, 110])
    assert np.allclose(np.diff(torus.angles), np.radians(5.0))  # unwrapped across ±pi
    # node_index puts the shuffled store nodes back on their grid places
    xyz = torus_ds["inner_xyz"].values
    assert np.array_equal(torus.xyz, xyz[torus.node_index])
    assert np.array_equal(torus.node_xyz, xyz)
    rows = torus_ds["inner_row"].values[torus.node_index]
    cols = torus_ds["inner_col"].values[torus.node_index]
    assert (rows == np.arange(ROWS)[:, None]).all() and (cols == np.arange(COLS)).all()


def test_meridional_arc_length_is_zero_at_the_crown_and_symmetric(torus):
    assert np.all(np.diff(torus.s) > 0)
    assert np.allclose(torus.s, -torus.s[::-1])  # symmetric profile: crown between rows
    chord = np.linalg.norm(np.diff(torus.xyz[:, 0], axis=0), axis=1)
    assert np.allclose(np.diff(torus.s), chord)
    assert torus.crown_radius == pytest.approx(CROWN, abs=0.5)


def test_a_sector_is_not_periodic(cylinder):
    assert cylinder.shape == (9, 24) and not cylinder.periodic
    assert np.allclose(cylinder.s, np.linspace(-100, 100, 9))  # a cylinder: s = y
    assert np.degrees(cylinder.angles[[0, -1]]) == pytest.approx([-60, 60])
    assert cylinder.crown_radius == pytest.approx(300.0)


def test_graded_columns_around_the_full_circle_are_periodic():
    steps = np.r_[np.full(20, 2.0), np.full(32, 10.0)]  # 40° fine about the patch
    xyz, row, col = torus_nodes(cols=52, first_deg=-20.0)
    theta = np.radians(-20.0 + np.r_[0.0, np.cumsum(steps)[:-1]])[col]
    r = np.hypot(xyz[:, 0], xyz[:, 2])
    xyz = np.column_stack([r * np.sin(theta), xyz[:, 1], -r * np.cos(theta)])
    surface = InnerSurface.from_dataset(dataset(xyz, row, col))
    assert surface.periodic
    half = InnerSurface.from_dataset(dataset(xyz[col < 40], row[col < 40], col[col < 40]))
    assert not half.periodic


def test_a_group_without_the_grid_is_refused_in_one_line(torus_ds):
    with pytest.raises(MissingVariableError, match="inner_row") as info:
        InnerSurface.from_dataset(torus_ds.drop_vars("inner_row"))
    assert "\n" not in str(info.value)


def test_rows_and_columns_must_form_a_full_grid(torus_ds):
    ds = torus_ds.isel(inner_node=slice(1, None))
    with pytest.raises(ParameterError, match="full 12 x 72 grid"):
        InnerSurface.from_dataset(ds)
    with pytest.raises(ParameterError, match="increase in angle"):
        xyz, row, col = torus_nodes()
        InnerSurface.from_dataset(dataset(xyz, row, COLS - 1 - col))
