"""``farm analyse surrogate``: how well a surrogate of the farm's own experiments predicts
the inner-surface field and the six totals from the load parameters (issue 28).

k-fold cross-validation of :class:`analysis.surrogate.FieldSurrogate` on a group's done
experiments: per target, the held-out RMSE in % of its range and the share of held-out
errors within two predicted standard deviations (about 95 % for an honest Gaussian).
Then the surrogate is refitted on every experiment and saved (``<out>/surrogate``, a
model directory :func:`analysis.camera.predict.persist.load_model` reads).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from sklearn.model_selection import KFold

from analysis.camera.predict.persist import save_model
from analysis.errors import MissingVariableError, NoVarianceError, TooFewExperimentsError
from analysis.render import markdown
from analysis.studies.combined import TOTALS, field_matrix, totals, varying_parameters
from analysis.studies.common import Report
from analysis.surrogate import FieldSurrogate

FIELDS = ("displacement", "strain")
#: a range below this x the largest total is floating-point round-off (as the report's
#: analysis.report.readable.ROUND_OFF)
ROUND_OFF = 1e-9


def run(ds: xr.Dataset, out: Path, *, field: str = "displacement", folds: int = 5,
        seed: int = 0, restarts: int = 3) -> Report:
    """Cross-validate, refit and save the surrogate of ``ds``; tables ``cv_errors``."""
    params = varying_parameters(ds)
    if not params:
        raise NoVarianceError(f"group {ds.attrs.get('group', '?')!r}: no load parameter "
                              "varies, so there is nothing for a surrogate to map")
    if field not in FIELDS or field not in ds:
        raise MissingVariableError(f"field {field!r} is not in the group; choose one of "
                                   f"{', '.join(f for f in FIELDS if f in ds) or 'none'}")
    n = ds.sizes["experiment"]
    if n < folds + 2:
        raise TooFewExperimentsError(f"{n} experiments are too few for {folds}-fold "
                                     f"cross-validation of a surrogate: need {folds + 2}")
    P = np.column_stack([np.asarray(ds[p].values, dtype=float) for p in params])
    F, T = field_matrix(ds, field), totals(ds)
    Y = np.hstack([F, T])
    pred, std = np.empty_like(Y), np.empty_like(Y)
    for train, test in KFold(folds, shuffle=True, random_state=seed).split(P):
        model = FieldSurrogate(n_field=F.shape[1], restarts=restarts, seed=seed)
        pred[test], std[test] = model.fit(P[train], Y[train]).predict(P[test], return_std=True)
    report = Report(Path(out))
    report.csv("cv_errors", _errors(Y, pred, std, F.shape[1], field))
    model = FieldSurrogate(n_field=F.shape[1], restarts=restarts, seed=seed).fit(P, Y)
    path = save_model(report.out / "surrogate", model, {
        "group": str(ds.attrs.get("group", "")), "inputs": params,
        "targets": [f"{field} (experiment, inner_node x 3, component-major)", *TOTALS],
        "experiment_ids": [str(e) for e in ds["experiment"].values]})
    report.files.append(path)
    _summary(report, params, n, folds, model.n_components_, field)
    return report


def _errors(Y, pred, std, n_field: int, field: str) -> pd.DataFrame:
    """One row per target (:func:`rmse_pct`), with the share within two std."""
    rows = []
    for name, (cols, pct) in rmse_pct(Y, pred, n_field, field).items():
        err, s = pred[:, cols] - Y[:, cols], std[:, cols]
        rows.append({"target": name, "rmse_pct_of_range": pct,
                     "within_2_std_pct": (100 * float(np.mean(np.abs(err) <= 2 * s))
                                          if np.isfinite(pct) else np.nan)})
    return pd.DataFrame(rows)


def rmse_pct(Y, pred, n_field: int, field: str) -> dict[str, tuple[slice, float]]:
    """Per target - the field (all its columns together), then each total - its columns
    and its RMSE in % of its range. A total whose range is round-off beside the largest
    total (Mz of a symmetric load: 1e-12 N mm beside 1e4) has no error to speak of: NaN,
    and the summary says so."""
    out = {}
    parts = [(field, slice(0, n_field))] + [(name, slice(n_field + i, n_field + i + 1))
                                            for i, name in enumerate(TOTALS)]
    largest = float(np.abs(Y[:, n_field:]).max(initial=0.0))
    for name, cols in parts:
        err, y = pred[:, cols] - Y[:, cols], Y[:, cols]
        span = float(np.ptp(y)) if y.size else 0.0
        varies = span > 0 and (name == field or span > ROUND_OFF * largest)
        rmse = float(np.sqrt(np.mean(err**2))) if y.size else np.nan
        out[name] = (cols, 100 * rmse / span if varies else np.nan)
    return out


def _summary(report: Report, params, n: int, folds: int, n_components: int,
             field: str) -> None:
    report.files.append(markdown.write(report.out / "summary.md",
                                       "Surrogate of the virtual experiments", [
        ("What was fitted",
         f"{n} done experiments; load parameters varied: {', '.join(params)}. {folds}-fold "
         f"cross-validation of a Gaussian process per PCA score of the {field} field and per "
         f"total ({n_components} scores when fitted on every experiment)."
         " 'within 2 std' is near 95 % when the predicted uncertainty is honest. An empty "
         "row is a total that does not vary beyond floating-point round-off."),
        ("Held-out errors", report.tables["cv_errors"]),
        ("Model", "The surrogate fitted on every experiment is in `surrogate/` (read it with "
         "`analysis.camera.predict.persist.load_model`)."),
    ]))
