"""Inverse solves in the store: one group per study, written by the client alone.

The group sits beside the experiment groups of the same Zarr store; it carries no
``schema_version``, so :func:`storage.list_groups` (experiment groups) does not list
it. It opens with ``xarray.open_zarr(store, group=...)``:

| variable | dims | units |
|---|---|---|
| ``x_true``, ``unknown_xyz`` | unknown (, component) | N, mm |
| ``x0``, ``x_final`` | solve, unknown | N |
| ``x_history`` | solve, evaluation, unknown | N (NaN past a solve's last evaluation) |
| ``objective_history`` | solve, evaluation | mm, 1 or dimensionless (per method) |
| ``objective`` | solve | as above |
| ``total_force``, ``moment`` | solve, component | N, N mm (final forward evaluation) |
| ``rmse`` | solve, direction | mm for U*, 1 for e* |
| ``status``, ``message``, ``condition``, ``method``, ``optimizer`` | solve | - |
| ``repeat``, ``evaluations``, ``solved``, ``rounds`` | solve | 1 |
| ``wall_seconds``, ``solver_seconds`` | solve | s |

The ``solve`` coordinate is each loop's content hash; a re-run overwrites the group
with the same values (the loops are deterministic).
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np
import xarray as xr

from jobs.errors import JobError
from jobs.inverse.loop import LoopResult
from jobs.inverse.problem import Problem
from jobs.inverse.study import InverseStudy
from jobs.inverse.tables import DIRECTIONS

UNITS = {"displacement": "mm", "strain": "1", "combined": "1"}


def _history(results: Sequence[LoopResult], n: int) -> tuple[np.ndarray, np.ndarray]:
    k = max((len(r.f_history) for r in results), default=0)
    xs = np.full((len(results), k, n), np.nan)
    fs = np.full((len(results), k), np.nan)
    for i, r in enumerate(results):
        xs[i, : len(r.f_history)] = r.x_history
        fs[i, : len(r.f_history)] = r.f_history
    return xs, fs


def _var(dims, data, units: str, long_name: str) -> xr.Variable:
    return xr.Variable(dims, data, attrs={"units": units, "long_name": long_name})


def to_dataset(study: InverseStudy, problem: Problem,
               results: Sequence[LoopResult]) -> xr.Dataset:
    """The group's contents as an xarray Dataset."""
    xs, fs = _history(results, problem.n)
    final = [r.final if r.rmse else None for r in results]

    def per_solve(getter, width: int):
        return np.array([getter(f) if f is not None else np.full(width, np.nan) for f in final])

    units = sorted({UNITS[r.spec.method] for r in results})
    data = {
        "x_true": _var("unknown", problem.x_true, "N", "reference vertical force per unknown"),
        "unknown_xyz": _var(("unknown", "component"), problem.xyz, "mm",
                            "reference coordinates of the unknown nodes"),
        "x0": _var(("solve", "unknown"), np.array([r.x0 for r in results]), "N",
                   "initial guess"),
        "x_final": _var(("solve", "unknown"), np.array([r.x for r in results]), "N",
                        "identified forces"),
        "x_history": _var(("solve", "evaluation", "unknown"), xs, "N",
                          "forces of every evaluation, in order"),
        "objective_history": _var(("solve", "evaluation"), fs, "/".join(units),
                                  "objective of every evaluation as the optimiser saw it"),
        "objective": _var("solve", np.array([r.objective for r in results]), "/".join(units),
                          "final objective"),
        "total_force": _var(("solve", "component"),
                            per_solve(lambda f: f["total_force"], 3), "N", "Fx, Fy, Fz"),
        "moment": _var(("solve", "component"), per_solve(lambda f: f["moment"], 3), "N mm",
                       "Mx, My, Mz about the contact centre"),
        "rmse": _var(("solve", "direction"),
                     np.array([[r.rmse.get(d, np.nan) for d in DIRECTIONS] for r in results]),
                     "mm (U*), 1 (e*)", "field RMSE against the noise-free reference"),
    }
    text = {"status": [r.status for r in results], "message": [r.message for r in results],
            "condition": [r.spec.condition.name for r in results],
            "method": [r.spec.method for r in results],
            "optimizer": [r.spec.optimizer.name for r in results]}
    for name, values in text.items():
        data[name] = xr.Variable("solve", np.array(values, dtype=object))
    counts = {"repeat": [r.spec.repeat for r in results],
              "evaluations": [len(r.f_history) for r in results],
              "solved": [r.stats.solved for r in results],
              "rounds": [r.stats.rounds for r in results]}
    for name, values in counts.items():
        data[name] = _var("solve", np.array(values, dtype=np.int64), "1", name)
    data["wall_seconds"] = _var("solve", np.array([r.wall_seconds for r in results]), "s",
                                "wall time of the loop")
    data["solver_seconds"] = _var("solve", np.array([r.stats.solver_seconds for r in results]),
                                  "s", "ccx seconds of the evaluations this loop solved")
    coords = {"solve": np.array([r.id for r in results], dtype=object),
              "unknown": problem.nodes, "component": np.array(["x", "y", "z"], dtype=object),
              "direction": np.array(DIRECTIONS, dtype=object)}
    attrs = {"study": study.name, "kind": "inverse-solves", "model_spec":
             json.dumps(study.model.to_dict(), sort_keys=True), "solver": problem.solver,
             "deflection_mm": study.deflection, "road_z_mm": problem.road_z,
             "noise": json.dumps({"displacement_mm": study.noise.displacement,
                                  "strain": study.noise.strain}),
             "problem_hash": study.problem_hash()}
    return xr.Dataset(data, coords=coords, attrs=attrs)


def write_results(study: InverseStudy, problem: Problem, results: Sequence[LoopResult]) -> None:
    """(Re)write the study's group; the client is the only writer."""
    import storage
    from storage.paths import publish

    ds = to_dataset(study, problem, results)  # text as object arrays: variable-length
    try:
        zs = storage.open_store(study.store)
        ds.to_zarr(zs, group=study.group, mode="w", zarr_format=3, consolidated=False)
        publish(zs)
    except (OSError, ValueError) as e:
        raise JobError(f"cannot write the inverse results to {study.store} "
                       f"(group {study.group}): {e}") from e
