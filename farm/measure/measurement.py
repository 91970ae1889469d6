"""What one virtual experiment yields: the camera's measurements and the true forces.

Measurements are taken relative to the unloaded reference state of the load path - the
inflated, unloaded tyre for the full model, the undeformed one for the reduced model -
because T2Cam measures against a reference point cloud of the inflated but unloaded tyre
(thesis §2.2). The solver strain is reported as its change from that state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from farm.measure.patch import PatchMetrics, inflation_growth, patch_metrics, tread_areas
from farm.measure.surface import cst_surface_strain, rotate_to_surface, surface_frames
from farm.mesh.tyremesh import TyreMesh
from farm.solve.states import PathSolution, SolvedState
from farm.specs import RoadMotion


@dataclass(frozen=True, eq=False)
class Measurement:
    """One experiment's arrays (units: mm, N, N mm; strains dimensionless).

    Attributes
    ----------
    deflection, pressure : float
        Load case: road travel from first touch (mm) and inflation pressure (MPa).
    displacement : ndarray, shape (n_inner, 3)
        Inner-surface displacement from the reference state, global x, y, z.
    strain : ndarray, shape (n_inner, 3)
        Solver strain change from the reference state, local xx, yy, xy.
    surface_strain : ndarray, shape (n_inner, 3)
        CST surface strain from the reference state, local xx, yy, xy.
    reaction_force : ndarray, shape (n_tread, 3)
        Road force on each outer tread node.
    total_force : ndarray, shape (3,)
        Fx, Fy, Fz summed over the tread.
    moment : ndarray, shape (3,)
        Mx, My, Mz of the tread forces about the contact centre (0, 0, road z).
    road_reaction : ndarray, shape (3,)
        The road's reaction obtained independently of the tread forces (a check).
    contact_nodes : int
        Tread nodes carrying road force.
    solve_seconds : float
        Solver seconds spent to reach this state (see ``SolvedState``).

    Combined loads only (None for a vertical path; issue 13, docs/combined-loads.md):

    motion : RoadMotion or None
        Friction coefficient and the road's shift (mm) and tilt (degrees) of this state.
    contact_status : ndarray of int8, shape (n_tread,)
        0 open, 1 stick, 2 slip per outer tread node (``farm.solve.states``).
    tread_slip : ndarray, shape (n_tread, 3)
        Tangential displacement of each tread node relative to the road, mm.
    road_moment : ndarray, shape (3,)
        Moment of the road's reactions about the contact centre, N mm (a check of
        ``moment``; differs by the force times the tread's float above the road).

    Contact patch and inflation growth (issue 24, :mod:`farm.measure.patch`):

    patch : ndarray, shape (7,), or None
        The contact patch of this state (:func:`patch_array`: the values of
        :attr:`PATCH_FIELDS`, in that order; None: not measured). Plain float64, so that
        the loops' evaluation cache (``jobs.loops.cache``) stores it without pickle.
    inflation_growth : float or None
        Radial growth of the tread in the path's inflated reference state, mm; the same
        for every state of the path; NaN for a model without inflation (None: not
        measured, e.g. a cached evaluation of an older farm).

    Radii (issue 30; None: not measured, e.g. a cached evaluation of an older farm):

    loaded_radius : float or None
        Distance from the wheel centre down to the road under it (the contact centre),
        mm: the loaded radius of a standing or rolling tyre.
    rolling_radius : float or None
        The effective rolling radius r_e a roll turned the rim with, mm (given, or found
        for free rolling); NaN for a tyre that does not roll.
    """

    deflection: float
    pressure: float
    displacement: np.ndarray
    strain: np.ndarray
    surface_strain: np.ndarray
    reaction_force: np.ndarray
    total_force: np.ndarray
    moment: np.ndarray
    road_reaction: np.ndarray
    contact_nodes: int
    solve_seconds: float
    motion: RoadMotion | None = None
    contact_status: np.ndarray | None = None
    tread_slip: np.ndarray | None = None
    road_moment: np.ndarray | None = None
    patch: np.ndarray | None = None
    inflation_growth: float | None = None
    loaded_radius: float | None = None
    rolling_radius: float | None = None

    # units of the arrays of combined_arrays() (the store's `units` attributes)
    COMBINED_UNITS: ClassVar[dict[str, str]] = {
        "contact_status": "1", "tread_slip": "mm", "road_reaction": "N", "road_moment": "N mm",
    }

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays the store holds for an experiment."""
        return {
            "displacement": self.displacement, "strain": self.strain,
            "surface_strain": self.surface_strain, "reaction_force": self.reaction_force,
            "total_force": self.total_force, "moment": self.moment,
        }

    def combined_arrays(self) -> dict[str, np.ndarray]:
        """The extra arrays of a combined-load experiment (empty for a vertical one).

        ``contact_status`` (n_tread,), ``tread_slip`` (n_tread, 3), ``road_reaction``
        and ``road_moment`` (3,); units in :attr:`COMBINED_UNITS`. The load case itself
        (friction, shifts, tilt) is ``motion.to_dict()``.
        """
        if self.motion is None:
            return {}
        # a state with a motion carries all three (farm.solve.contact fills them together)
        assert (self.contact_status is not None and self.tread_slip is not None
                and self.road_moment is not None)
        return {"contact_status": self.contact_status, "tread_slip": self.tread_slip,
                "road_reaction": self.road_reaction, "road_moment": self.road_moment}

    # the store's names of patch's values, in order -> the PatchMetrics field of each
    PATCH_FIELDS: ClassVar[dict[str, str]] = {
        "patch_area": "area", "patch_length": "length", "patch_width": "width",
        "peak_pressure": "peak_pressure", "mean_pressure": "mean_pressure",
        "nodal_force_mean": "nodal_mean", "nodal_force_std": "nodal_std",
    }
    # units of patch_values() (the store's `units` attributes)
    PATCH_UNITS: ClassVar[dict[str, str]] = {
        "patch_area": "mm2", "patch_length": "mm", "patch_width": "mm",
        "peak_pressure": "MPa", "mean_pressure": "MPa", "nodal_force_mean": "N",
        "nodal_force_std": "N", "inflation_growth": "mm", "loaded_radius": "mm",
        "rolling_radius": "mm",
    }

    def patch_values(self) -> dict[str, float]:
        """The contact patch, the inflation growth and the radii by the store's names
        (units in :attr:`PATCH_UNITS`), NaN where not measured."""
        values = (np.full(len(self.PATCH_FIELDS), np.nan) if self.patch is None
                  else np.asarray(self.patch, dtype=np.float64))
        out = {name: float(v) for name, v in zip(self.PATCH_FIELDS, values, strict=True)}
        for name in ("inflation_growth", "loaded_radius", "rolling_radius"):
            value = getattr(self, name)
            out[name] = math.nan if value is None else float(value)
        return out


def patch_array(metrics: PatchMetrics) -> np.ndarray:
    """The values of :attr:`Measurement.PATCH_FIELDS` of ``metrics``, in order."""
    return np.array([float(getattr(metrics, f)) for f in Measurement.PATCH_FIELDS.values()])


def tread_totals(mesh: TyreMesh, state: SolvedState) -> tuple[np.ndarray, np.ndarray]:
    """Total force and moment about the contact centre from the tread node forces.

    The contact centre is the point of the road plane under the wheel centre (TYDEX C
    origin, thesis §2.5); lever arms use the deformed node positions, as a wheel force
    transducer would see them.
    """
    force = state.tread_force
    centre = np.array([0.0, 0.0, state.road_z])
    arms = state.positions(mesh, mesh.tread_nodes) - centre
    return force.sum(axis=0), np.cross(arms, force).sum(axis=0)


def measure(mesh: TyreMesh, solution: PathSolution, pressure: float, *,
            inflated: bool = False) -> list[Measurement]:
    """Derive the measurements of every state of a solved load path; ``inflated``: the
    path's reference is the inflated tyre (the full model), whose growth is measured
    (NaN otherwise)."""
    ref = solution.reference
    grid = mesh.inner_grid
    shape = (*grid.shape, 3)
    x0 = mesh.xyz(mesh.inner_nodes)
    ref_xyz = (x0 + ref.displacement[mesh.inner_nodes - 1]).reshape(shape)
    frames = surface_frames(x0.reshape(shape)).reshape(-1, 3, 3)
    areas = tread_areas(mesh)
    growth = inflation_growth(mesh, ref) if inflated else math.nan
    out = []
    for state in solution.states:
        u = state.displacement[mesh.inner_nodes - 1]
        cur_xyz = (x0 + u).reshape(shape)
        total, moment = tread_totals(mesh, state)
        out.append(Measurement(
            deflection=state.deflection, pressure=pressure,
            displacement=u - ref.displacement[mesh.inner_nodes - 1],
            strain=rotate_to_surface(state.strain - ref.strain, frames),
            surface_strain=cst_surface_strain(ref_xyz, cur_xyz, mesh.periodic).reshape(-1, 3),
            reaction_force=state.tread_force, total_force=total, moment=moment,
            road_reaction=state.road_reaction,
            contact_nodes=int(np.count_nonzero(np.abs(state.tread_force).sum(axis=1))),
            solve_seconds=state.solve_seconds, motion=state.motion,
            contact_status=state.contact_status, tread_slip=state.tread_slip,
            road_moment=state.road_moment, patch=patch_array(patch_metrics(mesh, state, areas)),
            inflation_growth=growth, loaded_radius=-float(state.road_z),
            rolling_radius=float(state.rolling_radius),
        ))
    return out
