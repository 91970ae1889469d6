"""Run a calibration on Dask (``farm calibrate``) and report what it fitted.

The client drives the least-squares loop; evaluations run on the workers (embedded
LocalCluster or ``--scheduler``), cached by content hash in ``cache`` so that a second
run, or a run resumed after the client died, replays them without ccx. After the fit,
the start and fitted models' force-deflection curves are solved side by side for the
report (one load path per pressure of the references).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from farm.specs import SolverSettings
from jobs.calibrate.evaluate import curve_evaluation
from jobs.calibrate.fit import CalibrationResult, CalibrationSettings, CalibrationState, calibrate
from jobs.calibrate.params import Parameters
from jobs.calibrate.references import ReferencePoint
from jobs.cluster import connect, dashboard_link
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluator, failed
from jobs.sweep import solver_version

POLL_SECONDS = 0.5
CURVE_DEFLECTIONS = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0)


@dataclass
class CalibrationReport:
    result: CalibrationResult
    curves: pd.DataFrame = field(default_factory=pd.DataFrame)
    dashboard: str = ""
    wall_seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return self.result.status != "failed"


def run_calibration(params: Parameters, points: Sequence[ReferencePoint], cache: str | None,
                    *, settings: SolverSettings | None = None,
                    cal: CalibrationSettings | None = None,
                    scheduler: str | None = None, workers: int | None = None,
                    curves: bool = True,
                    progress: Callable[[CalibrationState], None] | None = None
                    ) -> CalibrationReport:
    """Fit ``params`` to ``points`` on a cluster; return the fit and (optionally) curves."""
    start = time.perf_counter()
    settings = settings or SolverSettings()
    cal = cal or CalibrationSettings()
    with connect(scheduler, workers) as client:
        solver = solver_version(client, scheduler is None)
        evaluator = Evaluator(client, EvaluationCache(cache))
        state = CalibrationState(cal.max_evaluations)
        result = _in_thread(lambda: calibrate(params, points, evaluator, solver, settings,
                                              cal, state), state, progress, evaluator)
        table = _curves(params, result, points, evaluator, solver, settings) if curves \
            else pd.DataFrame()
        report = CalibrationReport(result, table, dashboard_link(client))
    report.wall_seconds = time.perf_counter() - start
    return report


def _in_thread(fn, state: CalibrationState, progress, evaluator: Evaluator):
    """Run the loop in a thread while this one reports progress (and catches Ctrl-C)."""
    box: dict = {}

    def target():
        try:
            box["result"] = fn()
        except BaseException as e:
            box["error"] = e

    thread = threading.Thread(target=target, name="calibration", daemon=True)
    thread.start()
    try:
        while thread.is_alive():
            thread.join(POLL_SECONDS)
            if progress is not None:
                progress(state)
    except BaseException:
        evaluator.close()
        thread.join()
        raise
    if "error" in box:
        raise box["error"]
    return box["result"]


def _curves(params: Parameters, result: CalibrationResult, points, evaluator: Evaluator,
            solver: str, settings: SolverSettings) -> pd.DataFrame:
    """Fz along each reference pressure's path, start vs fitted model."""
    pressures = sorted({p.pressure for p in points})
    limit = max(p.deflection for p in points)
    defl = tuple(d for d in CURVE_DEFLECTIONS if d <= max(limit, 30.0))
    labels = [("start", params.spec(np.zeros(len(params.names)))),
              ("fitted", params.spec(result.theta))]
    batch = [(label, p, curve_evaluation(spec, defl, p, settings, solver))
             for label, spec in labels for p in pressures]
    out = evaluator.run([e for _, _, e in batch])
    rows = []
    for (label, p, _), arrays in zip(batch, out, strict=True):
        fz = np.full(len(defl), np.nan) if failed(arrays) else arrays["fz"]
        rows += [{"model": label, "pressure_kpa": 1000 * p, "deflection_mm": d, "fz_n": f}
                 for d, f in zip(defl, fz, strict=True)]
    return pd.DataFrame(rows)


def parameter_table(result: CalibrationResult) -> pd.DataFrame:
    start, units = result.parameters.start(), result.parameters.units()
    return pd.DataFrame([{"parameter": n, "start": start[n], "fitted": result.values[n],
                          "ratio": result.values[n] / start[n], "units": units[n]}
                         for n in result.parameters.names])


def point_table(result: CalibrationResult) -> pd.DataFrame:
    return pd.DataFrame([{"model": p.model, "deflection_mm": p.deflection,
                          "pressure_kpa": 1000 * p.pressure, "reference_n": p.force,
                          "start_n": s, "fitted_n": f, "residual_pct": 100 * r,
                          "start_residual_pct": 100 * (s - p.force) / p.force,
                          "source": p.source}
                         for p, s, f, r in zip(result.points, result.start_forces,
                                               result.forces, result.residuals, strict=True)])
