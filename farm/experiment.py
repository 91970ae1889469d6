"""Run one load path end to end: mesh (cached), solve with ccx, measure.

This is the unit of work a farm worker executes: one model, one pressure, several
deflections, one :class:`PathResult` with a :class:`~farm.measure.Measurement` per
deflection.
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from farm.ccx.runner import ccx_version
from farm.errors import SolverError
from farm.measure.camera import rolling_solution
from farm.measure.measurement import Measurement, measure
from farm.measure.patch import PatchMetrics, inflation_growth, patch_metrics, tread_areas
from farm.mesh import TyreMesh, mesh_for
from farm.solve.contact import solve_contact_path
from farm.solve.iterative import solve_iterative_path
from farm.solve.paths import PathSolver
from farm.solve.rolling import (
    RadiusTry,
    RolledState,
    free_roll_mm,
    free_rolling_radius,
    inflated_radius,
    solve_roll,
)
from farm.solve.states import PathSolution, SolvedState
from farm.specs import LoadPath, ModelSpec, Roll, SolverSettings


@dataclass(frozen=True, eq=False)
class PathResult:
    """The measurements of a solved load path and what solving it cost.

    ``reference`` is the unloaded state the measurements are taken from (the inflated
    tyre for the full model); ``states`` are the solved states (full fields) behind the
    measurements, one per deflection.
    """

    model: ModelSpec
    path: LoadPath
    measurements: tuple[Measurement, ...]
    reference: SolvedState
    states: tuple[SolvedState, ...]
    solve_seconds: float
    wall_seconds: float
    ccx_runs: int
    increments: int
    solver: str

    def save(self, file: str | Path, mesh: TyreMesh) -> None:
        """Write every array the store would hold, one row per state, to a ``.npz``.

        The load case (``deflection``, ``pressure`` and, for a combined path,
        ``friction``, ``shift_x``, ``shift_y``, ``tilt``), the results
        (:meth:`Measurement.arrays` and :meth:`Measurement.combined_arrays`), the
        bookkeeping (``contact_nodes``, ``solve_seconds``), the contact patch
        (``patch_*``, :mod:`farm.measure.patch`), node ids and reference coordinates
        with their grid positions, and ``model_json``/``solver``. Issue 25: the file once
        dropped every combined-load array, so both states of a slide read alike.
        """
        # allow_pickle is numpy's default, named so that the type checker knows that no
        # array of **arrays takes its place
        np.savez_compressed(file, allow_pickle=True, **self.arrays(mesh))

    def patches(self, mesh: TyreMesh) -> list[PatchMetrics]:
        """The contact patch of each state (:mod:`farm.measure.patch`)."""
        areas = tread_areas(mesh)
        return [patch_metrics(mesh, s, areas) for s in self.states]

    def growth(self, mesh: TyreMesh) -> float:
        """Inflation growth of the reference state, mm (0 for an uninflated model)."""
        return inflation_growth(mesh, self.reference)

    def arrays(self, mesh: TyreMesh) -> dict[str, np.ndarray]:
        """What :meth:`save` writes, by name."""
        m = self.measurements
        out: dict[str, np.ndarray] = {
            "deflection": np.array([x.deflection for x in m]),
            "pressure": np.array([x.pressure for x in m]),
            "inner_node": mesh.inner_nodes, "inner_xyz": mesh.xyz(mesh.inner_nodes),
            "tread_node": mesh.tread_nodes, "tread_xyz": mesh.xyz(mesh.tread_nodes),
            **{k: np.stack([x.arrays()[k] for x in m]) for k in m[0].arrays()},
            "contact_nodes": np.array([x.contact_nodes for x in m]),
            "solve_seconds": np.array([x.solve_seconds for x in m]),
        }
        if self.path.motion is not None:
            for name in ("friction", "shift_x", "shift_y", "tilt"):
                out[name] = np.array([getattr(x.motion, name) for x in m])
            out.update({k: np.stack([x.combined_arrays()[k] for x in m])
                        for k in m[0].combined_arrays()})
        patches = [p.to_dict() for p in self.patches(mesh)]
        out.update({f"patch_{k}": np.array([p[k] for p in patches]) for k in patches[0]})
        if self.model.inflated:
            out["inflation_growth"] = np.array(self.growth(mesh))
        out["model_json"] = np.array(json.dumps(self.model.to_dict(), sort_keys=True))
        out["solver"] = np.array(self.solver)
        return out


def solve_path(model: ModelSpec, mesh: TyreMesh, path: LoadPath, settings: SolverSettings,
               should_stop: Callable[[], bool] | None = None) -> PathSolution:
    """Dispatch on the road boundary condition of ``model`` (and on a rolling motion:
    :func:`farm.measure.camera.rolling_solution`: the roll's end as the camera sees it)."""
    return path_solver(model, path)(model, mesh, path, settings, should_stop)


def path_solver(model: ModelSpec, path: LoadPath) -> PathSolver:
    """The solver of ``path`` on ``model`` (:mod:`farm.solve.paths`): a roll's, the
    contact road's, or the thesis' iterative road's."""
    if path.motion is not None and path.motion.rolls:
        return rolling_solution
    return solve_contact_path if model.road == "contact" else solve_iterative_path


def run_load_path(model: ModelSpec, path: LoadPath, settings: SolverSettings | None = None,
                  *, should_stop: Callable[[], bool] | None = None) -> PathResult:
    """Mesh ``model`` (cached), solve ``path`` and derive the measurements.

    Raises :class:`~farm.errors.SpecError` for a load the model cannot take (nothing
    is run) and :class:`~farm.errors.SolverError` when ccx fails.
    """
    settings = settings or SolverSettings()
    path.check_against(model)
    start = time.perf_counter()
    mesh = mesh_for(model)
    try:
        solution = solve_path(model, mesh, path, settings, should_stop)
    except SolverError as e:
        if not isinstance(e.partial, PathSolution):
            raise
        # a roll that stopped (issue 45): the states it reached, measured as any others
        raise e.with_partial(tuple(measure(mesh, e.partial, path.pressure,
                                           inflated=model.inflated))) from e
    measurements = measure(mesh, solution, path.pressure, inflated=model.inflated)
    return PathResult(
        model=model, path=path, measurements=tuple(measurements), reference=solution.reference,
        states=solution.states,
        solve_seconds=solution.solve_seconds, wall_seconds=time.perf_counter() - start,
        ccx_runs=solution.ccx_runs, increments=solution.increments,
        solver=f"CalculiX {ccx_version()}",
    )


@dataclass(frozen=True)
class RollOnce:
    """One roll of ``farm roll``: its motion (at the radius found, when searched), the
    states along it, the inflated radius, and the free-rolling search's rolls (empty
    when the radius was given)."""

    motion: Roll
    states: tuple[RolledState, ...]
    inflated_radius: float
    tried: tuple[RadiusTry, ...] = ()


def roll_once(model: ModelSpec, deflection: float, pressure: float, motion: Roll,
              settings: SolverSettings, samples: int, *, find_radius: bool = False,
              say: Callable[[str], None] = lambda text: None) -> RollOnce:
    """Mesh ``model`` (cached) and roll it once (:func:`farm.solve.rolling.solve_roll`),
    writing ``samples`` states evenly along the roll; with ``find_radius`` the
    free-rolling radius is searched first (rolls at kappa = 0) and replaces
    ``motion.rolling_radius``. ``pressure`` in MPa; ``say`` hears each stage."""
    mesh = mesh_for(model)
    tried: tuple[RadiusTry, ...] = ()
    if find_radius:
        say("finding the free-rolling radius (rolls at kappa = 0)")
        # the search's rolls have their own length, not the roll's: a short roll's
        # Fx at its end is still the roll-in's (``farm roll --distance 20`` searched with
        # 20 mm rolls until 2026-11-30, and found 394.7 mm for patch where a tree's
        # states put free rolling near 392.6 mm; docs/rolling.md)
        search = dataclasses.replace(motion, distance=free_roll_mm(model))
        radius, found = free_rolling_radius(model, mesh, deflection, pressure, search, settings)
        motion, tried = dataclasses.replace(motion, rolling_radius=radius), tuple(found)
    say(f"rolling {motion.distance:g} mm at r_e {motion.rolling_radius:.2f} mm")
    fractions = tuple(float(f) for f in np.round(np.linspace(0, 1, samples + 1), 9))
    states = solve_roll(model, mesh, deflection, pressure, motion, settings, fractions)
    return RollOnce(motion, tuple(states), inflated_radius(model, mesh, pressure, settings),
                    tried)
