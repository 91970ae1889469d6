"""What a force model learns from and predicts: the targets a store holds, the
displacements the camera measures, and the features of noisy measurements (issue 27).

Shared by ``farm analyse sensor`` (:mod:`analysis.studies.sensor`), ``farm fit``
(:mod:`analysis.camera.predictor`), ``farm measure`` and ``farm mismatch``, so that each
trains and scores on the same rows:

- :data:`TARGETS` and :func:`targets`: Fx, Fy, Fz (N) and Mz (N mm) of each experiment;
- :func:`displacements`: the inner-surface displacements a virtual T2Cam measures;
- :func:`measured_features`: features of ``draws`` noisy measurements of each experiment
  (a model applied to measurements is trained on measurements).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.camera.sensor import VirtualSensor
from analysis.camera.sensor.model import INPUTS
from analysis.data import TOTALS, totals
from analysis.errors import MissingVariableError

__all__ = ["TARGETS", "UNITS", "displacements", "measured_features", "targets"]

TARGETS = ("Fx", "Fy", "Fz", "Mz")
UNITS = {"Fx": "N", "Fy": "N", "Fz": "N", "Mz": "N mm"}


def targets(ds: xr.Dataset) -> np.ndarray:
    """(K, 4): Fx, Fy, Fz (N) from ``total_force``, Mz (N mm) from ``moment``."""
    if "displacement" not in ds:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no 'displacement'")
    return totals(ds)[:, [TOTALS.index(name) for name in ("Fx", "Fy", "Fz", "Mz")]]


def displacements(ds: xr.Dataset) -> np.ndarray:
    """(K, N, 3) inner-surface displacements in the store's node order."""
    arr = ds["displacement"].transpose("experiment", "inner_node", "component")
    return np.asarray(arr.sel(component=["x", "y", "z"]).values, dtype=float)


def measured_features(virtual: VirtualSensor, clean: np.ndarray, draws: int,
                      rng: np.random.Generator, inputs=INPUTS) -> tuple[np.ndarray, list[int]]:
    """Features of ``draws`` noisy measurements of each experiment, stacked draw by draw,
    from the point displacements ``clean`` (K, pr, pc, 3) of :meth:`VirtualSensor.clean`;
    0 draws, or a noise-free sensor: the noise-free measurement once.

    Returns ``(X, blocks)``: X of shape (K x draws, n_features), the column count of each
    input.
    """
    if draws == 0 or not virtual.spec.noisy:
        return virtual.features(*virtual.measure(clean, None), inputs)
    parts = [virtual.features(*virtual.measure(clean, rng), inputs) for _ in range(draws)]
    return np.concatenate([p[0] for p in parts]), parts[0][1]
