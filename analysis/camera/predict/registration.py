"""Rigid (and similarity) registration of point clouds: put a measured cloud in the
model's frame.

- :class:`Transform`: ``x -> scale * R x + t`` with R a proper rotation (det +1).
- :func:`rigid_fit`: the least-squares transform between *corresponding* points
  (Kabsch; with ``scale=True`` Umeyama 1991). The SVD's sign is corrected, so a
  reflection is never returned: the result is the best proper rotation even where the
  plain SVD solution would mirror (coplanar or noisy points, a mirrored target).
- :func:`icp`: point-to-point ICP (Besl & McKay 1992) between clouds *without*
  correspondences, nearest neighbours by :class:`scipy.spatial.cKDTree`; it needs an
  initial guess within a few degrees / a fraction of the cloud's size.
- :func:`read_transform`: a transform from a file (a 4x4 matrix as text/CSV, or JSON).

Coordinates are in mm throughout. Bad input raises one
:class:`~analysis.errors.RegistrationError` line.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from analysis.errors import RegistrationError

__all__ = ["Transform", "icp", "read_transform", "rigid_fit"]

#: how far from orthonormal (max |RᵀR - I|) a rotation may be (rounding in files)
ORTHO_TOL = 1e-6
#: largest transform file read (a 4x4 matrix or a small JSON)
MAX_TRANSFORM_BYTES = 1_000_000


@dataclass(frozen=True, eq=False)
class Transform:
    """The similarity transform ``x -> scale * rotation @ x + translation``.

    Parameters
    ----------
    rotation : array_like of shape (3, 3)
        A proper rotation (orthonormal, det +1, to within :data:`ORTHO_TOL`).
    translation : array_like of shape (3,)
        In mm.
    scale : float, default=1.0
        Positive; 1 for a rigid transform.

    The arrays are stored as read-only float64 copies.
    """

    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale: float = 1.0

    def __post_init__(self) -> None:
        R = np.array(self.rotation, dtype=np.float64)
        t = np.array(self.translation, dtype=np.float64).reshape(-1)
        s = float(self.scale)
        if R.shape != (3, 3) or t.shape != (3,):
            raise RegistrationError(f"a transform needs rotation (3, 3) and translation (3,), "
                                    f"got {R.shape} and {t.shape}")
        if not (np.isfinite(R).all() and np.isfinite(t).all() and np.isfinite(s) and s > 0):
            raise RegistrationError("a transform needs finite rotation and translation and a "
                                    f"positive finite scale (scale = {s})")
        err = float(np.abs(R.T @ R - np.eye(3)).max())
        if err > ORTHO_TOL:
            raise RegistrationError(f"rotation is not orthonormal (max |RᵀR - I| = {err:.2g}); "
                                    "give a rotation matrix, the scale separately")
        if np.linalg.det(R) < 0:
            raise RegistrationError("rotation has det -1 (a reflection); a rigid transform "
                                    "cannot mirror: mirror the cloud itself instead")
        R.flags.writeable = False
        t.flags.writeable = False
        object.__setattr__(self, "rotation", R)
        object.__setattr__(self, "translation", t)
        object.__setattr__(self, "scale", s)

    @classmethod
    def identity(cls) -> Transform:
        """The identity transform."""
        return cls()

    def apply(self, points) -> np.ndarray:
        """Transform points of shape (M, 3) (or one point (3,)); returns the same shape."""
        p = np.asarray(points, dtype=np.float64)
        if p.shape[-1:] != (3,) or p.ndim > 2:
            raise RegistrationError(f"points must have shape (M, 3) or (3,), got {p.shape}")
        return self.scale * (p @ self.rotation.T) + self.translation

    def inverse(self) -> Transform:
        """The transform undoing this one: ``x -> (1/s) Rᵀ (x - t)``."""
        Rt = self.rotation.T
        return Transform(Rt, -(Rt @ self.translation) / self.scale, 1.0 / self.scale)

    def __matmul__(self, other: Transform) -> Transform:
        """``(a @ b).apply(x) == a.apply(b.apply(x))``."""
        if not isinstance(other, Transform):
            return NotImplemented
        return Transform(self.rotation @ other.rotation,
                         self.scale * (self.rotation @ other.translation) + self.translation,
                         self.scale * other.scale)

    def matrix(self) -> np.ndarray:
        """The homogeneous 4x4 matrix [[s R, t], [0, 0, 0, 1]]."""
        M = np.eye(4)
        M[:3, :3] = self.scale * self.rotation
        M[:3, 3] = self.translation
        return M

    @classmethod
    def from_matrix(cls, matrix) -> Transform:
        """From a homogeneous 4x4 matrix (last row 0, 0, 0, 1; upper 3x3 = s R)."""
        M = np.asarray(matrix, dtype=np.float64)
        if M.shape != (4, 4):
            raise RegistrationError(f"a transform matrix must be 4x4, got {M.shape}")
        if not np.isfinite(M).all():
            raise RegistrationError("the transform matrix holds NaN or inf")
        if np.abs(M[3] - [0.0, 0.0, 0.0, 1.0]).max() > ORTHO_TOL:
            raise RegistrationError(f"the last row of a 4x4 transform must be 0 0 0 1, got "
                                    f"{M[3].tolist()} (a projective matrix?)")
        A = M[:3, :3]
        det = float(np.linalg.det(A))
        if det <= 0:
            raise RegistrationError(f"the 3x3 block of the matrix has det {det:.3g} <= 0 (a "
                                    "reflection or degenerate); it must be s R with s > 0")
        s = det ** (1.0 / 3.0)
        return cls(A / s, M[:3, 3], s)

    def rotation_angle(self) -> float:
        """Angle of the rotation, in degrees (0..180)."""
        c = (np.trace(self.rotation) - 1.0) / 2.0
        return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))

    def to_dict(self) -> dict:
        """``{"rotation": 3x3 list, "translation": 3 list, "scale": float}`` (JSON-ready)."""
        return {"rotation": self.rotation.tolist(), "translation": self.translation.tolist(),
                "scale": self.scale}

    @classmethod
    def from_dict(cls, d) -> Transform:
        """From :meth:`to_dict`'s dict (``scale`` optional), or ``{"matrix": 4x4}``."""
        if not isinstance(d, dict):
            raise RegistrationError(f"a transform dict is needed, got {type(d).__name__}")
        try:
            if "matrix" in d:
                return cls.from_matrix(np.asarray(d["matrix"], dtype=np.float64))
            unknown = set(d) - {"rotation", "translation", "scale"}
            if unknown:
                raise RegistrationError(f"unknown transform keys {sorted(unknown)}; use "
                                        "rotation, translation and scale (or matrix)")
            return cls(np.asarray(d["rotation"], dtype=np.float64),
                       np.asarray(d["translation"], dtype=np.float64),
                       float(d.get("scale", 1.0)))
        except KeyError as exc:
            raise RegistrationError(f"the transform lacks {exc.args[0]!r}; give rotation and "
                                    "translation (or a 4x4 matrix)") from None
        except (TypeError, ValueError) as exc:
            if isinstance(exc, RegistrationError):
                raise
            raise RegistrationError("the transform's values are not numbers of the right "
                                    "shape (rotation 3x3, translation 3, scale)") from None

    def __repr__(self) -> str:
        return (f"Transform(angle={self.rotation_angle():.4g} deg, "
                f"translation={np.round(self.translation, 6).tolist()}, scale={self.scale:.6g})")


def _points(name: str, a, min_points: int = 1) -> np.ndarray:
    p = np.asarray(a, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise RegistrationError(f"{name} must have shape (M, 3), got {p.shape}")
    if p.shape[0] < min_points:
        raise RegistrationError(f"{name} has {p.shape[0]} point(s); registration needs at "
                                f"least {min_points}")
    if not np.isfinite(p).all():
        raise RegistrationError(f"{name} holds NaN or inf; drop those points first")
    return p


def rigid_fit(source, target, scale: bool = False, weights=None) -> Transform:
    """Least-squares transform mapping ``source[i]`` onto ``target[i]``.

    Minimises ``sum_i w_i |target_i - (s R source_i + t)|²`` over proper rotations R
    (det +1), t, and with ``scale=True`` s > 0 (Umeyama 1991; else s = 1, Kabsch). The
    sign correction of the SVD makes the result a rotation even where the unconstrained
    optimum is a reflection (a mirrored target gives the best rotation, not the mirror).

    Parameters
    ----------
    source, target : array_like of shape (M, 3)
        Corresponding points, M >= 3, not all on one line.
    scale : bool, default=False
        Fit a uniform scale too.
    weights : array_like of shape (M,), optional
        Non-negative weights of the pairs (default all 1).

    Returns
    -------
    Transform
        With ``transform.apply(source) ≈ target``.
    """
    src = _points("source", source, 3)
    dst = _points("target", target, 3)
    if src.shape != dst.shape:
        raise RegistrationError(f"source {src.shape} and target {dst.shape} must have the same "
                                "shape: rigid_fit needs corresponding points (use icp otherwise)")
    w = _weights(weights, src.shape[0])
    mu_s, mu_t = w @ src, w @ dst
    S, D = src - mu_s, dst - mu_t
    sv = np.linalg.svd(S * np.sqrt(w)[:, None], compute_uv=False)
    if sv[1] <= 1e-9 * max(sv[0], np.finfo(float).tiny):
        raise RegistrationError("the source points (with non-zero weight) are all on one line "
                                "or one point: the rotation about that line is undetermined")
    cov = (D * w[:, None]).T @ S  # (3, 3) = sum w (t - mu_t)(s - mu_s)ᵀ
    U, sig, Vt = np.linalg.svd(cov)
    d = np.ones(3)
    d[2] = np.sign(np.linalg.det(U) * np.linalg.det(Vt)) or 1.0
    R = (U * d) @ Vt
    s = float((sig * d).sum() / (w @ (S * S).sum(axis=1))) if scale else 1.0
    if s <= 0:
        raise RegistrationError("the fitted scale is not positive: source and target do not "
                                "correspond (check the point order)")
    return Transform(R, mu_t - s * (R @ mu_s), s)


def _icp_start(init: Transform | None, max_iter: int, max_distance: float | None
               ) -> Transform:
    """ICP's first guess (the identity by default), once its settings are valid."""
    if max_iter < 1:
        raise RegistrationError(f"max_iter must be >= 1, got {max_iter}")
    if max_distance is not None and not max_distance > 0:
        raise RegistrationError(f"max_distance must be positive, got {max_distance}")
    current = init if init is not None else Transform.identity()
    if not isinstance(current, Transform):
        raise RegistrationError(f"init must be a Transform, got {type(current).__name__}")
    return current


def _pairs(tree: cKDTree, src: np.ndarray, t: Transform, max_distance: float | None
           ) -> tuple[np.ndarray, np.ndarray, float]:
    """Each moved source point's nearest target point: (kept pairs (M,) bool, target
    index (M,), RMS distance of the kept pairs, mm)."""
    dist, idx = tree.query(t.apply(src))
    keep = np.ones(dist.shape, bool) if max_distance is None else dist <= max_distance
    if keep.sum() < 3:
        raise RegistrationError(f"only {int(keep.sum())} source point(s) lie within "
                                f"max_distance={max_distance} mm of the target; give a "
                                "better initial guess or a larger max_distance")
    return keep, idx, float(np.sqrt(np.mean(dist[keep] ** 2)))


def icp(source, target, init: Transform | None = None, max_iter: int = 50,
        tol: float = 1e-6, *, max_distance: float | None = None) -> tuple[Transform, float]:
    """Point-to-point ICP: the rigid transform putting ``source`` onto the surface that
    ``target`` samples, without correspondences.

    Each iteration pairs every (moved) source point with its nearest target point
    (:class:`scipy.spatial.cKDTree`), drops pairs farther apart than ``max_distance``,
    and refits with :func:`rigid_fit` on the original source points. It stops when the
    RMS distance changes by less than ``tol`` (mm) or after ``max_iter`` iterations.
    ICP finds the nearest local optimum: the initial guess must be close (a few degrees,
    a fraction of the cloud's extent), and a surface with a symmetry (a torus slides
    along itself) is only registered as well as its edges and features pin it.

    Parameters
    ----------
    source : array_like of shape (M, 3)
    target : array_like of shape (N, 3)
    init : Transform, optional
        Initial guess (default the identity).
    max_iter : int, default=50
    tol : float, default=1e-6
        Stop when the RMS changes by less than this (mm).
    max_distance : float, optional
        Ignore pairs farther apart than this (mm): for clouds that only partly overlap.

    Returns
    -------
    transform : Transform
        Maps source onto target.
    rms : float
        RMS distance (mm) from the moved source points to their nearest target points
        (over the pairs within ``max_distance``).
    """
    src = _points("source", source, 3)
    dst = _points("target", target, 3)
    current = _icp_start(init, max_iter, max_distance)
    tree = cKDTree(dst)
    keep, idx, rms = _pairs(tree, src, current, max_distance)
    for _ in range(max_iter):
        current = rigid_fit(src[keep], dst[idx[keep]])
        keep, idx, new = _pairs(tree, src, current, max_distance)
        done = abs(rms - new) < tol
        rms = new
        if done:
            break
    return current, rms


def _weights(weights, m: int) -> np.ndarray:
    """The pairs' weights normalised to sum 1, (m,); all equal by default."""
    if weights is None:
        return np.full(m, 1.0 / m)
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if w.shape != (m,) or not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
        raise RegistrationError(f"weights must be {m} finite non-negative numbers, not all "
                                "zero")
    return w / w.sum()


def read_transform(path: str | os.PathLike) -> Transform:
    """Read a transform from a file.

    Formats: ``.json`` with ``rotation`` (3x3), ``translation`` (3) and optional ``scale``,
    or ``matrix`` (4x4); any other extension: a 4x4 homogeneous matrix as text, comma or
    whitespace separated, ``#`` comments allowed. The matrix maps the cloud's frame to the
    model's (points as column vectors).

    Returns
    -------
    Transform

    Raises
    ------
    RegistrationError
        One line naming the file and what is wrong.
    """
    path = Path(path)
    if not path.is_file():
        raise RegistrationError(f"transform file {path}: "
                                + ("is a directory" if path.is_dir() else "no such file")
                                + "; give a 4x4 matrix (text) or a JSON file")
    size = path.stat().st_size
    if size == 0 or size > MAX_TRANSFORM_BYTES:
        raise RegistrationError(f"transform file {path}: {size} bytes; a transform file holds "
                                "a 4x4 matrix or a small JSON object")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise RegistrationError(f"transform file {path}: not UTF-8 text; give a 4x4 matrix "
                                "(text) or a JSON file") from None
    try:
        if path.suffix.lower() == ".json":
            try:
                data = json.loads(text)
            except ValueError as exc:
                raise RegistrationError(f"not valid JSON ({exc})") from None
            return Transform.from_dict(data)
        return Transform.from_matrix(_matrix_rows(text))
    except RegistrationError as exc:
        raise RegistrationError(f"transform file {path}: {exc}") from None


def _matrix_rows(text: str) -> np.ndarray:
    """A 4x4 matrix from text rows (comma, semicolon or whitespace separated, ``#``
    comments); one line of error otherwise."""
    rows = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].replace(",", " ").replace(";", " ").strip()
        if line:
            try:
                rows.append([float(v) for v in line.split()])
            except ValueError:
                raise RegistrationError(f"{line[:40]!r} is not a row of numbers") from None
    if len(rows) != 4 or any(len(r) != 4 for r in rows):
        raise RegistrationError(f"{len(rows)} rows of {sorted({len(r) for r in rows})} "
                                "numbers; a transform is a 4x4 matrix")
    return np.array(rows)
