"""Does the virtual camera's reference cloud matter? Measured on a store (issue 46).

T2Cam measures against a cloud of the inflated, unloaded tyre (thesis §2.2). The store's
``displacement`` and ``surface_strain`` are taken from that state
(:func:`farm.measure.measurement.measure`), but :class:`~.model.VirtualSensor` places its
points on the mesh as built (``inner_xyz``): its reference cloud is the *uninflated*
tyre. The displacement it measures (deformed minus reference cloud) is the store's
either way; only its CST strain is computed on the wrong geometry, by the growth under
inflation (a few mm on a 400 mm tyre, the store's ``inflation_growth``).

:func:`reference_gap` measures what that costs on a store's own experiments: the ideal
sensor's CST strain (every node in the window, no noise: the uninflated reference) against
the store's ``surface_strain`` (the same CST function on the inflated reference) at the
same nodes (the whole circumference where the window holds too few node columns),
beside how far the sensor's own noise moves the strain it measures. A gap far
below the noise does not matter to a model trained on measurements; a gap near it would.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import xarray as xr

from analysis.camera.sensor.layout import interpolate
from analysis.camera.sensor.model import VirtualSensor
from analysis.camera.sensor.spec import SensorSpec
from analysis.camera.sensor.surface import InnerSurface
from analysis.errors import MissingVariableError, ParameterError

__all__ = ["ReferenceGap", "reference_gap"]


@dataclass(frozen=True)
class ReferenceGap:
    """RMS values of surface strain (dimensionless) over the window's inner points and
    every experiment.

    Attributes
    ----------
    gap : the ideal sensor's CST strain (uninflated reference) minus the store's
        ``surface_strain`` (inflated reference).
    signal : the store's ``surface_strain`` itself.
    noise : the sensor's measured strain minus its noise-free measurement (the spec's
        own noise; 0 for a noise-free sensor).
    points, experiments : how many interior points and experiments the RMS values span.
    window_deg : the window the points lie in: the sensor's, or 360 where its window held
        too few node columns.
    """

    gap: float
    signal: float
    noise: float
    points: int
    experiments: int
    window_deg: float

    @property
    def relative(self) -> float:
        """The gap as a fraction of the signal."""
        return self.gap / self.signal if self.signal > 0 else float("nan")

    def sentence(self) -> str:
        """One line for a report."""
        against = (f"the sensor's strain noise is {self.noise:.2e} RMS "
                   f"({self.noise / self.gap:.0f}x the gap)" if self.noise > 0
                   and self.gap > 0 else "the sensor has no noise")
        return (f"The virtual camera's reference cloud is the uninflated mesh; measured "
                f"against the store's strain on the inflated tyre over {self.points} nodes "
                f"of a {self.window_deg:g}° window and {self.experiments} experiments, the "
                f"CST strain differs "
                f"by {self.gap:.2e} RMS ({100 * self.relative:.2f} % of the strain's "
                f"{self.signal:.2e}); {against}.")


def reference_gap(ds: xr.Dataset, surface: InnerSurface, U: np.ndarray, spec: SensorSpec,
                  rng: np.random.Generator) -> ReferenceGap:
    """Measure the reference cloud's effect on the strain ``spec``'s camera measures.

    Parameters
    ----------
    ds : xarray.Dataset
        A loaded group holding ``surface_strain``.
    surface : InnerSurface
        Its inner surface (:meth:`InnerSurface.from_dataset`).
    U : ndarray, shape (K, N, 3)
        Its displacements (:func:`analysis.camera.features.displacements`).
    spec : SensorSpec
        The camera; its window and width bound the points, its noise the comparison.
    rng : numpy.random.Generator
        The noise of the noisy measurement.
    """
    if "surface_strain" not in ds:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no "
                                   "'surface_strain': the reference's effect is measured on it")
    ideal = _ideal(spec, surface)
    clean = ideal.clean(U)
    measured = ideal.features(*ideal.measure(clean, None), ["surface_strain"])[0]
    stored = np.asarray(ds["surface_strain"].transpose("experiment", "inner_node", ...)
                        .values, dtype=float)
    truth = interpolate(ideal.layout, stored)  # the nodes' own values (K, pr, pc, 3)
    K, pr, pc, _ = truth.shape
    mine = measured.reshape(K, 3, pr, pc).transpose(0, 2, 3, 1)
    inner = _interior(pr, pc, ideal.layout.periodic)
    gap = _rms((mine - truth)[:, inner])
    return ReferenceGap(gap=gap, signal=_rms(truth[:, inner]),
                        noise=_noise(VirtualSensor(spec, surface), U, rng),
                        points=int(inner.sum()), experiments=K,
                        window_deg=ideal.spec.window_deg)


def _ideal(spec: SensorSpec, surface: InnerSurface) -> VirtualSensor:
    """The noise-free sensor at the FE nodes of ``spec``'s window; the whole circumference
    where the window holds too few node columns (a coarse mesh: 16 elements round leave
    one column in 40°)."""
    exact = replace(spec.noise_free(), spacing_mm=None)
    try:
        return VirtualSensor(exact, surface)
    except ParameterError:
        return VirtualSensor(replace(exact, window_deg=360.0, centre_deg=0.0), surface)


def _interior(pr: int, pc: int, periodic: bool) -> np.ndarray:
    """(pr, pc) mask without the window's edge rows and columns, where the CST has fewer
    triangles than the store's (a seam-spanning window keeps its columns)."""
    mask = np.zeros((pr, pc), dtype=bool)
    mask[1:-1, :] = True
    if not periodic:
        mask[:, [0, -1]] = False
    return mask


def _noise(sensor: VirtualSensor, U: np.ndarray, rng: np.random.Generator) -> float:
    """RMS of the sensor's measured strain minus its noise-free measurement."""
    if not sensor.spec.noisy:
        return 0.0
    clean = sensor.clean(U)
    noisy = sensor.features(*sensor.measure(clean, rng), ["surface_strain"])[0]
    exact = sensor.features(*sensor.measure(clean, None), ["surface_strain"])[0]
    return _rms(noisy - exact)


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(a))))
