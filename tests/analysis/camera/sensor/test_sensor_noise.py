"""The errors of a measured cloud, and the t2cam-2020 preset's noise (the 0.5 % band)."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.camera.sensor import PRESETS, SensorSpec, VirtualSensor, layout, sensor_spec
from analysis.camera.sensor import noise as nz
from analysis.errors import ParameterError


@pytest.fixture(scope="module")
def grid(torus):
    """A 11 x 12 point layout (20 mm spacing) of the torus: reference positions."""
    return layout(torus, sensor_spec("t2cam-2017,spacing_mm=20")).xyz


def test_iid_noise_has_the_asked_std_and_no_bias(grid):
    rng = np.random.default_rng(0)
    noisy = nz.iid(np.broadcast_to(grid, (200, *grid.shape)), 0.5, rng)
    err = noisy - grid
    assert err.std() == pytest.approx(0.5, rel=0.02) and abs(err.mean()) < 0.005
    assert np.array_equal(nz.iid(grid, 0.0, rng), grid)


def test_correlated_noise_decays_with_distance_like_its_kernel(grid):
    length, sigma, draws = 50.0, 1.5, 600
    chol = nz.correlation_factor(grid, length)
    rng = np.random.default_rng(1)
    err = nz.correlated(np.broadcast_to(grid, (draws, *grid.shape)), sigma, chol, rng) - grid
    assert err.std() == pytest.approx(sigma, rel=0.05)
    e = err.reshape(draws, -1, 3)[..., 0]  # x component, (draws, P)
    corr = np.corrcoef(e.T)
    pts = grid.reshape(-1, 3)
    dist = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    kernel = np.exp(-(dist**2) / (2 * length**2))
    off = ~np.eye(dist.shape[0], dtype=bool)
    assert np.abs(corr - kernel)[off].max() < 0.2
    bins = [(dist > lo) & (dist <= hi) for lo, hi in ((15, 25), (35, 65), (90, 130),
                                                       (200, 400))]
    assert all(b.sum() > 50 for b in bins)
    means = [corr[b].mean() for b in bins]
    assert means == sorted(means, reverse=True)
    assert means[0] > 0.85 and abs(means[-1]) < 0.05
    # components and clouds are independent
    assert abs(np.corrcoef(err[..., 0].ravel(), err[..., 1].ravel())[0, 1]) < 0.02


def test_the_correlation_factor_refuses_too_many_points():
    with pytest.raises(ParameterError, match="coarsen spacing_mm"):
        nz.correlation_factor(np.zeros((nz.MAX_CORRELATED_POINTS + 1, 3)), 50.0)


def test_rotations_are_orthonormal():
    rng = np.random.default_rng(2)
    R = nz.rotation_matrices(rng.standard_normal((50, 3)), rng.normal(0, 1, 50))
    assert np.allclose(R @ np.swapaxes(R, -1, -2), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0)


@pytest.mark.parametrize("scale", [0.0, 0.01])
def test_calibration_error_is_rigid_up_to_one_scale_per_cloud(grid, scale):
    rng = np.random.default_rng(3)
    clouds = np.broadcast_to(grid, (5, *grid.shape))
    moved = nz.calibrate(clouds, 2.0, scale, rng)
    assert not np.allclose(moved, clouds)
    pts = grid.reshape(-1, 3)
    d0 = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    off = ~np.eye(d0.shape[0], dtype=bool)
    factors = []
    for cloud in moved.reshape(5, -1, 3):
        ratio = (np.linalg.norm(cloud[:, None] - cloud[None], axis=-1)[off] / d0[off])
        assert ratio.std() < 1e-12  # one factor for every pair: rotation is rigid
        factors.append(ratio.mean())
        assert np.allclose(cloud.mean(axis=0), pts.mean(axis=0))  # about the centroid
    if scale == 0.0:
        assert np.allclose(factors, 1.0, rtol=0, atol=1e-12)
    else:
        assert np.std(factors) > 1e-4


def test_drop_misses_a_fixed_share_of_points_per_cloud(grid):
    out = nz.drop(np.broadcast_to(grid, (4, *grid.shape)), 0.2, np.random.default_rng(4))
    missed = np.isnan(out).all(axis=-1).reshape(4, -1).sum(axis=1)
    assert (missed == round(0.2 * grid[..., 0].size)).all()
    assert np.isnan(out).any(axis=-1).sum() == missed.sum()  # whole points


def test_perturb_without_noise_changes_nothing_and_with_noise_applies_every_error(grid):
    rng = np.random.default_rng(5)
    assert np.array_equal(nz.perturb(grid, SensorSpec(), rng), grid)
    spec = SensorSpec(noise_mm=0.1, correlated_mm=0.5, rotation_deg=0.5, scale=0.01,
                      drop_fraction=0.1)
    out = nz.perturb(np.broadcast_to(grid, (3, *grid.shape)), spec, rng)
    assert out.shape == (3, *grid.shape)
    assert np.isnan(out).any() and np.nanstd(out - grid) > 0.1


def test_t2cam_2020_noise_gives_the_half_percent_strain_band(torus):
    """CST strain std ~ sigma sqrt(2) c / h: measure c with this implementation, and
    check the preset's noise gives std 0.25 % (band = 2 std = 0.5 %) at interior points
    on the crown (where the circumferential spacing is exactly h)."""
    spec = PRESETS["t2cam-2020"]
    sensor = VirtualSensor(spec, torus)
    K, (pr, pc), h = 300, sensor.layout.shape, spec.spacing_mm
    u = np.zeros((K, pr, pc, 3))
    X, _ = sensor.features(*sensor.measure(u, np.random.default_rng(6)),
                           ("surface_strain",))
    strain = X.reshape(K, 3, pr, pc)
    crown = np.abs(sensor.layout.s) <= 30.0
    std = strain[:, :, crown][..., 1:-1].std(axis=0).mean(axis=(1, 2))  # xx, yy, xy
    c = std[:2] * h / (spec.noise_mm * np.sqrt(2.0))
    assert c == pytest.approx([1 / np.sqrt(2)] * 2, rel=0.05)
    assert std[:2] == pytest.approx([2.5e-3] * 2, rel=0.05)
    assert std[2] < std[0]  # shear: differences of both edges, half the weight
