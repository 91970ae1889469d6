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
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
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
    root: Path, n_writes: int, n_inner: int, n_tread: int
) -> tuple[list[float], float]:
    """Wall seconds of each ``write_experiment`` call (after one warm-up write), and the
    process CPU seconds per write (all threads: zarr's event loop and I/O pool)."""
    path = root / "write.zarr"
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


def fill_for_read(root: Path, n_exp: int, n_inner: int, block: int = 1000) -> Path:
    """A group of ``n_exp`` done experiments with synthetic displacements (bulk writes)."""
    path = root / "read.zarr"
    _group(path, n_inner, 400)
    ids = _ids(n_exp)
    storage.reserve(path, "g", ids, {"deflection": np.linspace(1, 40, n_exp), "pressure": 0.2})
    g = zarr.open_group(path, path="g", mode="r+", use_consolidated=False)
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


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--writes", type=int, default=200, help="timed experiment writes")
    p.add_argument("--experiments", type=int, default=10_000, help="experiments to read")
    p.add_argument("--inner", type=int, default=1000, help="inner-surface nodes")
    p.add_argument("--tread", type=int, default=400, help="tread nodes")
    p.add_argument("--repeat", type=int, default=3, help="repeats of each read")
    p.add_argument("--dir", type=Path, default=None, help="where to put the stores (tmp)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory(dir=args.dir, prefix="bench_store_") as tmp:
        root = Path(tmp)
        print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} "
              "(wall-clock figures below are only as quiet as the machine)")
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
