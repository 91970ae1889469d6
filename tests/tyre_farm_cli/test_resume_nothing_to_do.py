"""``farm sweep resume`` of a study whose experiments are all done answers from the store,
without starting a cluster (issue 25: it took 16.6 s to learn there was nothing to do)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_helpers import run_cli

import jobs.cluster
import storage
from jobs.driver import solver_version
from jobs.errors import ClusterError
from jobs.expand import experiments, parameters, plan
from jobs.storeio import ensure_group
from jobs.study import load_study
from tests.jobs.conftest import study_text

pytestmark = pytest.mark.usefixtures("ccx")  # the ids hold the local solver's version

STARTED = "a cluster was started"


@pytest.fixture
def no_cluster(monkeypatch):
    """Every cluster start fails, with a line the test can recognise."""
    def refuse(*args, **kwargs):
        raise ClusterError(STARTED)

    monkeypatch.setattr(jobs.cluster, "connect", refuse)


def _result(n_inner: int, n_tread: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"displacement": rng.normal(size=(n_inner, 3)),
            "strain": rng.normal(scale=1e-3, size=(n_inner, 3)),
            "surface_strain": rng.normal(scale=1e-3, size=(n_inner, 3)),
            "reaction_force": rng.normal(size=(n_tread, 3)),
            "total_force": rng.normal(size=3), "moment": rng.normal(size=3)}


INFO = {"solve_seconds": 1.0, "increments": 3, "ccx_runs": 1, "contact_nodes": 4}


def _stored(tmp_path, outcome: dict[int, str]) -> tuple:
    """A study of three deflections and its store, written as a sweep would (no ccx):
    experiment k ``done``, ``failed`` or ``pending`` as ``outcome`` says (default done)."""
    path = tmp_path / "study.toml"
    path.write_text(study_text(tmp_path / "store.zarr",
                               deflections="{ start = 10, stop = 30, step = 10 }"))
    study = load_study(path)
    solver = solver_version(None, embedded=True)
    ensure_group(study, solver)
    exps = experiments(plan(study, solver))
    store, group = study.store, study.group_name
    storage.reserve(store, group, [e.id for e in exps], parameters(exps))
    ds = storage.open_dataset(store, group)
    n_inner, n_tread = ds.sizes["inner_node"], ds.sizes["tread_node"]
    for k, e in enumerate(exps):
        status = outcome.get(k, "done")
        if status == "done":
            storage.write_experiment(store, group, e.id, _result(n_inner, n_tread, k), INFO)
        elif status == "failed":
            storage.write_failure(store, group, e.id, "did not converge", {})
    return path, exps


def test_resume_of_a_finished_sweep_starts_no_cluster(tmp_path, no_cluster, capsys):
    path, exps = _stored(tmp_path, {})
    code, out, err = run_cli(["sweep", "resume", str(path)], capsys)
    assert code == 0, err
    assert STARTED not in err
    assert "nothing to do" in out and f"{len(exps)} of {len(exps)} experiments done" in out


def test_resume_json_says_nothing_to_do(tmp_path, no_cluster, capsys):
    path, exps = _stored(tmp_path, {})
    code, out, err = run_cli(["sweep", "resume", str(path), "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert doc["nothing_to_do"] is True and doc["ok"] is True
    assert (doc["experiments"], doc["already_done"], doc["done_now"]) == (len(exps),
                                                                           len(exps), 0)


def test_failed_before_is_nothing_to_do_without_retry(tmp_path, no_cluster, capsys):
    path, exps = _stored(tmp_path, {1: "failed"})
    code, out, err = run_cli(["sweep", "resume", str(path), "--json"], capsys)
    assert code == 1 and STARTED not in err  # not ok: one experiment failed
    doc = json.loads(out)
    assert doc["nothing_to_do"] is True and doc["already_done"] == len(exps) - 1
    assert [f["experiment"] for f in doc["failed"]] == [exps[1].id]
    assert "--retry-failed" in doc["failed"][0]["error"]


@pytest.mark.parametrize(("outcome", "flags"), [({2: "pending"}, []),
                                                 ({0: "failed"}, ["--retry-failed"])],
                         ids=["pending", "retry-failed"])
def test_work_left_still_starts_the_cluster(tmp_path, no_cluster, capsys, outcome, flags):
    path, _ = _stored(tmp_path, outcome)
    code, _, err = run_cli(["sweep", "resume", str(path), *flags], capsys)
    assert code == 1 and STARTED in err


def test_a_study_never_submitted_starts_the_cluster(tmp_path, no_cluster, capsys):
    path = tmp_path / "study.toml"
    path.write_text(study_text(tmp_path / "store.zarr"))
    code, _, err = run_cli(["sweep", "submit", str(path)], capsys)
    assert code == 1 and STARTED in err
