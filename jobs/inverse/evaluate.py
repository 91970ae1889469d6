"""What a worker solves for an inverse loop, and the keys that name it.

Three kinds of evaluation, each a plain picklable task and a function returning a typed
result (:class:`jobs.guard.Solved` of one :class:`~farm.measure.measurement.Measurement`,
or :class:`jobs.guard.Failed`), cached by :class:`jobs.loops.cache.EvaluationCache`:

- :func:`reference`: the virtual experiment, the reduced model pushed onto the
  iterative road (thesis §4.2);
- :func:`forward`: the forward model, vertical forces x on the unknown nodes
  (:func:`farm.solve.forces.solve_applied_forces`), one ccx run;
- :func:`prescribed`: vertical displacements prescribed on the unknown nodes; their
  reactions are the thickness-offset initial guess (§5.2/§6.2).

Keys come from :func:`jobs.identity.evaluation_key`: model, mesh key, solver version,
the version of the outputs, and the task (nodes, forces or displacements rounded
canonically, the contact-centre height). The task solves the rounded values, so a
cached result is exactly the result of its key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from farm.experiment import run_load_path
from farm.measure.measurement import measure
from farm.mesh import mesh_for
from farm.solve.forces import solve_applied_forces, solve_prescribed_uz
from farm.specs import LoadPath, ModelSpec, SolverSettings
from jobs.guard import Result, Solved, cancellation_check, guarded
from jobs.identity import evaluation_key

OUTPUTS_VERSION = 2  # bump when what an evaluation returns changes (2: typed Measurement)


@dataclass(frozen=True)
class ReferenceTask:
    model: ModelSpec
    deflection: float
    settings: SolverSettings


@dataclass(frozen=True)
class ForwardTask:
    model: ModelSpec
    nodes: tuple[int, ...]
    forces: tuple[float, ...]
    road_z: float
    settings: SolverSettings


@dataclass(frozen=True)
class PrescribedTask:
    model: ModelSpec
    nodes: tuple[int, ...]
    uz: tuple[float, ...]
    road_z: float
    settings: SolverSettings


def task_key(kind: str, task, solver: str) -> str:
    """Key of an inverse task: everything but the model (an ingredient) and the settings."""
    body = {f.name: getattr(task, f.name) for f in dataclasses.fields(task)
            if f.name not in ("model", "settings")}
    return evaluation_key(kind, task.model, solver, OUTPUTS_VERSION, body)


def reference(task: ReferenceTask) -> Result:
    """The virtual experiment: reduced model, iterative road, one deflection."""
    def solve(settings):
        r = run_load_path(task.model, LoadPath((task.deflection,)), settings,
                          should_stop=cancellation_check())
        return Solved(r.measurements, r.solve_seconds, r.ccx_runs, r.increments)

    return guarded(solve, task.settings)


def forward(task: ForwardTask) -> Result:
    """The forward model: vertical forces on the unknown nodes, one ccx run."""
    mesh = mesh_for(task.model)

    def solve(settings):
        sol = solve_applied_forces(task.model, mesh, np.array(task.nodes),
                                   np.array(task.forces), settings, road_z=task.road_z,
                                   should_stop=cancellation_check())
        return Solved(tuple(measure(mesh, sol, 0.0)), sol.solve_seconds)

    return guarded(solve, task.settings)


def prescribed(task: PrescribedTask) -> Result:
    """Vertical displacements prescribed on the unknown nodes; returns their reactions."""
    mesh = mesh_for(task.model)

    def solve(settings):
        sol = solve_prescribed_uz(task.model, mesh, dict(zip(task.nodes, task.uz, strict=True)),
                                  settings, road_z=task.road_z,
                                  should_stop=cancellation_check())
        return Solved(tuple(measure(mesh, sol, 0.0)), sol.solve_seconds)

    return guarded(solve, task.settings)
