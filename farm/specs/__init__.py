"""Plain, typed, immutable descriptions of a tyre model and of what to do with it.

Everything that changes a result lives in these frozen dataclasses, validated once when
constructed, so that a spec that exists is a spec that can be meshed and solved. Units
are N, mm, MPa and s throughout (docs/architecture.md); the CLI converts kPa at its boundary.

``to_dict``/``from_dict`` give the canonical form used for content hashes (jobs) and
for study files; ``from_dict`` rejects unknown keys so that a typo is never ignored.
"""

from __future__ import annotations

from farm.specs.model import (
    CLEARANCE_MM,
    CONTACT_PRESSURE_MPA,
    FRICTION,
    GEOMETRY_MM,
    MAX_BRANCH_MM,
    MAX_INCREMENTS,
    MAX_ITERATIONS,
    MAX_PRESSURE_MPA,
    MAX_THROUGH,
    MIN_DEFLECTION_MM,
    MIN_INCREMENT,
    MODULUS_MPA,
    RISES,
    ROLL_MM,
    ROLLING_RADIUS_MM,
    SHIFT_MM,
    SLIP_ANGLE_DEG,
    SLIP_RATIO,
    STICK_SLOPE,
    THREADS,
    TILT_DEG,
    TIMEOUT_S,
    ContactLaw,
    CutFaces,
    LoadPath,
    Material,
    Materials,
    MeshDensity,
    ModelKind,
    ModelSpec,
    RoadKind,
    RoadMotion,
    Roll,
    SolverSettings,
    TyreGeometry,
    content_hash,
)

__all__ = [
    "CLEARANCE_MM", "CONTACT_PRESSURE_MPA", "FRICTION", "GEOMETRY_MM", "MAX_BRANCH_MM",
    "MAX_INCREMENTS", "MAX_ITERATIONS", "MAX_PRESSURE_MPA", "MAX_THROUGH",
    "MESH_NODES", "MIN_DEFLECTION_MM", "MIN_INCREMENT", "MODULUS_MPA", "RISES", "ROLLING_RADIUS_MM",
    "ROLL_MM", "SHIFT_MM", "SLIP_ANGLE_DEG", "SLIP_RATIO", "STICK_SLOPE", "THREADS",
    "TILT_DEG", "TIMEOUT_S", "ContactLaw", "CutFaces", "LoadPath", "Material", "Materials",
    "MeshDensity", "ModelKind", "ModelSpec", "RoadKind", "RoadMotion", "Roll",
    "SolverSettings", "TyreGeometry", "content_hash",
]
