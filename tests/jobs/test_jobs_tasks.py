"""The worker task's failure policy, with a fake solver (queue logic only).

The real solver runs in test_jobs_sweep.py; here ``run_load_path`` is replaced so that
the retry/split/record decisions can be checked exactly.
"""

from pathlib import Path

import numpy as np
import pytest
from conftest import study_text

import storage
from farm.errors import SolverError
from farm.measure.measurement import Measurement, patch_array
from farm.measure.patch import PatchMetrics
from jobs.expand import experiments, parameters, plan
from jobs.storeio import ensure_group
from jobs.study import parse_study
from jobs.tasks import PathTask, run_path

SOLVER = "CalculiX 2.20"


@pytest.fixture
def setup(tmp_path):
    study = parse_study(study_text(tmp_path / "s.zarr", deflections="[10, 20, 30]", solver=""))
    paths = plan(study, SOLVER)
    ensure_group(study, SOLVER)
    exps = experiments(paths)
    storage.reserve(study.store, study.group_name, [e.id for e in exps], parameters(exps))
    task = PathTask(paths[0], study.model, study.settings, study.store,
                    study.group_name)
    return study, task


class FakeSolver:
    """Fails (with ``outcome``) on any path reaching ``fail_at`` mm; logs every call."""

    def __init__(self, mesh_counts, fail_at=None, outcome="too_many_cutbacks"):
        self.n_inner, self.n_tread = mesh_counts
        self.fail_at, self.outcome, self.calls = fail_at, outcome, []

    def __call__(self, model, path, settings, should_stop=None):
        self.calls.append((path.deflections, settings.max_increment))
        if self.fail_at is not None and path.deflections[-1] >= self.fail_at:
            raise SolverError(self.outcome, ["ccx", "-i", "path"], 201, "*ERROR: boom")
        ms = tuple(Measurement(d, 0.0, np.full((self.n_inner, 3), d), np.zeros((self.n_inner, 3)),
                               np.zeros((self.n_inner, 3)), np.zeros((self.n_tread, 3)),
                               np.array([0, 0, d]), np.zeros(3), np.array([0, 0, d]), 1, 1.0,
                               patch=patch_array(PatchMetrics(3, 2, 10.0 * d, d, 2.0, 0.5, 0.1, 1.0,
                                                             0.5)))
                   for d in path.deflections)
        return type("R", (), {"measurements": ms, "increments": 3, "ccx_runs": 1,
                              "solve_seconds": 1.0})()


def _fake(monkeypatch, study, **kwargs):
    ds = storage.open_dataset(study.store, study.group_name)
    fake = FakeSolver((ds.sizes["inner_node"], ds.sizes["tread_node"]), **kwargs)
    monkeypatch.setattr("jobs.tasks.run_load_path", fake)
    return fake


def test_success_writes_every_experiment(setup, monkeypatch):
    study, task = setup
    fake = _fake(monkeypatch, study)
    out = run_path(task)
    assert len(out.done) == 3 and not out.failed and len(fake.calls) == 1
    ds = storage.done(storage.open_dataset(study.store, study.group_name))
    assert sorted(ds["deflection"].values) == [10, 20, 30]


def test_done_experiments_are_skipped(setup, monkeypatch):
    study, task = setup
    fake = _fake(monkeypatch, study)
    run_path(task)
    again = run_path(task)
    assert len(again.skipped) == 3 and not again.done and len(fake.calls) == 1


@pytest.mark.parametrize("outcome", ["too_many_cutbacks", "crash"])
def test_non_convergence_retries_smaller_then_splits(setup, monkeypatch, outcome):
    study, task = setup
    fake = _fake(monkeypatch, study, fail_at=30.0, outcome=outcome)
    out = run_path(task)
    # whole path, then with 4x smaller increments, then one path per deflection
    assert fake.calls[0] == ((10.0, 20.0, 30.0), 0.5)
    assert fake.calls[1] == ((10.0, 20.0, 30.0), 0.125)
    assert [c[0] for c in fake.calls[2:]] == [(10.0,), (20.0,), (30.0,)]
    assert len(out.done) == 2 and len(out.failed) == 1
    status = storage.statuses(study.store, study.group_name)
    assert sorted(status.values()) == [storage.DONE, storage.DONE, storage.FAILED]
    ds = storage.open_dataset(study.store, study.group_name)
    failed = ds.isel(experiment=np.flatnonzero(ds["status"].values == storage.FAILED))
    assert outcome in str(failed["error"].values[0])
    assert float(failed["deflection"].values[0]) == 30.0


@pytest.mark.parametrize("outcome", ["input_error", "nonpositive_jacobian", "timeout"])
def test_other_failures_are_recorded_at_once(setup, monkeypatch, outcome):
    study, task = setup
    fake = _fake(monkeypatch, study, fail_at=10.0, outcome=outcome)
    out = run_path(task)
    assert len(fake.calls) == 1 and len(out.failed) == 3
    assert all(outcome in reason for _, reason in out.failed)


def test_cancellation_propagates(setup, monkeypatch):
    study, task = setup
    _fake(monkeypatch, study, fail_at=10.0, outcome="cancelled")
    with pytest.raises(SolverError):
        run_path(task)
    assert set(storage.statuses(study.store, study.group_name).values()) == {storage.PENDING}


def test_group_of_another_model_is_refused(setup, tmp_path):
    study, _ = setup
    other = parse_study(study_text(Path(study.store), group=study.group_name).replace(
        "circumferential = 8", "circumferential = 10"))
    from jobs.errors import StudyError

    with pytest.raises(StudyError, match="holds another model"):
        ensure_group(other, SOLVER)


def test_patch_metrics_go_into_the_store(setup, monkeypatch):
    """Issue 24: the worker stores each state's contact patch; the reduced model has no
    inflation, so no growth (NaN)."""
    study, task = setup
    _fake(monkeypatch, study)
    run_path(task)
    assert storage.verify(study.store).ok
    ds = storage.done(storage.open_dataset(study.store, study.group_name))
    d = ds["deflection"].values
    np.testing.assert_array_equal(ds["patch_area"].values, 10.0 * d)
    np.testing.assert_array_equal(ds["patch_length"].values, d)
    assert (ds["mean_pressure"].values == 0.1).all()
    assert np.isnan(ds["inflation_growth"].values).all()
    assert ds["patch_area"].attrs["units"] == "mm2"


def test_a_group_made_before_patch_metrics_resumes(setup, monkeypatch):
    """A group created before issue 24 has no patch arrays: today's worker skips them."""
    import shutil

    from storage.paths import publish
    from storage.schema import PATCH_NAMES

    study, task = setup
    root = Path(str(study.store)) / study.group_name
    for name in PATCH_NAMES:
        shutil.rmtree(root / name)
    publish(storage.open_store(study.store))
    storage.handles.forget()
    _fake(monkeypatch, study)
    out = run_path(task)
    assert len(out.done) == 3 and not out.failed
    assert storage.verify(study.store).ok
    ds = storage.done(storage.open_dataset(study.store, study.group_name))
    assert ds.sizes["experiment"] == 3 and not set(ds.variables) & set(PATCH_NAMES)
