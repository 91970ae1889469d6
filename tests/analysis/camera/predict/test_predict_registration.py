"""analysis.camera.predict.registration: Kabsch/Umeyama, ICP on a tyre-like patch, transform
files."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from analysis.camera.predict.registration import Transform, icp, read_transform, rigid_fit
from analysis.errors import AnalysisError, RegistrationError


def _rotation(deg: float, axis) -> np.ndarray:
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return Rotation.from_rotvec(np.radians(deg) * axis).as_matrix()


@pytest.fixture
def points():
    return np.random.default_rng(0).normal(scale=[100.0, 60.0, 30.0], size=(200, 3))


@pytest.fixture
def known():
    return Transform(_rotation(25.0, [1, -2, 0.5]), [12.0, -7.5, 30.0])


def torus_patch(n: int, rng, R: float = 300.0, r: float = 100.0) -> np.ndarray:
    """n random points on a patch of a torus (major radius R about z, tube radius r), in
    mm: roughly the inner surface of a tyre."""
    theta, phi = rng.uniform(-0.35, 0.35, n), rng.uniform(-1.0, 1.0, n)
    return np.c_[(R + r * np.cos(phi)) * np.cos(theta), (R + r * np.cos(phi)) * np.sin(theta),
                 r * np.sin(phi)]


def test_registration_error_is_an_analysis_value_error():
    assert issubclass(RegistrationError, AnalysisError)
    assert issubclass(RegistrationError, ValueError)


# -- Transform ---------------------------------------------------------------------------


def test_transform_apply_inverse_compose_matrix(points, known):
    moved = known.apply(points)
    np.testing.assert_allclose(moved, points @ known.rotation.T + known.translation)
    np.testing.assert_allclose(known.inverse().apply(moved), points, atol=1e-12)
    np.testing.assert_allclose(known.apply(points[0]), moved[0])
    other = Transform(_rotation(-10.0, [0, 0, 1]), [1.0, 2.0, 3.0], 1.5)
    np.testing.assert_allclose((other @ known).apply(points), other.apply(moved), atol=1e-12)
    np.testing.assert_allclose((other @ other.inverse()).matrix(), np.eye(4), atol=1e-12)
    homogeneous = np.c_[points, np.ones(len(points))] @ other.matrix().T
    np.testing.assert_allclose(homogeneous[:, :3], other.apply(points), atol=1e-9)
    back = Transform.from_matrix(other.matrix())
    np.testing.assert_allclose(back.matrix(), other.matrix(), atol=1e-12)
    assert back.scale == pytest.approx(1.5)
    assert known.rotation_angle() == pytest.approx(25.0)


def test_transform_dict_round_trip_and_immutability(known):
    d = json.loads(json.dumps(known.to_dict()))
    again = Transform.from_dict(d)
    np.testing.assert_array_equal(again.matrix(), known.matrix())
    with pytest.raises(dataclasses.FrozenInstanceError):
        known.scale = 2.0  # type: ignore[misc]
    with pytest.raises(ValueError):
        known.rotation[0, 0] = 2.0  # read-only array


@pytest.mark.parametrize("kwargs,expected", [
    ({"rotation": np.diag([1.0, 1.0, -1.0])}, "reflection"),
    ({"rotation": 2 * np.eye(3)}, "not orthonormal"),
    ({"rotation": np.eye(2)}, r"got \(2, 2\)"),
    ({"translation": [0.0, np.nan, 0.0]}, "finite"),
    ({"scale": 0.0}, "positive"),
])
def test_invalid_transforms(kwargs, expected):
    with pytest.raises(RegistrationError, match=expected):
        Transform(**kwargs)


def test_from_dict_errors():
    with pytest.raises(RegistrationError, match="lacks 'translation'"):
        Transform.from_dict({"rotation": np.eye(3).tolist()})
    with pytest.raises(RegistrationError, match="unknown transform keys"):
        Transform.from_dict({"rotation": np.eye(3).tolist(), "translation": [0, 0, 0],
                             "shear": 1})
    with pytest.raises(RegistrationError, match="not numbers"):
        Transform.from_dict({"rotation": "eye", "translation": [0, 0, 0]})


# -- rigid_fit ---------------------------------------------------------------------------


def test_rigid_fit_recovers_a_known_transform_exactly(points, known):
    fit = rigid_fit(points, known.apply(points))
    np.testing.assert_allclose(fit.matrix(), known.matrix(), atol=1e-10)
    assert fit.scale == 1.0


def test_rigid_fit_with_scale_recovers_the_similarity(points):
    known = Transform(_rotation(140.0, [0.2, 1, -1]), [-50.0, 3.0, 8.0], 0.8)
    fit = rigid_fit(points, known.apply(points), scale=True)
    np.testing.assert_allclose(fit.matrix(), known.matrix(), atol=1e-10)
    assert fit.scale == pytest.approx(0.8, abs=1e-12)


def test_rigid_fit_with_noise_is_close(points, known):
    rng = np.random.default_rng(1)
    noisy = known.apply(points) + rng.normal(scale=0.05, size=points.shape)
    fit = rigid_fit(points, noisy)
    assert (fit.inverse() @ known).rotation_angle() < 0.01
    np.testing.assert_allclose(fit.translation, known.translation, atol=0.02)


def test_weights_ignore_outliers(points, known):
    target = known.apply(points)
    target[:10] += 500.0  # ten wrong correspondences
    w = np.ones(len(points))
    w[:10] = 0.0
    fit = rigid_fit(points, target, weights=w)
    np.testing.assert_allclose(fit.matrix(), known.matrix(), atol=1e-10)


def test_coplanar_points_give_the_rotation_not_a_reflection():
    """For coplanar points the SVD leaves the sign of the normal open: uncorrected Kabsch
    returns a reflection for some configurations; the corrected fit recovers the rotation
    exactly in all of them."""
    naive_reflections = 0
    for seed in range(20):
        rng = np.random.default_rng(seed)
        flat = np.c_[rng.normal(size=(30, 2)) * 50.0, np.zeros(30)]
        known = Transform(Rotation.from_rotvec(rng.normal(size=3)).as_matrix(),
                          rng.normal(size=3) * 10.0)
        target = known.apply(flat)
        fit = rigid_fit(flat, target)
        assert np.linalg.det(fit.rotation) == pytest.approx(1.0)
        np.testing.assert_allclose(fit.matrix(), known.matrix(), atol=1e-9)
        u, _, vt = np.linalg.svd((target - target.mean(0)).T @ (flat - flat.mean(0)))
        naive_reflections += np.linalg.det(u @ vt) < 0
    assert naive_reflections > 0  # the case the sign correction exists for did occur


def test_a_mirrored_target_gives_the_best_rotation(points):
    mirrored = points * [1.0, 1.0, -1.0]
    fit = rigid_fit(points, mirrored)
    assert np.linalg.det(fit.rotation) == pytest.approx(1.0)
    # plain Kabsch would return the mirror itself, with zero residual
    assert np.sqrt(np.mean(np.sum((fit.apply(points) - mirrored) ** 2, axis=1))) > 1.0


@pytest.mark.parametrize("source,target,expected", [
    (np.zeros((2, 3)), np.zeros((2, 3)), "at least 3"),
    (np.zeros((5, 3)), np.zeros((4, 3)), "same shape"),
    (np.zeros((5, 2)), np.zeros((5, 2)), r"shape \(M, 3\)"),
    (np.outer(np.arange(5.0), [1, 2, 3]), np.outer(np.arange(5.0), [1, 2, 3]), "one line"),
    (np.full((4, 3), np.nan), np.zeros((4, 3)), "NaN"),
])
def test_rigid_fit_refuses_ill_posed_input(source, target, expected):
    with pytest.raises(RegistrationError, match=expected) as info:
        rigid_fit(source, target)
    assert "\n" not in str(info.value)


# -- ICP ---------------------------------------------------------------------------------


def _small_transform(target: np.ndarray, deg: float, axis, shift) -> Transform:
    """A rotation by ``deg`` about an axis through the patch's centre, then ``shift``."""
    R, c = _rotation(deg, axis), target.mean(axis=0)
    return Transform(R, c - R @ c + np.asarray(shift, float))


def test_icp_recovers_a_small_transform_of_a_torus_patch():
    rng = np.random.default_rng(3)
    target = torus_patch(4000, rng)
    known = _small_transform(target, 3.0, [1, -1, 1], [3.0, 2.0, -3.0])
    # a shuffled subset of the surface's points: no correspondences given
    source = known.inverse().apply(target[rng.permutation(len(target))[:1500]])
    fit, rms = icp(source, target)
    assert rms < 1e-8
    np.testing.assert_allclose(fit.matrix(), known.matrix(), atol=1e-8)


def test_icp_with_noise_and_partial_overlap():
    rng = np.random.default_rng(4)
    target = torus_patch(4000, rng)
    known = _small_transform(target, 4.0, [1, 2, 0.5], [-4.0, 3.0, 2.0])
    source = known.inverse().apply(target[rng.permutation(len(target))[:1500]])
    source += rng.normal(scale=0.05, size=source.shape)
    fit, rms = icp(source, target)
    assert rms < 0.15  # the noise, 0.05 mm per axis
    assert (fit.inverse() @ known).rotation_angle() < 0.01
    assert np.abs(fit.apply(source) - known.apply(source)).max() < 0.05
    # the target sees only part of the patch: far pairs must be dropped
    part = target[target[:, 2] < 40.0]
    fit, rms = icp(source, part, max_distance=3.0)
    assert (fit.inverse() @ known).rotation_angle() < 0.1
    assert np.abs(fit.apply(source) - known.apply(source)).max() < 0.2


def test_icp_from_a_good_initial_guess_stays_put():
    rng = np.random.default_rng(5)
    target = torus_patch(2000, rng)
    known = _small_transform(target, 2.0, [0, 0, 1], [1.0, 1.0, 1.0])
    source = known.inverse().apply(target)
    fit, rms = icp(source, target, init=known, max_iter=3)
    assert rms < 1e-9
    np.testing.assert_allclose(fit.matrix(), known.matrix(), atol=1e-9)


def test_icp_errors():
    pts = np.random.default_rng(6).normal(size=(20, 3))
    with pytest.raises(RegistrationError, match="within max_distance"):
        icp(pts, pts + 100.0, max_distance=1.0)
    with pytest.raises(RegistrationError, match="max_iter"):
        icp(pts, pts, max_iter=0)
    with pytest.raises(RegistrationError, match="init must be a Transform"):
        icp(pts, pts, init=np.eye(4))  # type: ignore[arg-type]


# -- transform files ---------------------------------------------------------------------


def test_read_transform_text_csv_and_json(tmp_path, known):
    M = known.matrix()
    (tmp_path / "t.txt").write_text("# cloud -> model\n" + "\n".join(
        " ".join(f"{v:.17g}" for v in row) for row in M) + "\n")
    (tmp_path / "t.csv").write_text("\n".join(",".join(f"{v:.17g}" for v in row) for row in M))
    (tmp_path / "t.json").write_text(json.dumps(known.to_dict()))
    (tmp_path / "m.json").write_text(json.dumps({"matrix": M.tolist()}))
    for name in ("t.txt", "t.csv", "t.json", "m.json"):
        np.testing.assert_allclose(read_transform(tmp_path / name).matrix(), M, atol=1e-12)


@pytest.mark.parametrize("name,content,expected", [
    ("short.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n", "4x4"),
    ("word.txt", "1 0 0 0\n0 1 0 0\n0 0 one 0\n0 0 0 1\n", "not a row of numbers"),
    ("proj.txt", "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n", "last row"),
    ("mirror.txt", "1 0 0 0\n0 1 0 0\n0 0 -1 0\n0 0 0 1\n", "reflection"),
    ("shear.txt", "1 0.5 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n", "not orthonormal"),
    ("bad.json", "{rotation: [1]", "not valid JSON"),
    ("list.json", "[1, 2, 3]", "dict"),
    ("nokey.json", '{"rotation": [[1,0,0],[0,1,0],[0,0,1]]}', "translation"),
    ("empty.txt", "", "bytes"),
])
def test_bad_transform_files_give_one_line(tmp_path, name, content, expected):
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(RegistrationError, match=expected) as info:
        read_transform(path)
    assert "\n" not in str(info.value) and name in str(info.value)


def test_missing_binary_and_directory_transform_files(tmp_path):
    (tmp_path / "bin.txt").write_bytes(b"\xff\xfe\x00\x01" * 10)
    for path, expected in ((tmp_path / "absent.txt", "no such file"),
                           (tmp_path, "directory"), (tmp_path / "bin.txt", "UTF-8")):
        with pytest.raises(RegistrationError, match=expected) as info:
            read_transform(path)
        assert "\n" not in str(info.value)
