"""The reference cloud's effect (issue 46): the virtual camera measures strain against the
uninflated mesh, the store against the inflated tyre; :func:`reference_gap` measures the
difference on a store's own experiments."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from analysis.camera.sensor import PRESETS, VirtualSensor, sensor_spec
from analysis.camera.sensor.reference import reference_gap
from farm.measure.surface import cst_surface_strain


def _with_store_strain(torus_ds, torus, U, growth):
    """The torus group with the store's ``surface_strain`` of displacements ``U`` (K, N,
    3) taken from a reference inflated by ``growth`` (a radial stretch of x and z)."""
    ref = torus.xyz * np.array([1.0 + growth, 1.0, 1.0 + growth])
    strain = np.empty(U.shape)
    for k in range(U.shape[0]):
        grid = cst_surface_strain(ref, ref + U[k][torus.node_index], True)
        strain[k][torus.node_index.ravel()] = grid.reshape(-1, 3)
    return torus_ds.assign(surface_strain=(("experiment", "inner_node", "strain_component"),
                                           strain))


def _displacements(torus, K=3, seed=0):
    """Smooth displacements: a flattening under the contact centre (-z) and a twist."""
    rng = np.random.default_rng(seed)
    theta = np.arctan2(torus.xyz[..., 0], -torus.xyz[..., 2])
    bump = np.exp(-(theta / 0.3) ** 2)
    out = np.zeros((K, torus.n_nodes, 3))
    for k in range(K):
        a, b = rng.uniform(5.0, 15.0), rng.uniform(-3.0, 3.0)
        grid = np.stack([b * bump, 0.5 * b * bump, a * bump], axis=-1)
        out[k][torus.node_index.ravel()] = grid.reshape(-1, 3)
    return out


def test_the_gap_is_the_inflation_s_and_grows_with_it(torus_ds, torus):
    U = _displacements(torus)
    rng = np.random.default_rng(1)
    gaps = {}
    for growth in (0.0, 0.01, 0.02):
        ds = _with_store_strain(torus_ds, torus, U, growth)
        gaps[growth] = reference_gap(ds, torus, U, PRESETS["ideal-full"], rng)
    assert gaps[0.0].gap < 1e-12  # the same reference: the same strain, to round-off
    assert gaps[0.01].gap > 1e3 * max(gaps[0.0].gap, 1e-15)
    # first order in the growth: twice the stretch, about twice the gap
    assert gaps[0.02].gap / gaps[0.01].gap == pytest.approx(2.0, rel=0.05)
    assert gaps[0.01].noise == 0.0 and "no noise" in gaps[0.01].sentence()
    assert 0.0 < gaps[0.01].relative < 0.1


def test_the_gap_is_set_beside_the_sensor_s_own_noise(torus_ds, torus):
    U = _displacements(torus)
    ds = _with_store_strain(torus_ds, torus, U, 0.01)
    noisy = sensor_spec("t2cam-2017,spacing_mm=20,width_mm=150")
    gap = reference_gap(ds, torus, U, noisy, np.random.default_rng(2))
    window = VirtualSensor(replace(noisy.noise_free(), spacing_mm=None), torus)
    assert gap.points < window.layout.n_points  # the window's edge rows and columns out
    assert gap.noise > gap.gap > 0.0  # 2 mm of position noise swamps a 1 % stretch
    assert f"{gap.noise / gap.gap:.0f}x the gap" in gap.sentence()


def test_a_window_with_too_few_node_columns_is_measured_round_the_tyre(torus_ds, torus):
    """A coarse mesh leaves fewer than three node columns in the window (16 elements
    round: one in 40°): the gap is then measured on the whole circumference."""
    U = _displacements(torus)
    ds = _with_store_strain(torus_ds, torus, U, 0.01)
    narrow = reference_gap(ds, torus, U, sensor_spec("t2cam-2017,window_deg=8,width_mm=150"),
                           np.random.default_rng(3))
    whole = reference_gap(ds, torus, U, sensor_spec("t2cam-2017,window_deg=360,width_mm=150"),
                          np.random.default_rng(3))
    assert narrow.points == whole.points and narrow.gap == whole.gap > 0.0
    assert narrow.window_deg == 360.0 and "a 360° window" in narrow.sentence()
