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
    ('[[conditions]]\nname = "d"\ninitial = "surrogate"\n',
     r"conditions\[0\].initial: \"surrogate\" needs a \[distribution\] table"),
    ('[distribution]\nstore = "s.zarr"\n', "distribution.group"),
    ('[distribution]\nstore = "s.zarr"\ngroup = "g"\ndegree = 9\n', "distribution.degree"),
    ('[distribution]\nstore = "s.zarr"\ngroup = "g"\nmodes = 2\n', "distribution.modes"),
])
def test_bad_keys_are_one_clear_error(extra, match):
    with pytest.raises(StudyError, match=match):
        parse(extra)


# ------------------------------------------- the two-stage loop on a linear forward model

N_INNER, N_UNKNOWN = 30, 8


def _linear_map():
    """Inner displacements (mm) of forces on 8 tread nodes: a wide smoothing kernel, so
    that 1 mm noise hides how the load is split between neighbours (as in §4.4)."""
    s = np.linspace(0, 1, 3 * N_INNER)[:, None]
    t = np.linspace(0, 1, N_UNKNOWN)[None, :]
    return 0.2 * np.exp(-((s - t) ** 2) / 0.05)


def _linear_forward(x):
    from jobs.guard import Solved

    u = (_linear_map() @ np.asarray(x)).reshape(N_INNER, 3)
    z = np.zeros((N_INNER, 3))
    return Solved((Measurement(30.0, 0.0, u, z, z, np.zeros((2, 3)), np.zeros(3),
                               np.zeros(3), np.zeros(3), 2, 0.0),), 0.0)


class LinearProblem(Problem):
    def forward_evaluation(self, x):
        from jobs.identity import value_key
        from jobs.loops.evaluator import Evaluation

        return Evaluation(value_key({"x": [round(float(v), 9) for v in x]}), _linear_forward,
                          tuple(float(v) for v in x), "linear")


def _linear_problem():
    x_true = 30 + 15 * np.sin(np.linspace(0, np.pi, N_UNKNOWN))  # smooth along the row
    ref = _linear_forward(x_true).measurement
    grid = np.column_stack([np.zeros(N_UNKNOWN, int), np.arange(N_UNKNOWN)])
    return LinearProblem(None, None, "t", None, 30.0, 0.0, np.arange(1, N_UNKNOWN + 1),
                         x_true, grid, np.zeros((N_UNKNOWN, 3)), ref)


# τ > 1 (Engl, Hanke & Neubauer §4.3): with 90 residuals and 8 unknowns the least-squares
# residual itself is sqrt(82/90) δ ± 8 %, so τ = 1 leaves some draws unregularised
TAU = 1.2


def _solve(regularisation: str, weight: str, repeat: int):
    from jobs.inverse.loop import LoopState, expand_loops, run_loop
    from jobs.loops.cache import EvaluationCache
    from jobs.loops.evaluator import Evaluator

    study = parse(f"""
        [optimizers.least-squares]
        max_evaluations = 200
        fd_step_n = 0.1
        jacobian = "broyden"
        warm_starts = false  # the linear stand-in has no solver states to continue from
        regularisation = "{regularisation}"
        weight = {weight}
        discrepancy = {TAU}
        [[conditions]]
        name = "noise"
        methods = ["displacement"]
        repeats = {repeat + 1}
        """)
    spec = expand_loops(study)[repeat]
    problem = _linear_problem()
    ev = Evaluator(None, EvaluationCache(None))
    return run_loop(study, problem, spec, ev, LoopState(spec.label, 200)), problem, study


def test_the_loop_chooses_the_weight_at_its_unregularised_solution():
    result, problem, study = _solve("smoothness", '"discrepancy"', 0)
    assert result.weight > 1e-6 and "discrepancy weight" in result.message
    # the data residual of the regularised solution matches the expected noise norm
    obj = Objective(problem, "displacement", study.noise, "per_solve",
                    _seed(study, result.spec))
    data = np.linalg.norm(obj.data_residuals(result.final, 0))
    delta = expected_noise_norm("displacement", 1.0, 4e-4, N_INNER)
    assert data == pytest.approx(TAU * delta, rel=0.02)  # linear: the linearisation is exact


def _seed(study, spec):
    from jobs.inverse.loop import loop_seed

    return loop_seed(study, spec)


def test_regularised_by_the_discrepancy_principle_beats_unregularised_on_a_smooth_truth():
    errors = {"none": [], "smoothness": []}
    for repeat in range(3):
        for reg, weight in (("none", "0.0"), ("smoothness", '"discrepancy"')):
            result, problem, _ = _solve(reg, weight, repeat)
            errors[reg].append(np.sqrt(np.mean((result.x - problem.x_true) ** 2)))
    assert np.mean(errors["smoothness"]) < 0.7 * np.mean(errors["none"])


def test_guess_regularisation_pulls_towards_the_initial_guess():
    problem = _linear_problem()
    x0 = problem.x_true + 5.0
    obj = Objective(problem, "displacement", None, "per_solve", [0],
                    regularisation=("guess", 4.0, 2.0), center=x0)
    r = obj.residuals(_linear_forward(problem.x_true), problem.x_true, 0)
    np.testing.assert_allclose(r[-N_UNKNOWN:], 2.0 * (problem.x_true - x0) / 2.0)
