"""The discrepancy principle picks the regularisation weight from the noise level alone,
and the study keys that ask for it (and for the distribution guess) are validated."""

import textwrap

import numpy as np
import pytest

from farm.measure.measurement import Measurement
from jobs.errors import StudyError
from jobs.inverse.objective import Objective
from jobs.inverse.problem import Problem
from jobs.inverse.regularisation import (
    bisect_log,
    data_residual,
    discrepancy_weight,
    expected_noise_norm,
    gauss_newton_step,
)
from jobs.inverse.study import NoiseSettings, parse_inverse_study


def toy(seed=0, m=60, n=12, sigma=0.05):
    """A smoothing (ill-conditioned) linear forward model, a smooth truth, known noise."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0, 1, m)[:, None]
    t = np.linspace(0, 1, n)[None, :]
    a = np.exp(-((s - t) ** 2) / 0.02) / n
    x_true = 20 + 10 * np.sin(np.pi * np.linspace(0, 1, n))
    b = a @ x_true + rng.normal(0, sigma, m)
    return a, b, x_true, sigma * np.sqrt(m)


def test_the_chosen_weight_makes_the_residual_match_the_noise():
    a, b, _, delta = toy()
    x0 = np.zeros(a.shape[1])
    reg = np.eye(a.shape[1]) / 20.0
    r0 = a @ x0 - b
    w = discrepancy_weight(a, r0, reg, x0, delta)
    assert 1e-12 < w < 1e12
    assert data_residual(a, r0, reg, x0, w) == pytest.approx(delta, rel=1e-2)
    # ρ grows with λ: a smaller weight fits the noise, a larger one under-fits
    assert data_residual(a, r0, reg, x0, w / 10) < delta < data_residual(a, r0, reg, x0, w * 10)


def test_the_discrepancy_weight_beats_no_regularisation_on_the_truth():
    """Chosen without x_true, it recovers x_true better than plain least squares does,
    over several noise draws (the reason to regularise at all, thesis §6.2)."""
    better = 0
    for seed in range(5):
        a, b, x_true, delta = toy(seed)
        x0 = np.full(a.shape[1], 20.0)
        reg = np.diff(np.eye(a.shape[1]), axis=0) / 20.0  # smoothness, as objective.py's
        r0 = a @ x0 - b
        w = discrepancy_weight(a, r0, reg, x0, delta)
        x_reg = x0 + gauss_newton_step(a, r0, reg, x0, w)
        x_ls = x0 + gauss_newton_step(a, r0, reg, x0, 0.0)
        better += np.linalg.norm(x_reg - x_true) < np.linalg.norm(x_ls - x_true)
    assert better == 5


def test_edge_cases_of_the_search():
    assert discrepancy_weight(np.eye(2), np.ones(2), np.eye(2), np.zeros(2), 0.0) == 0.0
    assert bisect_log(lambda w: 10.0, 1.0, 1e-3, 1e3) == 1e-3  # cannot reach the noise level
    assert bisect_log(lambda w: 0.0, 1.0, 1e-3, 1e3) == 1e3  # fits anyway
    w = bisect_log(lambda w: np.log10(w), 2.0, 1e-6, 1e6)
    assert w == pytest.approx(100.0, rel=1e-2)


@pytest.mark.parametrize(("method", "sigma_u", "sigma_e"),
                         [("displacement", 1.0, 4e-4), ("strain", 1.0, 4e-4),
                          ("combined", 2.0, 1e-3)])
def test_the_expected_noise_norm_is_that_of_the_objective_residuals(method, sigma_u, sigma_e):
    """Monte Carlo: the residual of the noise-free field against noisy measurements."""
    n_inner = 200
    z = np.zeros((n_inner, 3))
    ref = Measurement(30.0, 0.0, z + 1.0, z + 1e-3, z, np.zeros((4, 3)), np.zeros(3),
                      np.zeros(3), np.zeros(3), 4, 1.0)
    problem = Problem(None, None, "t", None, 30.0, 0.0, np.arange(2), np.ones(2),
                      np.zeros((2, 2), int), np.zeros((2, 3)), ref)
    norms = [np.linalg.norm(Objective(problem, method, NoiseSettings(sigma_u, sigma_e),
                                      "per_solve", [k]).data_residuals(ref, 0))
             for k in range(200)]
    want = expected_noise_norm(method, sigma_u, sigma_e, n_inner)
    assert np.sqrt(np.mean(np.square(norms))) == pytest.approx(want, rel=0.02)


STUDY = """
[study]
name = "t"
store = "out/inverse.zarr"
[model]
kind = "reduced"
"""


def parse(extra: str):
    return parse_inverse_study(STUDY + textwrap.dedent(extra), "study.toml")


def test_discrepancy_and_distribution_keys_parse():
    study = parse("""
        [optimizers.least-squares]
        regularisation = "smoothness"
        weight = "discrepancy"
        discrepancy = 1.5
        [distribution]
        store = "out/thesis.zarr"
        group = "reduced-table-3.1-coarse"
        components = 2
        [[conditions]]
        name = "d"
        initial = "distribution"
        """)
    opt = study.optimizer("least-squares")
    assert (opt.weight_rule, opt.weight, opt.discrepancy) == ("discrepancy", 0.0, 1.5)
    assert study.distribution.group == "reduced-table-3.1-coarse"
    assert study.distribution.components == 2 and study.distribution.exclude_within == 0.5
    assert study.conditions[0].initial == "distribution"


@pytest.mark.parametrize(("extra", "match"), [
    ('[optimizers.least-squares]\nweight = "discrepancy"\n', "set regularisation"),
    ('[optimizers.least-squares]\nregularisation = "tikhonov"\nweight = "lcurve"\n',
     r"optimizers.least-squares.weight: got 'lcurve'"),
    ('[optimizers.least-squares]\nregularisation = "tikhonov"\nweight = "discrepancy"\n'
     "discrepancy = 0\n", "optimizers.least-squares.discrepancy"),
    ('[[conditions]]\nname = "d"\ninitial = "distribution"\n',
     r"conditions\[0\].initial: .*\[distribution\] table"),
    ('[distribution]\nstore = "s.zarr"\n', "distribution.group"),
    ('[distribution]\nstore = "s.zarr"\ngroup = "g"\ndegree = 9\n', "distribution.degree"),
    ('[distribution]\nstore = "s.zarr"\ngroup = "g"\nmodes = 2\n', "distribution.modes"),
])
def test_bad_keys_are_one_clear_error(extra, match):
    with pytest.raises(StudyError, match=match):
        parse(extra)
