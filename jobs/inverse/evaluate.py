"""What a worker solves for an inverse loop, and the keys that name it.

Three kinds of evaluation, each a plain picklable task and a function returning a typed
result (:class:`jobs.guard.Solved` of one :class:`~farm.measure.measurement.Measurement`
per force vector, or :class:`jobs.guard.Failed`), cached by
:class:`jobs.loops.cache.EvaluationCache`:

- :func:`reference`: the virtual experiment, the reduced model pushed onto the
  iterative road (thesis §4.2);
- :func:`forward`: the forward model, vertical forces x on the unknown nodes
  (:func:`farm.solve.forces.solve_applied_forces`), one ccx run; or a continuation
  (:func:`farm.solve.continuation.solve_force_path`): from the kept state of another
  evaluation, through one or more force vectors, keeping its own last state;
- :func:`prescribed`: vertical displacements prescribed on the unknown nodes; their
  reactions are the thickness-offset initial guess (§5.2/§6.2).

Keys come from :func:`jobs.identity.evaluation_key`: model, mesh key, solver version,
the version of the outputs, and the task (nodes, forces or displacements rounded
canonically, the contact-centre height). The task solves the rounded values, so a
cached result is exactly the result of its key.
"""

from __future__ import annotations

import dataclasses
import zlib
from dataclasses import dataclass, field

import numpy as np

from farm.experiment import run_load_path
from farm.measure.measurement import measure
from farm.mesh import mesh_for
from farm.solve.continuation import solve_force_path
from farm.solve.forces import solve_applied_forces, solve_prescribed_uz
from farm.specs import LoadPath, ModelSpec, SolverSettings
from jobs.guard import Failed, Result, Solved, cancellation_check, guarded
from jobs.identity import evaluation_key

OUTPUTS_VERSION = 2  # bump when what an evaluation returns changes (2: typed Measurement)
# zlib level of a kept solver state: a restart file of the default reduced mesh is
# 629 kB, 310 kB at level 1 in 13 ms (level 6: 303 kB)
STATE_LEVEL = 1


@dataclass(frozen=True)
class ReferenceTask:
    model: ModelSpec
    deflection: float
    settings: SolverSettings


@dataclass(frozen=True)
class ForwardTask:
    """Forces ``forces`` on ``nodes``, then each vector of ``then`` in turn (one ccx run).

    The defaults are the plain forward evaluation: one vector ramped up from rest at
    ccx's default convergence. ``keep_state`` or ``start`` make it a continuation
    (:mod:`farm.solve.continuation`, tightly converged): ``keep_state`` returns the
    last state for others to continue from; ``start`` names the evaluation whose kept
    state ``start_state`` this one continues from. ``start_state`` is not part of the
    key (``start`` is).
    """

    model: ModelSpec
    nodes: tuple[int, ...]
    forces: tuple[float, ...]
    road_z: float
    settings: SolverSettings
    then: tuple[tuple[float, ...], ...] = ()
    keep_state: bool = False
    start: str | None = None
    start_state: bytes | None = field(default=None, repr=False)

    @property
    def continued(self) -> bool:
        """A continuation (tight convergence), not the plain evaluation."""
        return self.keep_state or self.start is not None or bool(self.then)


@dataclass(frozen=True)
class PrescribedTask:
    model: ModelSpec
    nodes: tuple[int, ...]
    uz: tuple[float, ...]
    road_z: float
    settings: SolverSettings


def task_key(kind: str, task, solver: str) -> str:
    """Key of an inverse task: everything but the model (an ingredient), the settings
    and a start state's bytes (its evaluation's key stands for them). Fields at their
    defaults are left out, so the plain evaluations keep the keys they had before
    continuations existed."""
    body = {f.name: getattr(task, f.name) for f in dataclasses.fields(task)
            if f.name not in ("model", "settings", "start_state")
            and not (f.default is not dataclasses.MISSING and getattr(task, f.name) == f.default)}
    return evaluation_key(kind, task.model, solver, OUTPUTS_VERSION, body)


def reference(task: ReferenceTask) -> Result:
    """The virtual experiment: reduced model, iterative road, one deflection."""
    def solve(settings):
        r = run_load_path(task.model, LoadPath((task.deflection,)), settings,
                          should_stop=cancellation_check())
        return Solved(r.measurements, r.solve_seconds, r.ccx_runs, r.increments)

    return guarded(solve, task.settings)


def forward(task: ForwardTask) -> Result:
    """The forward model: vertical forces on the unknown nodes, one ccx run.

    A continuation that fails from its start state (after the guard's retry) is solved
    again from rest: a failure is a property of the start, not of the loads, and the
    answer is the same equilibrium either way (:mod:`farm.solve.continuation`).
    """
    if not task.continued:
        return _plain(task)
    result = _continued(task, task.start_state)
    if isinstance(result, Failed) and not result.transient and task.start_state is not None:
        result = _continued(task, None)
    return result


def _plain(task: ForwardTask) -> Result:
    mesh = mesh_for(task.model)

    def solve(settings):
        sol = solve_applied_forces(task.model, mesh, np.array(task.nodes),
                                   np.array(task.forces), settings, road_z=task.road_z,
                                   should_stop=cancellation_check())
        return Solved(tuple(measure(mesh, sol, 0.0)), sol.solve_seconds)

    return guarded(solve, task.settings)


def _continued(task: ForwardTask, start: bytes | None) -> Result:
    mesh = mesh_for(task.model)
    loads = [np.array(task.forces), *(np.array(f) for f in task.then)]

    def solve(settings):
        path = solve_force_path(task.model, mesh, np.array(task.nodes), loads, settings,
                                start=None if start is None else zlib.decompress(start),
                                keep_state=task.keep_state, road_z=task.road_z,
                                should_stop=cancellation_check())
        sol = path.solution
        kept = None if path.state is None else zlib.compress(path.state, STATE_LEVEL)
        return Solved(tuple(measure(mesh, sol, 0.0)), sol.solve_seconds, 1, sol.increments,
                      kept)

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
