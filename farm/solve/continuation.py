"""Forward solves that continue from a solved state: restart files and load paths.

The forward model of the inverse problem (:mod:`farm.solve.forces`) ramps its loads up
from rest in every ccx run: seven increments and some 30 Newton iterations on the
default reduced mesh, about 5 s. The optimisers of chapter 4 evaluate points that lie
close together (a trial step from the current point, the n columns of a
finite-difference Jacobian 0.1 N apart), and from a neighbour's converged state the
same equilibrium takes one increment of a few iterations. Two ways to start there:

- a *load path*: one ccx run, one ``*STEP`` per load vector, each step moving the loads
  from the previous vector to the next (``*CLOAD, OP=NEW``). The n columns of a
  Jacobian cost one ramp and n short steps instead of n ramps;
- a *restart*: ``*RESTART, WRITE`` leaves the state at the end of a run in its
  ``.rout`` file; a later run with ``*RESTART, READ`` continues from it (ccx's restart
  capability, its examples beamwrite/beamread). The file travels as bytes, so a worker
  can continue a state another worker solved.

The material is hyperelastic (Neo-Hooke) and the loads are dead loads, so the
equilibrium under a load vector does not depend on the path to it; what does is the
part of the solver's convergence error that Newton leaves behind. Every step here is
therefore converged tightly (:data:`farm.ccx.deck.TIGHT_FIELD_CONTROLS`), the ramp from
rest included: a state is then the same to the .frd's printed digits whichever way it
was reached (tests/farm/test_continuation.py).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from farm.ccx import deck as D
from farm.ccx.frd import FrdFile, read_frd
from farm.ccx.runner import CcxRun, run_ccx, scratch_dir
from farm.errors import ResultsError, SpecError
from farm.mesh.tyremesh import TyreMesh
from farm.solve.forces import (
    check_tread_nodes,
    cload_lines,
    positions_in,
    support_reaction,
    unloaded_reference,
)
from farm.solve.states import PathSolution, SolvedState, inner_strain, node_field
from farm.specs import ModelSpec, SolverSettings


@dataclass(frozen=True, eq=False)
class ForcePath:
    """A solved load path of the forward model.

    ``solution`` has one state per load vector, in order (``solve_seconds`` of each:
    the run's seconds up to that state); ``state`` is the ccx restart file of the last
    one (``keep_state``), from which :func:`solve_force_path` can continue, else None.
    """

    solution: PathSolution
    state: bytes | None


def path_deck(spec: ModelSpec, mesh: TyreMesh, nodes: np.ndarray,
              loads: Sequence[np.ndarray], settings: SolverSettings, *,
              restart: bool, keep_state: bool) -> str:
    """Deck of a load path: one step per load vector.

    ``restart``: the first step continues from the state in ``<job>.rin``; otherwise it
    ramps the loads up from rest, as :func:`farm.solve.forces.force_deck` does.
    """
    steps: list[str] = []
    for k, fz in enumerate(loads):
        first_ramp = k == 0 and not restart
        head = (D.static_step_lines(1.0, settings) + D.support_lines(spec) if first_ramp
                else D.continuation_step_lines(settings))
        steps += [*head, *D.tight_controls_lines(), *cload_lines(nodes, fz, new=not first_ramp),
                  *D.output_lines(time_points=False, contact=False), "*END STEP"]
    keep = D.restart_lines(read=False, write=keep_state)
    if restart:  # the model, its sets and its supports come with the restart file
        return "\n".join([*D.restart_lines(read=True, write=False), *keep, *steps]) + "\n"
    return D.assemble(
        D.mesh_lines(mesh), D.material_lines(spec.materials), D.cord_lines(spec, mesh),
        D.measured_set_lines(D.written_sets(mesh)), keep, steps)


def solve_force_path(spec: ModelSpec, mesh: TyreMesh, nodes: np.ndarray,
                     loads: Sequence[np.ndarray], settings: SolverSettings, *,
                     start: bytes | None = None, keep_state: bool = False,
                     road_z: float = np.nan,
                     should_stop: Callable[[], bool] | None = None) -> ForcePath:
    """Apply the vertical force vectors ``loads`` to ``nodes`` one after the other; one
    ccx run.

    Parameters
    ----------
    spec, mesh : the (reduced) model and its mesh.
    nodes : ndarray of int, shape (n,)
        Outer tread node ids that carry a force.
    loads : sequence of ndarray, each shape (n,)
        Force vectors (N, +z: the road pushing up), solved in this order, each from
        the state of the one before.
    start : bytes, optional
        A restart file (``ForcePath.state`` of an earlier solve of the same model and
        nodes) to continue from; None ramps the first vector up from rest.
    keep_state : bool
        Return the restart file of the last state.
    road_z : float
        Height of the contact centre the moments are taken about.

    Returns
    -------
    ForcePath with one state per load vector, ready for :func:`farm.measure.measure`.
    """
    nodes = check_tread_nodes(mesh, nodes)
    vectors = [np.asarray(f, dtype=float).ravel() for f in loads]
    if not vectors:
        raise SpecError("give at least one force vector")
    for fz in vectors:
        if fz.shape != nodes.shape or not np.isfinite(fz).all():
            raise SpecError(f"need one finite force per node: {nodes.size} nodes, "
                            f"{fz.size} forces")
    deck = path_deck(spec, mesh, nodes, vectors, settings, restart=start is not None,
                     keep_state=keep_state)
    with scratch_dir(keep=settings.keep_scratch, prefix="path-") as workdir:
        run = run_ccx(deck, workdir, threads=settings.threads, timeout=settings.timeout,
                      should_stop=should_stop, inputs=None if start is None else {"rin": start})
        frd = read_frd(run.file("frd"))
        state = _restart_file(run) if keep_state else None
    times = step_end_times(frd, len(vectors))
    states = tuple(_state(mesh, frd, t, nodes, fz, road_z, run)
                   for t, fz in zip(times, vectors, strict=True))
    solution = PathSolution(unloaded_reference(mesh), states, run.seconds, 1, run.increments)
    return ForcePath(solution, state)


def step_end_times(frd: FrdFile, steps: int) -> list[float]:
    """Total time of the last converged DISP block of each step of the run, in order.

    A restarted run numbers its steps on from the run it continues, and its file holds
    only its own steps; every step of this run must have written one."""
    last: dict[int, float] = {}
    for block in frd.results_named("DISP"):
        last[block.step] = max(last.get(block.step, -np.inf), block.time)
    if len(last) != steps:
        raise ResultsError(f"{frd.path}: expected results of {steps} steps, found "
                           f"{len(last)} (steps {sorted(last)})")
    return [last[s] for s in sorted(last)]


def _state(mesh: TyreMesh, frd: FrdFile, t: float, nodes: np.ndarray, fz: np.ndarray,
           road_z: float, run: CcxRun) -> SolvedState:
    force = np.zeros((mesh.tread_nodes.size, 3))
    force[positions_in(mesh.tread_nodes, nodes), 2] = fz
    rf = node_field(frd, "FORC", t, mesh.n_nodes)
    return SolvedState(0.0, road_z, node_field(frd, "DISP", t, mesh.n_nodes),
                       inner_strain(frd, mesh, t), force, support_reaction(mesh, rf),
                       run.seconds_to(t))


def _restart_file(run: CcxRun) -> bytes:
    try:
        return run.file("rout").read_bytes()
    except OSError as e:
        raise ResultsError(f"ccx wrote no restart file ({run.file('rout')}): {e}") from e
