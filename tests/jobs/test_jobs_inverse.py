"""Inverse loops without the solver: study files, objectives, noise, optimisers, cache,
evaluator. (The loops on the farm, with ccx, are in test_jobs_inverse_farm.py.)"""

import dataclasses
import textwrap
import threading
import time

import numpy as np
import pytest

from farm.measure.measurement import Measurement
from jobs.errors import StudyError
from jobs.guard import Failed, Solved
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


def measurement(u, e, fz=100.0) -> Measurement:
    z = np.zeros_like(u)
    return Measurement(30.0, 0.0, u, e, z, np.zeros((4, 3)), np.array([0, 0, fz]), np.zeros(3),
                       np.array([0, 0, fz]), 4, 1.0)


def changed(m: Measurement, **fields) -> Solved:
    """A forward evaluation: ``m`` with some fields replaced."""
    return Solved((dataclasses.replace(m, **fields),), 1.0)


def fake_problem(n_inner=40, n=4, seed=0) -> Problem:
    rng = np.random.default_rng(seed)
    ref = measurement(rng.normal(0, 5, (n_inner, 3)), rng.normal(0, 1e-2, (n_inner, 3)))
    grid = np.array([[0, 1], [0, 2], [2, 1], [2, 3]])[:n]
    return Problem(None, None, "test", None, 30.0, 0.0, np.arange(1, n + 1),
                   np.linspace(10, 40, n), grid, np.zeros((n, 3)), ref)


@pytest.mark.parametrize("method", ["displacement", "strain", "combined"])
def test_objective_is_zero_at_the_truth_without_noise(method):
    p = fake_problem()
    obj = Objective(p, method, None, "per_evaluation", [0])
    assert np.linalg.norm(obj.residuals(changed(p.reference), p.x_true, 0)) == 0.0


def test_displacement_objective_is_eq_4_1():
    p = fake_problem()
    arrays = changed(p.reference, displacement=p.reference.displacement + 0.5)
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
    assert np.std(u0 - p.reference.displacement) == pytest.approx(1.0, rel=0.25)
    assert np.std(e0 - p.reference.strain) == pytest.approx(4e-4, rel=0.25)


def test_masked_nodes_do_not_count():
    p = fake_problem()
    mask = np.zeros(40, bool)
    mask[:10] = True
    u = p.reference.displacement.copy()
    u[10:] += 100.0  # only outside the mask
    arrays = changed(p.reference, displacement=u)
    obj = Objective(p, "displacement", None, "per_solve", [0], mask=mask)
    assert np.linalg.norm(obj.residuals(arrays, p.x_true, 0)) == 0.0


@pytest.mark.parametrize(("kind", "rows"), [("tikhonov", 4), ("smoothness", 2)])
def test_regularisation_rows(kind, rows):
    p = fake_problem()
    obj = Objective(p, "displacement", None, "per_solve", [0],
                    regularisation=(kind, 4.0, 2.0))
    r = obj.residuals(changed(p.reference), p.x_true, 0)
    assert r.size == 3 * 40 + rows
    reg = r[-rows:]
    if kind == "tikhonov":
        np.testing.assert_allclose(reg, 2.0 * p.x_true / 2.0)
    else:  # consecutive unknowns along rows 0 and 2: (1,2) and (3,4)
        np.testing.assert_allclose(reg, [p.x_true[1] - p.x_true[0], p.x_true[3] - p.x_true[2]])


def test_failed_evaluations_get_a_penalty_far_above_any_real_objective():
    p = fake_problem()
    obj = Objective(p, "strain", None, "per_solve", [0])
    r = obj.residuals(Failed("ccx failed (diverged)", "diverged"), p.x_true, 0)
    assert r.size == obj.size() and np.linalg.norm(r) > 1e3


def test_field_rmse_per_direction():
    p = fake_problem()
    moved = dataclasses.replace(p.reference,
                                displacement=np.add(p.reference.displacement, [0, 0, 2.0]))
    got = field_rmse(moved, p.reference)
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
    key, bad = "a" * 64, "d" * 64
    rng = np.random.default_rng(0)
    m = measurement(rng.normal(size=(7, 3)), rng.normal(size=(7, 3)), fz=12.5)
    cache.put(key, Solved((m, dataclasses.replace(m, deflection=40.0)), 2.5, 3, 17))
    cache.put(bad, Failed("ccx failed (diverged)", "diverged"))
    again = EvaluationCache(tmp_path / "c").get(key)  # a new process: from disk
    assert (again.solve_seconds, again.ccx_runs, again.increments) == (2.5, 3, 17)
    for a, b in zip(again.measurements, (m, dataclasses.replace(m, deflection=40.0)),
                    strict=True):
        for f in dataclasses.fields(Measurement):
            np.testing.assert_array_equal(getattr(a, f.name), getattr(b, f.name))
            assert type(getattr(a, f.name)) is type(getattr(b, f.name))
    assert EvaluationCache(tmp_path / "c").get(bad) == Failed("ccx failed (diverged)",
                                                              "diverged")
    assert len(EvaluationCache(tmp_path / "c")) == 2
    assert not list((tmp_path / "c").rglob("*.tmp*"))
    assert EvaluationCache(tmp_path / "c").get("b" * 64) is None
    with pytest.raises(ValueError):
        cache.get("../../etc/passwd")


def test_the_contact_patch_round_trips_and_older_files_still_read(tmp_path):
    """Issue 24: a measurement's patch and growth are plain floats in the cache file (no
    pickle); a file written before them reads with both None (not re-solved)."""
    from jobs.loops.cache import decode, encode

    m = dataclasses.replace(measurement(np.ones((7, 3)), np.zeros((7, 3))),
                            patch=np.arange(7.0), inflation_growth=float("nan"))
    cache = EvaluationCache(tmp_path / "c")
    cache.put("a" * 64, Solved((m,), 1.0))
    (again,) = EvaluationCache(tmp_path / "c").get("a" * 64).measurements
    np.testing.assert_array_equal(again.patch, m.patch)
    assert np.isnan(again.inflation_growth)
    assert again.patch_values()["patch_length"] == 1.0
    older = {k: v for k, v in encode(Solved((m,), 1.0)).items()
             if k not in ("m0.patch", "m0.inflation_growth")}
    (old,) = decode(older).measurements
    assert old.patch is None and old.inflation_growth is None
    assert all(np.isnan(v) for v in old.patch_values().values())


def test_a_kept_solver_state_round_trips_byte_for_byte(tmp_path):
    state = bytes(range(256)) * 40 + b"\x00"  # any bytes, trailing zeros included
    m = measurement(np.zeros((2, 3)), np.zeros((2, 3)), fz=1.0)
    EvaluationCache(tmp_path).put("a" * 64, Solved((m,), 1.0, 1, 3, state))
    EvaluationCache(tmp_path).put("b" * 64, Solved((m,), 1.0))
    cache = EvaluationCache(tmp_path)
    assert cache.state("a" * 64) == state and cache.state("b" * 64) is None
    assert cache.state("c" * 64) is None
    # measurements are held in memory, states are read from disk when needed
    assert cache.get("a" * 64).state is None and cache.get("a" * 64).increments == 3
    memory = EvaluationCache(None)
    memory.put("a" * 64, Solved((m,), 1.0, 1, 3, state))
    assert memory.state("a" * 64) == state


def test_a_cache_file_of_another_layout_reads_as_absent(tmp_path):
    (tmp_path / "aa").mkdir()
    np.savez(tmp_path / "aa" / f"{'a' * 64}.npz", displacement=np.zeros(3))  # layout 1
    assert EvaluationCache(tmp_path).get("a" * 64) is None


def _timeout(x):
    return Failed("ccx failed (timeout)", "timeout", transient=True)


def test_transient_failures_are_not_cached(tmp_path):
    ev = Evaluator(None, EvaluationCache(tmp_path))
    out = ev.run([Evaluation("e" * 64, _timeout, 1, "test")])
    assert out[0].transient and "e" * 64 not in EvaluationCache(tmp_path)


def _square(x):
    return Solved((measurement(np.zeros((2, 3)), np.zeros((2, 3)), fz=x * x),), 0.0)


def _evaluation(x) -> Evaluation:
    return Evaluation(f"{int(x):064x}", _square, x, "test")


def test_evaluator_dedups_within_a_batch_and_answers_from_the_cache(tmp_path):
    ev = Evaluator(None, EvaluationCache(tmp_path))
    stats = LoopStats()
    out = ev.run([_evaluation(3), _evaluation(3), _evaluation(4)], stats)
    assert [o.measurement.total_force[2] for o in out] == [9, 9, 16]
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


class _Pending:
    """A future another loop submitted, whose result its own thread has not yet cached."""

    def result(self):
        return _square(3)


def test_a_loop_that_joined_an_evaluation_finds_it_cached_when_it_gets_it(tmp_path):
    """Whichever waiting thread wakes first caches the result: a warm start reads the
    kept state of its base from the cache, so a loop's path must not depend on which
    thread woke first (jobs/inverse/warm.py)."""
    ev = Evaluator(None, EvaluationCache(tmp_path))
    e = Evaluation("f" * 64, _square, 3, "test")
    ev._inflight[e.key] = _Pending()  # submitted by another loop, still in flight
    (got,) = ev.run([e])
    assert ev.total.shared == 1 and e.key in EvaluationCache(tmp_path)
    assert EvaluationCache(tmp_path).get(e.key).measurement.total_force[2] == \
        got.measurement.total_force[2]
    assert e.key not in ev._inflight


# ---------------------------------------------------------------- results in the store, tables
# Loops' results go into the store (storage.solves) and Tables 4.1-4.4 come back out of it
# (analysis.report.ch4). The expected numbers are worked out by hand below; they are also
# what jobs/inverse/tables.py computed from the loops themselves before the tables moved.

X_TRUE = np.array([10.0, 20.0, 30.0, 40.0])


def _measured(force, moment) -> Measurement:
    z = np.zeros((2, 3))
    return Measurement(deflection=30.0, pressure=0.0, displacement=z, strain=z,
                       surface_strain=z, reaction_force=np.zeros((4, 3)),
                       total_force=np.array(force, float), moment=np.array(moment, float),
                       road_reaction=np.array(force, float), contact_nodes=4, solve_seconds=1.0)


def _loops():
    """(problem, results): noise/displacement x3 (the last one's final evaluation fails) and
    guess-90/strain x1, all with least squares."""
    from jobs.inverse.loop import LoopResult, LoopSpec
    from jobs.inverse.study import Condition, OptimizerSettings

    problem = Problem(model=None, mesh=None, solver="test", settings=None, deflection=30.0,
                      road_z=-369.2, nodes=np.arange(1, 5), x_true=X_TRUE,
                      grid=np.zeros((4, 2), int), xyz=np.zeros((4, 3)),
                      reference=_measured([0, 0, 71.5], [-500, 40, 0]))
    lsq = OptimizerSettings("least-squares", 50, "per_solve")
    noise = Condition("noise", ("displacement",), ("least-squares",), True, "scaled", 0.9, 0.0, 3)
    guess = Condition("guess-90", ("strain",), ("least-squares",), True, "scaled", 0.9, 4.0, 1)
    plan = [  # spec, error x - x_true, Fz, (Mx, My) N mm, rmse, evaluations, solved, rounds,
        # solver s, wall s, objective, status
        (LoopSpec(noise, "displacement", lsq, 0), [1, -1, 0, 2], 70, (-1000, 200),
         [0.1, 0.2, 0.3, 1e-4, 2e-4, 3e-4], 5, 4, 2, 8, 20, 0.5, "converged"),
        (LoopSpec(noise, "displacement", lsq, 1), [-1, 1, 2, 0], 74, (-3000, 0),
         [0.3, 0.4, 0.5, 3e-4, 4e-4, 5e-4], 7, 6, 3, 12, 30, 0.25, "max_evaluations"),
        (LoopSpec(noise, "displacement", lsq, 2), [0, 0, 0, 0], None, None, None, 3, 3, 1, 3,
         9, 1.0, "failed"),
        (LoopSpec(guess, "strain", lsq, 0), [4, 0, 0, -4], 71, (100, -100),
         [1, 2, 3, 1e-3, 2e-3, 3e-3], 10, 10, 10, 50, 60, 2e-3, "converged"),
    ]
    results = []
    for i, (spec, err, fz, m, rmse, k, solved, rounds, solver_s, wall, f, status) in \
            enumerate(plan):
        final = None if fz is None else _measured([0, 0, fz], [*m, 0])
        results.append(LoopResult(
            spec=spec, id=f"{i:064x}", x0=0.9 * X_TRUE, x=X_TRUE + np.array(err, float),
            objective=f, status=status, message="", x_history=np.tile(X_TRUE, (k, 1)),
            f_history=np.linspace(2.0, f, k), final=final,
            rmse={} if final is None else dict(zip(("Ux", "Uy", "Uz", "exx", "eyy", "exy"),
                                                   rmse, strict=True)),
            stats=LoopStats(evaluations=k, rounds=rounds, solved=solved,
                            solver_seconds=float(solver_s)), wall_seconds=float(wall)))
    return problem, results


@pytest.fixture
def stored(tmp_path):
    """The loops written by jobs.inverse.store and read back through storage."""
    from jobs.inverse.store import write_results
    from storage.solves import open_solves

    study = parse_inverse_study(STUDY.replace("out/inverse.zarr", str(tmp_path / "s.zarr")),
                                "study.toml")
    problem, results = _loops()
    write_results(study, problem, results)
    return study, problem, results, open_solves(study.store, study.group)


KEYS = {"condition": ["noise", "guess-90"], "method": ["displacement", "strain"],
        "optimizer": ["least-squares", "least-squares"]}


def _same(got, want: dict) -> None:
    import pandas as pd

    pd.testing.assert_frame_equal(got.reset_index(drop=True), pd.DataFrame(want),
                                  check_dtype=False, rtol=1e-12)


def test_forces_tables_4_1_and_4_3_from_the_store(stored):
    from analysis.report import ch4

    nan = np.nan
    _same(ch4.forces(stored[3]), {
        "condition": ["reference", "noise", "guess-90"], "method": ["", *KEYS["method"]],
        "optimizer": ["", *KEYS["optimizer"]], "repeats": [1, 3, 1],
        # noise: Fz 70 and 74 (the failed solve has none), Mx -1 and -3 N m, My 0.2 and 0
        "Fz_mean": [71.5, 72.0, 71.0], "Fz_std": [0.0, np.sqrt(8), nan],
        "Mx_mean": [-0.5, -2.0, 0.1], "Mx_std": [0.0, np.sqrt(2), nan],
        "My_mean": [0.04, 0.1, -0.1], "My_std": [0.0, np.sqrt(0.02), nan],
        "thesis_Fz": [359.08, 358.28, 356.6], "thesis_Fz_std": [0, 0.4, 5],
        "thesis_Mx": [0, -0.84, -1.239], "thesis_Mx_std": [0, 0.1, 2],
        "thesis_My": [0, -0.020, -0.1884], "thesis_My_std": [0, 0.05, 1]})


def test_rmse_tables_4_2_and_4_4_from_the_store(stored):
    from analysis.report import ch4

    _same(ch4.rmse(stored[3]), {
        **KEYS, "Ux": [0.2, 1.0], "Uy": [0.3, 2.0], "Uz": [0.4, 3.0],
        "exx": [200.0, 1000.0], "eyy": [300.0, 2000.0], "exy": [400.0, 3000.0],
        "thesis_Ux": [0.010, 0.05158], "thesis_Uy": [0.040, 0.4087],
        "thesis_Uz": [0.070, 0.4987], "thesis_exx": [131.08, 911.0],
        "thesis_eyy": [171.22, 1029.0], "thesis_exy": [147.54, 487.2]})


def test_nodal_errors_and_cost_from_the_store(stored):
    from analysis.report import ch4

    # noise: errors 1 -1 0 2 -1 1 2 0 (two finished repeats): mean 0.5, mean square 1.5
    _same(ch4.nodal_errors(stored[3]), {
        **KEYS, "mean": [0.5, 0.0], "std": [np.sqrt(1.25), np.sqrt(8)],
        "rms": [np.sqrt(1.5), np.sqrt(8)],
        "std_over_max_force": [np.sqrt(1.25) / 40, np.sqrt(8) / 40],
        "thesis_std": [2.0, 11.6], "thesis_std_over_max_force": [2.0 / 35.5, 11.6 / 35.5]})
    _same(ch4.cost(stored[3]), {
        **KEYS, "evaluations": [5.0, 10.0], "solved": [13 / 3, 10.0], "rounds": [2.0, 10.0],
        "wall_s": [59 / 3, 60.0], "solver_s": [23 / 3, 50.0], "objective": [1.75 / 3, 2e-3],
        "solves": [3, 1], "statuses": ["converged 1, max_evaluations 1, failed 1",
                                       "converged 1"]})


def test_farm_invert_reports_from_the_stored_group(stored, tmp_path):
    import io

    from rich.console import Console

    from tyre_farm_cli.frames import print_frame
    from tyre_farm_cli.invert import TITLES, _report

    study = stored[0]
    out = io.StringIO()
    frames, figures = _report(study.store, study.group, tmp_path / "r")
    console = Console(file=out, width=200)
    for name, frame in frames["views"].items():  # what `farm invert` prints of them
        print_frame(console, TITLES[name], frame)
    text = out.getvalue()
    assert "Tables 4.1/4.3" in text and "72 ± 2.8" in text and "358.28 ± 0.4" in text
    for name in ("forces", "rmse", "nodal_errors", "cost", "per_solve", "guesses"):
        assert (tmp_path / "r" / f"{name}.csv").stat().st_size > 0
    assert "Initial guesses" in text
    assert [p.name for p in figures] == ["nodal_errors_noise.png", "nodal_errors_guess-90.png"]
