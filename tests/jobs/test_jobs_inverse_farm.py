"""Inverse loops on the farm with the real solver (coarse reduced model, 6 unknowns).

A small solve recovers the forces and lands in the store; a second run replays every
evaluation from the cache (no ccx); a client killed mid-loop resumes to the very same
result as an uninterrupted run; more loops than workers all finish (no deadlock) and
share identical evaluations; the CLI prints the tables and refuses bad input at once.
"""

import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
import xarray as xr
from conftest import ccx_processes, ccx_runs

from jobs.inverse.objective import Objective
from jobs.inverse.run import run_inverse
from jobs.inverse.study import load_inverse_study
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluator
from tyre_farm_cli import main

pytestmark = pytest.mark.ccx

MODEL = """
[model]
kind = "reduced"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 8
"""

LSQ = """
[optimizers.least-squares]
max_evaluations = 60
fd_step_n = 0.5
tolerance = 1e-6
jacobian = "full"
[[conditions]]
name = "ideal"
methods = ["displacement"]
noise = false
"""

MANY = """
[optimizers.nelder-mead]
max_evaluations = 10
[[conditions]]
name = "ideal"
methods = ["displacement", "strain"]
noise = false
[[conditions]]
name = "noisy"
methods = ["displacement", "strain"]
repeats = 2
"""


def write(tmp_path, body: str, name: str = "inverse", cache: str = "cache") -> str:
    path = tmp_path / f"{name}.toml"
    path.write_text(f'[study]\nname = "{name}"\nstore = "{tmp_path / "store.zarr"}"\n'
                    f'cache = "{tmp_path / cache}"\n' + MODEL + textwrap.dedent(body))
    return str(path)


@pytest.fixture(scope="module")
def solved(tmp_path_factory, ccx):
    """One uninterrupted least-squares solve (ideal case, displacement objective)."""
    tmp = tmp_path_factory.mktemp("inverse")
    study = load_inverse_study(write(tmp, LSQ))
    return study, run_inverse(study, workers=2)


def test_a_small_solve_recovers_the_forces(solved):
    _, report = solved
    assert report.ok and len(report.results) == 1
    r, p = report.results[0], report.problem
    assert p.n == 6 and r.status in ("converged", "stopped")
    np.testing.assert_allclose(r.x, p.x_true, rtol=0.01, atol=0.01 * p.x_true.max())
    assert r.x.sum() == pytest.approx(p.x_true.sum(), rel=5e-3)
    assert r.final.total_force[2] == pytest.approx(p.reference.total_force[2], rel=5e-3)
    assert r.f_history[0] > 100 * r.objective  # from 90 % of the truth to ~0
    assert r.stats.rounds < len(r.f_history) / 2  # Jacobian columns solved side by side


def test_the_objective_is_zero_at_the_truth(solved):
    study, report = solved
    p = report.problem
    ev = Evaluator(None, EvaluationCache(study.cache))
    arrays = ev.run([p.forward_evaluation(p.x_true)])[0]
    for method in ("displacement", "strain"):
        f = np.linalg.norm(Objective(p, method, None, "per_solve", [0]).residuals(
            arrays, p.x_true, 0))
        start = np.linalg.norm(Objective(p, method, None, "per_solve", [0]).residuals(
            ev.run([p.forward_evaluation(0.9 * p.x_true)])[0], p.x_true, 0))
        assert f < 1e-3 * start  # .frd precision, not exactly zero


def test_results_are_in_the_store_with_units(solved):
    study, report = solved
    ds = xr.open_zarr(study.store, group=study.group)
    r = report.results[0]
    assert ds.sizes["solve"] == 1 and ds.sizes["unknown"] == 6
    np.testing.assert_array_equal(ds["x_final"].values[0], r.x)
    k = len(r.f_history)
    np.testing.assert_array_equal(ds["objective_history"].values[0, :k], r.f_history)
    assert str(ds["status"].values[0]) == r.status and ds["x_history"].attrs["units"] == "N"
    assert ds["rmse"].attrs["units"].startswith("mm") and ds["moment"].attrs["units"] == "N mm"
    assert str(ds["condition"].values[0]) == "ideal"


def test_a_second_run_replays_every_evaluation_from_the_cache(solved, counting_ccx):
    study, report = solved
    again = run_inverse(study, workers=1)
    assert ccx_runs(counting_ccx) == 0
    assert again.totals.solved == 0 and again.totals.cached > 0
    np.testing.assert_array_equal(again.results[0].x, report.results[0].x)
    np.testing.assert_array_equal(again.results[0].f_history, report.results[0].f_history)


def _wait_for_cache(folder, n, timeout=180):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if len(list(folder.glob("*/*.npz"))) >= n:
            return
        time.sleep(0.2)
    raise AssertionError(f"fewer than {n} cached evaluations after {timeout} s")


def _solvers_in(folder) -> list:
    """Live ccx processes whose working directory is under ``folder``."""
    import psutil

    found = []
    for p in ccx_processes():
        try:
            if p.cwd().startswith(str(folder)):
                found.append(p)
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
    return found


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_killed_client_resumes_to_the_same_result(solved, tmp_path, counting_ccx):
    _, clean = solved
    path = write(tmp_path, LSQ, cache="resume-cache")
    scratch = tmp_path / "scratch"  # to tell this test's solvers from any other's
    client = subprocess.Popen([sys.executable, "-m", "farm", "invert", path, "--workers", "2"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                              env={**os.environ, "FARM_SCRATCH_DIR": str(scratch)})
    try:
        _wait_for_cache(tmp_path / "resume-cache", 10)
    finally:
        client.send_signal(signal.SIGKILL)
        client.wait()
    deadline = time.monotonic() + 30
    while _solvers_in(scratch) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert _solvers_in(scratch) == []  # the solvers died with their workers
    done_before = len(list((tmp_path / "resume-cache").glob("*/*.npz")))
    runs_before = ccx_runs(counting_ccx)
    resumed = run_inverse(load_inverse_study(path), workers=2)
    solved_now = ccx_runs(counting_ccx) - runs_before
    total = clean.totals.solved
    assert solved_now <= total - done_before + 2  # at most the in-flight ones again
    assert resumed.totals.cached >= done_before
    np.testing.assert_array_equal(resumed.results[0].x, clean.results[0].x)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.timeout(600)
def test_more_loops_than_workers_finish_and_share_evaluations(tmp_path):
    study = load_inverse_study(write(tmp_path, MANY))
    report = run_inverse(study, workers=1)
    assert len(report.results) == 6 and report.ok
    assert {r.status for r in report.results} <= {"max_evaluations", "converged"}
    # methods of one repeat start from the same guess: their simplices are solved once
    assert report.totals.cached + report.totals.shared >= 7
    assert report.totals.solved < report.totals.evaluations


def test_cli_prints_tables_and_writes_csv_and_png(solved, tmp_path, capsys):
    study, _ = solved
    out = tmp_path / "report"
    with pytest.raises(SystemExit) as info:
        main(["invert", study.source, "--workers", "1", "--out", str(out)])
        raise SystemExit(0)  # main returns normally on success
    assert info.value.code == 0
    text = capsys.readouterr().out
    assert "Tables 4.1/4.3" in text and "reference" in text and "thesis Fz" in text
    for name in ("forces", "rmse", "nodal_errors", "cost", "per_solve"):
        assert (out / f"{name}.csv").stat().st_size > 0
    assert (out / "nodal_errors_ideal.png").stat().st_size > 1000


@pytest.mark.parametrize(("body", "message"), [
    ("[optimizers.least-squares]\nnoise_draw = 'per_evaluation'\n", "needs 'per_solve'"),
    ("[reference]\ndeflection_mm = 500\n", "reaches through the tyre"),
    ("[mask]\neigen_vectors = 'missing.csv'\n", "cannot read"),
])
def test_cli_refuses_bad_input_before_submitting(tmp_path, capsys, body, message,
                                                  counting_ccx):
    path = write(tmp_path, body)
    with pytest.raises(SystemExit) as info:
        main(["invert", path, "--workers", "1"])
    err = capsys.readouterr().err
    assert info.value.code == 1 and message in err and len(err.strip().splitlines()) == 1
    assert ccx_runs(counting_ccx) == 0 and not (tmp_path / "cache").exists()


@pytest.mark.slow
def test_a_worker_lost_mid_loop_costs_at_most_its_evaluation(solved, tmp_path, counting_ccx,
                                                             monkeypatch):
    """External scheduler, two workers; the one running a solve is SIGKILLed mid-loop."""
    import threading

    from test_jobs_distributed import Topology

    _, clean = solved
    scratch = tmp_path / "scratch"
    monkeypatch.setenv("FARM_SCRATCH_DIR", str(scratch))  # inherited by the workers
    topo = Topology(tmp_path)
    try:
        for name in ("w1", "w2"):
            topo.start_worker(name)
        study = load_inverse_study(write(tmp_path, LSQ, cache="worker-loss-cache"))
        box = {}
        thread = threading.Thread(target=lambda: box.setdefault(
            "report", run_inverse(study, scheduler=topo.address, workers=2)))
        thread.start()
        _wait_for_cache(tmp_path / "worker-loss-cache", 8)  # past the first round
        victim = _worker_running_a_solve(topo, scratch)
        runs_at_kill = ccx_runs(counting_ccx)
        topo.kill_worker(victim)
        topo.start_worker(f"{victim}-new")
        thread.join(timeout=600)
    finally:
        topo.close()
    report = box["report"]
    np.testing.assert_array_equal(report.results[0].x, clean.results[0].x)
    # every evaluation solved once, but the one the lost worker was running: the clean
    # run's ccx runs are the reference's iterations plus one per other evaluation
    clean_runs = clean.problem.reference_ccx_runs + clean.totals.solved - 1
    assert runs_at_kill > 0 and ccx_runs(counting_ccx) <= clean_runs + 1


def _worker_running_a_solve(topo, scratch, timeout=120) -> str:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for proc in _solvers_in(scratch):
            for name, worker in topo.workers.items():
                try:
                    if worker.pid in {p.pid for p in proc.parents()}:
                        return name
                except Exception:
                    continue
        time.sleep(0.05)
    raise AssertionError("no solve started on a worker")
