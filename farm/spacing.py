"""Circumferential element spacing: uniform, or fine over a window about the road.

Issue 24: on a uniform mesh the road force of the affordable meshes sits on one column
of tread nodes, and Fz moved 22 % between 16 and 24 elements round the tyre (the
model-space study): the contact patch was not resolved. A *window* refines the
circumference where the patch and the camera are (thesis §2.2: T2Cam sees about 40
degrees about the contact centre) and coarsens it elsewhere. Inside ``+-window``
degrees of the contact centre (angle 0, under the wheel centre) the elements are equal,
``window / window_elements`` degrees each; outside, each element is ``growth`` times the
previous one, ``growth`` chosen so that the elements exactly fill the rest of the sector
(a geometric progression: the usual smooth grading, with no jump in size at the
window's edge beyond one growth factor). Pure arithmetic, no gmsh: the spec validates
with it and the mesher places its layers with it.
"""

from __future__ import annotations

import numpy as np

from farm.errors import SpecError

MAX_GROWTH = 1.25
"""Largest size ratio of neighbouring elements outside the window. Grading ratios
beyond ~1.2-1.3 are where finite element practice starts to lose accuracy in the
coarser element (and ccx's contact search dislikes abrupt changes in facet size)."""


def half_steps(half_angle: float, n_half: int, window: float = 0.0,
               window_elements: int = 0) -> np.ndarray:
    """Element angles (degrees), from the contact centre outwards, over half a sector.

    Parameters
    ----------
    half_angle : float
        Half the revolved sector in degrees (180 for the full tyre).
    n_half : int
        Elements over that half (half of ``mesh.circumferential``).
    window, window_elements : float, int
        Half-width in degrees of the fine window, and its elements per side; ``window``
        0 means a uniform mesh.

    Returns
    -------
    ndarray, shape (n_half,)
        Positive angles summing to ``half_angle``.

    Raises
    ------
    SpecError
        If the window does not fit, is not finer than the rest, or needs a growth
        ratio above :data:`MAX_GROWTH`; the message names the numbers to change.
    """
    if window == 0:
        return np.full(n_half, half_angle / n_half)
    if not 0 < window < half_angle:
        raise SpecError(f"mesh.window must lie in (0, {half_angle:g}) degrees (half the "
                        f"sector), got {window:g}")
    if not 1 <= window_elements < n_half:
        raise SpecError(
            f"mesh.window_elements must be at least 1 and less than half of "
            f"mesh.circumferential ({n_half}), got {window_elements}")
    fine = window / window_elements
    n_out, rest = n_half - window_elements, half_angle - window
    if fine * n_out >= rest * (1 - 1e-12):
        raise SpecError(
            f"the window's elements ({fine:.3g} deg) are not finer than the "
            f"{n_out} outside them would be ({rest / n_out:.3g} deg each): lower "
            "mesh.circumferential or raise mesh.window_elements")
    growth = _growth(fine, n_out, rest)
    if growth > MAX_GROWTH:
        raise SpecError(
            f"the mesh would grow by {growth:.3f} per element outside the window "
            f"(at most {MAX_GROWTH}): raise mesh.circumferential (now {2 * n_half}) or "
            "lower mesh.window_elements")
    outside = fine * growth ** np.arange(1, n_out + 1)
    outside *= rest / outside.sum()  # exact sum despite the bisection's tolerance
    return np.concatenate([np.full(window_elements, fine), outside])


def _growth(fine: float, n: int, total: float) -> float:
    """The ratio r > 1 with ``fine * (r + r**2 + ... + r**n) = total`` (bisection)."""
    low, high = 1.0, 2.0
    while fine * sum(high ** k for k in range(1, n + 1)) < total:
        high *= 2.0
    for _ in range(200):
        mid = 0.5 * (low + high)
        if fine * float(np.sum(mid ** np.arange(1, n + 1))) < total:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)


def column_angles(sector_angle: float, circumferential: int, full: bool, window: float = 0.0,
                  window_elements: int = 0) -> np.ndarray:
    """Angles (radians) of the node columns, increasing, the contact centre at 0.

    The full tyre has ``circumferential`` columns from -pi (the seam, shared with +pi)
    upwards; a sector has ``circumferential + 1`` from one cut face to the other.
    """
    if window == 0:  # the uniform mesh's formula, bit for bit as before windows existed
        step = np.radians(sector_angle) / circumferential
        n_cols = circumferential if full else circumferential + 1
        return (np.arange(n_cols) - circumferential // 2) * step
    steps = np.radians(half_steps(sector_angle / 2, circumferential // 2, window,
                                  window_elements))
    side = np.concatenate([[0.0], np.cumsum(steps)])
    both = np.concatenate([-side[:0:-1], side])
    return both[:-1] if full else both
