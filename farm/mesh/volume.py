"""Element volumes, for checks against the volume of the revolved section (Pappus)."""

from __future__ import annotations

import numpy as np

_G = 1.0 / np.sqrt(3.0)
_CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                     [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)


def hex_volumes(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """Exact volumes of trilinear hexahedra, shape (n_elements,).

    The Jacobian determinant of a trilinear map is at most quadratic in each parent
    coordinate, so 2x2x2 Gauss quadrature integrates it exactly.
    """
    x = nodes[elements - 1]  # (E, 8, 3)
    total = np.zeros(len(elements))
    for gp in _CORNERS * _G:
        # derivatives of the 8 shape functions N_a = (1 + xi xi_a)(1 + eta eta_a)(1 + zeta zeta_a)/8
        d = np.empty((8, 3))
        for a, (xa, ya, za) in enumerate(_CORNERS):
            d[a] = [xa * (1 + ya * gp[1]) * (1 + za * gp[2]),
                    ya * (1 + xa * gp[0]) * (1 + za * gp[2]),
                    za * (1 + xa * gp[0]) * (1 + ya * gp[1])]
        jac = np.einsum("eai,aj->eij", x, d / 8.0)  # (E, 3, 3)
        total += np.linalg.det(jac)
    return total
