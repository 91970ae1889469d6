"""Rolling experiments per hour when a roll keeps its states (issue 45: a roll is a load
path), side by side in one run.

    .venv/bin/python benchmarks/bench_roll_states.py [--mesh PRESET | --circumferential N
        --wall T,S,B --window DEG,N] [--distance MM] [--states N] [--repeat R]
        [--materials NAME] [--alpha DEG] [--radius MM]

The same roll (full model, 200 kPa, 15 mm, mu 0.6, ``--alpha`` degrees of slip angle, a
prescribed rolling radius), solved R times each way, alternating: keeping its end alone (today's
rolling experiment: one experiment per ccx run) and keeping ``--states`` states evenly
spaced along it (one experiment per state, one ccx run). The inflation is cached before
timing. Printed: ccx wall seconds of each run, experiments per hour of ccx each way and
their ratio (the issue's goal: at least 20x), and whether the end state is the same
answer both ways (forces within 0.5 % of |F|, the camera's displacement field within 1 %
of its RMS: the issue's rule for a speed-up). Nothing is asserted (noisy machines).
"""

from __future__ import annotations

import argparse
import statistics
import time

from answer_rule import differences, verdict

from farm.experiment import PathResult, run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.contact import touch_height
from farm.specs import LoadPath, MeshDensity, RoadMotion, SolverSettings

PRESSURE, DEFLECTION, MU = 0.2, 15.0, 0.6


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mesh", default="", help="a mesh preset (e.g. patch) instead of the "
                   "counts below")
    p.add_argument("--circumferential", type=int, default=16)
    p.add_argument("--wall", default="4,2,1", help="elements: tread, sidewall, bead")
    p.add_argument("--window", default="", help="DEG,N: a refined window (patch: 32,16)")
    p.add_argument("--distance", type=float, default=160.0, help="road travel, mm")
    p.add_argument("--radius", type=float, default=403.8, help="rolling radius, mm")
    p.add_argument("--states", type=int, default=20)
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--materials", default="table-3.1")
    p.add_argument("--alpha", type=float, default=2.0, help="slip angle, degrees")
    return p.parse_args()


def _model(a: argparse.Namespace):
    if a.mesh:
        return default_model("full", mesh=a.mesh, materials=a.materials)
    tread, sidewall, bead = (int(v) for v in a.wall.split(","))
    window = {}
    if a.window:
        deg, n = a.window.split(",")
        window = {"window": float(deg), "window_elements": int(n)}
    mesh = MeshDensity(tread=tread, sidewall=sidewall, bead=bead,
                       circumferential=a.circumferential, **window)
    return default_model("full", mesh=mesh, materials=a.materials)


def main() -> None:
    a = _args()
    spec = _model(a)
    touch_height(spec, mesh_for(spec), PRESSURE, SolverSettings())  # cached, not timed
    motion = RoadMotion(friction=MU, roll=a.distance, slip_angle=a.alpha,
                        rolling_radius=a.radius)
    fractions = tuple(k / a.states for k in range(1, a.states + 1))
    ways = {"end alone": LoadPath((DEFLECTION,), PRESSURE, motion),
            f"{a.states} states": LoadPath((DEFLECTION,), PRESSURE, motion, fractions)}
    seconds: dict[str, list[float]] = {k: [] for k in ways}
    last: dict[str, PathResult] = {}
    print(f"{spec.mesh}, {a.materials}, {a.distance:g} mm roll at {a.alpha:g} deg, "
          f"r = {a.radius:g} mm; {a.repeat} runs each way, alternating")
    for r in range(a.repeat):
        for name, path in ways.items():
            start = time.perf_counter()
            last[name] = run_load_path(spec, path)
            wall = time.perf_counter() - start
            seconds[name].append(last[name].solve_seconds)
            print(f"  run {r + 1} {name:>12}: {last[name].solve_seconds:7.1f} s of ccx "
                  f"({wall:.1f} s wall), {len(last[name].measurements)} experiments")
    rate = {k: 3600.0 * len(last[k].measurements) / statistics.median(v)
            for k, v in seconds.items()}
    one, many = ways
    print(f"experiments per hour of ccx (median run): {one} {rate[one]:.0f}, "
          f"{many} {rate[many]:.0f}; ratio {rate[many] / rate[one]:.1f}x")
    alone, end = last[one].measurements[-1], last[many].measurements[-1]
    force, field = differences(alone.road_reaction, end.road_reaction, alone.displacement,
                               end.displacement)
    print(f"end state, {many} against {one}: forces {force:.3f} % of |F|, camera "
          f"field {field:.3f} % of its RMS: {verdict(force, field)} (rule: 0.5 %, 1 %)")


if __name__ == "__main__":
    main()
