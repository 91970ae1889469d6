"""Membrane stiffness of cord plies (netting theory) and of a network of axial members.

Netting theory (Clark (ed.), "Mechanics of Pneumatic Tires", NHTSA 1981, ch. 7; Gough's
netting analysis): the rubber carries nothing, each cord only its axial force. A ply whose
cords run at ``theta`` to the circumferential direction ``c`` with stiffness ``S`` (cord
modulus x cord area per unit ply width, N/mm) resists the membrane strain
``(eps_c, eps_m, gamma_cm)`` with the Voigt tensor ``S b b^T``, ``b = (cos^2, sin^2,
sin cos)``. A balanced +-theta pair of total ``S`` gives ``A11 = S cos^4``, ``A22 = S
sin^4``, ``A12 = A66 = S sin^2 cos^2`` and no shear coupling (``A16 = A26 = 0``).

A network of straight members of axial stiffness ``E*A`` and length ``L`` under a
uniform membrane strain stores ``1/2 E*A L (b . eps)^2`` each (``b`` of its direction),
so its homogenised stiffness over an ``area`` is ``sum E*A L b b^T / area``. Members
along the two edge directions of a structured grid (b = (1, 0, 0) and (0, 1, 0)) thus
have ``A66 = 0`` whatever their stiffness: the shear stiffness of the belt pair, which
governs the lateral force and the aligning moment, is lost (issue 24). Members along
the cords restore it: a member that stands for the cords over a tributary ``area`` and
has the cord direction gets ``E*A = (S / 2) area / L`` per ply (:mod:`farm.ccx.belt_cords`).
"""

from __future__ import annotations

import numpy as np


def _directions(c: np.ndarray, m: np.ndarray) -> np.ndarray:
    """``b = (c^2, m^2, c m)`` of unit directions ``(c, m)``, shape (..., 3)."""
    return np.stack([c * c, m * m, c * m], axis=-1)


def netting_tensor(stiffness: float, angle: float) -> np.ndarray:
    """Voigt membrane stiffness (3, 3), N/mm, of a balanced +-``angle`` ply pair.

    ``stiffness`` is the pair's cord stiffness per unit width, all plies (N/mm),
    ``angle`` the cords' angle to the circumferential direction in degrees; half the
    cords run at ``+angle``, half at ``-angle``.
    """
    t = np.radians(angle)
    b = _directions(np.array([np.cos(t), np.cos(t)]), np.array([np.sin(t), -np.sin(t)]))
    return 0.5 * stiffness * np.einsum("ki,kj->ij", b, b)


def network_tensor(vectors: np.ndarray, ea: np.ndarray, area: float) -> np.ndarray:
    """Homogenised Voigt membrane stiffness (3, 3), N/mm, of axial members.

    Parameters
    ----------
    vectors : ndarray, shape (n, 2)
        Each member's vector (mm) in the local (circumferential, meridional) frame.
    ea : ndarray, shape (n,)
        Axial stiffness ``E*A`` (N) of each member.
    area : float
        The membrane area (mm^2) the members stand for together.
    """
    vectors = np.asarray(vectors, dtype=float)
    length = np.linalg.norm(vectors, axis=1)
    b = _directions(vectors[:, 0] / length, vectors[:, 1] / length)
    return np.einsum("k,ki,kj->ij", np.asarray(ea, dtype=float) * length, b, b) / area
