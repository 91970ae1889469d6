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
    assert (opt.jacobian, opt.jacobian_radius, opt.jacobian_patience) == ("shared", 0.1, 0)
    assert optimizer('jacobian = "full"').jacobian == "full"
    assert optimizer("jacobian_patience = 2").jacobian_patience == 2


def test_patience_left_at_its_default_keeps_the_loop_ids():
    """Loops stored before the key existed keep their ids (and their cached solves)."""
    from jobs.inverse.loop import expand_loops, loop_id

    text = STUDY + '[[conditions]]\nname = "ideal"\nnoise = false\n'
    study = parse_inverse_study(text.format(keys=""), "t.toml")
    again = parse_inverse_study(text.format(keys="jacobian_patience = 0"), "t.toml")
    other = parse_inverse_study(text.format(keys="jacobian_patience = 2"), "t.toml")
    ids = [loop_id(s, expand_loops(s)[0]) for s in (study, again, other)]
    assert ids[0] == ids[1] != ids[2]


@pytest.mark.parametrize(("keys", "match"), [
    ('jacobian = "secant"', r"optimizers.least-squares.jacobian.*full"),
    ("jacobian_radius = -0.1", "optimizers.least-squares.jacobian_radius"),
    ("jacobian_radius = 2", "optimizers.least-squares.jacobian_radius"),
    ("jacobian_patience = -1", "optimizers.least-squares.jacobian_patience"),
    ("jacobian_patience = 1.5", "optimizers.least-squares.jacobian_patience"),
    ('jacobian = "full"\njacobian_patience = 2', r"jacobian_patience: applies to Jacobian "
                                                  "reuse only"),
    ('warm_starts = "yes"', "optimizers.least-squares.warm_starts"),
    ("columns_per_run = 0", "optimizers.least-squares.columns_per_run"),
    ("columns_per_run = 1000", "optimizers.least-squares.columns_per_run"),
])
def test_bad_jacobian_keys_are_one_clear_error(keys, match):
    with pytest.raises(StudyError, match=match):
        optimizer(keys)


def test_least_squares_warm_starts_by_default():
    opt = optimizer()
    assert opt.warm_starts and opt.columns_per_run == 8
    assert not optimizer("warm_starts = false").warm_starts
    assert optimizer("columns_per_run = 16").columns_per_run == 16


def test_loops_from_rest_keep_their_ids_and_warm_ones_get_new_ones():
    """Solves stored before warm starts existed are the ``warm_starts = false`` ones:
    they keep their ids; warm-started solves (other numbers, at the solver's precision)
    and each run length are other solves."""
    from jobs.inverse.loop import expand_loops, loop_id

    text = STUDY + '[[conditions]]\nname = "ideal"\nnoise = false\n'
    ids = []
    for keys in ("warm_starts = false", "warm_starts = false\ncolumns_per_run = 4",
                 "", "columns_per_run = 4"):
        study = parse_inverse_study(text.format(keys=keys), "t.toml")
        ids.append(loop_id(study, expand_loops(study)[0]))
    assert ids[0] == ids[1] and len(set(ids[1:])) == 3


def test_nelder_mead_has_no_jacobian():
    with pytest.raises(StudyError, match="jacobian"):
        parse_inverse_study(STUDY.replace("least-squares", "nelder-mead").format(
            keys='jacobian = "full"'), "t.toml")
