"""The comma lists of ``farm analyse`` (``--noise-levels``, ``--deflection``,
``--pressure-kpa``): one parser, one kind of message (issue 25)."""

from __future__ import annotations

import math

import pytest

from analysis.errors import ParameterError
from tyre_farm_cli.analyse import MAX_NOISE_LEVEL, _levels, _numbers


def test_a_comma_list_is_read_in_order_blanks_skipped():
    assert _numbers("10, 20,,30 ", "--deflection", low=0.0) == (10.0, 20.0, 30.0)
    assert _numbers(None, "--deflection", low=0.0) is None
    assert _levels("0,0.5,2") == (0.0, 0.5, 2.0)


@pytest.mark.parametrize(("text", "low", "high", "match"), [
    ("20,x", 0.0, math.inf, "--opt must be numbers separated by commas, got '20,x'"),
    (",", 0.0, math.inf, "--opt must be numbers >= 0, got ','"),
    ("nan", 0.0, math.inf, "numbers >= 0"),
    ("inf", 0.0, math.inf, "numbers >= 0"),
    ("-1", 0.0, math.inf, "numbers >= 0"),
    ("3", 0.0, 2.0, "numbers >= 0"),
])
def test_bad_lists_are_one_parameter_error(text, low, high, match):
    with pytest.raises(ParameterError, match=match.replace("(", r"\(")):
        _numbers(text, "--opt", low=low, high=high)


def test_each_option_says_what_its_numbers_must_be():
    with pytest.raises(ParameterError, match=f"in \\[0, {MAX_NOISE_LEVEL:g}\\]"):
        _levels("0,1000")
    with pytest.raises(ParameterError, match="--noise-levels must be numbers separated"):
        _levels("a")
