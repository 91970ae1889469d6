"""Two single-threaded workers, or one worker whose ccx runs two threads? (issue 29, item 4)

Run ``.venv/bin/python benchmarks/bench_threads.py [--mesh coarse|default|both]``. The
same combined-load design (Latin hypercube slides, one ccx run per experiment) is swept
twice into fresh stores on the embedded cluster: ``--workers 2`` with ``[solver] threads
= 1``, then ``--workers 1`` with ``threads = 2``. The mesh is built before either is timed
(the on-disk mesh cache), so both pay the same. Printed per mesh: wall seconds of each
(cluster start included), their ratio, and the largest relative difference of the total
forces between the two stores (SPOOLES with several threads must give the same answer:
its old versions had a thread-safety bug; the packaged ccx links its own build).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import storage
from farm.mesh import mesh_for
from jobs.study import parse_study
from jobs.sweep import run_sweep

MESHES = {
    "coarse": "tread = 4\nsidewall = 2\nbead = 1\ncircumferential = 16",
    "default": "",  # the full model's default mesh
}
STUDY = """
[study]
name = "bench-threads"
store = "{store}"
[model]
kind = "full"
materials = "table-3.1"
[model.mesh]
{mesh}
[loads]
pressure_kpa = [200]
[loads.sample]
method = "lhs"
n = {n}
seed = 0
deflection_mm = [10, 20]
shift_y_mm = [-2, 2]
friction = [0.3, 0.6]
[solver]
threads = {threads}
"""


def _sweep(mesh: str, n: int, workers: int, threads: int, folder: Path):
    store = folder / f"w{workers}t{threads}.zarr"
    study = parse_study(STUDY.format(store=store, mesh=MESHES[mesh], n=n, threads=threads))
    mesh_for(study.model)  # cached on disk for the workers: meshing is not timed
    start = time.perf_counter()
    report = run_sweep(study, workers=workers)
    wall = time.perf_counter() - start
    if not report.done:
        return wall, report, np.empty(0)
    ds = storage.done(storage.open_dataset(store, storage.list_groups(store)[0]))
    return wall, report, ds["total_force"].sortby("deflection").values


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mesh", choices=[*MESHES, "both"], default="both")
    parser.add_argument("-n", type=int, default=6, help="experiments per sweep")
    args = parser.parse_args()
    for mesh in MESHES if args.mesh == "both" else [args.mesh]:
        with tempfile.TemporaryDirectory() as tmp:
            a = _sweep(mesh, args.n, 2, 1, Path(tmp))
            b = _sweep(mesh, args.n, 1, 2, Path(tmp))
        diff = (np.abs(a[2] - b[2]).max() / np.abs(a[2]).max()
                if a[2].shape == b[2].shape and a[2].size else float("nan"))
        print(f"{mesh} mesh, {args.n} combined experiments:")
        for name, (wall, report, _f) in (("2 workers x 1 thread ", a),
                                         ("1 worker  x 2 threads", b)):
            print(f"  {name}: {wall:7.1f} s wall, {len(report.done)} done, "
                  f"{len(report.failed)} failed, {report.ccx_runs} ccx runs")
        print(f"  ratio (1 worker x 2 threads) / (2 workers x 1 thread): {b[0] / a[0]:.2f} "
              f"(above 1: two workers win); largest relative force difference {diff:.1e}")


if __name__ == "__main__":
    main()
