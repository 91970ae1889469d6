"""Solved states of a load path: the raw fields the measurements are derived from."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from farm.ccx.frd import FrdFile
from farm.errors import ResultsError
from farm.mesh.tyremesh import TyreMesh
from farm.specs import RoadMotion

# Contact status codes of a tread node (combined loads, issue 13)
OPEN, STICK, SLIP = 0, 1, 2


@dataclass(frozen=True, eq=False)
class SolvedState:
    """One converged state of the tyre.

    Attributes
    ----------
    deflection : float
        Road travel from first touch, mm (0 for the unloaded reference).
    road_z : float
        Height of the road plane, mm (NaN for the reference state).
    displacement : ndarray, shape (n_nodes, 3)
        U of every tyre node, mm; NaN where the solver wrote none.
    strain : ndarray, shape (n_inner, 6)
        Solver strain at the inner nodes (grid order), global axes, components
        xx, yy, zz, xy, yz, zx (tensor shear), Lagrange (NLGEOM).
    tread_force : ndarray, shape (n_tread, 3)
        Force of the road on each outer tread node (grid order), N.
    road_reaction : ndarray, shape (3,)
        The road's total reaction on the tyre, N, measured independently of
        ``tread_force`` (the rigid road's reactions, or what the supports do not carry).
    solve_seconds : float
        Solver seconds spent to reach this state: cumulative along a one-run path, the
        state's own iterations for the iterative road.

    Combined loads only (None for a vertical path, issue 13):

    motion : RoadMotion or None
        Friction and the road's shift and tilt reached in this state (the path's motion
        scaled to the state's fraction; zero shift and tilt at the deflections).
    contact_status : ndarray of int8, shape (n_tread,)
        Per outer tread node (grid order): :data:`OPEN` (no contact), :data:`STICK` or
        :data:`SLIP` (shear stress at the Coulomb limit mu p; every contact node of a
        frictionless road slips).
    tread_slip : ndarray, shape (n_tread, 3)
        Relative tangential displacement of each tread node with respect to the road
        since it touched (elastic + sliding; ccx CSLIP), global axes, mm.
    road_moment : ndarray, shape (3,)
        Moment of the road's reactions about the contact centre (0, 0, ``road_z``),
        N mm: an independent check of the tread forces' moment.

    Rolling only (issue 30):

    rolling_radius : float
        The effective rolling radius r_e the roll turned the rim with, mm (given, or
        found for free rolling; NaN: not a roll).
    """

    deflection: float
    road_z: float
    displacement: np.ndarray
    strain: np.ndarray
    tread_force: np.ndarray
    road_reaction: np.ndarray
    solve_seconds: float = float("nan")
    motion: RoadMotion | None = None
    contact_status: np.ndarray | None = None
    tread_slip: np.ndarray | None = None
    road_moment: np.ndarray | None = None
    rolling_radius: float = float("nan")

    def positions(self, mesh: TyreMesh, ids: np.ndarray) -> np.ndarray:
        """Current coordinates of nodes ``ids``, shape (len(ids), 3)."""
        return mesh.xyz(ids) + self.displacement[np.asarray(ids) - 1]


@dataclass(frozen=True, eq=False)
class PathSolution:
    """A solved load path: the unloaded reference and one state per deflection.

    ``solve_seconds`` is the wall time of all ccx runs the path took, ``ccx_runs`` their
    number, ``increments`` the converged increments summed over them.
    """

    reference: SolvedState
    states: tuple[SolvedState, ...]
    solve_seconds: float
    ccx_runs: int
    increments: int


def node_field(frd: FrdFile, name: str, time: float, n_nodes: int, width: int = 3) -> np.ndarray:
    """A nodal result block as an (n_nodes, width) array indexed by node id - 1.

    Nodes beyond the tyre (the road) are dropped; missing nodes are NaN.
    """
    block = frd.at(name, time)
    out = np.full((n_nodes, width), np.nan)
    keep = block.node_ids <= n_nodes
    out[block.node_ids[keep] - 1] = block.values[keep, :width]
    return out


def inner_strain(frd: FrdFile, mesh: TyreMesh, time: float) -> np.ndarray:
    """Solver strain at the inner nodes, (n_inner, 6); every inner node must have one."""
    strain = node_field(frd, "TOSTRAIN", time, mesh.n_nodes, width=6)[mesh.inner_nodes - 1]
    if not np.isfinite(strain).all():
        raise ResultsError(f"the .frd has no strain for some inner nodes at time {time}")
    return strain
