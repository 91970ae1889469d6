"""Sweeps on the embedded LocalCluster with the real solver.

Resubmission solves nothing again; a case that cannot converge is recorded while the
others finish; a client killed mid-sweep leaves no solver behind, and resuming solves
exactly what was left.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import ccx_processes, ccx_runs

import storage
from jobs.study import load_study
from jobs.sweep import run_sweep
from tyre_farm_cli import main

pytestmark = pytest.mark.ccx


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_sweep_fills_the_store_and_resubmission_solves_nothing(write_study, counting_ccx):
    study = load_study(write_study())
    report = run_sweep(study, workers=2)
    assert report.ok and len(report.done) == 6 and report.skipped == 0
    runs = ccx_runs(counting_ccx)
    assert runs == 6  # rigid-road contact, uninflated: one ccx run per experiment
    ds = storage.done(storage.open_dataset(study.store, study.group_name))
    assert ds.sizes["experiment"] == 6
    fz = ds["total_force"].sel(component="z").values[np.argsort(ds["deflection"].values)]
    assert np.all(np.diff(fz) > 0)
    # issue 24: the contact patch of each experiment, stored by the worker. mean_pressure
    # is the loaded nodes' normal force over patch_area (farm.measure.patch), so their
    # product is Fz less the nodes under LOADED_N (1e-6 N each), up to rounding
    fz = ds["total_force"].sel(component="z").values
    area = ds["patch_area"].values
    assert (fz > 0).all() and (area > 0).all()
    np.testing.assert_allclose(ds["mean_pressure"].values * area, fz, rtol=1e-9,
                               atol=ds.sizes["tread_node"] * 1e-6)
    assert (ds["peak_pressure"].values >= ds["mean_pressure"].values).all()
    assert np.isnan(ds["inflation_growth"].values).all()  # the reduced model: no inflation

    again = run_sweep(study, workers=2)
    assert again.ok and again.skipped == 6 and not again.done
    assert ccx_runs(counting_ccx) == runs


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_case_that_cannot_converge_is_recorded(write_study, capsys):
    path = write_study(deflections="[10, 20, 170]",
                       solver="max_path_length = 1\nretry_smaller_increments = false")
    with pytest.raises(SystemExit) as info:
        main(["sweep", "submit", str(path), "--workers", "2"])
    out = capsys.readouterr().out
    assert info.value.code == 1
    assert "failed experiments" in out and "170" in out and "increment" in out
    study = load_study(path)
    counts = storage.status_counts(study.store, study.group_name)
    assert counts == {"pending": 0, "done": 2, "failed": 1}


def _wait_for_done(store, group, n, timeout=120):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            if storage.status_counts(store, group)["done"] >= n:
                return
        except storage.StoreError:
            pass
        time.sleep(0.5)
    raise AssertionError(f"fewer than {n} experiments done after {timeout} s")


@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_killed_client_then_resume_solves_only_what_was_left(write_study, counting_ccx):
    path = write_study(deflections="{ start = 2, stop = 40, step = 2 }")
    study = load_study(path)
    # the client's solvers carry a mark of their own: a solver another test left behind
    # is not this client's (a CI run once counted one)
    mark = ("FARM_TEST_KILLED_CLIENT", str(os.getpid()))
    client = subprocess.Popen([sys.executable, "-m", "farm", "sweep", "submit", str(path),
                               "--workers", "2"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, env={**os.environ, mark[0]: mark[1]})
    try:
        _wait_for_done(study.store, study.group_name, 4)
    finally:
        client.send_signal(signal.SIGKILL)
        client.wait()
    deadline = time.monotonic() + 30
    while ccx_processes(mark) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert ccx_processes(mark) == []  # the solvers died with their workers
    before = storage.status_counts(study.store, study.group_name)
    assert before["done"] >= 4 and before["done"] + before["pending"] == 20
    runs = ccx_runs(counting_ccx)
    report = run_sweep(study, workers=2)
    assert report.ok and report.skipped == before["done"]
    assert ccx_runs(counting_ccx) - runs == before["pending"]


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_repair_then_resume_restores_every_promised_case(write_study, counting_ccx, capsys):
    """Issue 26, end to end with the solver: each kind of damage is repaired, then the
    study resumed; the runs it costs are exactly the experiments whose data were lost."""
    import zarr

    study = load_study(write_study())
    assert run_sweep(study, workers=2).ok
    group = Path(study.store) / study.group_name
    ids = storage.statuses(study.store, study.group_name, None)

    def round_trip(damage) -> int:
        damage()
        main_code = _cli_code(["sweep", "verify", study.store, "--repair"])
        assert main_code == 1  # it was damaged
        capsys.readouterr()
        runs = ccx_runs(counting_ccx)
        report = run_sweep(study, workers=2)
        assert report.ok
        assert storage.status_counts(study.store, study.group_name) == {
            "pending": 0, "done": 6, "failed": 0}
        assert storage.verify(study.store).ok
        return ccx_runs(counting_ccx) - runs

    def swap():
        a = zarr.open_array(str(group / "experiment"), mode="r+")
        a[1], a[2] = a[2], a[1]

    def edit():
        zarr.open_array(str(group / "deflection"), mode="r+")[3] = 99.5

    def reset():
        (group / "status" / "c" / "4").write_bytes(bytes([storage.PENDING]))

    assert round_trip(lambda: (group / "pressure" / "c" / "0").unlink()) == 0  # lost load case
    assert round_trip(swap) == 0  # ids put back where they were signed
    assert round_trip(reset) == 0  # the status given back by its checksum
    assert round_trip(edit) == 1  # its data went pending; the true load case is solved again
    assert set(storage.statuses(study.store, study.group_name, None)) == set(ids)


def _cli_code(argv) -> int:
    with pytest.raises(SystemExit) as info:
        main(argv)
        raise SystemExit(0)
    return int(info.value.code or 0)


class _UnhashableStore:
    """Like zarr's FsspecStore (an S3 store): no __hash__."""

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return "s3-store"


@pytest.mark.parametrize("store", ["s.zarr", _UnhashableStore()], ids=["path", "unhashable"])
def test_a_sweep_counts_the_states_its_running_tasks_have_stored(monkeypatch, store):
    """Issue 46: a rolling tree writes each part as it ends and returns after its last;
    the sweep's state counts what the store holds of its running tasks (each group read
    once, ids the report or an earlier sweep already counted left out). An S3 store is
    not hashable (CI's S3 sweep failed on a dict keyed by it)."""
    from types import SimpleNamespace as NS

    import jobs.sweep as sweep

    read = []

    def statuses(store, group, ids):
        read.append((store, group))
        return {i: storage.DONE if i.endswith("d") else storage.PENDING for i in ids}

    monkeypatch.setattr(storage, "statuses", statuses)
    part = NS(store=store, group_name="g")
    tree = NS(experiments=[NS(id=i) for i in ("1d", "2d", "3p", "4d")])
    other = NS(experiments=[NS(id="5d"), NS(id="6p")])
    run = object.__new__(sweep.Sweep)
    run._pending = {"tree": (part, tree), "other": (part, other)}
    run.report, run._before, run._stored = NS(done=["1d"]), {"4d"}, 7
    assert run._in_store() == 2  # 2d and 5d; 1d is in the report, 4d was done before
    assert len(read) == 1 and read[0][0] is store and read[0][1] == "g"

    def gone(*a):
        raise storage.StoreError("not now")

    monkeypatch.setattr(storage, "statuses", gone)
    assert run._in_store() == 7  # unanswered: the last count stands
