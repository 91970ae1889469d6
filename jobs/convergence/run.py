"""Solve the convergence study's (level, case) pairs on a Dask cluster and measure them.

Each pair is one task (:func:`solve_case`) that meshes, solves one load path with ccx
and returns only small, plain numbers per state (forces, patch metrics, window RMS of
the inner-surface fields): the fields themselves stay on the worker. A solver failure
is a record with its reason, never a crash of the study.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from farm.experiment import run_load_path
from farm.measure.patch import window_rms
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.specs import ModelSpec, SolverSettings
from jobs.convergence.levels import Case, Level
from jobs.guard import Failed, guarded

WINDOW_DEG = 20.0
"""Half-angle of the camera window whose field RMS is compared: T2Cam sees about 40
degrees of arc about the contact centre (thesis §2.2)."""


def model_of(level: Level, materials: str = "table-3.1") -> ModelSpec:
    return default_model("full", materials, mesh=level.mesh)


def solve_case(model: ModelSpec, case: Case, settings: SolverSettings | None = None
               ) -> dict[str, Any]:
    """Solve ``case`` on ``model`` and measure every state (runs on a worker)."""
    start = time.perf_counter()
    # the farm's failure policy: one retry with smaller increments, then a failure is
    # data (its reason), never a crashed study
    result = guarded(lambda s: run_load_path(model, case.path(), s),
                     settings or SolverSettings())
    if isinstance(result, Failed):
        return {"status": "failed", "reason": result.reason[:600],
                "wall_s": time.perf_counter() - start}
    mesh = mesh_for(model)
    states = []
    for m, patch in zip(result.measurements, result.patches(mesh), strict=True):
        label = ("rolled" if m.motion is not None and m.motion.rolls
                 else f"{m.deflection:g} mm" if m.motion is None or not m.motion.moves
                 else "slid")
        states.append({
            "state": label, "Fx": float(m.total_force[0]), "Fy": float(m.total_force[1]),
            "Fz": float(m.total_force[2]), "Mz": float(m.moment[2]) / 1000.0,
            "patch": patch.to_dict(),
            "U_rms": window_rms(mesh, m.displacement, WINDOW_DEG),
            "strain_rms": window_rms(mesh, m.surface_strain, WINDOW_DEG),
            "solver_strain_rms": window_rms(mesh, m.strain, WINDOW_DEG),
        })
    return {"status": "done", "states": states, "nodes": mesh.n_nodes,
            "elements": mesh.n_elements, "growth": result.growth(mesh),
            "ccx_runs": result.ccx_runs, "solve_s": result.solve_seconds,
            "wall_s": time.perf_counter() - start}


def run_study(levels: Sequence[Level], cases: Sequence[Case], client: Any,
              materials: str = "table-3.1", settings: SolverSettings | None = None,
              on_record: Callable[[dict[str, Any]], None] | None = None
              ) -> list[dict[str, Any]]:
    """Every (level, case) pair as a task on ``client``; the records in study order.

    The finest levels are submitted first, so that the longest tasks do not start last.
    """
    pairs = [(level, case) for level in levels for case in cases]
    models = {level.name: model_of(level, materials) for level in levels}
    order = sorted(range(len(pairs)), key=lambda i: -models[pairs[i][0].name].node_estimate)
    futures = {}
    for i in order:
        level, case = pairs[i]
        futures[client.submit(solve_case, models[level.name], case, settings, pure=False,
                              key=f"converge-{level.name}-{case.name}")] = i
    from distributed import as_completed

    records: list[dict[str, Any] | None] = [None] * len(pairs)
    for future in as_completed(futures):
        level, case = pairs[futures[future]]
        record = {"level": level.name, "case": case.name, **future.result()}
        records[futures[future]] = record
        if on_record is not None:
            on_record(record)
    return [r for r in records if r is not None]
