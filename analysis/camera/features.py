"""What a force model learns from and predicts: the targets a store holds, the
displacements the camera measures, and the features of noisy measurements (issue 27).

Shared by ``farm analyse sensor`` (:mod:`analysis.studies.sensor`), ``farm fit``
(:mod:`analysis.camera.predictor`), ``farm measure`` and ``farm mismatch``, so that each
trains and scores on the same rows:

- :data:`TARGETS` and :func:`targets`: Fx, Fy, Fz (N) and Mz (N mm) of each experiment;
- :func:`displacements`: the inner-surface displacements a virtual T2Cam measures;
- :func:`measured_features`: features of ``draws`` noisy measurements of each experiment
  (a model applied to measurements is trained on measurements);
- :data:`TPMS` and :func:`pressures`: the inflation pressure a tyre-pressure sensor
  reads, a model input a real system also has (issue 47), beside the camera's.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from analysis.camera.sensor import VirtualSensor
from analysis.camera.sensor.model import INPUTS
from analysis.data import TOTALS, totals
from analysis.errors import MissingVariableError, ParameterError

__all__ = ["MODEL_INPUTS", "TARGETS", "TPMS", "UNITS", "camera_inputs", "displacements",
           "measured_features", "model_inputs", "pressures", "targets", "with_tpms"]

TARGETS = ("Fx", "Fy", "Fz", "Mz")
UNITS = {"Fx": "N", "Fy": "N", "Fz": "N", "Mz": "N mm"}
#: the inflation pressure (kPa) a TPMS reads: one feature column after the camera's
TPMS = "tpms_pressure"
#: every input a force model may read, in the order of its feature columns
MODEL_INPUTS = (*INPUTS, TPMS)


def model_inputs(tpms: bool) -> tuple[str, ...]:
    """A force model's inputs: the camera's fields, and the TPMS reading if ``tpms``."""
    return MODEL_INPUTS if tpms else INPUTS


def camera_inputs(inputs) -> tuple[str, ...]:
    """The inputs of ``inputs`` the camera measures (all but :data:`TPMS`)."""
    return tuple(i for i in inputs if i != TPMS)


def pressures(ds: xr.Dataset) -> np.ndarray:
    """(K,) each experiment's inflation pressure in kPa (the store holds MPa)."""
    if "pressure" not in ds:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no 'pressure': "
                                   "a model reading a TPMS needs each experiment's pressure")
    return 1000.0 * np.asarray(ds["pressure"].values, dtype=float)


def with_tpms(X: np.ndarray, kpa: np.ndarray | float | None, inputs) -> np.ndarray:
    """``X`` (N, F) with the TPMS reading ``kpa`` (N,) as its last column where
    ``inputs`` hold :data:`TPMS`; ``X`` unchanged otherwise."""
    if TPMS not in inputs:
        return X
    if kpa is None:
        raise ParameterError("a model reading a TPMS needs a pressure for every cloud")
    return np.column_stack([X, np.broadcast_to(np.asarray(kpa, dtype=float), X.shape[:1])])


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
