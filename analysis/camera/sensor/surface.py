"""The FE inner surface (the cavity wall the camera looks at) as a structured grid.

The store lists the inner-surface nodes with their reference positions ``inner_xyz`` and
their places ``inner_row`` (meridian, from the -y bead) and ``inner_col`` (circumference,
angle increasing towards +x) on a structured grid (docs/schema.md). The mesh is a
revolve about the tyre axis y, so every column has one angle and every row one
meridional arc length: the grid is parametrised by ``(theta, s)``, which is what the
virtual T2Cam (thesis §2.2) places its points by.

Angles are ``theta = arctan2(x, -z)`` (0 at the contact centre under the wheel centre,
as :func:`farm.measure.surface.surface_frames`). A full tyre's columns cover 360° and
wrap around (periodic); a reduced model covers a sector.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import xarray as xr

from analysis.errors import MissingVariableError, ParameterError

__all__ = ["InnerSurface", "wrap_angle"]

TWO_PI = 2.0 * np.pi


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Angles (radians) mapped into (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), TWO_PI)


@dataclass(frozen=True, eq=False)
class InnerSurface:
    """The inner surface's structured grid in the reference (inflated, unloaded) state.

    Parameters
    ----------
    xyz : ndarray, shape (rows, cols, 3)
        Reference node positions (mm); rows along the meridian (from the -y bead),
        columns around the axis (angle increasing towards +x).
    theta : ndarray, shape (cols,)
        Angle of each column, ``arctan2(x, -z)`` in radians, in (-pi, pi].
    s : ndarray, shape (rows,)
        Meridional arc length of each row (mm), strictly increasing, 0 at the crown
        (y = 0, interpolated).
    periodic : bool
        Whether the columns cover the circle (full tyre): column ``cols - 1`` then
        neighbours column 0.
    node_index : ndarray of int, shape (rows, cols)
        Position of each grid node in the store's ``inner_node`` order.
    """

    xyz: np.ndarray
    theta: np.ndarray
    s: np.ndarray
    periodic: bool
    node_index: np.ndarray

    def __post_init__(self) -> None:
        xyz = np.asarray(self.xyz, dtype=float)
        theta = np.asarray(self.theta, dtype=float)
        s = np.asarray(self.s, dtype=float)
        index = np.asarray(self.node_index)
        if xyz.ndim != 3 or xyz.shape[2] != 3 or min(xyz.shape[:2]) < 2:
            raise ParameterError(f"inner surface xyz must have shape (rows >= 2, cols >= 2, "
                                 f"3), got {xyz.shape}")
        rows, cols = xyz.shape[:2]
        if theta.shape != (cols,) or s.shape != (rows,) or index.shape != (rows, cols):
            raise ParameterError(f"inner surface of {rows} x {cols} nodes needs theta "
                                 f"({cols},), s ({rows},) and node_index ({rows}, {cols}), "
                                 f"got {theta.shape}, {s.shape} and {index.shape}")
        if not (np.isfinite(xyz).all() and np.isfinite(theta).all() and np.isfinite(s).all()):
            raise ParameterError("inner surface xyz, theta and s must be finite")
        if not np.array_equal(np.sort(index.ravel()), np.arange(index.size)):
            raise ParameterError(f"inner surface node_index must number the {index.size} "
                                 f"nodes 0..{index.size - 1}, each once")
        if np.any(np.diff(s) <= 0.0):
            raise ParameterError("inner surface rows must have strictly increasing meridional "
                                 "arc length s (two rows coincide?)")
        object.__setattr__(self, "xyz", xyz)
        object.__setattr__(self, "theta", theta)
        object.__setattr__(self, "s", s)
        object.__setattr__(self, "node_index", index.astype(np.int64))
        object.__setattr__(self, "periodic", bool(self.periodic))
        if np.any(np.diff(self.angles) <= 0.0):
            raise ParameterError("inner surface columns must increase in angle towards +x "
                                 "(inner_col order)")

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the grid."""
        return self.xyz.shape[0], self.xyz.shape[1]

    @property
    def n_nodes(self) -> int:
        """Number of inner nodes (N of the store's fields)."""
        return int(self.node_index.size)

    @cached_property
    def angles(self) -> np.ndarray:
        """Column angles unwrapped along the columns, (cols,) in radians, strictly
        increasing, shifted by a multiple of 2 pi so their mid-range lies in (-pi, pi]
        (a sector about the contact centre reads about 0)."""
        a = np.unwrap(self.theta)
        mid = 0.5 * (a[0] + a[-1])
        return a + (wrap_angle(mid) - mid)

    @cached_property
    def node_xyz(self) -> np.ndarray:
        """Reference positions in the store's ``inner_node`` order, (N, 3)."""
        out = np.empty((self.n_nodes, 3))
        out[self.node_index.ravel()] = self.xyz.reshape(-1, 3)
        return out

    @cached_property
    def profile(self) -> np.ndarray:
        """Meridian profile, (rows, 2): radius ``sqrt(x**2 + z**2)`` and ``y`` of each row
        (mm), averaged over the columns (one value per row for a revolve)."""
        r = np.hypot(self.xyz[..., 0], self.xyz[..., 2]).mean(axis=1)
        return np.column_stack([r, self.xyz[..., 1].mean(axis=1)])

    @cached_property
    def crown_radius(self) -> float:
        """Inner radius at the crown (s = 0), mm: the radius at which the sensor's
        circumferential spacing is an arc length."""
        return float(np.interp(0.0, self.s, self.profile[:, 0]))

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> InnerSurface:
        """The inner surface of a store group (``inner_xyz``, ``inner_row``, ``inner_col``).

        Raises
        ------
        MissingVariableError
            The group lacks one of the three variables.
        ParameterError
            Rows and columns do not form a full grid.
        """
        missing = [v for v in ("inner_xyz", "inner_row", "inner_col") if v not in ds]
        if missing:
            raise MissingVariableError(
                f"group {ds.attrs.get('group', '?')!r} has no {', '.join(missing)}: the "
                "virtual sensor needs the inner surface's grid (re-measure the group with "
                "a farm that writes inner_row/inner_col)")
        arr = ds["inner_xyz"].transpose("inner_node", "component")
        if "component" in arr.coords:
            arr = arr.sel(component=["x", "y", "z"])
        xyz = np.asarray(arr.values, dtype=float)
        row = np.asarray(ds["inner_row"].values).astype(np.int64)
        col = np.asarray(ds["inner_col"].values).astype(np.int64)
        return cls.from_arrays(xyz, row, col)

    @classmethod
    def from_arrays(cls, xyz: np.ndarray, row: np.ndarray, col: np.ndarray) -> InnerSurface:
        """The surface from node positions (N, 3) and grid places ``row``, ``col`` (N,).

        Rows and columns are ranked by their index (gaps allowed); columns are ordered
        by index, never by angle, so a grid across the +-pi seam stays in order.
        """
        xyz = np.asarray(xyz, dtype=float)
        n = xyz.shape[0]
        if xyz.shape != (n, 3) or np.shape(row) != (n,) or np.shape(col) != (n,):
            raise ParameterError(f"inner surface needs xyz (N, 3), row (N,) and col (N,), "
                                 f"got {xyz.shape}, {np.shape(row)} and {np.shape(col)}")
        rows, r = np.unique(row, return_inverse=True)
        cols, c = np.unique(col, return_inverse=True)
        index = np.full((rows.size, cols.size), -1, dtype=np.int64)
        index[r, c] = np.arange(n)
        if rows.size * cols.size != n or (index < 0).any():
            raise ParameterError(f"inner_row/inner_col of {n} nodes do not form a full "
                                 f"{rows.size} x {cols.size} grid (one node per row and "
                                 "column)")
        grid = xyz[index]
        theta = _column_angles(grid)
        s = _meridian(grid)
        return cls(grid, theta, s, _is_periodic(theta), index)


def _column_angles(grid: np.ndarray) -> np.ndarray:
    """(cols,) angle of each column, the circular mean over its nodes, in (-pi, pi]."""
    phi = np.arctan2(grid[..., 0], -grid[..., 2])
    return wrap_angle(np.angle(np.exp(1j * phi).mean(axis=0)))


def _meridian(grid: np.ndarray) -> np.ndarray:
    """(rows,) meridional arc length (mm), 0 where the profile crosses y = 0 (the crossing
    nearest the middle of the meridian; the row nearest y = 0 if none)."""
    r = np.hypot(grid[..., 0], grid[..., 2]).mean(axis=1)
    y = grid[..., 1].mean(axis=1)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(r), np.diff(y)))])
    i = np.flatnonzero((y[:-1] <= 0.0) & (y[1:] >= 0.0) | (y[:-1] >= 0.0) & (y[1:] <= 0.0))
    if i.size:
        i = i[np.argmin(np.abs(s[i] - 0.5 * s[-1]))]
        dy = y[i + 1] - y[i]
        t = 0.0 if dy == 0.0 else -y[i] / dy
        s0 = s[i] + t * (s[i + 1] - s[i])
    else:
        s0 = s[np.argmin(np.abs(y))]
    return s - s0


def _is_periodic(theta: np.ndarray) -> bool:
    """Whether columns (ordered by index) close the circle: the gap from the last to the
    first column is no larger than 1.5 times the largest spacing between columns."""
    a = np.unwrap(theta)
    steps = np.diff(a)
    gap = a[0] + TWO_PI - a[-1]
    return bool(steps.size >= 2 and 0.0 < gap <= 1.5 * steps.max() + 1e-9)
