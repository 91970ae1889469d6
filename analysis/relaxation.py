"""A slip's steady force from short led rolls (issue 45, docs/rolling.md "A steady roll").

Along a roll at constant slip the force follows the first-order (string) model of the
transient tyre (Pacejka, *Tyre and Vehicle Dynamics*, ch. 7)::

    dF/ds = (F_ss - F) / sigma

with ``F_ss`` the steady force and ``sigma`` the relaxation length. A roll led by its
steady carcass deflection (``Roll.lead``, ``Roll.lead_x``) starts near ``F_ss``; two
rolls whose leads straddle the right one end on either side of it, their drifts of
opposite signs. At each roll's end ``F = F_ss - sigma dF/ds``: linear in (``F_ss``,
``sigma``), so two ends fix both (:func:`secant`), and the lead whose force would not
drift is the zero of the drift's line in the lead (:func:`flat_lead`); the steady force
over that lead is the carcass's stiffness. ``benchmarks/bench_steady_roll.py`` prints
both for its led rolls.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from analysis.errors import ParameterError


def secant(ends: Sequence[tuple[float, float]]) -> tuple[float, float]:
    """The steady force and the relaxation length through the ends of led rolls.

    Parameters
    ----------
    ends : sequence of (F, dF/ds), length >= 2
        Each roll's force at its end (N) and its slope there (N/mm).

    Returns
    -------
    steady : float
        ``F_ss`` (N), the least-squares fit of ``F = F_ss - sigma dF/ds`` (two rolls:
        exact).
    sigma : float
        The relaxation length (mm).
    """
    f, s = _pairs(ends, "ends")
    if np.ptp(s) == 0:
        raise ParameterError(f"rolls ending at equal slopes {s.tolist()} N/mm fix no "
                             "relaxation length: give rolls led by different leads")
    (steady, sigma), *_ = np.linalg.lstsq(np.column_stack([np.ones_like(s), -s]), f,
                                          rcond=None)
    return float(steady), float(sigma)


def flat_lead(leads: Sequence[float], slopes: Sequence[float]) -> float:
    """The lead (mm) whose force would not drift.

    Parameters
    ----------
    leads : sequence of float, length n >= 2
        The rolls' leads (mm), at least two different.
    slopes : sequence of float, length n
        Their force's slope at the roll's end (N/mm).

    Returns
    -------
    float
        The zero of the least-squares line through (lead, slope) (two rolls: exact).
    """
    x, y = _pairs(list(zip(leads, slopes, strict=True)), "leads")
    if np.ptp(x) == 0:
        raise ParameterError(f"leads {x.tolist()} mm are all equal: give two different")
    gain, offset = np.polyfit(x, y, 1)
    if abs(gain) * np.ptp(x) <= 1e-12 * np.abs(y).max():  # round-off of a flat line
        raise ParameterError("the drift does not change with the lead: no flat lead")
    return float(-offset / gain)


def _pairs(pairs, what: str) -> tuple[np.ndarray, np.ndarray]:
    values = np.asarray(pairs, dtype=float)
    if values.ndim != 2 or values.shape[0] < 2 or values.shape[1] != 2:
        raise ParameterError(f"{what}: need at least two (value, slope) pairs, got "
                             f"{values.tolist()}")
    if not np.isfinite(values).all():
        raise ParameterError(f"{what}: {values.tolist()} holds a non-finite value")
    return values[:, 0], values[:, 1]
