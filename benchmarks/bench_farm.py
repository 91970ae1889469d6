"""Benchmark of the physics layer (run: .venv/bin/python benchmarks/bench_farm.py [--quick]).

1. Package overhead: the same decks run bare (``ccx`` alone, plain subprocess) and
   through the package (mesh + deck + run + parse + measure), side by side, best of
   ``--repeat``; target: overhead <= 3 % of the solve time (full model).
2. Load-path saving: solver seconds of the thesis' 7-point sweep (10-40 mm step 5,
   200 kPa) as ONE load path vs seven separate load paths; target >= 5x.
Prints measured figures only; nothing is asserted (shared, noisy machines).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

from bare_ccx import bare_seconds

from farm.experiment import run_load_path
from farm.mesh import cache as mesh_cache
from farm.presets import default_model
from farm.specs import LoadPath, MeshDensity, SolverSettings

DEFLECTIONS = (10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0)


def package_run(spec, path, scratch: Path) -> tuple[float, list[Path]]:
    """Wall time of the package on a cold mesh cache; returns the decks it ran."""
    mesh_cache._MEMO.clear()
    os.environ["FARM_CACHE_DIR"] = str(scratch / "cache")
    os.environ["FARM_SCRATCH_DIR"] = str(scratch / "runs")
    start = time.perf_counter()
    run_load_path(spec, path, SolverSettings(keep_scratch=True))
    wall = time.perf_counter() - start
    decks = sorted((scratch / "runs").glob("*/*.inp"), key=lambda p: p.stat().st_mtime)
    return wall, decks


def overhead(spec, path, repeat: int) -> None:
    pkg, bare = [], []
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as tmp:
            wall, decks = package_run(spec, path, Path(tmp))
            pkg.append(wall)
            bare.append(bare_seconds(decks))
    p, b = min(pkg), min(bare)
    print(f"overhead  {spec.kind} model, {len(decks)} decks: bare ccx {b:.2f} s, "
          f"package {p:.2f} s  ->  overhead {100 * (p - b) / b:+.1f} % of solve time "
          f"(target <= 3 %)")


def path_saving(spec, pressure: float) -> None:
    one = run_load_path(spec, LoadPath(DEFLECTIONS, pressure)).solve_seconds
    separate = sum(run_load_path(spec, LoadPath((d,), pressure)).solve_seconds
                   for d in DEFLECTIONS)
    print(f"load path {spec.kind} model, {len(DEFLECTIONS)} deflections: one path {one:.1f} s "
          f"of ccx, seven separate paths {separate:.1f} s  ->  saving {separate / one:.1f}x "
          f"(target >= 5x)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="coarse mesh, one repeat")
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    spec = default_model("full")
    if args.quick:
        spec = dataclasses.replace(spec, mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                          circumferential=16))
    overhead(spec, LoadPath(DEFLECTIONS, 0.2), 1 if args.quick else args.repeat)
    path_saving(spec, 0.2)


if __name__ == "__main__":
    main()
