"""Tasks outlive their workers whatever the scheduler's ``allowed-failures``.

A scheduler gives a task up (``KilledWorker``) once more than ``allowed-failures`` workers
died running it; ``dask scheduler`` allows 3. The farm resubmits such a task under a new
key (:class:`jobs.cluster.Attempts`). Here the schedulers allow 0 or 1 and workers are
SIGKILLed - by the task itself, or while it runs ccx - and the work still completes.
"""

import contextlib
import os
import signal
import threading
import time
from pathlib import Path

import dask
import numpy as np
import psutil
import pytest

import storage
from jobs.cluster import EMBEDDED_CONFIG, Attempts, ResubmittingClient
from jobs.guard import Solved
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluation, Evaluator
from jobs.study import load_study
from jobs.sweep import run_sweep


@contextlib.contextmanager
def _cluster(allowed_failures: int):
    """The embedded cluster's settings but ``allowed_failures``, and one single-threaded
    worker process under a nanny (which restarts it when it is killed)."""
    from distributed import LocalCluster

    config = {**EMBEDDED_CONFIG, "distributed.scheduler.allowed-failures": allowed_failures}
    with dask.config.set(config), LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
            host="127.0.0.1", silence_logs=40) as cluster:
        yield cluster


@pytest.fixture(scope="module")
def strict():
    """A scheduler that gives a task up at the first lost worker."""
    from distributed import Client

    with _cluster(0) as cluster, Client(cluster) as client:
        yield client


def _dies_first(folder: str, deaths: int) -> int:
    """Kill this worker on the first ``deaths`` calls (counted in ``folder``); return the
    number of earlier calls."""
    calls = len(os.listdir(folder))
    Path(folder, f"call-{calls}").touch()
    if calls < deaths:
        os.kill(os.getpid(), signal.SIGKILL)
    return calls


def _dies_once(folder: str) -> Solved:
    """A loop evaluation whose first worker dies; ``ccx_runs`` says which call it was."""
    return Solved((), 0.0, ccx_runs=_dies_first(folder, 1))


def _raises(_: int) -> int:
    raise ValueError("a bug, not a lost worker")


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_task_is_resubmitted_until_it_outlives_its_workers(strict, tmp_path):
    task = Attempts(strict, _dies_first, (str(tmp_path), 2), key="dies-twice", limit=3)
    assert task.result(timeout=120) == 2
    assert task.attempt == 2 and task.key == "dies-twice-retry2"
    task.release()  # else a later test's lost worker has the scheduler compute it again


def test_resubmissions_are_bounded(strict, tmp_path):
    from distributed import KilledWorker

    task = Attempts(strict, _dies_first, (str(tmp_path), 1), key="dies-once", limit=0)
    with pytest.raises(KilledWorker):
        task.result(timeout=120)
    assert task.attempt == 0 and len(os.listdir(tmp_path)) == 1


def test_other_errors_are_not_resubmitted(strict):
    task = Attempts(strict, _raises, (1,), key="raises")
    with pytest.raises(ValueError, match="a bug"):
        task.result(timeout=60)
    assert task.attempt == 0 and not task.resubmit()


class _Lost:
    """A future whose worker was lost (the scheduler gave it up)."""

    status = "error"

    def __init__(self, key: str) -> None:
        self.key, self.cancelled = key, False

    def exception(self):
        from distributed import KilledWorker

        return KilledWorker(self.key, None, 0)

    def release(self) -> None: ...

    def cancel(self) -> None:
        self.cancelled = True


class _LosingClient:
    """Every task submitted loses its worker."""

    def __init__(self) -> None:
        self.keys: list[str] = []
        self.cancelled: list = []

    def submit(self, function, *args, key: str, pure: bool, **kwargs) -> _Lost:
        self.keys.append(key)
        return _Lost(key)

    def cancel(self, futures) -> None:
        self.cancelled += futures


def test_attempts_take_new_keys_up_to_the_limit():
    client = _LosingClient()
    task = Attempts(client, print, (), key="k", limit=2)
    first = task.future
    assert task.resubmit() and task.resubmit() and not task.resubmit()
    assert client.keys == ["k", "k-retry1", "k-retry2"]
    assert task.resubmit(first)  # another waiter saw the first attempt fail: it goes on


def test_a_cancelled_task_is_not_resubmitted():
    client = ResubmittingClient(_LosingClient())
    task = client.submit(print, key="k")
    client.cancel([task])
    assert client.client.cancelled == [task.future]
    assert not task.resubmit() and client.client.keys == ["k"]


def test_loop_evaluations_outlive_their_workers(strict, tmp_path):
    # what LoopThreads gives the loops: one lost worker is not a failed evaluation
    folder = tmp_path / "calls"
    folder.mkdir()
    ev = Evaluator(ResubmittingClient(strict), EvaluationCache(None))
    [result] = ev.run([Evaluation("d" * 64, _dies_once, str(folder), "test")])
    assert isinstance(result, Solved) and result.ccx_runs == 1  # the second call's


def _our_solves() -> list[psutil.Process]:
    """Running ccx solves (not `ccx -v`) of this process's workers: other processes on
    this machine run ccx too. (Not conftest's: the workers import this module, and
    `conftest` may name another module there.)"""
    found = []
    for p in psutil.process_iter(["name", "cmdline"]):
        try:
            if (p.info["name"] == "ccx" and "-i" in (p.info["cmdline"] or ())
                    and os.getpid() in {q.pid for q in p.parents()}):
                found.append(p)
        except psutil.Error:
            continue
    return found


def _kill_workers_running_ccx(kills: int, done: list[int], jobs: tuple[str, ...] = ()) -> None:
    """SIGKILL the worker running a ccx solve of ours, ``kills`` times; with ``jobs``,
    the k-th kill waits for a solve of job name ``jobs[k]`` (``ccx -i <job>``)."""
    deadline = time.monotonic() + 240
    while len(done) < kills and time.monotonic() < deadline:
        for ccx in _our_solves():
            if jobs and jobs[len(done)] not in ccx.info["cmdline"]:
                continue
            try:
                worker = ccx.parent()
                if worker is None:
                    continue
                worker.send_signal(signal.SIGKILL)
                done.append(worker.pid)
                psutil.wait_procs([worker, ccx], timeout=30)
            except psutil.NoSuchProcess:
                continue
            break
        time.sleep(0.05)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_sweep_outlives_a_scheduler_that_allows_one_failure(write_study):
    """Two kills of the worker running the sweep's only task: the scheduler re-runs it
    once, then gives it up; the farm resubmits it, and every experiment ends done."""
    study = load_study(write_study(solver="max_path_length = 0"))  # one task, one ccx run
    kills: list[int] = []
    with _cluster(1) as cluster:
        chaos = threading.Thread(target=_kill_workers_running_ccx, args=(2, kills),
                                 daemon=True)
        chaos.start()
        report = run_sweep(study, scheduler=cluster.scheduler_address)
        chaos.join(timeout=10)
    assert len(kills) == 2
    assert not report.failed, set(report.failed.values())
    assert report.ok and len(report.done) == 6 and report.resubmitted == 1
    assert storage.status_counts(study.store, study.group_name) == {
        "pending": 0, "done": 6, "failed": 0}


#: The quick tree studies (coarse model): file, edits, experiments. The rolling one is
#: cut to one trunk and three branches (slip angle 3 degrees alone).
TREE_STUDIES = {
    "static": ("combined_tree_quick.toml", {}, 12),
    "rolling": ("rolling_tree_quick.toml",
                {"slip_angle_deg = [-3, 0, 3]": "slip_angle_deg = [3]"}, 13),
}


def _tree_example(store: Path, kind: str):
    """The quick tree study ``kind`` of :data:`TREE_STUDIES` into ``store``."""
    name, edits, _ = TREE_STUDIES[kind]
    text = (Path(__file__).parents[2] / "examples" / name).read_text()
    for old, new in {f'store = "results/{Path(name).stem}.zarr"': f'store = "{store}"',
                     **edits}.items():
        assert old in text, old
        text = text.replace(old, new)
    path = store.with_suffix(".toml")
    path.write_text(text)
    return load_study(path)


@pytest.mark.e2e  # chaos: ~1-2 min of nanny restarts each, kept out of the default run
@pytest.mark.ccx
@pytest.mark.parametrize("kind", sorted(TREE_STUDIES))
def test_a_tree_sweep_outlives_workers_lost_in_a_trunk_and_in_a_branch(tmp_path, kind):
    """Tree tasks are plain futures (no new keys, jobs/sweep.py): the worker running a
    trunk's ccx is killed, then the one running a branch's (a slide, or a roll on from a
    rolling trunk). The nanny brings a worker back, Dask runs what was lost again (the
    trunk's task too, where a branch still needs it: it reads the trunk from the store,
    storage/saved.py - issue 50 for the static trees, issue 45 for the rolling ones),
    and every experiment ends done with the results of an undisturbed sweep."""
    total = TREE_STUDIES[kind][2]
    kills: list[int] = []
    with _cluster(3) as cluster:  # Dask's default allowed-failures
        chaos = threading.Thread(target=_kill_workers_running_ccx,
                                 args=(2, kills, ("trunk", "branch")), daemon=True)
        chaos.start()
        report = run_sweep(_tree_example(tmp_path / "chaos.zarr", kind),
                           scheduler=cluster.scheduler_address)
        chaos.join(timeout=10)
    assert len(kills) == 2
    assert report.ok and len(report.done) == total and not report.failed
    calm = run_sweep(_tree_example(tmp_path / "calm.zarr", kind), workers=1)
    assert calm.ok and len(calm.done) == total
    a, b = (_road_reactions(tmp_path / f"{n}.zarr") for n in ("chaos", "calm"))
    assert a.keys() == b.keys() and len(a) == total
    for k in a:  # the same decks: the same numbers
        assert abs(a[k] - b[k]).max() <= 1e-6 * abs(b[k]).max(), k


def _road_reactions(store: Path) -> dict[str, np.ndarray]:
    (group,) = storage.list_groups(str(store))
    ds = storage.done(storage.open_dataset(str(store), group))
    return dict(zip((str(i) for i in ds["experiment"].values), np.asarray(ds["road_reaction"]),
                    strict=True))
