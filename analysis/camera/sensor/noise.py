"""The errors of a measured point cloud (thesis §2.2; the 2017 and 2020 T2Cam papers).

A cloud is an array (..., pr, pc, 3) of point positions (mm); leading axes are separate
clouds (one measurement each). Every function takes a :class:`numpy.random.Generator`
and returns a new array:

- :func:`iid`: independent Gaussian position noise per coordinate (DIC's sub-pixel
  matching noise);
- :func:`correlated`: spatially correlated Gaussian noise, squared-exponential kernel
  ``exp(-d**2 / (2 l**2))`` over the distance d of two points' reference positions
  (speckle-pattern and lens errors vary smoothly over the image);
- :func:`calibrate`: the stereo calibration error, one small rigid rotation about a
  random axis through the cloud's centroid and one scale factor per cloud;
- :func:`drop`: the points the correlation misses (NaN).

:func:`perturb` applies them all, as a :class:`~analysis.camera.sensor.spec.SensorSpec` says.
"""

from __future__ import annotations

import numpy as np

from analysis.camera.sensor.spec import SensorSpec
from analysis.errors import ParameterError

__all__ = ["MAX_CORRELATED_POINTS", "calibrate", "correlated", "correlation_factor", "drop",
           "iid", "perturb", "rotation_matrices"]

#: the most points correlated noise is drawn for (a dense P x P Cholesky factor)
MAX_CORRELATED_POINTS = 5000


def iid(cloud: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """``cloud`` (..., 3) plus i.i.d. Gaussian noise of std ``sigma`` (mm) per coordinate."""
    cloud = np.asarray(cloud, dtype=float)
    if sigma == 0.0:
        return cloud.copy()
    return cloud + sigma * rng.standard_normal(cloud.shape)


def correlation_factor(xyz: np.ndarray, length: float, jitter: float = 1e-6) -> np.ndarray:
    """Lower Cholesky factor L of the squared-exponential correlation of points.

    Parameters
    ----------
    xyz : ndarray, shape (..., 3)
        Reference positions of the P points (mm), in the clouds' point order.
    length : float
        Kernel length l (mm): correlation ``exp(-d**2 / (2 l**2))`` at distance d.
    jitter : float
        Added to the diagonal (a smooth kernel's matrix is numerically singular); raised
        tenfold until the factorisation succeeds (at most 1e-2). It adds independent
        noise of ``sqrt(jitter)`` times the correlated std: 0.1 % at 1e-6.

    Returns
    -------
    ndarray, shape (P, P)
        ``L @ z`` with z ~ N(0, I) has the kernel's covariance (unit variance).
    """
    pts = np.asarray(xyz, dtype=float).reshape(-1, 3)
    if pts.shape[0] > MAX_CORRELATED_POINTS:
        raise ParameterError(f"correlated noise over {pts.shape[0]} points needs a dense "
                             f"{pts.shape[0]}^2 factor, more than {MAX_CORRELATED_POINTS} "
                             "points: coarsen spacing_mm or narrow the window")
    sq = np.sum(pts**2, axis=1)
    d2 = np.maximum(sq[:, None] + sq[None, :] - 2.0 * pts @ pts.T, 0.0)
    cov = np.exp(-d2 / (2.0 * length**2))
    eye = np.eye(pts.shape[0])
    while True:
        try:
            return np.linalg.cholesky(cov + jitter * eye)
        except np.linalg.LinAlgError:
            if jitter >= 1e-2:
                raise
            jitter *= 10.0


def correlated(cloud: np.ndarray, sigma: float, chol: np.ndarray,
               rng: np.random.Generator) -> np.ndarray:
    """``cloud`` (..., pr, pc, 3) plus correlated noise: std ``sigma`` (mm) per coordinate,
    correlation by ``chol`` (P, P) from :func:`correlation_factor`; coordinates and
    clouds independent."""
    cloud = np.asarray(cloud, dtype=float)
    if sigma == 0.0:
        return cloud.copy()
    P = chol.shape[0]
    flat = cloud.reshape(-1, P, 3)
    z = rng.standard_normal((P, flat.shape[0] * 3))
    noise = (chol @ z).reshape(P, flat.shape[0], 3).transpose(1, 0, 2)
    return (flat + sigma * noise).reshape(cloud.shape)


def rotation_matrices(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues' rotations, (B, 3, 3), about unit ``axis`` (B, 3) by ``angle`` (B,) rad."""
    k = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    K = np.zeros((*k.shape[:-1], 3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -k[..., 2], k[..., 1], -k[..., 0]
    K = K - np.swapaxes(K, -1, -2)
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def calibrate(cloud: np.ndarray, rotation_deg: float, scale: float,
              rng: np.random.Generator) -> np.ndarray:
    """Each cloud of ``cloud`` (..., pr, pc, 3) rotated about its centroid by an angle
    ~ N(0, rotation_deg) (degrees) about a uniformly random axis, and scaled about the
    centroid by 1 + N(0, scale): a rigid motion plus one scale factor per cloud, so
    pairwise distances change by that factor only. NaN points stay NaN."""
    cloud = np.asarray(cloud, dtype=float)
    if rotation_deg == 0.0 and scale == 0.0:
        return cloud.copy()
    shape = cloud.shape
    flat = cloud.reshape(-1, shape[-3] * shape[-2], 3)
    B = flat.shape[0]
    centre = np.nanmean(flat, axis=1, keepdims=True)
    moved = flat - centre
    if rotation_deg > 0.0:
        angle = np.radians(rng.normal(0.0, rotation_deg, B))
        R = rotation_matrices(rng.standard_normal((B, 3)), angle)
        moved = moved @ np.swapaxes(R, -1, -2)
    if scale > 0.0:
        moved = moved * (1.0 + rng.normal(0.0, scale, B))[:, None, None]
    return (centre + moved).reshape(shape)


def drop(cloud: np.ndarray, fraction: float, rng: np.random.Generator) -> np.ndarray:
    """``cloud`` (..., pr, pc, 3) with ``round(fraction * P)`` random points of each
    cloud set to NaN (missed by the correlation)."""
    cloud = np.array(cloud, dtype=float)
    P = cloud.shape[-3] * cloud.shape[-2]
    m = round(fraction * P)
    if m == 0:
        return cloud
    flat = cloud.reshape(-1, P, 3)
    lost = rng.random((flat.shape[0], P)).argsort(axis=1)[:, :m]
    flat[np.arange(flat.shape[0])[:, None], lost] = np.nan
    return flat.reshape(cloud.shape)


def perturb(cloud: np.ndarray, spec: SensorSpec, rng: np.random.Generator,
            chol: np.ndarray | None = None) -> np.ndarray:
    """The measured version of exact positions ``cloud`` (..., pr, pc, 3).

    In this order: correlated noise, i.i.d. noise (both errors of where the image
    correlation puts each point), then the calibration transform (it maps the whole
    triangulated cloud, its noise included), then the dropped points.

    Parameters
    ----------
    cloud : ndarray, shape (..., pr, pc, 3)
    spec : SensorSpec
    rng : numpy.random.Generator
    chol : ndarray, shape (P, P), optional
        :func:`correlation_factor` of the layout's reference points, for
        ``spec.correlated_mm > 0``. None: computed from the first cloud's own points
        (pass it when perturbing many clouds: it costs O(P**3)).

    Returns
    -------
    ndarray, same shape as ``cloud``
    """
    out = np.asarray(cloud, dtype=float)
    if spec.correlated_mm > 0.0:
        if chol is None:
            first = out.reshape(-1, *out.shape[-3:])[0]
            chol = correlation_factor(first, spec.correlation_mm)
        out = correlated(out, spec.correlated_mm, chol, rng)
    out = iid(out, spec.noise_mm, rng)
    out = calibrate(out, spec.rotation_deg, spec.scale, rng)
    return drop(out, spec.drop_fraction, rng)
