"""The thesis' iterative road boundary condition for the reduced model (§3.2).

"The boundary condition between the tyre and the flat, smooth road is iteratively
applied by first displacing the node on the tread which most violates the road for a
given total displacement, running this simulation to determine the new penetration with
the road, and then repeating this process until no tread nodes penetrate the road. If a
node presents an opposing reaction force in the z-direction at any stage (tensile
reaction force instead of compressive), it is released."

Only the vertical displacement of a contact node is prescribed, so the road is
frictionless. Each iteration is one ccx run; the contact set found at one deflection is
the first guess at the next, which keeps the runs per deflection low. Every run counts
in ``PathSolution.ccx_runs``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from farm.ccx import deck as D
from farm.ccx.frd import read_frd
from farm.ccx.runner import run_ccx, scratch_dir
from farm.errors import SolverError
from farm.mesh.tyremesh import TyreMesh
from farm.solve.states import PathSolution, SolvedState, inner_strain, node_field
from farm.specs import LoadPath, ModelSpec, SolverSettings

PENETRATION_TOL = 1e-3  # mm: below this a node counts as on the road, not through it
TENSION_TOL = 1e-3  # N: a prescribed node pulling the road down by more is released
MAX_ITERATIONS = 30
SUPPORT_SETS = ("BEAD_SEAT", "CUT_START", "CUT_END")


def prescribed_deck(spec: ModelSpec, mesh: TyreMesh, uz: dict[int, float],
                    settings: SolverSettings) -> str:
    """Deck with the vertical displacement ``uz[node]`` prescribed on contact nodes."""
    bcs = D.support_lines(spec) + [f"{node}, 3, 3, {value!r}" for node, value in sorted(uz.items())]
    return D.assemble(
        D.mesh_lines(mesh), D.material_lines(spec.materials), D.cord_lines(spec, mesh),
        D.measured_set_lines(D.written_sets(mesh)),
        D.static_step_lines(1.0, settings), bcs,
        D.output_lines(time_points=False, contact=False), ["*END STEP"],
    )


class _Runner:
    """Runs the iterations and keeps the books (runs, seconds, increments)."""

    def __init__(self, spec, mesh, settings, should_stop):
        self.spec, self.mesh, self.settings, self.should_stop = spec, mesh, settings, should_stop
        self.runs = self.increments = 0
        self.seconds = 0.0

    def solve(self, uz: dict[int, float], deflection: float, road_z: float) -> SolvedState:
        deck = prescribed_deck(self.spec, self.mesh, uz, self.settings)
        with scratch_dir(keep=self.settings.keep_scratch, prefix="iterative-") as workdir:
            run = run_ccx(deck, workdir, threads=self.settings.threads,
                          timeout=self.settings.timeout, should_stop=self.should_stop)
            frd = read_frd(run.file("frd"))
        self.runs += 1
        self.seconds += run.seconds
        self.increments += run.increments
        t = frd.times("DISP")[-1]
        u = node_field(frd, "DISP", t, self.mesh.n_nodes)
        rf = node_field(frd, "FORC", t, self.mesh.n_nodes)
        tread = self.mesh.tread_nodes
        force = np.where(np.isin(tread, list(uz))[:, None], np.nan_to_num(rf[tread - 1]), 0.0)
        # The road's reaction, independently of the contact nodes: what the supports
        # (beads, cut faces) do not carry. Their reactions are in the output
        # (D.written_sets: every node of a one-element wall is on a surface).
        supports = np.concatenate([self.mesh.node_sets[k] for k in SUPPORT_SETS
                                   if k in self.mesh.node_sets])
        road = -rf[np.unique(supports) - 1].sum(axis=0)
        return SolvedState(deflection, road_z, u, inner_strain(frd, self.mesh, t), force, road,
                           run.seconds)


def _contact_state(runner: _Runner, mesh: TyreMesh, active: set[int], deflection: float,
                   road_z: float) -> SolvedState:
    """Iterate the contact set at one deflection until nothing penetrates or pulls."""
    tread = mesh.tread_nodes
    z0 = mesh.xyz(tread)[:, 2]
    seen: set[frozenset[int]] = set()
    spent = runner.seconds
    for _ in range(MAX_ITERATIONS):
        if not active:  # the node that most violates the road goes first
            active = {int(tread[np.argmin(z0)])}
        seen.add(frozenset(active))
        uz = {n: road_z - float(mesh.xyz(np.array([n]))[0, 2]) for n in active}
        state = runner.solve(uz, deflection, road_z)
        z = z0 + state.displacement[tread - 1, 2]
        inside = np.isin(tread, list(active))
        penetrating = set(tread[(z < road_z - PENETRATION_TOL) & ~inside].tolist())
        pulling = set(tread[inside & (state.tread_force[:, 2] < -TENSION_TOL)].tolist())
        if not penetrating and not pulling:
            return dataclasses.replace(state, solve_seconds=runner.seconds - spent)
        nxt = (active | penetrating) - pulling
        if frozenset(nxt) in seen:  # adding all at once cycles: add the worst one only
            worst = tread[np.argmin(np.where(inside, np.inf, z))]
            nxt = (active | {int(worst)}) - pulling
        if frozenset(nxt) in seen:
            break
        active = nxt
    raise SolverError(
        "contact_not_converged", ["iterative road", f"deflection={deflection}"], None,
        f"the contact set did not settle after {len(seen)} ccx runs",
        "Try the rigid-plane contact road (road='contact') for this load",
    )


def solve_iterative_path(spec: ModelSpec, mesh: TyreMesh, path: LoadPath,
                         settings: SolverSettings,
                         should_stop: Callable[[], bool] | None = None) -> PathSolution:
    """Solve every deflection of ``path`` with the iterative procedure."""
    runner = _Runner(spec, mesh, settings, should_stop)
    touch_z = mesh.bottom_z
    states: list[SolvedState] = []
    active: set[int] = set()
    for d in path.deflections:
        state = _contact_state(runner, mesh, set(active), d, touch_z + d)
        active = set(mesh.tread_nodes[state.tread_force[:, 2] > 0].tolist())
        states.append(state)
    reference = SolvedState(0.0, np.nan, np.zeros((mesh.n_nodes, 3)),
                            np.zeros((mesh.inner_nodes.size, 6)),
                            np.zeros((mesh.tread_nodes.size, 3)), np.zeros(3))
    return PathSolution(reference, tuple(states), runner.seconds, runner.runs, runner.increments)
