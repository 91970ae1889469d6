"""What a converged mesh costs beside ``patch`` (issue 44: at most 2x its ccx time).

Run ``.venv/bin/python benchmarks/bench_mesh_cost.py [--meshes patch,wall] [--materials
reinforced-calibrated] [--repeats 1]``. Each mesh preset solves the same vertical load
path (80 and 200 kPa, 5-40 mm in 5 mm steps: what ``farm compare`` and a study's
vertical experiments solve), one path at a time on one core, alternating the meshes so
that a change of machine load falls on both; the mesh is built before the clock starts
(the on-disk mesh cache). Printed per mesh and pressure: ccx seconds (the median over
``--repeats``), Fz at 25 and 30 mm, and the ratio of each mesh's ccx seconds to the
first mesh's.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.specs import LoadPath

DEFLECTIONS = tuple(float(d) for d in range(5, 45, 5))
PRESSURES_KPA = (80.0, 200.0)


def _solve(mesh: str, materials: str, pressure_kpa: float) -> tuple[float, dict[float, float]]:
    model = default_model("full", materials, mesh=mesh)
    result = run_load_path(model, LoadPath(DEFLECTIONS, pressure_kpa / 1000.0))
    fz = {m.deflection: float(m.total_force[2]) for m in result.measurements}
    return result.solve_seconds, fz


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", default="patch,wall")
    parser.add_argument("--materials", default="reinforced-calibrated")
    parser.add_argument("--repeats", type=int, default=1)
    args = parser.parse_args()
    meshes = args.meshes.split(",")
    for mesh in meshes:  # meshing is not timed
        mesh_for(default_model("full", args.materials, mesh=mesh))
    seconds: dict[tuple[str, float], list[float]] = {}
    forces: dict[tuple[str, float], dict[float, float]] = {}
    start = time.strftime("%Y-%m-%d %H:%M")
    for _ in range(args.repeats):
        for p in PRESSURES_KPA:
            for mesh in meshes:
                s, fz = _solve(mesh, args.materials, p)
                seconds.setdefault((mesh, p), []).append(s)
                forces[(mesh, p)] = fz
    print(f"# bench_mesh_cost: {args.materials}, vertical 5-40 mm, one core; started {start},"
          f" load average at the end {os.getloadavg()[0]:.1f}")
    print("| mesh | pressure kPa | ccx s | x first mesh | Fz 25 mm N | Fz 30 mm N |")
    print("|---|---|---|---|---|---|")
    for p in PRESSURES_KPA:
        base = statistics.median(seconds[(meshes[0], p)])
        for mesh in meshes:
            s = statistics.median(seconds[(mesh, p)])
            fz = forces[(mesh, p)]
            print(f"| {mesh} | {p:g} | {s:.0f} | {s / base:.2f} | {fz[25.0]:.1f} | "
                  f"{fz[30.0]:.1f} |")


if __name__ == "__main__":
    main()
