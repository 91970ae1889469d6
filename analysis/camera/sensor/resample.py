"""Measured clouds onto a sensor's points (for ``farm predict`` and ``farm mismatch``).

A real T2Cam cloud (thesis §2.2) has its points where the image correlation found them:
not on a trained model's :class:`~analysis.camera.sensor.layout.Layout`. :func:`to_layout`
resamples a reference cloud and a deformed cloud (the same M points, in the model's frame)
onto the layout's (pr, pc) grid, so :meth:`VirtualSensor.features
<analysis.camera.sensor.model.VirtualSensor.features>` can featurise them like the clouds the
model was trained on.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay, QhullError, cKDTree

from analysis.camera.sensor.layout import Layout, column_cells, face_weights
from analysis.camera.sensor.surface import TWO_PI, InnerSurface, wrap_angle
from analysis.errors import CloudError

__all__ = ["surface_coordinates", "to_layout"]

_BLOCK = 20_000  # points projected onto the meridian at once (bounded memory)
_SLIVER = 3.0  # longest triangle edge, in medians, that still interpolates linearly
_CLOSE = 0.1  # a known point this close (in spacings) gives its value as it is
_NEIGHBOURS = 6  # known points of the local plane at a gap
_FLAT = 0.05  # smallest area / longest edge² of a triangle that interpolates linearly


def surface_coordinates(surface: InnerSurface, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface coordinates (theta, s) of points near the inner surface.

    The angle comes from ``arctan2(x, -z)``; s from the nearest position on the
    surface's meridian profile (the polyline of the rows' (radius, y)), interpolated
    along its segment. Both are taken on the FE surface's faces, so that a point of a
    face gets the very (theta, s) that :func:`~analysis.camera.sensor.layout.face_weights`
    maps back onto it: between two columns a face is flat across the circumference, so
    its points sit inside the revolve by the chord's sag (0.3 mm for 5° columns at
    330 mm, more than T2Cam's 2020 noise), and their angle is not linear along the
    chord. Each point's angle is therefore turned into the face's parameter (the cell
    fraction u whose chord point has that angle) and its radius divided by the chord's
    radial factor at u, before it is projected onto the profile.

    Parameters
    ----------
    surface : InnerSurface
    xyz : ndarray, shape (M, 3)
        Positions (mm) in the model's frame.

    Returns
    -------
    theta : ndarray, shape (M,)
        Angle (the faces' parameter; the angle itself beyond a sector's edge columns) in
        (-pi, pi].
    s : ndarray, shape (M,)
        Meridional arc length (mm).
    """
    xyz = np.asarray(xyz, dtype=float)
    phi = np.arctan2(xyz[:, 0], -xyz[:, 2])
    _, _, lo, hi, t = column_cells(surface, phi)
    a, b = np.sin(t - lo), np.sin(hi - t)  # the chord point at fraction u has angle t
    on = (t >= lo) & (t <= hi)
    u = np.where(on, a / np.where(on, a + b, 1.0), 0.0)
    theta = np.where(on, lo + u * (hi - lo), t)
    sag = np.sqrt((1 - u) ** 2 + u**2 + 2 * u * (1 - u) * np.cos(hi - lo))  # 1 at columns
    q = np.column_stack([np.hypot(xyz[:, 0], xyz[:, 2]) / sag, xyz[:, 1]])  # (r, y)
    p0, d = surface.profile[:-1], np.diff(surface.profile, axis=0)  # segments (rows-1, 2)
    ds = np.diff(surface.s)
    s = np.empty(q.shape[0])
    for start in range(0, q.shape[0], _BLOCK):
        part = q[start:start + _BLOCK, None, :] - p0[None]  # (m, rows-1, 2)
        f = np.clip(np.sum(part * d, axis=-1) / np.sum(d * d, axis=-1), 0.0, 1.0)
        dist = np.sum((part - f[..., None] * d) ** 2, axis=-1)
        i = np.argmin(dist, axis=1)
        s[start:start + _BLOCK] = surface.s[i] + f[np.arange(i.size), i] * ds[i]
    return wrap_angle(theta), s


def to_layout(surface: InnerSurface, layout: Layout, ref_points: np.ndarray,
              points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A measured reference cloud and deformed cloud, resampled on the layout's points.

    Each measured reference point gets surface coordinates (:func:`surface_coordinates`);
    over (arc length at the crown's radius, s) two fields of the measured points are
    interpolated linearly (Delaunay) at the layout's points, a local least-squares
    plane outside their hull or in a sliver triangle of its ragged edge
    (:func:`_interpolate`):

    - the displacement ``points - ref_points``;
    - the reference point's offset from the FE surface at its (theta, s), so the
      resampled reference keeps what the measurement says about the surface's place
      without the chord error of interpolating curved positions linearly.

    On a periodic surface the measured points are repeated one turn on either side, so a
    360° layout interpolates across the seam.

    Parameters
    ----------
    surface : InnerSurface
        The reference surface the layout lies on.
    layout : Layout
    ref_points, points : ndarray, shape (M, 3)
        The same M measured points in the reference (inflated, unloaded) and the
        deformed state (mm), in the model's frame, without NaN.

    Returns
    -------
    ref_cloud, cloud : ndarray, shape (pr, pc, 3)
        Without NaN.

    Raises
    ------
    CloudError
        Shapes differ, values are not finite, or fewer than 3 points.
    """
    ref = np.asarray(ref_points, dtype=float)
    cur = np.asarray(points, dtype=float)
    if ref.ndim != 2 or ref.shape[1] != 3 or ref.shape != cur.shape:
        raise CloudError(f"a reference cloud and a cloud must both be (M, 3) with the same "
                         f"M, got {ref.shape} and {cur.shape}")
    if ref.shape[0] < 3:
        raise CloudError(f"resampling a cloud needs at least 3 points, got {ref.shape[0]}")
    if not (np.isfinite(ref).all() and np.isfinite(cur).all()):
        raise CloudError("clouds to resample must be finite: drop the NaN/inf points (of "
                         "both clouds) first")
    theta, s = surface_coordinates(surface, ref)
    offset = ref - face_weights(surface, theta, s) @ surface.node_xyz
    values = np.concatenate([offset, cur - ref], axis=1)  # (M, 6)
    R = surface.crown_radius
    known = np.column_stack([R * theta, s])
    if surface.periodic:
        up, down = theta < -np.pi / 2, theta > np.pi / 2
        known = np.concatenate([known, np.column_stack([R * (theta[up] + TWO_PI), s[up]]),
                                np.column_stack([R * (theta[down] - TWO_PI), s[down]])])
        values = np.concatenate([values, values[up], values[down]])
    T, S = np.meshgrid(layout.theta, layout.s)
    wanted = np.column_stack([R * wrap_angle(T.ravel()), S.ravel()])
    out = _interpolate(known, values, wanted)
    pr, pc = layout.shape
    ref_cloud = layout.xyz + out[:, :3].reshape(pr, pc, 3)
    return ref_cloud, ref_cloud + out[:, 3:].reshape(pr, pc, 3)


def _interpolate(known: np.ndarray, values: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values`` (M, c) from ``known`` (M, 2) at ``wanted``
    (P, 2) over a Delaunay triangulation of the known points. Where no *compact*
    triangle holds a wanted point: the value of a known point within :data:`_CLOSE`
    spacings (a measured point at the layout's point), else a plane through the
    nearest known points.

    A noisy cloud's hull is ragged: Delaunay closes it with long sliver triangles between
    far-apart edge points, and a layout point on the window's edge falls in one of them.
    Interpolating there mixes displacements from across the window (a test found 6.7 mm
    off a 23 mm displacement for 0.2 mm position noise), so triangles whose longest edge
    exceeds :data:`_SLIVER` times the median, or that are flat (area below :data:`_FLAT`
    times the longest edge squared; a right isosceles triangle has 0.25), are not used.
    """
    out = np.full((wanted.shape[0], values.shape[1]), np.nan)
    try:
        tri = Delaunay(known)
    except (QhullError, ValueError):
        tri = None
    if tri is not None:
        corners = known[tri.simplices]  # (n, 3, 2)
        longest = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
        e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
        area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        compact = ((longest <= _SLIVER * np.median(longest))
                   & (area >= _FLAT * np.maximum(longest, 1e-300) ** 2))
        simplex = tri.find_simplex(wanted)
        use = (simplex >= 0) & compact[np.maximum(simplex, 0)]
        idx = simplex[use]
        affine = tri.transform[idx]
        b = np.einsum("nij,nj->ni", affine[:, :2], wanted[use] - affine[:, 2])
        weights = np.column_stack([b, 1.0 - b.sum(axis=1)])
        out[use] = np.einsum("nk,nkc->nc", weights, values[tri.simplices[idx]])
    gap = np.flatnonzero(~np.isfinite(out).all(axis=1))
    if gap.size:
        dist, near = cKDTree(known).query(wanted[gap])
        close = dist <= _CLOSE * _spacing(known)
        out[gap[close]] = values[near[close]]
        if (~close).any():
            out[gap[~close]] = _local_planes(known, values, wanted[gap[~close]])
    return out


def _spacing(known: np.ndarray) -> float:
    """Median distance from a known point to its nearest neighbour."""
    if known.shape[0] < 2:
        return 0.0
    return float(np.median(cKDTree(known).query(known, k=2)[0][:, 1]))


def _local_planes(known: np.ndarray, values: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Each wanted point's value from a least-squares plane through its nearest known
    points (the nearest point's value alone where they span no plane): first order at
    a ragged edge, where the nearest value alone is zeroth order."""
    k = min(_NEIGHBOURS, known.shape[0])
    _dist, idx = cKDTree(known).query(wanted, k=k)
    idx = idx.reshape(wanted.shape[0], k)
    out = values[idx[:, 0]].copy()
    for n in range(wanted.shape[0]):
        local = known[idx[n]] - wanted[n]
        A = np.column_stack([np.ones(k), local])
        coef, _, rank, _ = np.linalg.lstsq(A, values[idx[n]], rcond=None)
        if rank == 3:
            out[n] = coef[0]
    return out
