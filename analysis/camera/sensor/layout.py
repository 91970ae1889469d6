"""Where the virtual camera's points are, and how FE fields reach them.

T2Cam's points (thesis §2.2) are where image correlation finds them, on a grid of the
camera's own, not the FE nodes. :func:`layout` places them on a regular grid in
(circumferential arc length at the crown's inner radius, meridional arc length s),
centred on the contact centre (theta = 0) and the crown (s = 0), inside the sensor's
window; or, for ``spacing_mm=None`` (the ideal sensor), at the FE nodes in the window.

A point lies on one quadrilateral face of the FE inner surface, the grid cell
(i..i+1, j..j+1); its value of a nodal field is the bilinear interpolation with the
face's shape functions at the point's normalised cell coordinates in (theta, s). The
interpolation is one sparse (P, N) matrix, :attr:`Layout.weights`, exact for every field
bilinear in (theta, s) on each face (so it returns the nodal values at the nodes).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from analysis.camera.sensor.spec import SensorSpec
from analysis.camera.sensor.surface import TWO_PI, InnerSurface, wrap_angle
from analysis.errors import ParameterError

__all__ = ["MAX_POINTS", "Layout", "column_cells", "face_weights", "interpolate", "layout"]

#: the most points a sensor may have (memory: features are K x 6 P floats)
MAX_POINTS = 200_000
_TOL = 1e-9
_CHUNK = 4_000_000  # field values interpolated per sparse product (bounded memory)


@dataclass(frozen=True, eq=False)
class Layout:
    """The sensor's points: a (pr, pc) grid on the inner surface.

    Parameters
    ----------
    theta : ndarray, shape (pc,)
        Angle of each point column, radians (``arctan2(x, -z)``), increasing.
    s : ndarray, shape (pr,)
        Meridional arc length of each point row, mm (0 at the crown), increasing.
    xyz : ndarray, shape (pr, pc, 3)
        Reference positions of the points on the FE surface (mm).
    weights : scipy.sparse.csr_matrix, shape (P, N)
        Bilinear face shape functions: row ``p = i * pc + j`` interpolates point (i, j)
        from the N inner nodes (the store's ``inner_node`` order).
    periodic : bool
        Whether point columns wrap around (a 360° window on a periodic surface whose
        circumference the spacing divides): the CST strain then spans the seam.
    """

    theta: np.ndarray
    s: np.ndarray
    xyz: np.ndarray
    weights: sp.csr_matrix
    periodic: bool

    @property
    def shape(self) -> tuple[int, int]:
        """(pr, pc): point rows (meridian) and point columns (circumference)."""
        return self.s.size, self.theta.size

    @property
    def n_points(self) -> int:
        """P = pr * pc."""
        return self.s.size * self.theta.size


def layout(surface: InnerSurface, spec: SensorSpec) -> Layout:
    """The points of the sensor ``spec`` on ``surface``.

    ``spacing_mm=None``: the FE nodes inside the window (weights select them). Else a
    regular grid centred on the window's centre (``centre_deg``, ``centre_mm``; 0, 0:
    the contact centre and the crown): circumferential step
    ``spacing_mm / crown_radius`` radians, meridional step ``spacing_mm``; clipped to the
    window and to the surface (a sector model's columns, the meridian's ends).

    Raises
    ------
    ParameterError
        Fewer than 3 x 3 points fall inside (CST strain needs neighbours), or more than
        :data:`MAX_POINTS`.
    """
    half = np.radians(spec.window_deg) / 2.0
    full = spec.window_deg == 360.0
    centre = np.radians(spec.centre_deg)
    if spec.spacing_mm is None:
        cols, theta = _node_columns(surface, half, full, centre)
        rows = _inside(surface.s - spec.centre_mm, spec.width_mm)
        s = surface.s[rows]
        periodic = full and surface.periodic
    else:
        theta, periodic = _point_columns(surface, spec.spacing_mm, half, full, centre)
        s = _point_rows(surface, spec.spacing_mm, spec.width_mm, spec.centre_mm)
    pr, pc = s.size, theta.size
    if pr < 3 or pc < 3:
        raise ParameterError(
            f"sensor {spec.name!r} sees only {pr} x {pc} points on this inner surface "
            f"(window {spec.window_deg:g}°, width {_mm(spec.width_mm)}, spacing "
            f"{_mm(spec.spacing_mm)}): at least 3 x 3 are needed; widen the window or "
            "the width, or refine the spacing")
    if pr * pc > MAX_POINTS:
        raise ParameterError(
            f"sensor {spec.name!r} has {pr} x {pc} = {pr * pc} points, more than "
            f"{MAX_POINTS}: coarsen spacing_mm or narrow the window")
    if spec.spacing_mm is None:
        index = surface.node_index[np.ix_(rows, cols)].ravel()
        weights = sp.csr_matrix((np.ones(index.size), (np.arange(index.size), index)),
                                shape=(index.size, surface.n_nodes))
    else:
        T, S = np.meshgrid(theta, s)
        weights = face_weights(surface, T.ravel(), S.ravel())
    xyz = weights @ surface.node_xyz
    return Layout(theta, s, xyz.reshape(pr, pc, 3), weights, bool(periodic))


def face_weights(surface: InnerSurface, theta: np.ndarray, s: np.ndarray) -> sp.csr_matrix:
    """Bilinear shape functions of the surface's faces at points (theta, s).

    Parameters
    ----------
    theta, s : ndarray, shape (M,)
        Angles (radians, any branch) and meridional arc lengths (mm) of the points.
        Points beyond the surface (past a sector's edge columns, the meridian's ends)
        are clamped onto its edge.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (M, N)
        Row m: the four shape functions of the face holding point m at its nodes (in
        the store's ``inner_node`` order); each row sums to 1. On a periodic surface the
        face between the last and the first column is one like any other.
    """
    theta = np.asarray(theta, dtype=float).ravel()
    s = np.asarray(s, dtype=float).ravel()
    j, j1, lo, hi, t = column_cells(surface, theta)
    u = np.clip((t - lo) / (hi - lo), 0.0, 1.0)
    i, v = _cells(surface.s, s)
    idx = surface.node_index
    cols = np.stack([idx[i, j], idx[i, j1], idx[i + 1, j], idx[i + 1, j1]], axis=1)
    data = np.stack([(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v], axis=1)
    rows = np.repeat(np.arange(theta.size), 4)
    w = sp.csr_matrix((data.ravel(), (rows, cols.ravel())), shape=(theta.size, surface.n_nodes))
    w.eliminate_zeros()
    return w


def column_cells(surface: InnerSurface, theta: np.ndarray):
    """The column cell of each angle.

    Parameters
    ----------
    surface : InnerSurface
    theta : ndarray, shape (M,)
        Angles in radians, any branch.

    Returns
    -------
    j, j1 : ndarray of int, shape (M,)
        The cell's columns (``j1 = j + 1``, or 0 across a periodic surface's index seam).
    lo, hi : ndarray, shape (M,)
        Their angles on the branch of ``t`` (``lo < hi``).
    t : ndarray, shape (M,)
        ``theta`` on the branch of :attr:`InnerSurface.angles` (a sector: the branch
        nearest it; beyond its edge columns ``t`` lies outside [lo, hi]).
    """
    a = surface.angles
    if surface.periodic:
        edges = np.append(a, a[0] + TWO_PI)
        t = a[0] + np.mod(theta - a[0], TWO_PI)
    else:
        edges = a
        mid = 0.5 * (a[0] + a[-1])
        t = mid + wrap_angle(theta - mid)  # the branch nearest the sector
    j = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, edges.size - 2)
    return j, (j + 1) % a.size, edges[j], edges[j + 1], t


def interpolate(layout: Layout, field: np.ndarray) -> np.ndarray:
    """A nodal field at the sensor's points.

    Parameters
    ----------
    layout : Layout
    field : ndarray, shape (K, N, c) or (N, c)
        Values at the N inner nodes (store order), c components.

    Returns
    -------
    ndarray, shape (K, pr, pc, c) (or (pr, pc, c) for a 2-d field)
    """
    f = np.asarray(field, dtype=float)
    single = f.ndim == 2
    if single:
        f = f[None]
    N = layout.weights.shape[1]
    if f.ndim != 3 or f.shape[1] != N:
        raise ParameterError(f"a field for this sensor must have shape (K, {N}, c) or "
                             f"({N}, c) (one value per inner node), got {np.shape(field)}")
    K, _, c = f.shape
    pr, pc = layout.shape
    out = np.empty((K, pr, pc, c))
    step = max(1, _CHUNK // max(N * c, 1))
    for k in range(0, K, step):
        part = f[k:k + step]
        flat = part.transpose(1, 0, 2).reshape(N, -1)  # (N, k * c)
        res = layout.weights @ flat  # (P, k * c)
        out[k:k + step] = res.reshape(pr, pc, part.shape[0], c).transpose(2, 0, 1, 3)
    return out[0] if single else out


def _mm(value: float | None) -> str:
    return "none (FE nodes)" if value is None else f"{value:g} mm"


def _cells(edges: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell index (M,) in ``edges`` (increasing) and normalised coordinate in [0, 1]."""
    i = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)
    u = np.clip((x - edges[i]) / (edges[i + 1] - edges[i]), 0.0, 1.0)
    return i, u


def _inside(values: np.ndarray, width: float | None) -> np.ndarray:
    """Indices of ``values`` within +-width/2 (all for None)."""
    if width is None:
        return np.arange(values.size)
    return np.flatnonzero(np.abs(values) <= width / 2.0 + _TOL * max(width, 1.0))


def _node_columns(surface: InnerSurface, half: float, full: bool, centre: float = 0.0):
    """Columns inside the window about ``centre`` (radians), in angle order, and their
    angles."""
    if surface.periodic:
        d = wrap_angle(surface.angles - (0.0 if full else centre))
        keep = np.arange(d.size) if full else np.flatnonzero(np.abs(d) <= half + _TOL)
        keep = keep[np.argsort(d[keep], kind="stable")]
        return keep, d[keep] + (0.0 if full else centre)
    d = surface.angles
    keep = np.arange(d.size) if full else np.flatnonzero(np.abs(d - centre) <= half + _TOL)
    return keep, d[keep]


def _point_columns(surface: InnerSurface, spacing: float, half: float, full: bool,
                   centre: float = 0.0):
    """Angles of the point columns (pc,) and whether they wrap around; a window short of
    the circle is a grid about ``centre`` (radians)."""
    step = spacing / surface.crown_radius
    if full and surface.periodic:
        ratio = TWO_PI / step
        n = round(ratio)
        if abs(ratio - n) <= 1e-6 * ratio and n >= 3:
            k = np.arange(-n // 2 + 1, n // 2 + 1)  # angles in (-pi, pi]: each column once
            return k * (TWO_PI / n), True
        k = np.arange(np.ceil(-np.pi / step + _TOL), np.floor(np.pi / step + _TOL) + 1)
        theta = k * step
        theta = theta[theta > -np.pi + _TOL]  # -pi is +pi
        return theta, False
    if full:
        centre = 0.0
    lo, hi = centre - half, centre + half
    if not surface.periodic:
        lo, hi = max(lo, surface.angles[0]), min(hi, surface.angles[-1])
    k = np.arange(np.ceil((lo - centre) / step - _TOL),
                  np.floor((hi - centre) / step + _TOL) + 1)
    theta = centre + k * step
    if full:
        theta = theta[theta > -np.pi + _TOL]
    return theta, False


def _point_rows(surface: InnerSurface, spacing: float, width: float | None,
               centre: float = 0.0) -> np.ndarray:
    """Meridional arc lengths of the point rows (pr,), a grid about ``centre`` (mm from
    the crown)."""
    lo, hi = surface.s[0], surface.s[-1]
    if width is not None:
        lo, hi = max(lo, centre - width / 2.0), min(hi, centre + width / 2.0)
    k = np.arange(np.ceil((lo - centre) / spacing - _TOL),
                  np.floor((hi - centre) / spacing + _TOL) + 1)
    return centre + k * spacing
