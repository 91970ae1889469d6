"""farm.solve.paths: every kind of path is solved through one interface (issue 49)."""

from __future__ import annotations

import inspect

import pytest

from farm.experiment import path_solver
from farm.measure.camera import rolling_solution
from farm.presets import default_model
from farm.solve.contact import solve_contact_path
from farm.solve.iterative import solve_iterative_path
from farm.solve.paths import PathSolver
from farm.specs import LoadPath, RoadMotion

ROLL = RoadMotion(friction=0.6, roll=100.0, rolling_radius=402.9)


@pytest.mark.parametrize(("kind", "road", "motion", "want"), [
    ("full", "contact", None, solve_contact_path),
    ("full", "contact", RoadMotion(friction=0.5, shift_y=2.0), solve_contact_path),
    ("full", "contact", ROLL, rolling_solution),
    ("reduced", "iterative", None, solve_iterative_path),
])
def test_each_path_has_its_solver(kind, road, motion, want):
    model = default_model(kind, road=road)
    path = LoadPath((15.0,), 0.2 if model.inflated else 0.0, motion)
    assert path_solver(model, path) is want


@pytest.mark.parametrize("solver", [solve_contact_path, solve_iterative_path,
                                    rolling_solution])
def test_every_solver_takes_the_interface_s_arguments(solver):
    """The protocol's parameters, in its order, with ``should_stop`` optional (mypy
    checks the types where :func:`farm.experiment.path_solver` returns them)."""
    want = inspect.signature(PathSolver.__call__).parameters
    got = inspect.signature(solver).parameters
    assert list(got) == [p for p in want if p != "self"]
    assert got["should_stop"].default is None
