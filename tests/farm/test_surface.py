"""Surface strains: the CST (T2Cam) strain and the rotation of solver strains."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from farm.measure.surface import (
    cst_surface_strain,
    rotate_to_surface,
    surface_frames,
    tensor_from_voigt,
)
from farm.mesh import build_mesh
from farm.presets import default_model


@pytest.fixture(scope="module", params=["reduced", "full"])
def grid(request):
    mesh = build_mesh(default_model(request.param))
    return mesh.xyz(mesh.inner_grid), mesh.periodic


def test_frames_are_orthonormal_and_right_handed(grid):
    xyz, _ = grid
    q = surface_frames(xyz)
    eye = np.einsum("...ij,...kj->...ik", q, q)
    np.testing.assert_allclose(eye, np.broadcast_to(np.eye(3), eye.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(q), 1.0, atol=1e-12)


def test_frame_at_the_crown_under_the_wheel_centre(grid):
    xyz, _ = grid
    q = surface_frames(xyz)
    row, col = xyz.shape[0] // 2, int(np.argmin(np.abs(xyz[0, :, 0])))
    # rolling direction +x, lateral +y, normal up into the cavity (TYDEX C)
    np.testing.assert_allclose(q[row, col], np.eye(3), atol=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rigid_body_motion_gives_zero_cst_strain(grid, seed):
    xyz, periodic = grid
    rng = np.random.default_rng(seed)
    rot = Rotation.random(random_state=seed).as_matrix()
    moved = xyz @ rot.T + rng.normal(scale=50.0, size=3)
    strain = cst_surface_strain(xyz, moved, periodic)
    assert np.isfinite(strain).all()
    np.testing.assert_allclose(strain, 0.0, atol=1e-12)


@pytest.mark.parametrize("stretch", [1.02, 0.97, 1.3])
def test_uniform_circumferential_stretch_gives_known_strain(grid, stretch):
    """Scaling radii by lambda stretches the circumference: E_xx = (lambda^2 - 1) / 2."""
    xyz, periodic = grid
    # on the crown row under the wheel centre the meridian runs along y, unaffected by
    # a pure radial scaling, so there E_yy = 0 and E_xy = 0 as well
    scaled = xyz * np.array([stretch, 1.0, stretch])
    strain = cst_surface_strain(xyz, scaled, periodic)
    row = xyz.shape[0] // 2
    np.testing.assert_allclose(strain[row, :, 0], 0.5 * (stretch**2 - 1), rtol=2e-3)
    np.testing.assert_allclose(strain[row, :, 1], 0.0, atol=1e-3 * abs(stretch - 1))


def test_uniform_lateral_stretch_on_a_flat_patch():
    """A flat grid stretched in y by lambda: E_yy = (lambda^2 - 1)/2 exactly, E_xx = 0."""
    x, y = np.meshgrid(np.linspace(-10, 10, 5), np.linspace(-20, 20, 7))
    # rows run along y (the meridian), columns along x; under the axis, phi ~ 0
    flat = np.stack([x, y, np.full_like(x, -400.0)], axis=-1)
    stretched = flat * np.array([1.0, 1.1, 1.0])
    strain = cst_surface_strain(flat, stretched, periodic=False)
    np.testing.assert_allclose(strain[..., 1], 0.5 * (1.1**2 - 1), rtol=1e-3)
    np.testing.assert_allclose(strain[..., 0], 0.0, atol=1e-3)


def test_simple_shear_gives_tensor_shear_component():
    x, y = np.meshgrid(np.linspace(-10, 10, 5), np.linspace(-20, 20, 7))
    flat = np.stack([x, y, np.full_like(x, -400.0)], axis=-1)
    gamma = 1e-4  # u_x = gamma * y: tensor shear gamma / 2 (small strain)
    sheared = flat + np.stack([gamma * flat[..., 1], 0 * x, 0 * x], axis=-1)
    strain = cst_surface_strain(flat, sheared, periodic=False)
    np.testing.assert_allclose(strain[..., 2], gamma / 2, rtol=1e-3)


def test_rotate_to_surface_of_a_known_tensor():
    frames = Rotation.from_euler("z", 90, degrees=True).as_matrix().T[None]  # e1 = +y, e2 = -x
    strain = np.array([[1.0, 2.0, 3.0, 0.5, 0.0, 0.0]])  # xx, yy, zz, xy, yz, zx
    local = rotate_to_surface(strain, frames)
    np.testing.assert_allclose(local, [[2.0, 1.0, -0.5]])
    t = tensor_from_voigt(strain)
    assert t[0, 0, 1] == t[0, 1, 0] == 0.5
