"""A writer killed mid-write leaves its experiment pending; everything else stays whole."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr
import zarr
from store_helpers import (
    GROUP,
    HERE,
    ROOT,
    make_attrs,
    make_info,
    make_mesh,
    make_params,
    make_result,
    run_python,
)

import storage
from storage.schema import RESULT_NAMES

N_INNER, N_TREAD = 2000, 400  # large chunks: a random kill often lands inside a write
IDS = [f"e{i}" for i in range(6)]


@pytest.fixture
def path(tmp_path):
    p = tmp_path / "farm.zarr"
    storage.create_group(p, GROUP, make_mesh(N_INNER, N_TREAD), make_attrs())
    storage.reserve(p, GROUP, IDS, make_params(IDS))
    return p


def _writer(path, ids, *extra):
    return [str(HERE / "store_writer.py"), str(path), GROUP, str(N_INNER), str(N_TREAD),
            *ids, *extra]


def _check_whole(path) -> dict[str, int]:
    """Every chunk decodes; every done experiment is exactly what was written."""
    for name in (*RESULT_NAMES, "status", "error", "increments"):
        zarr.open_array(path, path=f"{GROUP}/{name}", mode="r")[...]  # raises on a torn chunk
    ds = xr.open_zarr(path, group=GROUP).load()
    status = storage.statuses(path, GROUP)
    assert set(status.values()) <= {storage.PENDING, storage.DONE}
    for i, e in enumerate(IDS):
        if status[e] == storage.DONE:
            want = make_result(e, N_INNER, N_TREAD)
            for name in RESULT_NAMES:
                assert np.array_equal(ds[name].values[i], want[name]), (e, name)
    return status


def test_killed_before_its_status_the_experiment_stays_pending(path):
    run_python(*_writer(path, ["e0"]))
    proc = run_python(*_writer(path, ["e1", "e2"], "--kill-before-status", "e2"), check=False)
    assert proc.returncode == -signal.SIGKILL
    # Every data chunk of e2 is on disk, but it is not done:
    chunk = path / GROUP / "displacement" / "c" / "2" / "0" / "0"
    assert chunk.is_file()
    assert _check_whole(path) == {"e0": 1, "e1": 1, "e2": 0, "e3": 0, "e4": 0, "e5": 0}
    assert storage.done(storage.open_dataset(path, GROUP))["experiment"].values.tolist() == [
        "e0", "e1"]
    # The retry completes it.
    run_python(*_writer(path, ["e2"]))
    assert _check_whole(path)["e2"] == storage.DONE


def test_killed_while_rewriting_a_done_experiment_it_is_no_longer_done(path):
    # A re-run with other values (e.g. another solver build) dies before its status:
    # the slot now holds the new values, so it must not still claim the old "done".
    run_python(*_writer(path, ["e1"]))
    extra = ("--variant", "rerun", "--kill-before-status", "e1")
    proc = run_python(*_writer(path, ["e1"], *extra), check=False)
    assert proc.returncode == -signal.SIGKILL
    assert storage.statuses(path, GROUP, ["e1"]) == {"e1": storage.PENDING}


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_killed_at_a_random_moment_nothing_is_half_done(path, tmp_path, seed):
    rng = random.Random(seed)
    ready = tmp_path / f"ready-{seed}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(HERE)])}
    proc = subprocess.Popen([sys.executable, *_writer(path, IDS, "--loop", "--ready", str(ready))],
                            env=env, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not ready.exists():
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline
        time.sleep(0.01)
    time.sleep(rng.uniform(0.0, 0.3))
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    proc.stderr.close()
    _check_whole(path)
    # Leftovers of the killed write never confuse readers or the next writer.
    run_python(*_writer(path, IDS))
    assert set(_check_whole(path).values()) == {storage.DONE}
    ds = storage.open_dataset(path, GROUP)
    assert [ds[n].values[-1] for n in ("increments", "ccx_runs")] == [
        make_info(IDS[-1])["increments"], make_info(IDS[-1])["ccx_runs"]]
