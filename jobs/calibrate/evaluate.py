"""The worker task of a calibration: one load path of one parameter set, and its key."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from farm.experiment import run_load_path
from farm.mesh.version import mesh_key
from farm.specs import LoadPath, ModelSpec, SolverSettings, content_hash
from jobs.loops.evaluator import Evaluation
from jobs.loops.guard import guarded
from jobs.tasks import cancellation_check

OUTPUTS_VERSION = 1


@dataclass(frozen=True)
class CurveTask:
    """A load path (pressure in MPa, deflections in mm) of the model ``model`` (a dict)."""

    model: dict
    deflections: tuple[float, ...]
    pressure: float
    settings: SolverSettings


def curve(task: CurveTask) -> dict[str, np.ndarray]:
    """Fz (N) at each deflection of the path; deterministic failures as data."""
    def solve(settings):
        spec = ModelSpec.from_dict(task.model)
        result = run_load_path(spec, LoadPath(task.deflections, task.pressure), settings,
                               should_stop=cancellation_check())
        return {"fz": np.array([m.total_force[2] for m in result.measurements]),
                "seconds": np.array(result.solve_seconds),
                "ccx_runs": np.array(result.ccx_runs)}

    return guarded(solve, task.settings)


def curve_evaluation(model: ModelSpec, deflections, pressure: float,
                     settings: SolverSettings, solver: str) -> Evaluation:
    task = CurveTask(model.to_dict(), tuple(float(d) for d in deflections), float(pressure),
                     settings)
    body = {k: v for k, v in dataclasses.asdict(task).items() if k != "settings"}
    key = content_hash({"kind": "calibration-curve", "solver": solver,
                        "mesh": mesh_key(model), "outputs": OUTPUTS_VERSION, **body})
    return Evaluation(key, curve, task, "calibrate-curve")
