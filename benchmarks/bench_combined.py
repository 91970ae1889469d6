"""Cost of combined loads (issue 13): ccx seconds of a combined-load experiment vs a
vertical-only one on the same mesh (run: .venv/bin/python benchmarks/bench_combined.py
[--quick] [--repeat N] [--deflection MM] [--only TEXT]), and experiments per hour of a
sweep (``--sweep N [--workers 2] [--quick]``).

Each case is one load path at one deflection (200 kPa), solved in one ccx run; the
inflation pre-run is cached before timing, so only the path run is counted. Printed side
by side: wall seconds of ccx (the farm's ``solve_seconds``), CPU seconds of the ccx
child processes (steadier on a shared machine), increments, and the ratio to the
vertical-only experiment. Best of ``--repeat``. Nothing is asserted (noisy machines).

``--sweep N``: two sweeps of ``--workers`` workers, one after the other, each on its own
embedded cluster and into a fresh store: N combined-load experiments by LHS over the
ranges of ``examples/combined_coarse.toml`` (deflection, pressure, slides, tilt, mu) and
N vertical ones by LHS over its deflection and pressure only, one experiment a path.
Printed: experiments done and failed, ccx runs, wall seconds (the sweep report's) and
experiments per hour (done / wall), and the ratio vertical / combined.
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import tempfile
from pathlib import Path

from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.contact import touch_height
from farm.specs import LoadPath, MeshDensity, RoadMotion, SolverSettings
from jobs.study import parse_study
from jobs.sweep import run_sweep

PRESSURE = 0.2
CASES = {
    "vertical (frictionless)": None,
    "vertical, mu 0.8": RoadMotion(friction=0.8),
    "lateral 10 mm, mu 0.8": RoadMotion(friction=0.8, shift_y=10.0),
    "longitudinal 10 mm, mu 0.8": RoadMotion(friction=0.8, shift_x=10.0),
    "tilt 3 deg, mu 0.8": RoadMotion(friction=0.8, tilt=3.0),
    "x 5 + y 5 mm + tilt 2 deg, mu 0.8": RoadMotion(friction=0.8, shift_x=5.0, shift_y=5.0,
                                                    tilt=2.0),
}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def measure(spec, deflection: float, motion: RoadMotion | None,
            repeat: int) -> tuple[float, float, int]:
    """Best wall and CPU seconds of the path's ccx run, and its increments."""
    best = (float("inf"), float("inf"), 0)
    for _ in range(repeat):
        cpu = _children_cpu()
        result = run_load_path(spec, LoadPath((deflection,), PRESSURE, motion), SolverSettings())
        cpu = _children_cpu() - cpu
        assert result.ccx_runs == 1  # the inflation came from the cache
        best = min(best, (result.solve_seconds, cpu, result.increments))
    return best


SWEEP = """
[study]
name = "bench-combined-{kind}"
store = "{store}"
[model]
kind = "full"
materials = "table-3.1"
{mesh}
[loads.sample]
method = "lhs"
n = {n}
seed = 0
deflection_mm = [10, 30]
pressure_kpa = [80, 200]
{motion}
[solver]
max_path_length = 1
"""
MOTION = ("shift_x_mm = [-6, 6]\nshift_y_mm = [-6, 6]\ntilt_deg = [-4, 4]\n"
          "friction = [0.3, 1.0]")
COARSE = "[model.mesh]\ntread = 4\nsidewall = 2\nbead = 1\ncircumferential = 16"


def sweep_rates(n: int, workers: int, quick: bool) -> None:
    """Experiments per hour of a combined-load sweep and a vertical one (see the docstring)."""
    rates = {}
    with tempfile.TemporaryDirectory() as tmp:
        for kind, motion in (("vertical", ""), ("combined", MOTION)):
            study = parse_study(SWEEP.format(kind=kind, store=Path(tmp) / f"{kind}.zarr",
                                             mesh=COARSE if quick else "", n=n,
                                             motion=motion))
            report = run_sweep(study, workers=workers)
            wall = report.wall_seconds
            rates[kind] = 3600 * len(report.done) / wall
            print(f"{kind:9s} {len(report.done):4d} done {len(report.failed):4d} failed "
                  f"{report.ccx_runs:5d} ccx runs {wall:8.1f} s wall "
                  f"{rates[kind]:8.1f} experiments/hour", flush=True)
    print(f"{workers} workers, {'coarse' if quick else 'default'} full mesh: vertical / "
          f"combined experiments per hour = {rates['vertical'] / rates['combined']:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="the coarse full mesh (jobs/reproduce COARSE_MESH)")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--deflection", type=float, default=30.0)
    parser.add_argument("--only", default="", help="cases whose name contains this text "
                        "(the vertical frictionless baseline always runs)")
    parser.add_argument("--sweep", type=int, default=0, metavar="N",
                        help="experiments per hour of an N-experiment sweep instead")
    parser.add_argument("--workers", type=int, default=2, help="--sweep: worker processes")
    args = parser.parse_args()
    if args.sweep:
        sweep_rates(args.sweep, args.workers, args.quick)
        return
    spec = default_model("full")
    if args.quick:
        spec = dataclasses.replace(spec, mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                          circumferential=16))
    mesh = mesh_for(spec)
    touch_height(spec, mesh, PRESSURE, SolverSettings())  # cache the inflation pre-run
    print(f"full model, mesh {spec.mesh.meridional} x {spec.mesh.circumferential} "
          f"({mesh.n_elements} hexahedra), {args.deflection:g} mm, {PRESSURE * 1000:g} kPa, "
          f"best of {args.repeat}")
    print(f"{'case':36s} {'ccx wall s':>10s} {'ccx CPU s':>10s} {'incr':>5s} "
          f"{'wall ratio':>10s} {'CPU ratio':>10s}")
    base = None
    for name, motion in CASES.items():
        if base is not None and args.only not in name:
            continue
        wall, cpu, inc = measure(spec, args.deflection, motion, args.repeat)
        base = base or (wall, cpu)
        print(f"{name:36s} {wall:10.2f} {cpu:10.2f} {inc:5d} {wall / base[0]:10.2f} "
              f"{cpu / base[1]:10.2f}")


if __name__ == "__main__":
    main()
