"""The load-path interface: what every kind of path solver offers (issue 49).

A *path solver* turns a model, its mesh, a load path and solver settings into a
:class:`~farm.solve.states.PathSolution` (the inflated reference and one state per
stored point of the path); it polls ``should_stop`` while ccx runs. Every kind of path
the farm solves is one, chosen by :func:`farm.experiment.solve_path`:

============================  ================================================
path                          solver
============================  ================================================
vertical, slide, tilt (rigid  :func:`farm.solve.contact.solve_contact_path`
road with contact)
vertical (the thesis'         :func:`farm.solve.iterative.solve_iterative_path`
iterative road)
roll (``path.motion.rolls``)  :func:`farm.measure.camera.rolling_solution`
============================  ================================================

Paths that *continue from a saved state* come in pairs: a trunk solved once, whose ccx
restart state is kept, and branches that read it and go on in a new step -
:func:`farm.solve.tree.solve_trunk` / :func:`farm.solve.tree.solve_branch` (static
trees: rise, then slide) and :func:`farm.solve.rolling_tree.solve_rolling_trunk` /
:func:`farm.solve.rolling_tree.solve_rolling_branch` (rolling trees). A saved trunk is a
plain value (:class:`~farm.solve.tree.Trunk`, :class:`~farm.solve.rolling_tree.
RollingTrunk`) holding its states and its restart bytes.

Why an interface and not private helpers: each new kind of path (slides, trees, rolls)
used to reach into the contact solver's private parts; a module now builds on the
public functions of another (``tests/test_layering.py`` refuses a private name imported
across modules) and a new solver is one more function of this signature.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

from farm.mesh import TyreMesh
from farm.solve.states import PathSolution
from farm.specs import LoadPath, ModelSpec, SolverSettings

__all__ = ["PathSolver"]


class PathSolver(Protocol):
    """Solve ``path`` on ``mesh`` of ``spec``: the inflated reference and one state per
    stored point (deflection, fraction of a slide or of a roll). Raises
    :class:`~farm.errors.SolverError` (with the states reached as ``partial`` where the
    path keeps them) and :class:`~farm.errors.SpecError` for a path the model cannot
    take."""

    def __call__(self, spec: ModelSpec, mesh: TyreMesh, path: LoadPath,
                 settings: SolverSettings,
                 should_stop: Callable[[], bool] | None = None) -> PathSolution: ...
