"""The virtual T2Cam: FE displacements in, the camera's features out (thesis §2.2).

A measurement of one experiment, as the T2Cam papers (2017, 2020) describe the camera:

1. :meth:`VirtualSensor.clean`: the FE displacement at the sensor's points (bilinear
   face interpolation, :mod:`analysis.camera.sensor.layout`);
2. :meth:`VirtualSensor.measure`: a noisy reference cloud of the inflated, unloaded tyre
   and a noisy deformed cloud (:mod:`analysis.camera.sensor.noise`), each its own measurement;
3. :meth:`VirtualSensor.features`: the displacement (cloud - reference) and the surface
   strain of four constant-strain triangles around each point of the two noisy clouds,
   by :func:`farm.measure.surface.cst_surface_strain` - the very function that defines
   the store's ``surface_strain`` - as one feature row per experiment.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from analysis.camera.sensor.layout import Layout, interpolate, layout
from analysis.camera.sensor.noise import correlation_factor, perturb
from analysis.camera.sensor.spec import SensorSpec
from analysis.camera.sensor.surface import InnerSurface
from analysis.errors import ParameterError
from farm.measure.surface import cst_surface_strain

__all__ = ["INPUTS", "VirtualSensor", "fill_holes"]

#: the features a sensor gives, in this order by default
INPUTS = ("displacement", "surface_strain")


class VirtualSensor:
    """A :class:`SensorSpec` placed on one inner surface.

    Parameters
    ----------
    spec : SensorSpec
    surface : InnerSurface

    Attributes
    ----------
    spec : SensorSpec
    surface : InnerSurface
    layout : Layout
        The sensor's (pr, pc) points on ``surface``.
    """

    def __init__(self, spec: SensorSpec, surface: InnerSurface) -> None:
        self.spec = spec
        self.surface = surface
        self.layout: Layout = layout(surface, spec)
        self._chol: np.ndarray | None = None

    @property
    def chol(self) -> np.ndarray | None:
        """Cholesky factor (P, P) of the correlated noise over the layout's reference
        points, computed once per sensor; None without correlated noise."""
        if self.spec.correlated_mm == 0.0:
            return None
        if self._chol is None:
            self._chol = correlation_factor(self.layout.xyz, self.spec.correlation_mm)
        return self._chol

    def clean(self, displacement: np.ndarray) -> np.ndarray:
        """Exact FE displacements at the sensor's points.

        Parameters
        ----------
        displacement : ndarray, shape (K, N, 3) or (N, 3)
            Inner-surface displacements (mm) in the store's ``inner_node`` order.

        Returns
        -------
        ndarray, shape (K, pr, pc, 3)
        """
        u = np.asarray(displacement, dtype=float)
        if u.ndim == 2:
            u = u[None]
        if u.ndim != 3 or u.shape[2] != 3:
            raise ParameterError(f"displacements must have shape (K, N, 3), got {u.shape}")
        return interpolate(self.layout, u)

    def measure(self, u_points: np.ndarray,
                rng: np.random.Generator | None = None) -> tuple[np.ndarray, np.ndarray]:
        """One reference and one deformed measurement per experiment.

        Parameters
        ----------
        u_points : ndarray, shape (K, pr, pc, 3)
            Exact point displacements (:meth:`clean`).
        rng : numpy.random.Generator, optional
            Source of the noise; None: a noise-free measurement.

        Returns
        -------
        ref_clouds : ndarray, shape (K, pr, pc, 3)
            Reference clouds of the inflated, unloaded tyre (one measurement each).
        clouds : ndarray, shape (K, pr, pc, 3)
            Deformed clouds, ``layout.xyz + u`` plus their own noise. Dropped points are
            NaN.
        """
        u = self._on_points(u_points, "point displacements")
        ref = np.broadcast_to(self.layout.xyz, u.shape)
        cur = self.layout.xyz + u
        if rng is None or not self.spec.noisy:
            return ref.copy(), cur
        chol = self.chol
        return (perturb(ref, self.spec, rng, chol),
                perturb(cur, self.spec, rng, chol))

    def features(self, ref_clouds: np.ndarray, clouds: np.ndarray,
                 inputs: Sequence[str] = INPUTS) -> tuple[np.ndarray, list[int]]:
        """Feature rows of measured clouds on the sensor's points.

        Parameters
        ----------
        ref_clouds : ndarray, shape (K, pr, pc, 3) or (pr, pc, 3)
            Reference clouds (one for all experiments if 3-d).
        clouds : ndarray, shape (K, pr, pc, 3)
            Deformed clouds; NaN marks a point the correlation missed.
        inputs : sequence of {"displacement", "surface_strain"}
            Feature blocks, in this order.

        Returns
        -------
        X : ndarray, shape (K, F)
            Per input its components concatenated component-major (every point's x,
            then y, then z; strain xx, yy, xy), points row by row (meridian-major), as
            :func:`analysis.studies.combined._field` orders the store's fields. No NaN:
            a missed point takes the mean of its valid grid neighbours, repeatedly
            (:func:`fill_holes`), as DIC software interpolates its own holes, because a
            learner needs features of one fixed length.
        blocks : list of int
            Column count of each input (3 P each).
        """
        unknown = [name for name in inputs if name not in INPUTS]
        if unknown or not len(inputs):
            raise ParameterError(f"unknown sensor input(s) {', '.join(map(repr, unknown))}; "
                                 f"choose from {', '.join(INPUTS)}")
        cur = self._on_points(clouds, "clouds")
        pr, pc = self.layout.shape
        ref = np.asarray(ref_clouds, dtype=float)
        if ref.shape == (pr, pc, 3):
            ref = np.broadcast_to(ref, cur.shape)
        if ref.shape != cur.shape:
            raise ParameterError(f"reference clouds must have shape {cur.shape} or "
                                 f"({pr}, {pc}, 3), got {ref.shape}")
        blocks = []
        for name in inputs:
            field = cur - ref if name == "displacement" else self._strain(ref, cur)
            field = fill_holes(field, self.layout.periodic)
            K, c = field.shape[0], field.shape[-1]
            blocks.append(field.reshape(K, pr * pc, c).transpose(0, 2, 1).reshape(K, -1))
        return np.concatenate(blocks, axis=1), [b.shape[1] for b in blocks]

    def _on_points(self, values, what: str) -> np.ndarray:
        """``values`` as (K, pr, pc, 3) on this sensor's points ((pr, pc, 3): K = 1)."""
        arr = np.asarray(values, dtype=float)
        if arr.ndim == 3:
            arr = arr[None]
        pr, pc = self.layout.shape
        if arr.ndim != 4 or arr.shape[1:] != (pr, pc, 3):
            raise ParameterError(f"{what} for this sensor must have shape (K, {pr}, {pc}, 3), "
                                 f"got {np.shape(values)}")
        return arr

    def sample(self, displacement: np.ndarray, rng: np.random.Generator | None = None,
               inputs: Sequence[str] = INPUTS) -> tuple[np.ndarray, list[int]]:
        """:meth:`clean`, :meth:`measure` and :meth:`features` in one: FE displacements
        (K, N, 3) -> feature rows (K, F) and block sizes."""
        return self.features(*self.measure(self.clean(displacement), rng), inputs)

    def _strain(self, ref: np.ndarray, cur: np.ndarray) -> np.ndarray:
        """CST surface strain (K, pr, pc, 3) of each pair of clouds (NaN: no valid
        triangle about a point, i.e. a missed point or all its neighbours missed)."""
        out = np.empty(cur.shape)
        with warnings.catch_warnings():  # a point without a valid triangle: nanmean of none
            warnings.simplefilter("ignore", RuntimeWarning)
            for k in range(cur.shape[0]):
                out[k] = cst_surface_strain(ref[k], cur[k], self.layout.periodic)
        return out


def fill_holes(field: np.ndarray, periodic: bool) -> np.ndarray:
    """NaN values of a gridded field replaced by the mean of their valid neighbours.

    Parameters
    ----------
    field : ndarray, shape (K, pr, pc, c)
    periodic : bool
        Whether grid columns wrap around.

    Returns
    -------
    ndarray, shape (K, pr, pc, c)
        Without NaN: each pass fills the NaN values that have a valid 4-neighbour (row
        and column neighbours), until none is left; a field without any valid value
        becomes 0.
    """
    out = np.array(field, dtype=float)
    while True:
        miss = np.isnan(out)
        if not miss.any():
            return out
        total = _neighbour_sum(np.where(miss, 0.0, out), periodic)
        count = _neighbour_sum((~miss).astype(float), periodic)
        fill = miss & (count > 0)
        if not fill.any():
            out[miss] = 0.0
            return out
        out[fill] = total[fill] / count[fill]


def _neighbour_sum(a: np.ndarray, periodic: bool) -> np.ndarray:
    """Sum of the four grid neighbours of each value of ``a`` (K, pr, pc, c); zero
    beyond the grid's edges (and across the column seam unless periodic)."""
    out = np.zeros_like(a)
    out[:, 1:] += a[:, :-1]
    out[:, :-1] += a[:, 1:]
    if periodic:
        out += np.roll(a, 1, axis=2) + np.roll(a, -1, axis=2)
    else:
        out[:, :, 1:] += a[:, :, :-1]
        out[:, :, :-1] += a[:, :, 1:]
    return out
