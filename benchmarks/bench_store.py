"""Benchmark of the store: ms per experiment write, and read throughput.

Run ``.venv/bin/python benchmarks/bench_store.py`` (``--help`` for sizes). Not a test:
it prints the figures and their ratio to the targets of the store issue,

- write: <= 10 ms per full-model-sized experiment (1,000 inner nodes x 3 displacement
  + 3 + 3 strain components, 400 tread nodes x 3 forces, float64), through
  ``write_experiment`` exactly as a worker calls it (validation, id check, status last);
- read: >= 100 MB/s reading ``displacement`` of 10,000 experiments into one array,
  through ``open_dataset`` (xarray + dask) and through zarr directly.

The 10,000 read experiments are filled by bulk zarr writes, not ``write_experiment``
(that would time the writes again, for minutes); their layout is the same.

``--layouts`` compares, side by side on local disk and on an S3 server (moto's, started
here in its own process: ``pip install -e '.[s3]'``), the present layout (one object
per experiment and worker variable) with a sharded copy of it (zarr v3 sharding codec,
shards of ``--shard`` experiments, inner chunks of one experiment): writes as a worker
makes them, the cost of making the copy, and reads of every displacement. The copy is a
post-processing idea (an export after the sweep), not the live layout: a worker writes
one experiment, which in a shard is a read-modify-write of an object shared with other
workers.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import zarr

import storage
from storage.schema import DONE

WRITE_TARGET_MS = 10.0
READ_TARGET_MBS = 100.0


def _mesh(n_inner: int, n_tread: int) -> storage.MeshNodes:
    rng = np.random.default_rng(0)
    return storage.MeshNodes(
        inner_ids=np.arange(1, n_inner + 1), inner_xyz=rng.normal(size=(n_inner, 3)),
        inner_row=np.arange(n_inner) // 50, inner_col=np.arange(n_inner) % 50,
        tread_ids=np.arange(1, n_tread + 1) + 10**6, tread_xyz=rng.normal(size=(n_tread, 3)),
        tread_row=np.arange(n_tread) // 20, tread_col=np.arange(n_tread) % 20,
    )


def _group(path: Path, n_inner: int, n_tread: int) -> None:
    attrs = storage.GroupAttrs(json.dumps({"kind": "full"}), "bench", "CalculiX 2.20")
    storage.create_group(path, "g", _mesh(n_inner, n_tread), attrs)


def _ids(n: int) -> list[str]:
    return [f"exp-{i:06d}" for i in range(n)]


def bench_write(
    root: Path, n_writes: int, n_inner: int, n_tread: int, path=None
) -> tuple[list[float], float]:
    """Wall seconds of each ``write_experiment`` call (after one warm-up write), and the
    process CPU seconds per write (all threads: zarr's event loop and I/O pool)."""
    path = root / "write.zarr" if path is None else path
    _group(path, n_inner, n_tread)
    ids = _ids(n_writes + 1)
    storage.reserve(path, "g", ids, {"deflection": np.linspace(1, 40, len(ids)), "pressure": 0.2})
    rng = np.random.default_rng(1)
    result = {
        "displacement": rng.normal(size=(n_inner, 3)),
        "strain": rng.normal(size=(n_inner, 3)) * 1e-2,
        "surface_strain": rng.normal(size=(n_inner, 3)) * 1e-2,
        "reaction_force": rng.normal(size=(n_tread, 3)),
        "total_force": rng.normal(size=3),
        "moment": rng.normal(size=3),
    }
    info = {"solve_seconds": 3.2, "increments": 12, "ccx_runs": 1, "contact_nodes": 40}
    storage.write_experiment(path, "g", ids[0], result, info)  # warm-up: opens the arrays
    times = []
    cpu = time.process_time()
    for e in ids[1:]:
        t = time.perf_counter()
        storage.write_experiment(path, "g", e, result, info)
        times.append(time.perf_counter() - t)
    return times, (time.process_time() - cpu) / n_writes


def fill_for_read(root: Path, n_exp: int, n_inner: int, block: int = 1000, path=None):
    """A group of ``n_exp`` done experiments with synthetic displacements (bulk writes)."""
    path = root / "read.zarr" if path is None else path
    _group(path, n_inner, 400)
    ids = _ids(n_exp)
    storage.reserve(path, "g", ids, {"deflection": np.linspace(1, 40, n_exp), "pressure": 0.2})
    g = zarr.open_group(storage.open_store(path), path="g", mode="r+", use_consolidated=False)
    rng = np.random.default_rng(2)
    for start in range(0, n_exp, block):
        stop = min(start + block, n_exp)
        g["displacement"][start:stop] = rng.normal(size=(stop - start, n_inner, 3))
    g["status"][:] = np.full(n_exp, DONE, dtype=np.int8)
    return path


def _timed(f, repeat: int) -> tuple[list[float], object]:
    times, value = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        value = f()
        times.append(time.perf_counter() - t)
    return times, value


def bench_read(path: Path, repeat: int) -> dict[str, list[float]]:
    """Seconds (per repeat) to read all of ``displacement`` into one numpy array, through
    ``open_dataset`` and through zarr, and to read every status (the client's skip)."""
    out = {}
    out["open_dataset (metadata)"], _ = _timed(lambda: storage.open_dataset(path, "g"), repeat)
    out["xarray+dask .values"], a = _timed(
        lambda: storage.open_dataset(path, "g")["displacement"].values, repeat)
    out["zarr [...]"], b = _timed(
        lambda: zarr.open_array(path, path="g/displacement", mode="r")[...], repeat)
    assert a.shape == b.shape and np.array_equal(a, b)
    out["statuses (all)"], s = _timed(lambda: storage.statuses(path, "g"), repeat)
    assert len(s) == a.shape[0] and set(s.values()) == {DONE}
    out["bytes"] = [float(a.nbytes)]
    return out


# ------------------------------------------------- layouts: present vs sharded, local vs S3


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def start_moto() -> tuple[subprocess.Popen, str]:
    """moto's S3 server in its own process (not a thread: it would share our GIL)."""
    port = _free_port()
    proc = subprocess.Popen([sys.executable, "-m", "moto.server", "-H", "127.0.0.1", "-p",
                             str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    endpoint = f"http://127.0.0.1:{port}"
    for _ in range(200):
        try:
            socket.create_connection(("127.0.0.1", port), timeout=0.1).close()
            return proc, endpoint
        except OSError:
            time.sleep(0.05)
    proc.kill()
    raise RuntimeError(f"moto's server did not start on {endpoint}")


def s3_root(endpoint: str) -> tuple[dict, str]:
    import s3fs

    for key in ("AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY"):
        os.environ.setdefault(key, "testing")
    options = {"endpoint_url": endpoint}
    s3fs.S3FileSystem(skip_instance_cache=True, **options).mkdir("bench")
    return options, "s3://bench"


def reshard(source, target, n_exp: int, n_inner: int, shard: int) -> None:
    """Copy ``displacement`` into a sharded array: shards of ``shard`` experiments, inner
    chunks of one (a single experiment still reads alone), one shard written at a time."""
    src = zarr.open_array(source, path="g/displacement", mode="r")
    dst = zarr.create_array(target, name="displacement", shape=src.shape, dtype=src.dtype,
                            chunks=(1, n_inner, 3), shards=(shard, n_inner, 3),
                            compressors=None, dimension_names=("experiment", "inner_node",
                                                               "component"))
    for start in range(0, n_exp, shard):
        stop = min(start + shard, n_exp)
        dst[start:stop] = src[start:stop]


def _objects(store) -> int:
    """Files (local) or objects (S3) of a store: each one a request to read or write."""
    from zarr.storage import FsspecStore

    if isinstance(store, FsspecStore):
        import s3fs

        fs = s3fs.S3FileSystem(skip_instance_cache=True, **store.fs.storage_options
                               | {"asynchronous": False})
        return len(fs.find(store.path))
    return sum(1 for f in Path(store.root).rglob("*") if f.is_file())


def bench_layouts(args, root: Path) -> None:
    proc, endpoint = start_moto()
    try:
        options, bucket = s3_root(endpoint)
        places = {"local": (lambda name: storage.open_store(root / name)),
                  "s3 (moto)": (lambda name: storage.open_store(
                      f"{bucket}/{name}", storage_options=options))}
        rows: dict[str, dict[str, float]] = {}
        n, size = args.experiments, args.experiments * args.inner * 3 * 8 / 1e6
        for place, make in places.items():
            r = rows[place] = {}
            wall, _ = bench_write(root, args.writes, args.inner, args.tread,
                                  path=make("write.zarr"))
            r["write_experiment ms (median)"] = statistics.median(wall) * 1e3
            present = make("read.zarr")
            t = time.perf_counter()
            fill_for_read(root, n, args.inner, path=present)
            r["fill present s (bulk)"] = time.perf_counter() - t
            times, a = _timed(lambda s=present: zarr.open_array(
                s, path="g/displacement", mode="r")[...], args.repeat)
            r["read present s"] = statistics.median(times)
            sharded = make("sharded.zarr")
            t = time.perf_counter()
            reshard(present, sharded, n, args.inner, args.shard)
            r["reshard s"] = time.perf_counter() - t
            times, b = _timed(lambda s=sharded: zarr.open_array(
                s, path="displacement", mode="r")[...], args.repeat)
            r["read sharded s"] = statistics.median(times)
            assert np.array_equal(a, b)
            times, _ = _timed(lambda s=sharded: zarr.open_array(
                s, path="displacement", mode="r")[n // 2], args.repeat)
            r["read 1 exp sharded ms"] = statistics.median(times) * 1e3
            r["objects present"] = _objects(present)
            r["objects sharded"] = _objects(sharded)
        _print_layouts(rows, n, size, args.shard)
    finally:
        proc.kill()
        proc.wait()


def _print_layouts(rows: dict, n: int, size: float, shard: int) -> None:
    names = list(rows)
    print(f"layouts: {n} experiments, displacement {size:.0f} MB; shards of {shard}")
    print(f"  {'':34s}" + "".join(f"{p:>14s}" for p in names) + f"{'s3 / local':>12s}")
    local, s3 = (rows[p] for p in names)
    for key in local:
        print(f"  {key:34s}" + "".join(f"{rows[p][key]:14.2f}" for p in names)
              + f"{s3[key] / local[key]:12.2f}")
    for p in names:
        r = rows[p]
        print(f"  {p}: read sharded / present = {r['read sharded s'] / r['read present s']:.3f}"
              f" ({size / r['read present s']:.0f} -> {size / r['read sharded s']:.0f} MB/s); "
              f"reshard costs {r['reshard s'] / r['fill present s (bulk)']:.2f} x the bulk fill")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--writes", type=int, default=200, help="timed experiment writes")
    p.add_argument("--experiments", type=int, default=10_000, help="experiments to read")
    p.add_argument("--inner", type=int, default=1000, help="inner-surface nodes")
    p.add_argument("--tread", type=int, default=400, help="tread nodes")
    p.add_argument("--repeat", type=int, default=3, help="repeats of each read")
    p.add_argument("--dir", type=Path, default=None, help="where to put the stores (tmp)")
    p.add_argument("--layouts", action="store_true",
                   help="present vs sharded layout, local disk vs S3 (moto), side by side")
    p.add_argument("--shard", type=int, default=64, help="experiments per shard (--layouts)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory(dir=args.dir, prefix="bench_store_") as tmp:
        root = Path(tmp)
        print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} "
              "(wall-clock figures below are only as quiet as the machine)")
        if args.layouts:
            bench_layouts(args, root)
            return
        wall, cpu = bench_write(root, args.writes, args.inner, args.tread)
        times = np.array(wall) * 1e3
        med, p90 = statistics.median(times), np.percentile(times, 90)
        mb = (3 * args.inner * 3 + args.tread * 3 + 6) * 8 / 1e6
        print(f"write: {args.writes} experiments of {args.inner} inner x 3 (+3 +3) and "
              f"{args.tread} tread x 3 float64 ({mb:.3f} MB each)")
        print(f"  median {med:.2f} ms, min {times.min():.2f} ms, p90 {p90:.2f} ms per write "
              f"(CPU {cpu * 1e3:.2f} ms); target <= {WRITE_TARGET_MS:g} ms: median at "
              f"{med / WRITE_TARGET_MS:.2f} x target")
        t = time.perf_counter()
        path = fill_for_read(root, args.experiments, args.inner)
        print(f"read: {args.experiments} experiments filled in {time.perf_counter() - t:.1f} s")
        r = bench_read(path, args.repeat)
        size = r.pop("bytes")[0] / 1e6
        for name, secs in r.items():
            best, med = min(secs), statistics.median(secs)
            line = f"  {name}: median {med:.3f} s, best {best:.3f} s"
            if name.startswith(("xarray", "zarr")):
                line += (f" for {size:.0f} MB = {size / med:.0f} MB/s median, {size / best:.0f} "
                         f"best; target >= {READ_TARGET_MBS:g} MB/s: median at "
                         f"{size / med / READ_TARGET_MBS:.2f} x target")
            print(line)


if __name__ == "__main__":
    main()
