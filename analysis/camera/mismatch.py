"""Model mismatch, the farm's proxy for "will it work on the real tyre?" (issue 27).

A force model trained on one tyre model (store, group: mesh, materials, preset) is
applied to point clouds that a virtual T2Cam measured on *another* one. The clouds go
through the very path ``farm predict`` takes for measured files: each cloud and its
reference cloud (both noisy, on the other model's sensor points) are resampled onto the
trained model's sensor points over the trained model's reference surface
(:func:`analysis.camera.sensor.resample.to_layout`), then featurised and predicted. The error
on the other model's experiments, beside the trained model's own held-out error, is the
growth a mismatch of model and reality would cause (as far as the other model differs
the way reality does).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import xarray as xr

from analysis.camera.features import targets
from analysis.camera.population import tyre_features
from analysis.camera.predictor import ForceModel


def mismatch(model: ForceModel, ds: xr.Dataset, *, draws: int = 1,
             seed: int = 0) -> tuple[pd.DataFrame, np.ndarray, np.ndarray]:
    """Predict every experiment of ``ds`` from ``draws`` clouds each; errors per target.

    Returns
    -------
    table : pandas.DataFrame
        Per target: RMSE and % of the training group's range (``model.info["range"]``),
        mean error (bias), interval coverage, and the trained model's own held-out %
        (``model.info["check"]`` when saved with it) and the ratio of the two; ``outside``
        the share of the clouds the model's feature domain flags (NaN for a model saved
        before issue 47), whatever the target.
    truth, predicted : ndarray of shape (K x draws, 4)
    """
    X, T = clouds(model, ds, draws=draws, seed=seed)
    P = model.predict_features(X)
    return table(model, X, T, P), T, P[list(model.targets)].to_numpy()


def clouds(model: ForceModel, ds: xr.Dataset, *, draws: int = 1, seed: int = 0,
           tpms_error: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The features (K x draws, F) of ``ds``'s experiments as ``model`` sees them (each
    tyre measured by its own camera, resampled onto the model's points) and their true
    totals (K x draws, 4). A model reading a TPMS reads each experiment's pressure
    times ``1 + tpms_error`` (a sensor that reads 10 % high: 0.1)."""
    Y = targets(ds)
    parts = tyre_features(model.virtual, ds, draws, np.random.default_rng(seed), model.inputs)
    X = np.concatenate(parts)
    if model.tpms:
        X[:, -1] *= 1.0 + tpms_error
    return X, np.tile(Y, (len(parts), 1))


def table(model: ForceModel, X: np.ndarray, T: np.ndarray,
          P: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per target, ``model``'s errors on the features ``X`` (N, F) of clouds whose true
    totals are ``T`` (N, 4): the table :func:`mismatch` returns. ``P``: the model's
    predictions of ``X`` where already made."""
    P = model.predict_features(X) if P is None else P
    # the share of these clouds the model's domain (issue 47) would flag in farm predict
    flagged = (float(np.mean([bool(w) for w in model.domain.outside(X)]))
               if model.domain is not None else float("nan"))
    # % of the *training* group's range, so the growth compares like with like (a
    # small other group has a range of its own); its own range where the model has none
    span = np.asarray(model.info.get("range", np.ptp(T, axis=0)), dtype=float)
    own = {r["target"]: r["rmse_pct_range"] for r in model.info.get("check", [])}
    out = []
    for j, name in enumerate(model.targets):
        err = P[name].to_numpy() - T[:, j]
        rmse = float(np.sqrt(np.mean(err**2)))
        pct = 100.0 * rmse / span[j] if span[j] > 0 else float("nan")
        inside = (P[f"{name}_lower"] <= T[:, j]) & (T[:, j] <= P[f"{name}_upper"])
        mine = own.get(name, float("nan"))
        out.append({"target": name, "rmse": rmse, "rmse_pct_range": pct,
                    "bias": float(err.mean()), "coverage": float(np.mean(inside)),
                    "trained_heldout_pct_range": mine,
                    "growth": pct / mine if mine and np.isfinite(mine) else float("nan"),
                    "outside": flagged})
    return pd.DataFrame(out)
