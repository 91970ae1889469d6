"""Run a calibration on Dask (``farm calibrate``) and report what it fitted.

A strategy of the one driver (:mod:`jobs.driver`): the client drives the least-squares
loop in a thread; evaluations run on the workers (embedded LocalCluster or
``--scheduler``), cached by content hash in ``cache`` so that a second run, or a run
resumed after the client died, replays them without ccx. After the fit, the start and
fitted models' force-deflection curves are solved side by side for the report (one load
path per pressure of the references).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from farm.specs import SolverSettings
from jobs.calibrate.evaluate import curve_evaluation
from jobs.calibrate.evaluate import fz as curve_fz
from jobs.calibrate.fit import CalibrationResult, CalibrationSettings, CalibrationState, calibrate
from jobs.calibrate.params import Parameters
from jobs.calibrate.references import ReferencePoint
from jobs.cluster import ClusterSpec
from jobs.driver import LoopThreads, drive
from jobs.guard import Failed
from jobs.loops.evaluator import Evaluator
from jobs.progress import Progress, RunReport, Session

CURVE_DEFLECTIONS = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0)


@dataclass
class CalibrationReport(RunReport):
    result: CalibrationResult
    curves: pd.DataFrame = field(default_factory=pd.DataFrame)

    @property
    def ok(self) -> bool:
        return self.result.status != "failed"


class Calibration(LoopThreads[CalibrationReport]):
    """The calibration strategy: one least-squares loop; the progress state is its
    :class:`CalibrationState`."""

    def __init__(self, params: Parameters, points: Sequence[ReferencePoint], cache: str | None,
                 settings: SolverSettings, cal: CalibrationSettings, curves: bool) -> None:
        super().__init__(cache)
        self.params, self.points, self.settings, self.cal = params, points, settings, cal
        self.curves = curves
        self.progress_state = CalibrationState(cal.max_evaluations)
        self.result: CalibrationResult | None = None
        self.error: BaseException | None = None

    def loops(self, session: Session) -> list[Callable[[], CalibrationResult]]:
        return [lambda: calibrate(self.params, self.points, self.started_evaluator, session.solver,
                                  self.settings, self.cal, self.progress_state)]

    def collected(self, index: int, result, error) -> None:
        self.result, self.error = result, error

    def state(self) -> CalibrationState:
        return self.progress_state

    def finish(self, session: Session) -> CalibrationReport:
        if self.error is not None:
            raise self.error
        # poll() ended once the one loop was collected: with a result, or with an error
        assert self.result is not None
        # the result's parameters: the fit may rebase a start on a bound (fit.start_inside)
        table = (_curves(self.result.parameters, self.result, self.points, self.started_evaluator,
                         session.solver, self.settings) if self.curves else pd.DataFrame())
        return CalibrationReport(self.result, table)


def run_calibration(params: Parameters, points: Sequence[ReferencePoint], cache: str | None,
                    *, settings: SolverSettings | None = None,
                    cal: CalibrationSettings | None = None,
                    scheduler: str | None = None, workers: int | None = None,
                    curves: bool = True, progress: Progress | None = None,
                    cluster: ClusterSpec | None = None) -> CalibrationReport:
    """Fit ``params`` to ``points`` on a cluster (``cluster``, e.g. SLURM, replaces
    ``scheduler``/``workers``); return the fit and (optionally) curves."""
    strategy = Calibration(params, points, cache, settings or SolverSettings(),
                           cal or CalibrationSettings(), curves)
    return drive(strategy, cluster=cluster, scheduler=scheduler, workers=workers,
                 progress=progress)


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
    for (label, p, _), outcome in zip(batch, out, strict=True):
        fz = np.full(len(defl), np.nan) if isinstance(outcome, Failed) else curve_fz(outcome)
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
