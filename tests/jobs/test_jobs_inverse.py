"""Inverse loops without the solver: study files, objectives, noise, optimisers, cache,
evaluator. (The loops on the farm, with ccx, are in test_jobs_inverse_farm.py.)"""

import textwrap
import threading
import time

import numpy as np
import pytest

from jobs.errors import StudyError
from jobs.inverse.objective import Objective, field_rmse
from jobs.inverse.problem import Problem
from jobs.inverse.study import NoiseSettings, parse_inverse_study, thesis_conditions
from jobs.loops import optimizers
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluation, Evaluator, LoopStats

STUDY = """
[study]
name = "t"
store = "out/inverse.zarr"
[model]
kind = "reduced"
"""


def parse(extra: str = ""):
    return parse_inverse_study(STUDY + textwrap.dedent(extra), "study.toml")


def test_defaults_are_the_thesis_conditions():
    study = parse()
    assert [c.name for c in study.conditions] == ["ideal", "noise", "guess-90", "guess-uniform"]
    assert [c.repeats for c in study.conditions] == [1, 10, 10, 10]
    assert study.optimizers[0].name == "nelder-mead"
    assert study.optimizers[0].noise_draw == "per_evaluation"  # thesis §4.4
    assert study.noise == NoiseSettings(1.0, 4e-4)
    assert study.deflection == 30.0 and study.group == "inverse-t"
    assert study.cache.endswith("inverse.zarr.evaluations")
    assert study.conditions == thesis_conditions()


@pytest.mark.parametrize(("extra", "match"), [
    ("[reference]\ndeflection_mm = -3\n", "reference.deflection_mm"),
    ("[reference]\ndeflection_mm = 400\n", "reaches through the tyre"),
    ("[optimizers.bfgs]\n", "optimizers.bfgs: unknown key"),
    ("[optimizers.least-squares]\nnoise_draw = 'per_evaluation'\n", "needs 'per_solve'"),
    ("[optimizers.least-squares]\nregularisation = 'tikhonov'\n", "weight > 0"),
    ("[optimizers.nelder-mead]\nmax_evaluations = 1\n", "max_evaluations"),
    ("[[conditions]]\nname = 'a'\nmethods = ['stress']\n", "methods"),
    ("[[conditions]]\nname = 'a'\ninitial = 'random'\n", "initial"),
    ("[[conditions]]\nname = 'a'\noptimizers = ['least-squares']\n", "optimizers"),
    ("[[conditions]]\nname = 'a'\n[[conditions]]\nname = 'a'\n", "distinct"),
    ("[[conditions]]\nname = 'a'\nrepeats = 0\n", "repeats"),
    ("[mask]\nkeep = 0.5\n", "mask.eigen_vectors"),
    ("[mask]\neigen_vectors = 'w.csv'\nkeep = 2\n", "mask.keep"),
    ("[noise]\nstrain_pct = 1\n", "noise.strain_pct"),
])
def test_bad_studies_are_one_clear_error(extra, match):
    with pytest.raises(StudyError, match=match):
        parse(extra)


def test_the_full_model_is_refused():
    text = STUDY.replace('kind = "reduced"', 'kind = "full"')
    with pytest.raises(StudyError, match="reduced model with the iterative road"):
        parse_inverse_study(text)


# ---------------------------------------------------------------- objectives and noise


def fake_problem(n_inner=40, n=4, seed=0) -> Problem:
    rng = np.random.default_rng(seed)
    ref = {"displacement": rng.normal(0, 5, (n_inner, 3)),
           "strain": rng.normal(0, 1e-2, (n_inner, 3)),
           "total_force": np.array([0, 0, 100.0]), "moment": np.zeros(3)}
    grid = np.array([[0, 1], [0, 2], [2, 1], [2, 3]])[:n]
    return Problem(None, None, "test", None, 30.0, 0.0, np.arange(1, n + 1),
                   np.linspace(10, 40, n), grid, np.zeros((n, 3)), ref)


@pytest.mark.parametrize("method", ["displacement", "strain", "combined"])
def test_objective_is_zero_at_the_truth_without_noise(method):
    p = fake_problem()
    obj = Objective(p, method, None, "per_evaluation", [0])
    assert np.linalg.norm(obj.residuals(p.reference, p.x_true, 0)) == 0.0


def test_displacement_objective_is_eq_4_1():
    p = fake_problem()
    arrays = dict(p.reference, displacement=p.reference["displacement"] + 0.5)
    obj = Objective(p, "displacement", None, "per_evaluation", [0])
    # sqrt((sum dUx^2 + sum dUy^2 + sum dUz^2) / N) with dU = 0.5 everywhere
    assert np.linalg.norm(obj.residuals(arrays, p.x_true, 0)) == pytest.approx(
        np.sqrt(3 * 0.25))


@pytest.mark.parametrize(("draw", "same_across_evaluations"), [
    ("per_evaluation", False), ("per_solve", True)])
def test_noise_draws_are_seeded_and_documented(draw, same_across_evaluations):
    p = fake_problem()
    obj = Objective(p, "displacement", NoiseSettings(1.0, 4e-4), draw, [7, 1, 0])
    u0, e0 = obj.measured(0)
    u1, _ = obj.measured(1)
    again, _ = Objective(p, "displacement", NoiseSettings(1.0, 4e-4), draw,
                         [7, 1, 0]).measured(0)
    np.testing.assert_array_equal(u0, again)  # replayable on resume
    assert np.array_equal(u0, u1) is same_across_evaluations
    assert np.std(u0 - p.reference["displacement"]) == pytest.approx(1.0, rel=0.25)
    assert np.std(e0 - p.reference["strain"]) == pytest.approx(4e-4, rel=0.25)


def test_masked_nodes_do_not_count():
    p = fake_problem()
    mask = np.zeros(40, bool)
    mask[:10] = True
    arrays = dict(p.reference)
    arrays["displacement"] = p.reference["displacement"].copy()
    arrays["displacement"][10:] += 100.0  # only outside the mask
    obj = Objective(p, "displacement", None, "per_solve", [0], mask=mask)
    assert np.linalg.norm(obj.residuals(arrays, p.x_true, 0)) == 0.0


@pytest.mark.parametrize(("kind", "rows"), [("tikhonov", 4), ("smoothness", 2)])
def test_regularisation_rows(kind, rows):
    p = fake_problem()
    obj = Objective(p, "displacement", None, "per_solve", [0],
                    regularisation=(kind, 4.0, 2.0))
    r = obj.residuals(p.reference, p.x_true, 0)
    assert r.size == 3 * 40 + rows
    reg = r[-rows:]
    if kind == "tikhonov":
        np.testing.assert_allclose(reg, 2.0 * p.x_true / 2.0)
    else:  # consecutive unknowns along rows 0 and 2: (1,2) and (3,4)
        np.testing.assert_allclose(reg, [p.x_true[1] - p.x_true[0], p.x_true[3] - p.x_true[2]])


def test_failed_evaluations_get_a_penalty_far_above_any_real_objective():
    p = fake_problem()
    obj = Objective(p, "strain", None, "per_solve", [0])
    r = obj.residuals({"error": np.array("diverged")}, p.x_true, 0)
    assert r.size == obj.size() and np.linalg.norm(r) > 1e3


def test_field_rmse_per_direction():
    p = fake_problem()
    arrays = dict(p.reference, displacement=p.reference["displacement"] + [0, 0, 2.0])
    got = field_rmse(arrays, p.reference)
    assert got["Uz"] == pytest.approx(2.0) and got["Ux"] == 0 and got["exx"] == 0


# ---------------------------------------------------------------- optimisers


def linear_problem(n=5, m=12, seed=1):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(m, n))
    x_true = rng.uniform(5, 50, n)
    b = A @ x_true
    batches = []

    def evaluate(points):
        batches.append(len(points))
        return [A @ p - b for p in points]

    return x_true, evaluate, batches


def test_least_squares_solves_jacobian_columns_as_one_batch():
    x_true, evaluate, batches = linear_problem()
    out = optimizers.least_squares(evaluate, 0.9 * x_true, max_evaluations=100, fd_step=0.1)
    np.testing.assert_allclose(out.x, x_true, rtol=1e-6)
    assert out.status == "converged"
    assert batches[0] == 6  # x0 and its n Jacobian columns side by side
    assert 5 in batches[1:]  # later Jacobians: the n columns in one batch
    assert len(batches) < 12  # a handful of rounds, whatever n


def test_nelder_mead_starts_with_the_simplex_in_one_batch_and_respects_its_budget():
    x_true, evaluate, batches = linear_problem()
    out = optimizers.nelder_mead(evaluate, 0.9 * x_true, max_evaluations=40, xatol=1e-9,
                                 fatol=1e-12)
    assert batches[0] == 6 and set(batches[1:]) == {1}  # then strictly sequential
    assert sum(batches) <= 40 and out.status == "max_evaluations"
    assert np.linalg.norm(evaluate([out.x])[0]) <= np.linalg.norm(evaluate([0.9 * x_true])[0])


@pytest.mark.parametrize("optimizer", ["nelder_mead", "least_squares"])
def test_a_stop_condition_ends_the_loop(optimizer):
    x_true, evaluate, _ = linear_problem()
    start = np.linalg.norm(evaluate([0.9 * x_true])[0])
    kwargs = ({"xatol": 1e-9, "fatol": 1e-12} if optimizer == "nelder_mead"
              else {"fd_step": 0.1})
    out = getattr(optimizers, optimizer)(evaluate, 0.9 * x_true, max_evaluations=500,
                                         stop=lambda x, f: f < 0.5 * start, **kwargs)
    assert out.status == "stopped" and out.objective < 0.5 * start


# ---------------------------------------------------------------- cache and evaluator


def test_cache_round_trips_exactly_and_leaves_no_temporary_files(tmp_path):
    cache = EvaluationCache(tmp_path / "c")
    key = "a" * 64
    arrays = {"u": np.random.default_rng(0).normal(size=(7, 3)), "error": np.array("x")}
    cache.put(key, arrays)
    again = EvaluationCache(tmp_path / "c").get(key)  # a new process: from disk
    np.testing.assert_array_equal(again["u"], arrays["u"])
    assert str(again["error"]) == "x" and len(EvaluationCache(tmp_path / "c")) == 1
    assert not list((tmp_path / "c").rglob("*.tmp*"))
    assert EvaluationCache(tmp_path / "c").get("b" * 64) is None
    with pytest.raises(ValueError):
        cache.get("../../etc/passwd")


def _square(x):
    return {"y": np.array(x * x), "seconds": np.array(0.0)}


def _evaluation(x) -> Evaluation:
    return Evaluation(f"{int(x):064x}", _square, x, "test")


def test_evaluator_dedups_within_a_batch_and_answers_from_the_cache(tmp_path):
    ev = Evaluator(None, EvaluationCache(tmp_path))
    stats = LoopStats()
    out = ev.run([_evaluation(3), _evaluation(3), _evaluation(4)], stats)
    assert [int(o["y"]) for o in out] == [9, 9, 16]
    assert (stats.solved, stats.cached, stats.evaluations, stats.rounds) == (2, 0, 3, 1)
    ev.run([_evaluation(4)], stats)
    assert (stats.solved, stats.cached) == (2, 1)


def _slow_square(x):
    time.sleep(0.5)
    return _square(x)


def test_loops_share_an_evaluation_in_flight(tmp_path):
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        ev = Evaluator(client, EvaluationCache(tmp_path))
        stats = [LoopStats() for _ in range(4)]
        e = Evaluation("c" * 64, _slow_square, 5, "test")
        threads = [threading.Thread(target=ev.run, args=([e], s)) for s in stats]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert ev.total.solved == 1  # one task for four loops
    assert sum(s.shared + s.cached for s in stats) == 3
