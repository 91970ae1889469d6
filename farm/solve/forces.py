"""Forward model of the virtual inverse problem: vertical forces applied to tread nodes.

Thesis §4.2: "the problem is solved by using optimisation to apply forces to individual
nodes on the outside of the tyre until the resulting strains or deformations on the
inside match those of a corresponding virtual experiment". The model is the reduced
one with its beads clamped (the cut faces as the spec says) and NO road: each unknown
is a vertical concentrated force (``*CLOAD``, dof 3, a dead load along +z, the road's
push) on one outer tread node. One ccx run per evaluation.

With the reaction forces of an iterative-road solution applied at its contact nodes,
the deformation is that of the reference (the iterative road prescribes only uz there,
so the two boundary-value problems share their solution): the objective is zero at the
truth.

:func:`solve_prescribed_uz` is the same deck machinery with the vertical displacement
of the loaded nodes prescribed instead; their reaction forces are the thickness-offset
initial guess of §5.2/§6.2 (the deformed inner surface offset by the wall thickness
gives the outer surface; prescribing it returns the forces that hold it there).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from farm.ccx import deck as D
from farm.ccx.frd import read_frd
from farm.ccx.runner import run_ccx, scratch_dir
from farm.errors import SpecError
from farm.mesh.tyremesh import TyreMesh
from farm.solve.iterative import SUPPORT_SETS, prescribed_deck
from farm.solve.states import PathSolution, SolvedState, inner_strain, node_field
from farm.specs import ModelSpec, SolverSettings


def check_tread_nodes(mesh: TyreMesh, nodes: np.ndarray) -> np.ndarray:
    """``nodes`` as an int array of distinct outer tread node ids (raises SpecError)."""
    ids = np.asarray(nodes, dtype=np.int64).ravel()
    if ids.size == 0:
        raise SpecError("give at least one tread node to load")
    if np.unique(ids).size != ids.size:
        raise SpecError("loaded tread nodes must be distinct")
    outside = ids[~np.isin(ids, mesh.tread_nodes)]
    if outside.size:
        raise SpecError(f"node {int(outside[0])} is not an outer tread node of this mesh")
    return ids


def cload_lines(nodes: np.ndarray, fz: np.ndarray, new: bool = False) -> list[str]:
    """``*CLOAD`` of vertical forces ``fz[k]`` on ``nodes[k]``; ``new``: replacing every
    load of the previous step (``OP=NEW``)."""
    head = "*CLOAD, OP=NEW" if new else "*CLOAD"
    return [head] + [f"{int(n)}, 3, {float(f)!r}" for n, f in zip(nodes, fz, strict=True)]


def force_deck(spec: ModelSpec, mesh: TyreMesh, nodes: np.ndarray, fz: np.ndarray,
               settings: SolverSettings) -> str:
    """Deck with vertical forces ``fz[k]`` (N, +z pushes the tread up) on ``nodes[k]``."""
    loads = cload_lines(nodes, fz)
    return D.assemble(
        D.mesh_lines(mesh), D.material_lines(spec.materials), D.cord_lines(spec, mesh),
        D.measured_set_lines(D.written_sets(mesh)),
        D.static_step_lines(1.0, settings), D.support_lines(spec), loads,
        D.output_lines(time_points=False, contact=False), ["*END STEP"],
    )


def _run(deck: str, mesh: TyreMesh, settings: SolverSettings, should_stop, prefix: str):
    with scratch_dir(keep=settings.keep_scratch, prefix=prefix) as workdir:
        run = run_ccx(deck, workdir, threads=settings.threads, timeout=settings.timeout,
                      should_stop=should_stop)
        frd = read_frd(run.file("frd"))
    t = frd.times("DISP")[-1]
    u = node_field(frd, "DISP", t, mesh.n_nodes)
    rf = node_field(frd, "FORC", t, mesh.n_nodes)
    return run, frd, t, u, rf


def unloaded_reference(mesh: TyreMesh) -> SolvedState:
    """The undeformed tyre: the reference state of the forward model's measurements."""
    return SolvedState(0.0, np.nan, np.zeros((mesh.n_nodes, 3)),
                       np.zeros((mesh.inner_nodes.size, 6)),
                       np.zeros((mesh.tread_nodes.size, 3)), np.zeros(3))


def _solution(mesh: TyreMesh, state: SolvedState, run) -> PathSolution:
    return PathSolution(unloaded_reference(mesh), (state,), run.seconds, 1, run.increments)


def support_reaction(mesh: TyreMesh, rf: np.ndarray) -> np.ndarray:
    """What the supports carry, with the sign of a road force: minus their reactions."""
    ids = np.unique(np.concatenate([mesh.node_sets[k] for k in SUPPORT_SETS
                                    if k in mesh.node_sets]))
    return -np.nan_to_num(rf[ids - 1]).sum(axis=0)


def solve_applied_forces(spec: ModelSpec, mesh: TyreMesh, nodes: np.ndarray, fz: np.ndarray,
                         settings: SolverSettings, *, road_z: float = np.nan,
                         should_stop: Callable[[], bool] | None = None) -> PathSolution:
    """Apply vertical forces to tread nodes; one ccx run.

    Parameters
    ----------
    spec, mesh : the (reduced) model and its mesh.
    nodes : ndarray of int, shape (n,)
        Outer tread node ids that carry a force.
    fz : ndarray, shape (n,)
        Vertical force on each, N (positive: the road pushing the tyre up).
    road_z : float
        Height of the contact centre the moments are taken about (that of the
        reference experiment, so that Mx, My compare with it).

    Returns
    -------
    PathSolution with one state (deflection 0, since no road is modelled) whose
    ``tread_force`` holds the applied forces and ``road_reaction`` what the supports
    carry (equal to the applied total in equilibrium), ready for
    :func:`farm.measure.measure`.
    """
    nodes = check_tread_nodes(mesh, nodes)
    fz = np.asarray(fz, dtype=float).ravel()
    if fz.shape != nodes.shape or not np.isfinite(fz).all():
        raise SpecError(f"need one finite force per node: {nodes.size} nodes, "
                        f"{fz.size} forces")
    deck = force_deck(spec, mesh, nodes, fz, settings)
    run, frd, t, u, rf = _run(deck, mesh, settings, should_stop, "forces-")
    force = np.zeros((mesh.tread_nodes.size, 3))
    force[positions_in(mesh.tread_nodes, nodes), 2] = fz
    state = SolvedState(0.0, road_z, u, inner_strain(frd, mesh, t), force,
                        support_reaction(mesh, rf), run.seconds)
    return _solution(mesh, state, run)


def solve_prescribed_uz(spec: ModelSpec, mesh: TyreMesh, uz: Mapping[int, float],
                        settings: SolverSettings, *, road_z: float = np.nan,
                        should_stop: Callable[[], bool] | None = None) -> PathSolution:
    """Prescribe the vertical displacement of tread nodes; their reactions are the forces.

    Returns a one-state PathSolution whose ``tread_force`` holds the reaction force of
    each prescribed node (zero elsewhere), sign as a road force (+z pushes up).
    """
    nodes = check_tread_nodes(mesh, np.array(sorted(uz), dtype=np.int64))
    deck = prescribed_deck(spec, mesh, dict(uz), settings)  # the iterative road's deck
    run, frd, t, u, rf = _run(deck, mesh, settings, should_stop, "prescribed-")
    force = np.zeros((mesh.tread_nodes.size, 3))
    pos = positions_in(mesh.tread_nodes, nodes)
    force[pos] = np.nan_to_num(rf[nodes - 1])
    state = SolvedState(0.0, road_z, u, inner_strain(frd, mesh, t), force,
                        support_reaction(mesh, rf), run.seconds)
    return _solution(mesh, state, run)


def positions_in(haystack: np.ndarray, needles: np.ndarray) -> np.ndarray:
    """Index of each of ``needles`` in ``haystack`` (all present)."""
    where = {int(v): k for k, v in enumerate(haystack)}
    return np.array([where[int(n)] for n in needles], dtype=np.int64)


def offset_outer_uz(mesh: TyreMesh, inner_displacement: np.ndarray,
                    nodes: np.ndarray) -> dict[int, float]:
    """Vertical displacement of outer tread ``nodes`` estimated from the inner surface.

    The thickness-offset regularisation of thesis §5.2/§6.2: the rubber is nearly
    incompressible, so the wall keeps its thickness; the deformed inner surface offset
    by the wall estimates the deformed outer surface. The mesh has one element through
    the wall, so outer grid node (i, j) lies across the wall from inner grid node (i, j);
    the across-wall vector, expressed in the inner surface's local frame (tangents and
    normal), is carried along with that frame. This keeps the thickness and is exact
    for any rigid motion of the surface.

    Parameters
    ----------
    inner_displacement : ndarray, shape (n_inner, 3)
        Measured inner-surface displacement (grid order, as in a Measurement).
    nodes : ndarray of int, shape (n,)
        Outer tread node ids whose vertical displacement is wanted.

    Returns
    -------
    dict of node id -> uz (mm), in the order of ``nodes``.
    """
    nodes = check_tread_nodes(mesh, nodes)
    shape = (*mesh.inner_grid.shape, 3)
    inner0 = mesh.xyz(mesh.inner_nodes).reshape(shape)
    outer0 = mesh.xyz(mesh.outer_grid.ravel()).reshape(shape)
    deformed = inner0 + np.asarray(inner_displacement, dtype=float).reshape(shape)
    frame0 = _grid_frames(inner0, mesh.periodic)  # (rows, cols, 3 axes, 3)
    local = np.einsum("rcij,rcj->rci", frame0, outer0 - inner0)
    estimate = deformed + np.einsum("rcij,rci->rcj", _grid_frames(deformed, mesh.periodic),
                                    local)
    where = {int(n): k for k, n in enumerate(mesh.outer_grid.ravel())}
    flat = estimate.reshape(-1, 3)[:, 2] - outer0.reshape(-1, 3)[:, 2]
    return {int(n): float(flat[where[int(n)]]) for n in nodes}


def _grid_frames(xyz: np.ndarray, periodic: bool) -> np.ndarray:
    """Orthonormal frames (t1 along columns, t2 along rows, normal) of a surface grid.

    Returns shape (rows, cols, 3, 3); row k of each 3x3 matrix is axis k.
    """
    d_row = np.gradient(xyz, axis=0)
    if periodic:  # columns wrap around the full tyre
        d_col = 0.5 * (np.roll(xyz, -1, axis=1) - np.roll(xyz, 1, axis=1))
    else:
        d_col = np.gradient(xyz, axis=1)
    t1 = d_col / np.linalg.norm(d_col, axis=-1, keepdims=True)
    t2 = d_row - np.sum(d_row * t1, axis=-1, keepdims=True) * t1
    t2 /= np.linalg.norm(t2, axis=-1, keepdims=True)
    return np.stack([t1, t2, np.cross(t1, t2)], axis=-2)
