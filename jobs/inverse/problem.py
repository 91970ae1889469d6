"""The virtual inverse problem of a study: the reference experiment and its unknowns.

Thesis §4.2: the unknowns are the vertical forces on the tread nodes in contact in the
reference virtual experiment (14 in the thesis; 16 at 30 mm on the default mesh here);
their true values are the reference's road forces on those nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from farm.measure.measurement import Measurement
from farm.mesh import TyreMesh, mesh_for
from farm.specs import ModelSpec, SolverSettings
from jobs.errors import JobError
from jobs.guard import Failed
from jobs.identity import canonical
from jobs.inverse.evaluate import (
    ForwardTask,
    PrescribedTask,
    ReferenceTask,
    forward,
    prescribed,
    reference,
    task_key,
)
from jobs.inverse.study import InverseStudy
from jobs.loops.evaluator import Evaluation, Evaluator


class ReferenceFailedError(JobError, RuntimeError):
    """The reference virtual experiment failed or touches the road nowhere."""


@dataclass(frozen=True, eq=False)
class Problem:
    """Everything the loops of a study share.

    Attributes
    ----------
    nodes : ndarray of int, shape (n,)
        The unknowns' outer tread node ids (in contact in the reference).
    x_true : ndarray, shape (n,)
        The reference's vertical road force on each, N.
    grid : ndarray of int, shape (n, 2)
        (row, column) of each unknown on the tread grid.
    xyz : ndarray, shape (n, 3)
        Reference coordinates of the unknowns, mm.
    reference : Measurement
        The virtual experiment's measurements (displacement, strain, tread forces...).
    road_z : float
        Height of the road (the contact centre), mm.
    reference_ccx_runs : int
        ccx runs the iterative road took for the reference.
    """

    model: ModelSpec
    mesh: TyreMesh
    solver: str
    settings: SolverSettings
    deflection: float
    road_z: float
    nodes: np.ndarray
    x_true: np.ndarray
    grid: np.ndarray
    xyz: np.ndarray
    reference: Measurement
    reference_ccx_runs: int = 0

    @property
    def n(self) -> int:
        return self.nodes.size

    def forward_evaluation(self, x: np.ndarray, *, then=(), keep_state: bool = False,
                           start: tuple[str, bytes | None] | None = None) -> Evaluation:
        """The forward model at ``x``; then at each point of ``then`` in the same ccx run.

        ``keep_state``: the result keeps the solver's last state; ``start``: (key, kept
        state) of the evaluation to continue from. Either makes it a continuation
        (:class:`~jobs.inverse.evaluate.ForwardTask`).
        """
        key, state = start if start is not None else (None, None)
        task = ForwardTask(self.model, tuple(int(v) for v in self.nodes), canonical(x),
                           float(self.road_z), self.settings,
                           then=tuple(canonical(p) for p in then), keep_state=keep_state,
                           start=key, start_state=state)
        return Evaluation(task_key("inverse-forward", task, self.solver), forward, task,
                          "inverse-forward", 1 + len(task.then))

    def prescribed_evaluation(self, uz: dict[int, float]) -> Evaluation:
        nodes = tuple(int(v) for v in self.nodes)
        task = PrescribedTask(self.model, nodes, canonical([uz[n] for n in nodes]),
                              float(self.road_z), self.settings)
        return Evaluation(task_key("inverse-prescribed", task, self.solver), prescribed, task,
                          "inverse-prescribed")


def reference_evaluation(study: InverseStudy, solver: str) -> Evaluation:
    task = ReferenceTask(study.model, float(study.deflection), study.settings)
    return Evaluation(task_key("inverse-reference", task, solver), reference, task,
                      "inverse-reference")


def build_problem(study: InverseStudy, evaluator: Evaluator, solver: str) -> Problem:
    """Solve (or replay) the reference experiment and set up the unknowns."""
    result = evaluator.run([reference_evaluation(study, solver)])[0]
    if isinstance(result, Failed):
        raise ReferenceFailedError(
            f"the reference experiment at {study.deflection:g} mm failed: {result.reason}")
    ref = result.measurement
    mesh = mesh_for(study.model)
    fz = ref.reaction_force[:, 2]
    index = np.flatnonzero(fz > 0)
    if index.size == 0:
        raise ReferenceFailedError(f"no tread node touches the road at {study.deflection:g} mm")
    nodes = mesh.tread_nodes[index]
    first, stop = mesh.tread_rows
    tread = mesh.outer_grid[first:stop]
    grid = np.array([np.argwhere(tread == n)[0] for n in nodes])
    return Problem(study.model, mesh, solver, study.settings, study.deflection,
                   mesh.bottom_z + study.deflection, nodes, fz[index].copy(), grid,
                   mesh.xyz(nodes), ref, result.ccx_runs)
