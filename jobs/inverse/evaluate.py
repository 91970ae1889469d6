"""What a worker solves for an inverse loop, and the content hashes that name it.

Three kinds of evaluation, each a plain picklable task and a function returning numpy
arrays (cached by :class:`jobs.loops.cache.EvaluationCache`):

- :func:`reference`: the virtual experiment, the reduced model pushed onto the
  iterative road (thesis §4.2);
- :func:`forward`: the forward model, vertical forces x on the unknown nodes
  (:func:`farm.solve.forces.solve_applied_forces`), one ccx run;
- :func:`prescribed`: vertical displacements prescribed on the unknown nodes; their
  reactions are the thickness-offset initial guess (§5.2/§6.2).

A key hashes everything that changes a result: the model spec and its mesh's key
(which covers the mesher's code, :mod:`farm.mesh.version`), the nodes, the forces
(or displacements) rounded canonically, the contact-centre height, the solver version
and the version of the outputs. The task solves the rounded values, so a cached result
is exactly the result of its key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from farm.experiment import run_load_path
from farm.measure.measurement import measure
from farm.mesh import mesh_for
from farm.mesh.version import mesh_key
from farm.solve.forces import solve_applied_forces, solve_prescribed_uz
from farm.specs import LoadPath, ModelSpec, SolverSettings, content_hash
from jobs.loops.guard import guarded
from jobs.tasks import cancellation_check

OUTPUTS_VERSION = 1  # bump when the arrays an evaluation returns change
DIGITS = 9  # forces in N and displacements in mm are rounded to 1e-9 for keys and decks


def canonical(values) -> tuple[float, ...]:
    """Values rounded to :data:`DIGITS` decimals, -0.0 made 0.0 (hash- and deck-stable)."""
    return tuple(float(v) + 0.0 for v in np.round(np.asarray(values, dtype=float), DIGITS))


@dataclass(frozen=True)
class ReferenceTask:
    model: dict
    deflection: float
    settings: SolverSettings


@dataclass(frozen=True)
class ForwardTask:
    model: dict
    nodes: tuple[int, ...]
    forces: tuple[float, ...]
    road_z: float
    settings: SolverSettings


@dataclass(frozen=True)
class PrescribedTask:
    model: dict
    nodes: tuple[int, ...]
    uz: tuple[float, ...]
    road_z: float
    settings: SolverSettings


def _key(kind: str, task, solver: str) -> str:
    body = {k: v for k, v in dataclasses.asdict(task).items() if k != "settings"}
    return content_hash({"kind": kind, "solver": solver, "outputs": OUTPUTS_VERSION,
                         "mesh": mesh_key(ModelSpec.from_dict(task.model)), **body})


def reference_key(task: ReferenceTask, solver: str) -> str:
    return _key("inverse-reference", task, solver)


def forward_key(task: ForwardTask, solver: str) -> str:
    return _key("inverse-forward", task, solver)


def prescribed_key(task: PrescribedTask, solver: str) -> str:
    return _key("inverse-prescribed", task, solver)


def _arrays(m, seconds: float) -> dict[str, np.ndarray]:
    return {"displacement": m.displacement, "strain": m.strain,
            "tread_force": m.reaction_force, "total_force": m.total_force,
            "moment": m.moment, "support_reaction": m.road_reaction,
            "seconds": np.array(seconds)}


def reference(task: ReferenceTask) -> dict[str, np.ndarray]:
    """The virtual experiment: reduced model, iterative road, one deflection."""
    spec = ModelSpec.from_dict(task.model)

    def solve(settings):
        result = run_load_path(spec, LoadPath((task.deflection,)), settings,
                               should_stop=cancellation_check())
        return _arrays(result.measurements[0], result.solve_seconds) | {
            "ccx_runs": np.array(result.ccx_runs)}

    return guarded(solve, task.settings)


def forward(task: ForwardTask) -> dict[str, np.ndarray]:
    """The forward model: vertical forces on the unknown nodes, one ccx run."""
    spec = ModelSpec.from_dict(task.model)
    mesh = mesh_for(spec)

    def solve(settings):
        sol = solve_applied_forces(spec, mesh, np.array(task.nodes), np.array(task.forces),
                                   settings, road_z=task.road_z,
                                   should_stop=cancellation_check())
        return _arrays(measure(mesh, sol, 0.0)[0], sol.solve_seconds)

    return guarded(solve, task.settings)


def prescribed(task: PrescribedTask) -> dict[str, np.ndarray]:
    """Vertical displacements prescribed on the unknown nodes; returns their reactions."""
    spec = ModelSpec.from_dict(task.model)
    mesh = mesh_for(spec)

    def solve(settings):
        sol = solve_prescribed_uz(spec, mesh, dict(zip(task.nodes, task.uz, strict=True)),
                                  settings, road_z=task.road_z,
                                  should_stop=cancellation_check())
        return _arrays(measure(mesh, sol, 0.0)[0], sol.solve_seconds)

    return guarded(solve, task.settings)
