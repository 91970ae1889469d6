"""The worker task of a calibration: one load path of one parameter set, and its key."""

from __future__ import annotations

from dataclasses import dataclass

from farm.experiment import run_load_path
from farm.specs import LoadPath, ModelSpec, SolverSettings
from jobs.guard import Result, Solved, cancellation_check, guarded
from jobs.identity import evaluation_key
from jobs.loops.evaluator import Evaluation

OUTPUTS_VERSION = 2  # 2: typed results, every measurement of the path


@dataclass(frozen=True)
class CurveTask:
    """A load path (pressure in MPa, deflections in mm) of ``model``."""

    model: ModelSpec
    deflections: tuple[float, ...]
    pressure: float
    settings: SolverSettings


def curve(task: CurveTask) -> Result:
    """The measurements at each deflection of the path; deterministic failures as data."""
    def solve(settings):
        r = run_load_path(task.model, LoadPath(task.deflections, task.pressure), settings,
                          should_stop=cancellation_check())
        return Solved(r.measurements, r.solve_seconds, r.ccx_runs, r.increments)

    return guarded(solve, task.settings)


def curve_evaluation(model: ModelSpec, deflections, pressure: float,
                     settings: SolverSettings, solver: str) -> Evaluation:
    task = CurveTask(model, tuple(float(d) for d in deflections), float(pressure), settings)
    key = evaluation_key("calibration-curve", model, solver, OUTPUTS_VERSION,
                         {"deflections": task.deflections, "pressure": task.pressure})
    return Evaluation(key, curve, task, "calibrate-curve")


def fz(result: Solved):
    """Fz (N) at each deflection of a solved curve."""
    return [m.total_force[2] for m in result.measurements]
