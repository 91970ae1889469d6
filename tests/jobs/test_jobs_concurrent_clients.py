"""Two clients on one study: each experiment is solved once, the store stays consistent.

Where the clients share a scheduler, the tasks' Dask keys are the paths' keys, so the
scheduler runs each path once for both. Where they do not (two embedded clusters on one
store), the worker's claim on the path (``storage.claim``) makes the second one wait and
then skip what the first wrote. Before the claim, two embedded clusters on one existing
group solved every experiment twice (issue 14).
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading

import dask
import pytest
from conftest import ccx_runs

import storage
from farm.ccx.runner import ccx_version
from jobs.storeio import ensure_group
from jobs.study import load_study
from jobs.sweep import run_sweep

pytestmark = pytest.mark.ccx
DEFLECTIONS = "[10, 20]"  # max_path_length = 1: two paths, one ccx run each


def _in_threads(*calls):
    results: list[object] = [None] * len(calls)

    def run(i, call):
        try:
            results[i] = call()
        except BaseException as e:  # handed to the test
            results[i] = e

    threads = [threading.Thread(target=run, args=(i, c)) for i, c in enumerate(calls)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=300)
    return results


def _two_clients(study_file) -> list[str]:
    """Two `farm sweep submit` processes (two embedded clusters) on one study at once;
    both must succeed. Their outputs."""
    clients = [subprocess.Popen([sys.executable, "-m", "farm", "sweep", "submit",
                                 str(study_file), "--workers", "1"], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, env=os.environ.copy())
               for _ in range(2)]
    outputs = [c.communicate(timeout=300)[0] for c in clients]
    assert [c.returncode for c in clients] == [0, 0], outputs
    return outputs


def _consistent(study) -> None:
    ds = storage.open_dataset(study.store, study.group_name).compute(scheduler="sync")
    assert sorted(ds["deflection"].values.tolist()) == [10.0, 20.0]  # each id once
    assert storage.status_counts(study.store, study.group_name) == {
        "pending": 0, "done": 2, "failed": 0}


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_two_clients_on_one_scheduler_solve_each_experiment_once(write_study, counting_ccx):
    from distributed import LocalCluster

    study = load_study(write_study(deflections=DEFLECTIONS))
    # Two Clients in one process each set dask's default scheduler and restore what
    # they saw when they closed; the outer set puts back this process's own.
    with dask.config.set(scheduler=dask.config.get("scheduler", None)), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                         dashboard_address=":0", host="127.0.0.1", silence_logs=40) as cluster:
        address = cluster.scheduler_address
        reports = _in_threads(lambda: run_sweep(study, scheduler=address),
                              lambda: run_sweep(study, scheduler=address))
    for r in reports:
        assert not isinstance(r, BaseException), repr(r)
        assert r.ok and r.total == 2, r.summary()
    assert ccx_runs(counting_ccx) == 2
    _consistent(study)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_two_embedded_clusters_on_one_store_solve_each_experiment_once(write_study,
                                                                        counting_ccx):
    path = write_study(deflections=DEFLECTIONS)
    study = load_study(path)
    ensure_group(study, f"CalculiX {ccx_version()}")  # an existing group, as on a resume
    outputs = _two_clients(path)
    assert ccx_runs(counting_ccx) == 2, outputs
    _consistent(study)
    claims = os.path.join(study.store, ".claims", study.group_name)
    assert os.listdir(claims) == []  # every claim was given back


@pytest.mark.e2e  # two `farm sweep submit` processes, ~40 s: run by .ci/run (--e2e)
def test_two_embedded_clusters_on_one_tree_study_share_its_trunks(tmp_path, counting_ccx):
    """Issue 50: two clients on one tree study each solved both trunks (2 of 6 ccx runs
    repeated). The second waits on the trunk's claim, then reads the saved trunk."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    text = (root / "examples" / "combined_tree_quick.toml").read_text()
    path = tmp_path / "tree.toml"
    path.write_text(text.replace('store = "results/combined_tree_quick.zarr"',
                                 f'store = "{tmp_path / "tree.zarr"}"'))
    study = load_study(path)
    ensure_group(study, f"CalculiX {ccx_version()}")
    outputs = _two_clients(path)
    assert ccx_runs(counting_ccx) == 6, outputs  # 2 trunks and 4 slides, each once
    assert storage.status_counts(study.store, study.group_name) == {
        "pending": 0, "done": 12, "failed": 0}
