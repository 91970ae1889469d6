"""The least-squares optimiser's Jacobian keys: validated once, in the study file."""

import pytest

from jobs.errors import StudyError
from jobs.inverse.study import parse_inverse_study

STUDY = """
[study]
store = "out/inverse.zarr"
[model]
kind = "reduced"
[optimizers.least-squares]
{keys}
"""


def optimizer(keys: str = ""):
    return parse_inverse_study(STUDY.format(keys=keys), "t.toml").optimizers[0]


def test_the_default_reuses_jacobians_within_ten_percent():
    opt = optimizer()
    assert (opt.jacobian, opt.jacobian_radius) == ("shared", 0.1)
    assert optimizer('jacobian = "full"').jacobian == "full"


@pytest.mark.parametrize(("keys", "match"), [
    ('jacobian = "secant"', r"optimizers.least-squares.jacobian.*full"),
    ("jacobian_radius = -0.1", "optimizers.least-squares.jacobian_radius"),
    ("jacobian_radius = 2", "optimizers.least-squares.jacobian_radius"),
])
def test_bad_jacobian_keys_are_one_clear_error(keys, match):
    with pytest.raises(StudyError, match=match):
        optimizer(keys)


def test_nelder_mead_has_no_jacobian():
    with pytest.raises(StudyError, match="jacobian"):
        parse_inverse_study(STUDY.replace("least-squares", "nelder-mead").format(
            keys='jacobian = "full"'), "t.toml")
