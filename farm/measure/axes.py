"""Forces and moments in the road's axes (issue 45: camber as the literature reads it).

The farm states every force in the wheel's axes: x forward, y along the spin axis, z up
in the wheel plane (thesis §2.5, TYDEX C at zero camber). A tilted road
(:attr:`farm.specs.RoadMotion.tilt`: the road turned by ``tilt`` about +x, the camber)
pushes along its own normal, so in the wheel's axes its normal force shows up in Fy:
-90 N of the -44 N a 2 degree roll reported (docs/rolling.md). Tyre testing reports in
the road's axes (TYDEX W, ISO 8855's): x along the road's intersection with the wheel
plane, y in the road plane, z normal to it. With the tilt about x alone these are x,
(0, cos t, sin t) and (0, -sin t, cos t), :attr:`farm.specs.RoadMotion.normal`'s plane.
"""

from __future__ import annotations

import numpy as np


def road_axes(tilt_deg: float) -> np.ndarray:
    """(3, 3): the road's x, y and z axes (rows) in the wheel's axes, for a road turned
    by ``tilt_deg`` degrees about +x."""
    t = np.radians(tilt_deg)
    return np.array([[1.0, 0.0, 0.0],
                     [0.0, np.cos(t), np.sin(t)],
                     [0.0, -np.sin(t), np.cos(t)]])


def in_road_axes(vectors: np.ndarray, tilt_deg: float | np.ndarray) -> np.ndarray:
    """Wheel-axes vectors (..., 3) (forces, or moments about the contact centre, which
    lies on the road) in the road's axes; ``tilt_deg`` a scalar or one per leading row
    (K,) for vectors (K, 3)."""
    v = np.asarray(vectors, dtype=float)
    tilt = np.asarray(tilt_deg, dtype=float)
    if tilt.ndim == 0:
        return v @ road_axes(float(tilt)).T
    return np.einsum("kij,kj->ki", np.stack([road_axes(float(t)) for t in tilt]), v)
