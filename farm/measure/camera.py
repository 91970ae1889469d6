"""What a camera fixed to the contact centre sees of a rolling tyre (issue 30).

A rolled state (:class:`farm.solve.rolling.RolledState`) holds the solver's arrays in the
material's node order: after a turn by ``spin`` the material at each node's place is not
that node's. T2Cam is stabilised and looks at the patch while the tyre turns under it
(thesis §2.2), so what it measures - and what the store keeps - is the field at fixed
places of the contact frame. :func:`camera_state` re-reads a rolled state there, as a
standing tyre's :class:`~farm.solve.states.SolvedState`, so that
:func:`farm.measure.measurement.measure` and the store take it like any other;
:func:`rolling_solution` is a rolling experiment's load path in that frame.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from farm.errors import SolverError
from farm.measure.patch import tread_areas
from farm.mesh.tyremesh import TyreMesh
from farm.solve.rolling import (
    RolledState,
    on_grid,
    roll_path,
    turn_matrix,
    turned_strain,
)
from farm.solve.states import PathSolution, SolvedState
from farm.specs import LoadPath, ModelSpec, SolverSettings


def _nearest_column(values: np.ndarray, mesh: TyreMesh, spin: float,
                    grid: np.ndarray) -> np.ndarray:
    """Like :func:`on_grid` for values that do not interpolate (stick/slip states): the
    column nearest to phi + spin, (n_rows, n_columns, k)."""
    phi = np.asarray(mesh.angles, dtype=float)
    gap = np.angle(np.exp(1j * (phi[None, :] - (phi + spin)[:, None])))  # wrapped
    nearest = np.argmin(np.abs(gap), axis=1)
    return values[grid - 1][:, nearest]


def camera_state(rolled: RolledState, mesh: TyreMesh) -> SolvedState:
    """The rolled state read at the grid's fixed places, as a standing tyre's state.

    What lies at each node's place in the contact frame is the material the spin has
    carried there (:func:`on_grid`); each array is re-read so that
    :func:`farm.measure.measurement.measure` takes it as it takes a standing tyre's:

    - displacement: the reference's + the camera field, so that its change from the
      inflated reference is what the camera sees (the inflated tyre is axisymmetric);
    - strain: each material point's Lagrange strain is referred to its own reference
      axes; turned with it by the spin, its surface components are its own;
    - tread forces: as force per tributary area (a refined window holds smaller nodes),
      times the fixed place's area; stick/slip from the nearest column;
    - the road's reaction and moment, the road height and the motion: unchanged.

    Between the columns of a grid that is not uniform, the re-read forces sum to the road's reaction
    only approximately (``road_reaction`` stays exact; ``total_force`` is their sum).
    """
    state, spin = rolled.solved, rolled.turn  # the start (a windowed mesh) included
    first, stop = mesh.tread_rows
    tread_grid = mesh.outer_grid[first:stop]
    n_tread = tread_grid.size

    def tread(values: np.ndarray) -> np.ndarray:  # (n_tread, k) grid order -> on grid
        full = np.zeros((mesh.n_nodes, values.shape[1]))
        full[tread_grid.ravel() - 1] = values
        return on_grid(full, mesh, spin, tread_grid).reshape(n_tread, -1)

    displacement = rolled.reference.displacement.copy()
    for grid in (mesh.inner_grid, mesh.outer_grid):
        displacement[grid.ravel() - 1] += on_grid(rolled.camera, mesh, spin,
                                                  grid).reshape(-1, 3)
    # R E R^T: the strain in the axes the spin turned the material's into
    voigt = turned_strain(state.strain, turn_matrix(spin))
    full = np.zeros((mesh.n_nodes, 6))
    full[mesh.inner_grid.ravel() - 1] = voigt
    strain = on_grid(full, mesh, spin).reshape(-1, 6)
    areas = tread_areas(mesh)[:, None]
    force = tread(state.tread_force / areas) * areas
    status = np.zeros((mesh.n_nodes, 1))
    assert state.contact_status is not None and state.tread_slip is not None
    status[tread_grid.ravel() - 1, 0] = state.contact_status
    contact = _nearest_column(status, mesh, spin, tread_grid).reshape(-1).astype(np.int8)
    return dataclasses.replace(state, displacement=displacement, strain=strain,
                               tread_force=force, contact_status=contact,
                               tread_slip=tread(state.tread_slip))


def rolling_solution(spec: ModelSpec, mesh: TyreMesh, path: LoadPath,
                     settings: SolverSettings,
                     should_stop: Callable[[], bool] | None = None) -> PathSolution:
    """A rolling path (``path.motion.rolls``): one state per fraction of the roll
    (``path.motion_fractions``; the end alone by default) from
    :func:`farm.solve.rolling.roll_path`, each read by the camera (:func:`camera_state`)
    and carrying its own motion, a roll of its travel (issue 45: a state is labelled by
    how far the road had travelled); seconds and ccx runs include a free-radius search.
    A roll that stops raises its :class:`~farm.errors.SolverError` with the states it
    reached read the same way, as a path solution (``partial``)."""
    assert path.motion is not None
    try:
        rolled, seconds, runs, increments = roll_path(spec, mesh, path, settings, should_stop)
    except SolverError as e:
        if not isinstance(e.partial, tuple):
            raise
        reached: tuple[RolledState, ...] = e.partial  # before it stopped: a solution of those
        raise e.with_partial(PathSolution(
            reached[0].reference, tuple(_seen(s, mesh, path) for s in reached),
            max(s.solved.solve_seconds for s in reached), 1, 0)) from e
    states = tuple(_seen(s, mesh, path) for s in rolled)
    return PathSolution(rolled[0].reference, states, seconds, runs, increments)


def _seen(rolled: RolledState, mesh: TyreMesh, path: LoadPath) -> SolvedState:
    """A rolled state as the camera sees it, with the motion of a roll of its travel."""
    assert path.motion is not None
    motion = dataclasses.replace(path.motion, roll=path.motion.roll * rolled.fraction)
    return dataclasses.replace(camera_state(rolled, mesh), motion=motion)
