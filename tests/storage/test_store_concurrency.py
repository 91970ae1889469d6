"""Concurrency: many writers and several clients on one store at once, nothing lost.

Workers write into one group while the client keeps reserving (for contrast, measured
on the team's machine: 4 processes appending with xarray's ``append_dim`` kept 134 of
201 experiments and lost 67 without an error; here workers only write whole chunks of
slots the client reserved). Clients race each other: processes released together by a
barrier call ``reserve`` and ``create_group`` at the same moment, trial after trial,
and every id must end up stored once, under its own parameters, at the index its
reserver was given (``docs/store.md``, "Concurrent clients").
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue
import subprocess
import sys
import threading
import time
import traceback
from collections import Counter

import numpy as np
import pytest
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
)

import storage

N_INNER, N_TREAD = 300, 100
WORKERS, PER_WORKER = 4, 100


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_four_processes_write_400_experiments_bit_identical(tmp_path):
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, make_mesh(N_INNER, N_TREAD), make_attrs())
    ids = [f"w{w}-{k:03d}" for w in range(WORKERS) for k in range(PER_WORKER)]
    storage.reserve(path, GROUP, ids, make_params(ids))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(HERE)])}
    procs = [
        subprocess.Popen(
            [sys.executable, str(HERE / "store_writer.py"), str(path), GROUP, str(N_INNER),
             str(N_TREAD), *ids[w * PER_WORKER:(w + 1) * PER_WORKER]],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )
        for w in range(WORKERS)
    ]
    # Meanwhile the client grows the group (resizes every array) five times.
    late = [f"late-{k:02d}" for k in range(50)]
    for batch in np.array_split(np.array(late), 5):
        storage.reserve(path, GROUP, batch.tolist(), make_params(batch.tolist()))
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
    assert storage.status_counts(path, GROUP) == {"pending": 50, "done": 400, "failed": 0}
    ds = storage.open_dataset(path, GROUP).load()
    assert ds["experiment"].values.tolist() == ids + late
    for i, e in enumerate(ids):
        want = make_result(e, N_INNER, N_TREAD)
        for name, value in want.items():
            assert np.array_equal(ds[name].values[i], value), (e, name)
        for name, value in make_info(e).items():
            assert ds[name].values[i] == value, (e, name)
    np.testing.assert_array_equal(ds["deflection"].values, make_params(ids + late)["deflection"])


# ---------------------------------------------------------------- racing clients
#
# A module-wide pool of spawned processes (spawned once: importing the package costs
# more than a trial). Each trial hands every process one job; the processes wait at a
# barrier and then all call the store at once.

RACERS = 4
TRIALS = 10


def _job(kind: str, path: str, group: str, *args):
    if kind == "reserve":
        ids, params = args
        return storage.reserve(path, group, ids, params)
    if kind == "create":
        seed, key, spec = args
        attrs = make_attrs(key)
        if spec is not None:
            attrs = storage.GroupAttrs(spec, key, attrs.solver, attrs.package_versions)
        storage.create_group(path, group, make_mesh(seed=seed), attrs)
        return key
    if kind == "write":
        (ids,) = args
        for e in ids:
            storage.write_experiment(path, group, e, make_result(e, N_SMALL, T_SMALL),
                                     make_info(e))
        return len(ids)
    raise ValueError(kind)


def _serve(rank: int, barrier, tasks, results) -> None:
    """A racing process: for each job, wait for the others, run it, report."""
    while (job := tasks.get()) is not None:
        barrier.wait()
        try:
            results.put((rank, ("ok", _job(*job))))
        except Exception as e:  # reported, and judged by the test
            results.put((rank, ("err", type(e).__name__, str(e),
                                isinstance(e, storage.StoreError),
                                traceback.format_exc(limit=3))))


class Racers:
    def __init__(self, n: int) -> None:
        ctx = mp.get_context("spawn")
        self.barrier = ctx.Barrier(n, timeout=120)
        self.tasks = [ctx.Queue() for _ in range(n)]
        self.results = ctx.Queue()
        self.procs = [ctx.Process(target=_serve, args=(i, self.barrier, q, self.results),
                                  daemon=True) for i, q in enumerate(self.tasks)]
        for p in self.procs:
            p.start()

    def race(self, jobs: list[tuple]) -> list[tuple]:
        """Run one job per process, released together; results in process order."""
        assert len(jobs) == len(self.procs)
        for q, job in zip(self.tasks, jobs, strict=True):
            q.put(job)
        got: dict[int, tuple] = {}
        deadline = time.monotonic() + 180
        while len(got) < len(jobs):
            try:
                rank, result = self.results.get(timeout=1)
                got[rank] = result
            except queue.Empty:
                dead = [p.exitcode for p in self.procs if not p.is_alive()]
                assert not dead and time.monotonic() < deadline, f"racers died: {dead}"
        return [got[i] for i in range(len(jobs))]

    def close(self) -> None:
        for q in self.tasks:
            q.put(None)
        for p in self.procs:
            p.join(timeout=20)
            if p.is_alive():
                p.kill()


@pytest.fixture(scope="module")
def racers():
    pool = Racers(RACERS)
    yield pool
    pool.close()


N_SMALL, T_SMALL = 12, 5  # make_mesh()'s node counts


def _ids(trial: int, rank: int, m: int) -> list[str]:
    # distinct ids per process, and a few that every process reserves (the same load
    # case, as two clients submitting one study would)
    return [f"t{trial}-r{rank}-{k:02d}" for k in range(m)] + [f"t{trial}-shared-{k}"
                                                              for k in range(3)]


def _raw(results: list[tuple]) -> list[str]:
    return [f"{r[1]}: {r[2]}\n{r[4]}" for r in results if r[0] == "err"]


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_racing_reserves_lose_and_mislabel_nothing(racers, tmp_path):
    path = str(tmp_path / "farm.zarr")
    lost = mislabelled = misplaced = duplicated = 0
    errors: list[str] = []
    start = time.perf_counter()
    for trial in range(TRIALS):
        group = f"g{trial}"
        storage.create_group(path, group, make_mesh(), make_attrs())
        jobs = []
        for rank in range(RACERS):
            ids = _ids(trial, rank, 12)
            jobs.append(("reserve", path, group, ids, make_params(ids)))
        results = racers.race(jobs)
        errors += _raw(results)
        g = zarr.open_group(path, path=group, mode="r", use_consolidated=False)
        stored = [str(e) for e in g["experiment"][...]]
        deflection, pressure = g["deflection"][...], g["pressure"][...]
        where = {e: i for i, e in enumerate(stored)}
        duplicated += sum(n - 1 for n in Counter(stored).values())
        for job, result in zip(jobs, results, strict=True):
            ids, params = job[3], job[4]
            for j, e in enumerate(ids):
                if e not in where:
                    lost += 1
                    continue
                i = where[e]
                if (deflection[i] != params["deflection"][j]
                        or pressure[i] != params["pressure"][j]):
                    mislabelled += 1
                if result[0] == "ok" and result[1][e] != i:
                    misplaced += 1
        assert set(storage.statuses(path, group).values()) <= {storage.PENDING}
    counts = dict(lost=lost, mislabelled=mislabelled, misplaced=misplaced,
                  duplicated=duplicated, errors=len(errors))
    print(f"{TRIALS} trials x {RACERS} racing reserves: {counts}, "
          f"{time.perf_counter() - start:.1f} s")
    assert counts == dict(lost=0, mislabelled=0, misplaced=0, duplicated=0, errors=0), \
        (counts, errors[:2])


@pytest.mark.parametrize("differ", ["mesh", "model"])
def test_racing_create_group_one_of_two_wins(racers, tmp_path, differ):
    """Two meshes (or two models of one mesh) race for one group name on a new store."""
    outcomes, errors = Counter(), []
    for trial in range(TRIALS // 2):
        path = str(tmp_path / f"s{trial}.zarr")  # a new store: the root is raced for too
        jobs = []
        for rank in range(RACERS):
            other = rank % 2
            if differ == "mesh":
                jobs.append(("create", path, GROUP, other, f"mesh-{other}", None))
            else:
                jobs.append(("create", path, GROUP, 0, "mesh-0", f'{{"model": {other}}}'))
        results = racers.race(jobs)
        errors += [e for e in _raw(results) if not e.startswith("MeshMismatchError")]
        held = storage.open_dataset(path, GROUP).attrs
        winner = held["mesh_key"] if differ == "mesh" else held["model_spec"]
        for rank, r in enumerate(results):
            mine = f"mesh-{rank % 2}" if differ == "mesh" else f'{{"model": {rank % 2}}}'
            side = "winner" if mine == winner else "loser"
            if r[0] == "ok":
                outcomes[f"{side} ok"] += 1
            else:
                outcomes[f"{side} {'refused' if r[1] == 'MeshMismatchError' else 'raw error'}"] += 1
        assert storage.list_groups(path) == [GROUP]
        assert storage.status_counts(path, GROUP) == {"pending": 0, "done": 0, "failed": 0}
    print(f"racing create_group ({differ}): {dict(outcomes)}, raw errors {len(errors)}")
    n = TRIALS // 2 * RACERS // 2
    assert dict(outcomes) == {"winner ok": n, "loser refused": n}, (outcomes, errors[:2])
    assert not errors, errors[:2]


def test_racing_create_group_with_one_mesh_all_succeed(racers, tmp_path):
    errors = []
    for trial in range(TRIALS // 2):
        path = str(tmp_path / f"s{trial}.zarr")
        results = racers.race([("create", path, GROUP, 0, "mesh-0", None)] * RACERS)
        errors += _raw(results)
        assert storage.list_groups(path) == [GROUP]
    print(f"racing create_group (one mesh): {len(errors)} errors")
    assert not errors, errors[:2]


def test_worker_writes_beside_racing_reserves_lose_nothing(racers, tmp_path):
    path = str(tmp_path / "farm.zarr")
    storage.create_group(path, GROUP, make_mesh(), make_attrs())
    errors, written, reserved = [], [], []
    for trial in range(3):
        early = [f"t{trial}-w{w}-{k:02d}" for w in range(2) for k in range(10)]
        storage.reserve(path, GROUP, early, make_params(early))
        late = [_ids(trial, rank, 12) for rank in (2, 3)]
        results = racers.race([("write", path, GROUP, early[:10]),
                               ("write", path, GROUP, early[10:]),
                               *(("reserve", path, GROUP, ids, make_params(ids)) for ids in late)])
        errors += _raw(results)
        written += early
        reserved += list(dict.fromkeys(e for ids in late for e in ids))  # shared ones once
    assert not errors, errors[:2]
    ds = storage.open_dataset(path, GROUP).load()
    stored = ds["experiment"].values.tolist()
    assert sorted(stored) == sorted(written + reserved)
    status = storage.statuses(path, GROUP)
    assert [e for e in written if status[e] != storage.DONE] == []
    assert [e for e in reserved if status[e] != storage.PENDING] == []
    for e in written:
        i = stored.index(e)
        np.testing.assert_array_equal(ds["displacement"].values[i],
                                      make_result(e, N_SMALL, T_SMALL)["displacement"])
    want = make_params(stored)
    np.testing.assert_array_equal(ds["deflection"].values, want["deflection"])


# ---------------------------------------------------------------- the lock and the claims


def _in_thread(fn):
    out: dict[str, object] = {}

    def run():
        try:
            out["value"] = fn()
        except Exception as e:  # handed to the test
            out["error"] = e

    t = threading.Thread(target=run)
    t.start()
    t.join(timeout=60)
    assert not t.is_alive()
    return out


def test_a_held_lock_makes_another_client_wait_then_say_who_holds_it(tmp_path):
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, make_mesh(), make_attrs())
    zs = storage.open_store(path)
    with storage.client_lock(zs), storage.client_lock(zs):  # re-entrant in one thread
        out = _in_thread(lambda: storage.client_lock(zs, timeout=0.3).__enter__())
        assert isinstance(out["error"], storage.StoreBusyError)
        message = str(out["error"])
        assert "busy" in message and ".farm.lock" in message and f"pid {os.getpid()}" in message
        assert isinstance(out["error"], TimeoutError) and "\n" not in message
    # released: the next client gets it at once
    assert storage.reserve(path, GROUP, ["e1"], make_params(["e1"])) == {"e1": 0}


def test_a_lost_race_without_a_lock_is_detected(tmp_path, monkeypatch):
    """Where no lock excludes a second client (an object store ignoring conditional
    writes), reserve reads back its slots and raises instead of mislabelling silently."""
    reserve_module = sys.modules["storage.reserve"]  # the name is shadowed by the function
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, make_mesh(), make_attrs())
    check = reserve_module._check_written

    def other_client_first(zs, group, slots, ids, values):
        g = zarr.open_group(zs, path=group, mode="r+", use_consolidated=False)
        g["experiment"][slots.start + 1] = "theirs"  # another client took slot 1 meanwhile
        return check(zs, group, slots, ids, values)

    monkeypatch.setattr(reserve_module, "_check_written", other_client_first)
    with pytest.raises(storage.ConcurrentClientError, match=r"slot 1 should hold 'e1'.*'theirs'"):
        storage.reserve(path, GROUP, ["e0", "e1", "e2"], make_params(["e0", "e1", "e2"]))


def test_a_claim_makes_a_second_worker_wait_and_is_removed_after(tmp_path):
    path = tmp_path / "farm.zarr"
    storage.create_group(path, GROUP, make_mesh(), make_attrs())
    file = path / ".claims" / GROUP / "path-1"
    with storage.claim(path, GROUP, "path-1") as held:
        assert held and file.exists()
        stops = iter([False, False, True])
        out = _in_thread(lambda: _enter_claim(path, lambda: next(stops)))
        assert out["value"] is False  # gave up when told to stop, never held it
        other = _in_thread(lambda: _enter_claim(path, None, key="path-2"))
        assert other["value"] is True  # other paths are free
    assert not file.exists()
    assert _in_thread(lambda: _enter_claim(path, None))["value"] is True


def _enter_claim(path, should_stop, key="path-1"):
    with storage.claim(path, GROUP, key, should_stop=should_stop, poll_s=0.05) as held:
        return held


def test_claims_of_stores_without_files_are_free():
    from zarr.storage import MemoryStore

    with storage.claim(MemoryStore(), GROUP, "path-1") as held:
        assert held
    with pytest.raises(storage.SchemaError, match="claim key"), \
            storage.claim(MemoryStore(), GROUP, "../escape"):
        pass


# ---------------------------------------------------------------- object stores


@pytest.fixture
def s3_store(s3_endpoint, tmp_path, monkeypatch):
    """A store object on a fresh bucket; explicit options, so that fsspec's cached
    filesystems (keyed by them) are this server's own."""
    import s3fs

    monkeypatch.setenv("AWS_DEFAULT_REGION", "us-east-1")
    options = {"key": "testing", "secret": "testing",
               "client_kwargs": {"endpoint_url": s3_endpoint}}
    fs = s3fs.S3FileSystem(**options, skip_instance_cache=True)
    bucket = f"race-{os.getpid()}-{tmp_path.name.lower().replace('_', '-')[-30:]}"
    fs.mkdir(bucket)
    url = f"s3://{bucket}/farm.zarr"
    return storage.open_store(url, storage_options=options), fs, url


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_racing_reserves_on_an_object_store_take_turns(s3_store):
    """Two clients (threads: 1-3 s a reserve on moto) released together."""
    store, fs, url = s3_store
    storage.create_group(store, GROUP, make_mesh(), make_attrs())
    barrier, results = threading.Barrier(2, timeout=60), {}

    def client(rank: int, ids: list[str]) -> None:
        barrier.wait()
        try:
            results[rank] = storage.reserve(store, GROUP, ids, make_params(ids))
        except Exception as e:  # judged below
            results[rank] = e

    threads = [threading.Thread(target=client, args=(r, _ids(0, r, 4))) for r in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not [r for r in results.values() if isinstance(r, Exception)], results
    given = {e: i for r in results.values() for e, i in r.items()}
    g = zarr.open_group(store, path=GROUP, mode="r", use_consolidated=False)
    stored = [str(e) for e in g["experiment"][...]]
    assert {e: i for i, e in enumerate(stored)} == given and len(stored) == len(given)
    np.testing.assert_array_equal(g["deflection"][...], make_params(stored)["deflection"])
    assert not fs.exists(url.removeprefix("s3://") + "/.farm.lock")  # released


def test_a_lock_object_left_by_a_killed_client_is_named(s3_store):
    store, fs, url = s3_store
    fs.pipe(url.removeprefix("s3://") + "/.farm.lock", b"pid 1 on elsewhere since 03:00:00")
    busy = r"pid 1 on elsewhere.*delete s3://.*farm\.zarr/\.farm\.lock"
    with pytest.raises(storage.StoreBusyError, match=busy), \
            storage.client_lock(store, timeout=0.5):
        pass
    assert fs.exists(url.removeprefix("s3://") + "/.farm.lock")  # another's: never deleted
