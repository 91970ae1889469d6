"""Farm efficiency on the embedded cluster (run: .venv/bin/python benchmarks/bench_sweep.py).

efficiency = sum over load paths of the bare ccx time of its decks
             / (workers x wall time of the whole sweep, cluster start included)

The sweep runs first (2 workers by default, solver decks kept); then every deck it ran is
re-run bare (plain ``ccx``, one at a time, nothing else running) to get the bare times.
Target: >= 0.95 on 2 workers. Prints measured figures only.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

from bare_ccx import bare_seconds

from jobs.study import parse_study
from jobs.sweep import run_sweep

FULL = """
[study]
name = "bench-sweep"
store = "{store}"
[model]
kind = "full"
[loads]
pressure_kpa = [80, 120, 160, 200]
deflection_mm = {{ start = 10, stop = 40, step = 10 }}
"""
QUICK = """
[study]
name = "bench-sweep-quick"
store = "{store}"
[model]
kind = "reduced"
road = "contact"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 8
[loads]
deflection_mm = {{ start = 2, stop = 40, step = 2 }}
[solver]
max_path_length = 1
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="20 small reduced-model paths")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp) / "runs"
        os.environ["FARM_SCRATCH_DIR"] = str(scratch)  # inherited by the worker processes
        study = parse_study((QUICK if args.quick else FULL).format(store=Path(tmp) / "s.zarr"))
        study = dataclasses.replace(study, settings=dataclasses.replace(study.settings,
                                                                        keep_scratch=True))
        start = time.perf_counter()
        report = run_sweep(study, workers=args.workers)
        wall = time.perf_counter() - start
        decks = sorted(scratch.glob("*/*.inp"))
        bare = bare_seconds(decks)
    paths = len({d.parent.name for d in decks if d.name != "inflate.inp"})
    print(f"sweep: {report.total} experiments, {paths} load paths, {len(decks)} ccx runs, "
          f"{args.workers} workers, wall {wall:.1f} s (cluster start included)")
    print(f"bare ccx, one at a time: {bare:.1f} s  ->  efficiency "
          f"{bare / (args.workers * wall):.3f} (target >= 0.95)")


if __name__ == "__main__":
    main()
