"""The steady force from led rolls (analysis.relaxation), against the first-order lag it
assumes: rolls started at c x lead relax towards F_ss over sigma."""

from __future__ import annotations

import math

import pytest

from analysis.errors import ParameterError
from analysis.relaxation import flat_lead, secant


def _end(lead: float, steady: float, sigma: float, stiffness: float, travel: float
         ) -> tuple[float, float]:
    """(F, dF/ds) at ``travel`` mm of a first-order lag started at ``stiffness`` x lead."""
    gap = (stiffness * lead - steady) * math.exp(-travel / sigma)
    return steady + gap, -gap / sigma


# a braking Fx, a driving Fx and a lateral Fy of lean's measured sizes (docs/rolling.md)
CASES = [(-1630.0, 540.0, 520.0), (1442.0, 540.0, 520.0), (-923.0, 670.0, 190.0)]


@pytest.mark.parametrize(("steady", "sigma", "stiffness"), CASES)
@pytest.mark.parametrize("spread", [(0.8, 1.2), (0.5, 0.9, 1.4)])
def test_led_rolls_give_the_lag_s_steady_force_flat_lead_and_length(steady, sigma,
                                                                    stiffness, spread):
    flat = steady / stiffness
    leads = [flat * k for k in spread]
    ends = [_end(lead, steady, sigma, stiffness, 200.0) for lead in leads]
    assert secant(ends) == pytest.approx((steady, sigma), rel=1e-9)
    assert flat_lead(leads, [slope for _, slope in ends]) == pytest.approx(flat, rel=1e-9)


def test_rolls_on_one_side_still_extrapolate_to_the_steady_force():
    """Two long leads (both drifts one sign, as kappa -0.02's on lean) extrapolate."""
    ends = [_end(lead, -1630.0, 540.0, 520.0, 200.0) for lead in (-4.2, -3.6)]
    assert all(slope > 0 for _, slope in ends)
    assert secant(ends)[0] == pytest.approx(-1630.0)


@pytest.mark.parametrize(("ends", "words"), [
    ([(100.0, 0.5)], "at least two"),
    ([(100.0, 0.5), (120.0, 0.5)], "equal slopes"),
    ([(100.0, math.nan), (120.0, 0.5)], "non-finite"),
])
def test_secant_refuses_ends_that_fix_nothing(ends, words):
    with pytest.raises(ParameterError, match=words):
        secant(ends)


@pytest.mark.parametrize(("leads", "slopes", "words"), [
    ([1.0, 1.0], [0.2, -0.1], "all equal"),
    ([1.0, 2.0], [0.2, 0.2], "does not change"),
    ([1.0], [0.2], "at least two"),
])
def test_flat_lead_refuses_what_fixes_no_zero(leads, slopes, words):
    with pytest.raises(ParameterError, match=words):
        flat_lead(leads, slopes)
