"""Plain, typed, immutable descriptions of a tyre model and of what to do with it.

Everything that changes a result lives in these frozen dataclasses, validated once when
constructed, so that a spec that exists is a spec that can be meshed and solved. Units
are N, mm, MPa and s throughout (docs/architecture.md); the CLI converts kPa at its boundary.

One module per family, each holding its specs with their bounds and checks
(docs/architecture.md, "Specs"):

- :mod:`farm.specs.model`: :class:`ModelSpec` and its parts (geometry, mesh density,
  materials, contact law);
- :mod:`farm.specs.loads`: :class:`LoadPath`, :class:`RoadMotion`, :class:`Roll`;
- :mod:`farm.specs.solver`: :class:`SolverSettings`;
- :mod:`farm.specs.bounds`: what two families share (``STICK_SLOPE``, the number checks);
- :mod:`farm.specs.serial`: :func:`content_hash` and the dataclasses read from plain data.

``to_dict``/``from_dict`` give the canonical form used for content hashes (jobs) and
for study files; ``from_dict`` rejects unknown keys so that a typo is never ignored.
Every name is re-exported here: ``from farm.specs import ModelSpec`` is the way to import.
"""

from __future__ import annotations

from farm.specs.bounds import STICK_SLOPE
from farm.specs.loads import (
    FRICTION,
    FRICTION_FROM,
    LEAD_RAMP_MM,
    MAX_BRANCH_MM,
    MAX_PRESSURE_MPA,
    MIN_DEFLECTION_MM,
    RISES,
    ROLL_MM,
    ROLLING_RADIUS_MM,
    SHIFT_MM,
    SLIP_ANGLE_DEG,
    SLIP_RATIO,
    TILT_DEG,
    LoadPath,
    RoadMotion,
    Roll,
)
from farm.specs.model import (
    CLEARANCE_MM,
    CONTACT_PRESSURE_MPA,
    GEOMETRY_MM,
    MAX_THROUGH,
    MESH_NODES,
    MODULUS_MPA,
    ContactLaw,
    CutFaces,
    Material,
    Materials,
    MeshDensity,
    ModelKind,
    ModelSpec,
    RoadKind,
    TyreGeometry,
)
from farm.specs.serial import content_hash
from farm.specs.solver import (
    MAX_INCREMENTS,
    MAX_ITERATIONS,
    MIN_INCREMENT,
    RESTART_EVERY_MM,
    THREADS,
    TIMEOUT_S,
    SolverSettings,
)

__all__ = [
    "CLEARANCE_MM", "CONTACT_PRESSURE_MPA", "FRICTION", "FRICTION_FROM", "GEOMETRY_MM",
    "LEAD_RAMP_MM", "MAX_BRANCH_MM",
    "MAX_INCREMENTS", "MAX_ITERATIONS", "MAX_PRESSURE_MPA", "MAX_THROUGH",
    "MESH_NODES", "MIN_DEFLECTION_MM", "MIN_INCREMENT", "MODULUS_MPA", "RESTART_EVERY_MM",
    "RISES", "ROLLING_RADIUS_MM",
    "ROLL_MM", "SHIFT_MM", "SLIP_ANGLE_DEG", "SLIP_RATIO", "STICK_SLOPE", "THREADS",
    "TILT_DEG", "TIMEOUT_S", "ContactLaw", "CutFaces", "LoadPath", "Material", "Materials",
    "MeshDensity", "ModelKind", "ModelSpec", "RoadKind", "RoadMotion", "Roll",
    "SolverSettings", "TyreGeometry", "content_hash",
]
