"""VirtualSensor: clean point displacements, noisy clouds, features like the store's."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.camera.sensor import PRESETS, InnerSurface, SensorSpec, VirtualSensor, sensor_spec
from analysis.camera.sensor.model import fill_holes
from analysis.camera.sensor.noise import rotation_matrices
from analysis.errors import ParameterError
from farm.measure.surface import cst_surface_strain
from tests.analysis.camera.sensor.sensor_helpers import dataset
from tests.synthetic import combined_cases, combined_fields, geometry


def _field_like_the_store(a):
    """(K, N, c) -> (K, c N), component-major, as analysis.studies.combined._field."""
    return np.concatenate([a[:, :, j] for j in range(a.shape[2])], axis=1)


def _strain(sensor, ref, cur):
    X, _ = sensor.features(ref, cur, ("surface_strain",))
    pr, pc = sensor.layout.shape
    return X.reshape(X.shape[0], 3, pr, pc)


def test_the_ideal_sensor_reproduces_the_raw_displacement_and_strain(torus):
    sensor = VirtualSensor(PRESETS["ideal-full"], torus)
    assert sensor.layout.periodic
    rng = np.random.default_rng(0)
    U = rng.normal(0.0, 2.0, (3, torus.n_nodes, 3))
    clean = sensor.clean(U)
    order = sensor.layout.weights.indices  # one node per point, in point order
    assert np.array_equal(clean.reshape(3, -1, 3), U[:, order])  # exact, not close
    X, blocks = sensor.sample(U)
    assert blocks == [3 * torus.n_nodes] * 2
    assert np.allclose(X[:, :blocks[0]], _field_like_the_store(U[:, order]), rtol=0,
                       atol=1e-12)
    # the store's definition of surface_strain on the full grid, columns rolled
    ref = torus.xyz
    cur = ref + U[0][torus.node_index]
    store = np.roll(cst_surface_strain(ref, cur, True), -17, axis=1)  # col 17 at -175°
    assert np.allclose(X[0, blocks[0]:], _field_like_the_store(store.reshape(1, -1, 3))[0],
                       rtol=0, atol=1e-12)


def test_cst_strain_of_a_rigid_motion_is_zero(torus):
    sensor = VirtualSensor(PRESETS["t2cam-2017"], torus)
    rng = np.random.default_rng(1)
    ref = sensor.layout.xyz + rng.normal(0, 0.5, sensor.layout.xyz.shape)  # any cloud
    R = rotation_matrices(np.array([[0.3, 1.0, -0.2]]), np.array([0.4]))[0]
    cur = ref @ R.T + [5.0, -3.0, 12.0]
    X, blocks = sensor.features(ref[None], cur[None])
    assert np.abs(X[0, blocks[0]:]).max() < 1e-12
    assert np.abs(X[0, :blocks[0]]).max() > 1.0  # a large displacement, no strain


def test_cst_strain_of_a_homogeneous_stretch_is_its_green_lagrange_value(cylinder):
    """1 % circumferential stretch of the 300 mm cylinder (arc lengths x 1.01: chords
    between the points stretch a little less), then 2 % along the meridian (exact)."""
    sensor = VirtualSensor(PRESETS["t2cam-2017"], cylinder)
    T, S = np.meshgrid(sensor.layout.theta, sensor.layout.s)
    R, lam = 300.0, 1.01

    def cyl(theta, y):
        return np.stack([R * np.sin(theta), y, -R * np.cos(theta)], -1)

    ref = cyl(T, S)
    E = _strain(sensor, ref[None], cyl(lam * T, S)[None])[0]
    step = 10.0 / R
    chord = 0.5 * ((np.sin(lam * step / 2) / np.sin(step / 2)) ** 2 - 1.0)
    assert np.allclose(E[0], chord, rtol=1e-9, atol=0)
    assert np.allclose(E[0], 0.5 * (lam**2 - 1), rtol=1e-3)
    assert np.abs(E[1:]).max() < 1e-12
    E = _strain(sensor, ref[None], cyl(T, 1.02 * S)[None])[0]
    assert np.allclose(E[1], 0.5 * (1.02**2 - 1), rtol=1e-12)
    assert np.abs(E[[0, 2]]).max() < 1e-12


def test_measure_gives_one_noisy_reference_per_experiment(torus):
    spec = sensor_spec("t2cam-2017,noise_mm=0.3")
    sensor = VirtualSensor(spec, torus)
    u = sensor.clean(np.ones((4, torus.n_nodes, 3)))
    assert u.shape == (4, 21, 23, 3) and np.allclose(u, 1.0)
    ref, cur = sensor.measure(u)  # no rng: noise-free
    assert np.array_equal(ref, np.broadcast_to(sensor.layout.xyz, ref.shape))
    assert np.allclose(cur - ref, 1.0)
    ref, cur = sensor.measure(u, np.random.default_rng(2))
    assert ref.shape == cur.shape == (4, 21, 23, 3)
    assert (ref - sensor.layout.xyz).std() == pytest.approx(0.3, rel=0.05)
    assert not np.allclose(ref[0], ref[1])  # each experiment its own reference
    with pytest.raises(ParameterError, match=r"\(K, 21, 23, 3\)"):
        sensor.measure(u[:, :-1])


def test_features_are_component_major_and_nan_free_with_dropped_points(torus):
    spec = SensorSpec(noise_mm=0.05, correlated_mm=0.2, rotation_deg=0.1, scale=1e-3,
                      drop_fraction=0.2)
    sensor = VirtualSensor(spec, torus)
    assert sensor.chol is sensor.chol  # factored once per sensor
    rng = np.random.default_rng(3)
    U = rng.normal(0.0, 1.0, (5, torus.n_nodes, 3))
    ref, cur = sensor.measure(sensor.clean(U), rng)
    assert np.isnan(cur).any() and np.isnan(ref).any()
    X, blocks = sensor.features(ref, cur)
    P = sensor.layout.n_points
    assert X.shape == (5, 6 * P) and blocks == [3 * P, 3 * P]
    assert np.isfinite(X).all()
    X1, b1 = sensor.features(ref, cur, ("displacement",))
    assert np.array_equal(X1, X[:, :3 * P]) and b1 == [3 * P]
    # component-major: the first P columns are x of every point, row by row
    d = np.where(np.isnan(cur - ref), 0.0, cur - ref)
    seen = ~np.isnan(cur - ref).any(axis=-1)
    assert np.allclose(X[:, :P].reshape(5, *sensor.layout.shape)[seen], d[..., 0][seen])
    assert np.allclose(X[:, 2 * P:3 * P].reshape(5, *sensor.layout.shape)[seen],
                       d[..., 2][seen])
    with pytest.raises(ParameterError, match="displacement, surface_strain"):
        sensor.features(ref, cur, ("strain",))


def test_holes_take_the_mean_of_their_neighbours():
    pr, pc = 6, 7
    R, C = np.meshgrid(np.arange(pr), np.arange(pc), indexing="ij")
    linear = (2.0 * R - 0.5 * C + 1.0)[None, ..., None]  # (1, pr, pc, 1)
    holes = linear.copy()
    holes[0, 2, 3] = holes[0, 4, 1] = np.nan  # isolated: mean of 4 neighbours = value
    assert np.allclose(fill_holes(holes, False), linear)
    holes[0, 1:4, 2:5] = np.nan  # a block: filled from its rim inwards
    filled = fill_holes(holes, False)
    assert np.isfinite(filled).all() and np.allclose(filled[0, 2, 3], linear[0, 2, 3])
    seam = linear.copy()
    seam[0, 3, 0] = np.nan
    assert fill_holes(seam, True)[0, 3, 0, 0] == pytest.approx(
        (linear[0, 2, 0, 0] + linear[0, 4, 0, 0] + linear[0, 3, 1, 0] + linear[0, 3, -1, 0]) / 4)
    assert (fill_holes(np.full((1, 3, 3, 2), np.nan), False) == 0).all()


def test_a_synthetic_group_with_the_cli_sensor():
    """The grid of tests.synthetic's groups (a ±60° cylinder sector) and the sensor the
    CLI tests use: 11 x 11 points, features for combined-load fields."""
    geo = geometry(9, 24, 4, 8)
    surface = InnerSurface.from_dataset(dataset(geo.inner_xyz, *geo.inner_rc))
    sensor = VirtualSensor(sensor_spec("t2cam-2017,spacing_mm=20,noise_mm=0.2"), surface)
    assert sensor.layout.shape == (11, 11)
    U = combined_fields(geo, combined_cases(6, 0))["displacement"]
    X, _ = sensor.sample(U, np.random.default_rng(4))
    assert X.shape == (6, 6 * 121) and np.isfinite(X).all()
    with pytest.raises(ParameterError, match=r"\(K, 216, c\)"):
        sensor.clean(U[:, :-1])
