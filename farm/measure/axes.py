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


def road_axes(tilt_deg: float | np.ndarray) -> np.ndarray:
    """(..., 3, 3): the road's x, y and z axes (rows) in the wheel's axes, for a road
    turned by ``tilt_deg`` degrees about +x (a scalar, or one tilt per leading entry)."""
    t = np.radians(np.asarray(tilt_deg, dtype=float))
    c, s, one, zero = np.cos(t), np.sin(t), np.ones_like(t), np.zeros_like(t)
    return np.stack([np.stack([one, zero, zero], axis=-1),
                     np.stack([zero, c, s], axis=-1),
                     np.stack([zero, -s, c], axis=-1)], axis=-2)


def in_road_axes(vectors: np.ndarray, tilt_deg: float | np.ndarray) -> np.ndarray:
    """Wheel-axes vectors (..., 3) (forces, or moments about the contact centre, which
    lies on the road) in the road's axes; ``tilt_deg`` a scalar or one per leading row
    (K,) for vectors (K, 3) or (K, n, 3)."""
    v = np.asarray(vectors, dtype=float)
    r = road_axes(tilt_deg)
    if r.ndim == 3 and v.ndim == 3:  # one tilt per row of (K, n, 3)
        return np.einsum("kij,knj->kni", r, v)
    return np.einsum("...ij,...j->...i", r, v)
