"""One identity module: every key from the same ingredients (mesher included), and
stores written with the old (recipe-1) experiment ids still open and resume."""

import ast
from pathlib import Path

import numpy as np
import pytest
from conftest import ccx_runs, study_text

import farm.mesh.version as version
import storage
from farm.measure.measurement import Measurement
from farm.specs import SolverSettings
from jobs import identity
from jobs.calibrate.evaluate import curve_evaluation
from jobs.expand import experiments, load_cases, plan
from jobs.inverse.evaluate import ForwardTask, task_key
from jobs.storeio import ensure_group
from jobs.study import parse_study
from jobs.sweep import run_sweep
from jobs.tasks import PathTask

SOLVER = "CalculiX 2.20"
ROOT = Path(__file__).resolve().parents[2]


def _study(tmp_path, deflections="[10, 20, 30]"):
    return parse_study(study_text(tmp_path / "s.zarr", deflections=deflections, solver=""))


def _keys(model):
    task = ForwardTask(model, (1, 2), (10.0, 20.0), -380.0, SolverSettings())
    return (identity.experiment_id(model, 10.0, 0.0, SOLVER),
            task_key("inverse-forward", task, SOLVER),
            curve_evaluation(model, (10.0,), 0.0, SolverSettings(), SOLVER).key,
            identity.mesh_key(model))


def test_every_key_changes_with_the_mesher(tmp_path, monkeypatch):
    model = _study(tmp_path).model
    before = _keys(model)
    monkeypatch.setattr(version, "mesher_fingerprint", lambda: "another mesher")
    after = _keys(model)
    assert all(a != b for a, b in zip(before, after, strict=True))


def test_keys_ignore_solver_settings_but_not_the_solver(tmp_path):
    model = _study(tmp_path).model
    a = curve_evaluation(model, (10.0,), 0.0, SolverSettings(), SOLVER).key
    b = curve_evaluation(model, (10.0,), 0.0, SolverSettings(max_increment=0.3), SOLVER).key
    c = curve_evaluation(model, (10.0,), 0.0, SolverSettings(), "CalculiX 2.21").key
    assert a == b != c


def test_no_other_module_hashes_its_own_keys():
    """Ids and keys of jobs come from jobs.identity: no content_hash elsewhere but seeds."""
    users = []
    for path in (ROOT / "jobs").rglob("*.py"):
        if path.name == "identity.py":
            continue
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Name) and node.id == "content_hash":
                users.append(path.relative_to(ROOT).as_posix())
    assert set(users) <= {"jobs/inverse/loop.py"}  # there: a noise seed, not a key


def test_tasks_carry_the_model_spec_itself(tmp_path):
    study = _study(tmp_path)
    path = plan(study, SOLVER)[0]
    task = PathTask(path, study.model, study.settings, study.store, study.group_name)
    assert task.model is study.model


# ---------------------------------------------------------------- old stores


def _legacy_store(study, solver=SOLVER) -> list[str]:
    """A store as the farm wrote it before recipe 2: ids without the mesh key, all done."""
    ensure_group(study, solver)
    cases = load_cases(study)
    ids = [identity.legacy_experiment_id(study.model, d, p, solver) for d, p in cases]
    storage.reserve(study.store, study.group_name, ids,
                    {"deflection": np.array([d for d, _ in cases]),
                     "pressure": np.array([p for _, p in cases])})
    ds = storage.open_dataset(study.store, study.group_name)
    n, m = ds.sizes["inner_node"], ds.sizes["tread_node"]
    for i, (d, _) in zip(ids, cases, strict=True):
        meas = Measurement(d, 0.0, np.full((n, 3), d), np.zeros((n, 3)), np.zeros((n, 3)),
                           np.zeros((m, 3)), np.array([0, 0, d]), np.zeros(3),
                           np.array([0, 0, d]), 1, 1.0)
        storage.write_experiment(study.store, study.group_name, i, meas.arrays(),
                                 {"solve_seconds": 1.0, "increments": 1, "ccx_runs": 1,
                                  "contact_nodes": 1})
    return ids


def test_an_old_group_keeps_its_ids_and_new_cases_get_new_ones(tmp_path):
    study = _study(tmp_path)
    old = _legacy_store(study)
    held = frozenset(storage.statuses(study.store, study.group_name))
    ids = [e.id for e in experiments(plan(study, SOLVER, held))]
    assert ids == old  # every experiment found under its old id: nothing to solve
    more = _study(tmp_path, "[10, 20, 30, 35]")
    ids = [e.id for e in experiments(plan(more, SOLVER, held))]
    assert ids[:3] == old
    assert ids[3] == identity.experiment_id(more.model, 35.0, 0.0, SOLVER) not in old
    assert [e.id for e in experiments(plan(study, SOLVER))] != old  # a new group: recipe 2


@pytest.mark.ccx
def test_an_old_store_resumes_without_solving_again(tmp_path, counting_ccx):
    study = _study(tmp_path)
    from farm.ccx.runner import ccx_version

    _legacy_store(study, f"CalculiX {ccx_version()}")
    report = run_sweep(study, workers=1)
    assert report.ok and report.skipped == 3 and not report.done
    assert ccx_runs(counting_ccx) == 0
    assert storage.status_counts(study.store, study.group_name)["done"] == 3
