"""Adaptive studies (issue 28): the ``[study.adaptive]`` table, the rounds' points in
ids and the store, and a study that resumes at its round after its client stopped, on
the real solver (the surrogate is analysis.adaptive's, as the CLI passes it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import QUICK_MODEL, ccx_runs

import storage
from jobs.adaptive import log as rounds_log
from jobs.adaptive.loop import candidates, met, run_adaptive
from jobs.errors import StudyError
from jobs.expand import cases, experiments, plan
from jobs.study import load_study, parse_study
from jobs.sweep import run_sweep

SOLVER = "CalculiX 2.20"
SAMPLE = """
[loads.sample]
method = "lhs"
n = 4
seed = 0
deflection_mm = [10, 25]
friction = [0.3, 1.0]
shift_y_mm = [-3, 3]
"""
ADAPTIVE = "[study.adaptive]\nrounds = 2\nbatch = 2\ncandidates = 64\n"


def _text(tmp_path, adaptive: str = ADAPTIVE, loads: str = SAMPLE, extra: str = "") -> str:
    return (f'[study]\nname = "adaptive"\nstore = "{tmp_path / "s.zarr"}"\n' + adaptive
            + QUICK_MODEL + "\n[loads]\n" + loads + extra)


# ---------------------------------------------------------------- the study file


def test_an_adaptive_table_is_read_with_its_defaults(tmp_path):
    study = parse_study(_text(tmp_path))
    spec = study.adaptive
    assert (spec.rounds, spec.batch, spec.candidates, spec.seed) == (2, 2, 64, 0)
    assert spec.target_pct is None and spec.field == "displacement"
    assert spec.outputs == ("field", "Fx", "Fy", "Fz", "Mz") and spec.budget(4) == 8
    assert spec.acquisition == "variance"
    assert parse_study(_text(tmp_path, adaptive="")).adaptive is None


@pytest.mark.parametrize(("adaptive", "loads", "message"), [
    ("[study.adaptive]\nbatch = 2\n", SAMPLE, r"study\.adaptive.*rounds"),
    (ADAPTIVE.replace("candidates = 64", "candidates = 100"), SAMPLE, r"power of 2.*100"),
    (ADAPTIVE.replace("candidates = 64", "candidates = 1"), SAMPLE, r"at least batch = 2"),
    (ADAPTIVE + "target_pct = 0\n", SAMPLE, r"target_pct: must be in \(0, 100\]"),
    (ADAPTIVE + "outputs = ['Fz', 'Fq']\n", SAMPLE, r"outputs: must list field, Fx"),
    (ADAPTIVE + "field = 'stress'\n", SAMPLE, r"field: must be one of displacement, strain"),
    (ADAPTIVE + "round = 3\n", SAMPLE, r"study\.adaptive.*round"),
    (ADAPTIVE + "acquisition = 'ei'\n", SAMPLE, r"acquisition: must be one of variance, integ"),
    (ADAPTIVE, "deflection_mm = [10, 20]\n", r"\[loads\.sample\]"),
    (ADAPTIVE, SAMPLE + "[loads.extra]\n", r"loads"),
])
def test_a_bad_adaptive_study_is_one_line_naming_the_key(tmp_path, adaptive, loads, message):
    with pytest.raises(StudyError, match=message) as e:
        parse_study(_text(tmp_path, adaptive, loads))
    assert "\n" not in str(e.value)


def test_a_listed_load_that_varies_must_be_sampled(tmp_path):
    loads = SAMPLE.replace("[loads.sample]", "tilt_deg = [-2, 2]\n[loads.sample]")
    with pytest.raises(StudyError, match=r"loads\.tilt_deg: lists 2 values.*\[loads\.sample\]"):
        parse_study(_text(tmp_path, loads=loads))
    one = SAMPLE.replace("[loads.sample]", "tilt_deg = [2]\n[loads.sample]")
    assert parse_study(_text(tmp_path, loads=one)).adaptive is not None  # fixed: allowed


def test_a_model_design_cannot_be_adaptive(tmp_path):
    models = '\n[models]\nmethod = "lhs"\nn = 2\n[models.parameters]\n' \
             '"materials.tread.youngs_modulus" = [5.0, 10.0]\n'
    with pytest.raises(StudyError, match=r"study\.adaptive: .*\[models\]"):
        parse_study(_text(tmp_path, extra=models))


def test_the_budget_is_within_the_experiment_limit(tmp_path, monkeypatch):
    monkeypatch.setenv("FARM_MAX_EXPERIMENTS", "7")
    with pytest.raises(StudyError, match=r"4 initial experiments \+ 2 rounds x 2 is 8 "
                       r"experiments, above the limit of 7"):
        parse_study(_text(tmp_path))


# ---------------------------------------------------------------- rounds and ids


def test_chosen_points_are_cases_with_the_ids_of_a_plain_study(tmp_path):
    study = parse_study(_text(tmp_path))
    pool = candidates(study, 1)
    assert pool.shape == (64, 3)
    low, high = np.array([10, 0.3, -3]), np.array([25, 1.0, 3])
    assert ((pool >= low) & (pool <= high)).all()
    assert not np.allclose(pool, candidates(study, 2))  # each round its own draw
    np.testing.assert_array_equal(pool, candidates(study, 1))  # reproducibly
    chosen = rounds_log.Round(1, tuple(tuple(map(float, p)) for p in pool[:2]),
                              rounds_log.Fit(4))
    grown = rounds_log.with_points(study, rounds_log.Log(rounds_log.design(study), (chosen,)))
    before, after = cases(study), cases(grown)
    assert after[:4] == before and len(after) == 6
    assert after[4][0] == round(pool[0, 0], 9) and after[4][2].friction == round(pool[0, 1], 9)
    ids = [e.id for e in experiments(plan(grown, SOLVER))]
    assert set(e.id for e in experiments(plan(study, SOLVER))) < set(ids)


def test_the_target_judges_every_output_that_varies():
    errors = {"field": 0.2, "Fy": 1.5, "Fz": 0.4, "Mz": None}
    assert met(errors, ("field", "Fy", "Fz", "Mz"), 2.0)
    assert not met(errors, ("field", "Fy", "Fz", "Mz"), 1.0)
    assert not met(errors, ("field",), None)
    assert not met({"Mz": None}, ("Mz",), 5.0)  # nothing judged: no reason to stop


def test_a_record_of_another_design_is_refused(tmp_path):
    study = parse_study(_text(tmp_path))
    record = rounds_log.Log(rounds_log.design(study)).to_json("adaptive")
    assert rounds_log.parse(record, study).rounds == ()
    other = parse_study(_text(tmp_path, loads=SAMPLE.replace("n = 4", "n = 5")))
    with pytest.raises(StudyError, match=r"another design \(lhs n = 4 .*this study: lhs n = 5"):
        rounds_log.parse(record, other)


# ---------------------------------------------------------------- on the solver


class _Stop(Exception):
    """Stands for the client dying between storing a round and sweeping it."""


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_stopped_adaptive_study_resumes_at_its_round(tmp_path, counting_ccx):
    from analysis.adaptive import SurrogateChooser

    path = tmp_path / "study.toml"
    path.write_text(_text(tmp_path))
    study = load_study(path)
    sweeps = []

    def dying_sweep(s, **options):
        sweeps.append(s)
        if len(sweeps) == 2:  # round 1 is chosen and stored: the client dies now
            raise _Stop
        return run_sweep(s, **options)

    with pytest.raises(_Stop):
        run_adaptive(study, SurrogateChooser(restarts=1), sweep=dying_sweep, workers=2)
    stored = rounds_log.read(study)
    assert [r.index for r in stored.rounds] == [1] and len(stored.points()) == 2
    assert stored.rounds[0].fit.fitted_on == 4 and ccx_runs(counting_ccx) == 4

    fits = []
    report = run_adaptive(study, SurrogateChooser(restarts=1), workers=2,
                          on_round=lambda i, fit, chosen: fits.append((i, chosen)))
    assert fits == [(2, 2), (3, 0)]  # round 1 was not chosen again, round 2 was
    assert report.log.rounds[0] == stored.rounds[0] and report.log.stopped == "budget"
    assert report.ok and report.experiments == 8
    assert [s.skipped for s in report.sweeps] == [4, 6]
    assert ccx_runs(counting_ccx) == 8  # every experiment solved once
    ds = storage.done(storage.open_dataset(study.store, study.group_name))
    assert ds.sizes["experiment"] == 8
    assert storage.read_rounds(study.store, study.group_name)["final"]["fitted_on"] == 8
    errors = report.log.final.errors
    assert errors["Fz"] is not None and 0 < errors["Fz"] < 20, errors
    # `farm sweep status STUDY` counts the rounds' experiments, not the initial design's
    out = _cli(["sweep", "status", str(path), "--json"])
    assert out["groups"][0]["counts"] == {"done": 8, "failed": 0, "pending": 0}


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_an_adaptive_study_stops_once_its_target_is_met(tmp_path, counting_ccx):
    """A target every output meets after the initial design: no round is chosen."""
    from analysis.adaptive import SurrogateChooser

    path = tmp_path / "study.toml"
    path.write_text(_text(tmp_path, adaptive=ADAPTIVE + "target_pct = 100\n"))
    study = load_study(path)
    report = run_adaptive(study, SurrogateChooser(restarts=1), workers=2)
    assert report.log.rounds == () and report.log.stopped == "target"
    assert report.log.final.fitted_on == 4 and ccx_runs(counting_ccx) == 4
    assert all(e is None or e <= 100 for e in report.log.final.errors.values())


def _cli(argv: list[str]) -> dict:
    import contextlib
    import io
    import json

    from tyre_farm_cli import main

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        try:
            main(argv)
        except SystemExit as e:
            assert e.code in (0, None)
    return json.loads(buffer.getvalue())


def test_the_examples_adaptive_study_is_valid():
    study = load_study(Path(__file__).parents[2] / "examples/combined_adaptive.toml")
    assert study.adaptive is not None and study.combined


def _wait_for_round(study, index: int, timeout: float = 180) -> None:
    import time

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            record = storage.read_rounds(study.store, study.group_name)
            if record and len(record["rounds"]) >= index:
                return
        except storage.StoreError:
            pass
        time.sleep(0.25)
    raise AssertionError(f"round {index} was not chosen within {timeout} s")


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_a_killed_adaptive_client_resumes_at_its_round(tmp_path, counting_ccx):
    """SIGKILL the CLI's client once round 1 is stored; `farm sweep resume --json` then
    chooses round 2 only and solves no experiment twice."""
    import json
    import os
    import signal
    import subprocess
    import sys

    path = tmp_path / "study.toml"
    path.write_text(_text(tmp_path))
    study = load_study(path)
    client = subprocess.Popen([sys.executable, "-m", "farm", "sweep", "submit", str(path),
                               "--workers", "2"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        _wait_for_round(study, 1)
    finally:
        os.killpg(client.pid, signal.SIGKILL)  # the client and its workers
        client.wait()
    stored = rounds_log.read(study)
    assert len(stored.rounds) == 1
    done = storage.status_counts(study.store, study.group_name)["done"]
    runs = ccx_runs(counting_ccx)
    resumed = subprocess.run([sys.executable, "-m", "farm", "sweep", "resume", str(path),
                              "--workers", "2", "--json"], capture_output=True, text=True,
                             timeout=600)
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    out = json.loads(resumed.stdout)
    rounds = out["adaptive"]["rounds"]
    assert [r["round"] for r in rounds] == [1, 2]
    assert rounds[0]["points"] == [list(p) for p in stored.points()]  # not chosen again
    assert out["adaptive"]["final"]["stopped"] == "budget" and out["experiments"] == 8
    # each experiment solved once: what the killed client finished is not solved again
    assert ccx_runs(counting_ccx) - runs == 8 - done
    assert storage.status_counts(study.store, study.group_name)["done"] == 8


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_the_comparison_benchmark_prints_error_against_runs_for_every_design(tmp_path):
    """benchmarks/bench_adaptive.py on a tiny vertical study (one sampled deflection,
    frictionless reduced model): the curve of each design, side by side."""
    import subprocess
    import sys

    path = tmp_path / "study.toml"
    loads = '[loads.sample]\nmethod = "lhs"\nn = 3\ndeflection_mm = [10, 30]\n'
    path.write_text(_text(tmp_path, loads=loads))
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, str(root / "benchmarks/bench_adaptive.py"), str(path),
                          "--out", str(tmp_path / "bench"), "--start", "3", "--batch", "1",
                          "--rounds", "2", "--test", "4"], capture_output=True, text=True,
                         timeout=600, cwd=root)
    assert out.returncode == 0, out.stderr[-3000:]
    lines = out.stdout.splitlines()
    head = next(k for k, line in enumerate(lines) if line.startswith("held-out RMSE"))
    rows = [line.split() for line in lines[head + 2:head + 5]]
    assert [r[0] for r in rows] == ["3", "4", "5"]
    assert all(r[1].count("/") == 2 for r in rows)  # adaptive / LHS / Sobol'
    assert all(x != "-" for r in rows for x in r[1].split("/"))  # 3 sizes: LHS at each
    assert any(line.startswith("displacement: LHS at 5 runs") for line in lines)
