"""Cost of a rolling experiment (issue 30) vs a slide on the same mesh, and how far a roll
must go before its forces settle (run: .venv/bin/python benchmarks/bench_rolling.py
[--circumferential N] [--distance MM] [--slip-ratio K] [--radius MM]).

Both cases are one ccx run from rest on the full model with ``table-3.1`` materials at
200 kPa and 15 mm, mu 0.6, the inflation pre-run cached before timing: a slide of 10 mm
along x (a combined-load experiment, :mod:`farm.solve.contact`) and a roll of
``--distance`` mm (:mod:`farm.solve.rolling`) with results at ten fractions. Printed side
by side: wall and CPU seconds of ccx, and their ratio roll / slide; then Fx, Fy, Fz
along the roll and the first travel after which every later Fx stays within 1 % of the
final one (the roll-in distance; "not settled" when only the last one does). Nothing is
asserted (noisy machines).
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.contact import touch_height
from farm.solve.rolling import solve_roll
from farm.specs import LoadPath, MeshDensity, RoadMotion, Roll, SolverSettings

PRESSURE, DEFLECTION, MU = 0.2, 15.0, 0.6


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(solve):
    cpu, wall = _children_cpu(), time.perf_counter()
    out = solve()
    return out, time.perf_counter() - wall, _children_cpu() - cpu


def settled(travel: np.ndarray, fx: np.ndarray, rtol: float = 0.01) -> float | None:
    """The first travel after which every Fx stays within ``rtol`` of the last (None
    when only the last one does)."""
    inside = np.abs(fx - fx[-1]) <= rtol * max(abs(fx[-1]), 1e-9)
    for k in range(len(fx) - 1):
        if inside[k:].all():
            return float(travel[k])
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--circumferential", type=int, default=32)
    parser.add_argument("--distance", type=float, default=150.0)
    parser.add_argument("--slip-ratio", type=float, default=0.005)
    parser.add_argument("--radius", type=float, default=400.57,
                        help="free-rolling radius, mm (measured on 32 elements round)")
    args = parser.parse_args()
    spec = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                  circumferential=args.circumferential))
    mesh = mesh_for(spec)
    settings = SolverSettings()
    touch_height(spec, mesh, PRESSURE, settings)  # cached before timing
    _, slide_wall, slide_cpu = _timed(lambda: run_load_path(
        spec, LoadPath((DEFLECTION,), PRESSURE, RoadMotion(friction=MU, shift_x=10.0)),
        settings))
    fractions = tuple(np.round(np.linspace(0.1, 1.0, 10), 6))
    roll = Roll(friction=MU, slip_ratio=args.slip_ratio, distance=args.distance,
                rolling_radius=args.radius)
    states, roll_wall, roll_cpu = _timed(lambda: solve_roll(
        spec, mesh, DEFLECTION, PRESSURE, roll, settings, fractions))
    print(f"mesh: {mesh.n_nodes} nodes ({args.circumferential} elements round); "
          f"{PRESSURE * 1000:g} kPa, {DEFLECTION:g} mm, mu {MU:g}")
    print(f"{'case':<40} {'wall s':>8} {'cpu s':>8}")
    print(f"{'slide 10 mm along x':<40} {slide_wall:8.1f} {slide_cpu:8.1f}")
    print(f"{f'roll {args.distance:g} mm, kappa {args.slip_ratio:g}':<40} "
          f"{roll_wall:8.1f} {roll_cpu:8.1f}")
    print(f"ratio roll / slide: wall {roll_wall / slide_wall:.2f}x, "
          f"cpu {roll_cpu / slide_cpu:.2f}x")
    travel = np.array([s.travelled for s in states])
    fx = np.array([s.force[0] for s in states])
    for s in states:
        print(f"  {s.travelled:7.1f} mm  Fx {s.force[0]:9.1f}  Fy {s.force[1]:8.1f}  "
              f"Fz {s.force[2]:8.1f} N")
    where = settled(travel, fx)
    print("roll-in (Fx within 1 % of its last value from then on): "
          + (f"{where:g} mm" if where is not None else "not settled within the roll"))


if __name__ == "__main__":
    main()
