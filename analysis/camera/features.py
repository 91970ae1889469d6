"""What a force model learns from and predicts: the targets a store holds, the
displacements the camera measures, and the features of noisy measurements (issue 27).

Shared by ``farm analyse sensor`` (:mod:`analysis.studies.sensor`), ``farm fit``
(:mod:`analysis.camera.predictor`), ``farm measure`` and ``farm mismatch``, so that each
trains and scores on the same rows:

- :data:`TARGETS` and :func:`targets`: Fx, Fy, Fz (N) and Mz (N mm) of each experiment
  by default, any of :data:`ALL_TARGETS` on request (issue 46);
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
from analysis.free_rolling import free_rolling, free_slip_ratio

__all__ = ["ALL_TARGETS", "FREE_SLIP", "MODEL_INPUTS", "TARGETS", "TPMS", "UNITS", "camera_inputs",
           "displacements", "measured_features", "model_inputs", "pressures", "targets",
           "varying_targets", "with_tpms"]

TARGETS = ("Fx", "Fy", "Fz", "Mz")
#: the slip ratio measured from each rolling tree's own free rolling
#: (:func:`analysis.free_rolling.free_slip_ratio`), where ``slip_ratio`` is the one
#: commanded against the radius the trunk rolled with
FREE_SLIP = "free_slip_ratio"
#: every target a study may ask for (issue 46): the six forces and moments, and the
#: load case's slip ratio (commanded, and from free rolling), slip angle and camber (the
#: road's tilt) themselves
ALL_TARGETS = (*TOTALS, "slip_ratio", FREE_SLIP, "slip_angle", "tilt")
UNITS = {"Fx": "N", "Fy": "N", "Fz": "N", "Mx": "N mm", "My": "N mm", "Mz": "N mm",
         "slip_ratio": "1", FREE_SLIP: "1", "slip_angle": "deg", "tilt": "deg"}
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


def targets(ds: xr.Dataset, names=TARGETS) -> np.ndarray:
    """(K, len(names)) of :data:`ALL_TARGETS`: forces (N) from ``total_force``, moments
    (N mm) from ``moment``, the slips and the tilt from the load case's parameters
    (default: Fx, Fy, Fz, Mz)."""
    if "displacement" not in ds:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no 'displacement'")
    unknown = [n for n in names if n not in ALL_TARGETS]
    if unknown:
        raise ParameterError(f"unknown targets {unknown}: give some of {', '.join(ALL_TARGETS)}")
    forces = totals(ds)
    return np.column_stack([forces[:, TOTALS.index(n)] if n in TOTALS else _parameter(ds, n)
                            for n in names])


def _parameter(ds: xr.Dataset, name: str) -> np.ndarray:
    if name == FREE_SLIP:
        return _free_slip(ds)
    if name not in ds.variables:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no {name!r}: its "
                                   "load cases do not set it; leave it out of the targets")
    return np.asarray(ds[name].values, dtype=float)


def _free_slip(ds: xr.Dataset) -> np.ndarray:
    table = free_rolling(ds)  # one fit a tree, for the slips and for the error
    slip = free_slip_ratio(ds, table)
    if np.isnan(slip).any():
        lost = table[table["kappa0"].isna()]
        where = ", ".join(f"{p:.0f} kPa and {d:.1f} mm" for p, d in
                          zip(lost["pressure_kPa"], lost["deflection_mm"], strict=True))
        raise MissingVariableError(
            f"{FREE_SLIP}: the free rolling of {len(lost)} of {len(table)} trees is not "
            f"measured (fewer than two slips in their linear range: {where}); wait for "
            "their branches, or leave the target out")
    return slip


def varying_targets(ds: xr.Dataset) -> tuple[str, ...]:
    """The :data:`ALL_TARGETS` a group holds and that vary over its experiments (what
    ``--targets all`` asks a study to predict): every total, each parameter the group
    stores, the free slip where every tree's free rolling is measured."""
    out = []
    for name in ALL_TARGETS:
        try:
            values = targets(ds, (name,))
        except MissingVariableError:
            if name in TOTALS:
                raise  # a group without fields or forces: not a target missing
            continue
        if np.ptp(values) > 0:
            out.append(name)
    return tuple(out)


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
