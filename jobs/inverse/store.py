"""Inverse solves into the store: the loops' results as the plain values of
:mod:`storage.solves`, which owns the group's schema, its writer and its reader
(``docs/schema.md``, "Inverse-solves groups"). The client is the only writer.
"""

from __future__ import annotations

import json
from collections.abc import Sequence

from jobs.errors import JobError
from jobs.inverse.loop import LoopResult
from jobs.inverse.problem import Problem
from jobs.inverse.study import InverseStudy
from storage.errors import StoreError
from storage.solves import (
    SolveRecord,
    SolvesAttrs,
    Unknowns,
    write_solves,
)

#: Unit of each method's objective (eqs. 4.1, 4.2; the combined one is dimensionless).
UNITS = {"displacement": "mm", "strain": "1", "combined": "1"}


def unknowns(problem: Problem) -> Unknowns:
    """The unknowns and the reference experiment's totals of ``problem``."""
    ref = problem.reference
    return Unknowns(problem.nodes, problem.x_true, problem.xyz, ref.total_force, ref.moment)


def record(r: LoopResult) -> SolveRecord:
    """One loop's result; the final evaluation's numbers only when it succeeded."""
    final = r.final
    return SolveRecord(
        id=r.id, condition=r.spec.condition.name, method=r.spec.method,
        optimizer=r.spec.optimizer.name, repeat=r.spec.repeat, status=r.status,
        message=r.message, objective_units=UNITS[r.spec.method], x0=r.x0, x_final=r.x,
        x_history=r.x_history, objective_history=r.f_history, objective=r.objective,
        total_force=None if final is None else final.total_force,
        moment=None if final is None else final.moment,
        rmse=None if final is None else dict(r.rmse),
        solved=r.stats.solved, rounds=r.stats.rounds, wall_seconds=r.wall_seconds,
        solver_seconds=r.stats.solver_seconds)


def attrs(study: InverseStudy, problem: Problem) -> SolvesAttrs:
    """The study behind the group."""
    return SolvesAttrs(
        study=study.name, model_spec=json.dumps(study.model.to_dict(), sort_keys=True),
        solver=problem.solver, deflection_mm=study.deflection, road_z_mm=problem.road_z,
        noise=json.dumps({"displacement_mm": study.noise.displacement,
                          "strain": study.noise.strain}),
        problem_hash=study.problem_hash())


def write_results(study: InverseStudy, problem: Problem, results: Sequence[LoopResult]) -> None:
    """(Re)write the study's group; the client is the only writer."""
    try:
        write_solves(study.store, study.group, unknowns(problem),
                     [record(r) for r in results], attrs(study, problem))
    except StoreError as e:
        raise JobError(f"cannot write the inverse results to {study.location} "
                       f"(group {study.group}): {e}") from e
