"""The farm on a real Dask topology: `dask scheduler` + `dask worker` processes on 127.0.0.1.

The same topology as docker-compose.yml, without containers: a study submitted with
``--scheduler``, and a chaos run where a worker is SIGKILLed three times mid-sweep.
"""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from conftest import ccx_processes

import storage
from jobs.study import load_study
from jobs.sweep import run_sweep
from tyre_farm_cli import main

pytestmark = [pytest.mark.ccx, pytest.mark.e2e]  # real scheduler and worker processes
DASK = str(Path(sys.executable).with_name("dask"))


class Topology:
    """A scheduler and named worker processes; workers can be killed and restarted."""

    def __init__(self, folder: Path) -> None:
        self.folder, self.workers = folder, {}
        self.file = folder / "scheduler.json"
        self.scheduler = self._spawn("scheduler", [DASK, "scheduler", "--host", "127.0.0.1",
                                                   "--port", "0", "--dashboard-address", ":0",
                                                   "--scheduler-file", str(self.file)])
        deadline = time.monotonic() + 60
        while not self.file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        self.address = json.loads(self.file.read_text())["address"]

    def _spawn(self, name: str, argv: list[str]) -> subprocess.Popen:
        log = open(self.folder / f"{name}.log", "ab")  # noqa: SIM115 (closed with the process)
        return subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=os.environ.copy())

    def start_worker(self, name: str) -> None:
        self.workers[name] = self._spawn(name, [
            DASK, "worker", self.address, "--nthreads", "1", "--no-nanny",
            "--no-dashboard", "--name", name, "--death-timeout", "60"])

    def kill_worker(self, name: str) -> None:
        proc = self.workers[name]
        proc.send_signal(signal.SIGKILL)
        proc.wait()

    def close(self) -> None:
        for proc in [*self.workers.values(), self.scheduler]:
            if proc.poll() is None:
                proc.terminate()
        for proc in [*self.workers.values(), self.scheduler]:
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()


@pytest.fixture
def topology(tmp_path):
    topo = Topology(tmp_path)
    for name in ("w1", "w2"):
        topo.start_worker(name)
    yield topo
    topo.close()


def test_submit_to_an_external_scheduler(topology, write_study, capsys):
    path = write_study()
    with pytest.raises(SystemExit) as info:
        main(["sweep", "submit", str(path), "--scheduler", topology.address, "--workers", "2"])
        raise SystemExit(0)
    assert info.value.code == 0, capsys.readouterr()
    study = load_study(path)
    assert storage.status_counts(study.store, study.group_name) == {
        "pending": 0, "done": 6, "failed": 0}


def test_three_worker_kills_lose_nothing(topology, write_study):
    study = load_study(write_study(deflections="{ start = 2, stop = 40, step = 2 }"))
    kills: list[float] = []

    def chaos():
        for _ in range(3):
            # wait until a solve is under way, then kill the worker running it
            deadline = time.monotonic() + 120
            while not ccx_processes() and time.monotonic() < deadline:
                time.sleep(0.1)
            time.sleep(0.3)
            victim = "w1" if len(kills) % 2 == 0 else "w2"
            topology.kill_worker(victim)
            kills.append(time.monotonic())
            time.sleep(1.0)
            topology.start_worker(victim)

    thread = threading.Thread(target=chaos, daemon=True)
    thread.start()
    report = run_sweep(study, scheduler=topology.address, workers=2)
    thread.join(timeout=300)
    assert len(kills) == 3
    assert report.ok and len(report.done) + report.skipped == 20
    ds = storage.open_dataset(study.store, study.group_name)
    assert ds.sizes["experiment"] == 20 and len(set(ds["experiment"].values)) == 20
    assert (ds["status"].values == storage.DONE).all()
    deadline = time.monotonic() + 30
    while ccx_processes() and time.monotonic() < deadline:
        time.sleep(0.5)
    assert ccx_processes() == []
