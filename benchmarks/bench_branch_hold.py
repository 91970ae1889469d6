"""A rolling branch's hold: its length against the branch's ccx time and answer, side
by side in one run (issue 45: "increments that grow", "every speed-up shown equal in
answers").

    .venv/bin/python benchmarks/bench_branch_hold.py [--mesh PRESET | --circumferential N]
        [--materials NAME] [--radius MM] [--holds 0.1,0.002] [--cases K:A,..]
        [--branch-from MM] [--branch MM] [--friction MU] [--tilt DEG]

A branch (:mod:`farm.solve.rolling_tree`) holds road and rim still for the first
``BRANCH_DWELL`` of its step, then rolls on; ccx tries its first moving increment at the
hold's size. For each hold of ``--holds`` (the branch's output times are the trunk's
``*TIME POINTS``, so each hold has its own trunk): the trunk, then every case of
``--cases`` (slip ratio:slip angle in degrees) as a branch. Printed: each solve's wall
seconds, the branches' total per hold and its ratio to the first hold's, and every
branch state against the first hold's (forces in % of |F|, the camera field in % of its
RMS; the issue's rule: 0.5 % and 1 %). Nothing is asserted (noisy machines).
"""

from __future__ import annotations

import argparse
import time

from answer_rule import differences, verdict
from rolled_model import add_model_args, model

import farm.solve.rolling_tree as rolling_tree
from farm.mesh import mesh_for
from farm.solve.contact import touch_height
from farm.specs import Roll, SolverSettings

PRESSURE, DEFLECTION = 0.2, 15.0


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_model_args(p, radius=403.8)
    p.add_argument("--holds", default="0.1,0.002", help="BRANCH_DWELL values, the first "
                   "the reference")
    p.add_argument("--cases", default="0:2,0.05:-2,-0.08:3.5",
                   help="branches: slip ratio:slip angle (degrees), comma list")
    p.add_argument("--branch-from", type=float, default=40.0, help="the trunk, mm")
    p.add_argument("--branch", type=float, default=30.0, help="each branch, mm")
    p.add_argument("--friction", type=float, default=0.6)
    p.add_argument("--tilt", type=float, default=0.0, help="camber, degrees")
    return p.parse_args()


def _tree(spec, mesh, a: argparse.Namespace, hold: float, cases):
    """Trunk and branches with the hold ``hold``: (trunk s, {case: (states, s)})."""
    rolling_tree.BRANCH_DWELL = hold
    roll = Roll(friction=a.friction, tilt=a.tilt, distance=a.branch_from,
                rolling_radius=a.radius)
    start = time.perf_counter()
    trunk = rolling_tree.solve_rolling_trunk(spec, mesh, DEFLECTION, PRESSURE, roll,
                                             SolverSettings(), branch_mm=a.branch,
                                             fractions=(1.0,), branch_fractions=(0.5, 1.0))
    trunk_s = time.perf_counter() - start
    print(f"hold {hold:g}: trunk {a.branch_from:g} mm in {trunk_s:.1f} s")
    out = {}
    for kappa, alpha in cases:
        start = time.perf_counter()
        states = rolling_tree.solve_rolling_branch(trunk, Roll(
            friction=a.friction, slip_ratio=kappa, slip_angle=alpha, tilt=a.tilt,
            distance=a.branch, rolling_radius=a.radius), SolverSettings())
        out[(kappa, alpha)] = (states, time.perf_counter() - start)
        print(f"  branch kappa {kappa:+.3f} alpha {alpha:+.1f}: {out[(kappa, alpha)][1]:.1f} s")
    return trunk_s, out


def main() -> None:
    a = _args()
    spec = model(a)
    mesh = mesh_for(spec)
    touch_height(spec, mesh, PRESSURE, SolverSettings())  # cached, not timed
    holds = [float(h) for h in a.holds.split(",")]
    cases = [tuple(float(v) for v in c.split(":")) for c in a.cases.split(",")]
    print(f"{spec.mesh}, {a.materials}, mu {a.friction:g}, tilt {a.tilt:g} deg, r "
          f"{a.radius:g} mm; trunk {a.branch_from:g} mm, branches {a.branch:g} mm")
    runs = {h: _tree(spec, mesh, a, h, cases) for h in holds}
    ref = runs[holds[0]][1]
    base = sum(s for _, s in ref.values())
    for h in holds:
        total = sum(s for _, s in runs[h][1].values())
        worst_f = worst_c = 0.0
        for case, (states, _) in runs[h][1].items():
            for x, y in zip(states, ref[case][0], strict=True):
                f, c = differences(y.force, x.force, y.camera, x.camera)
                worst_f, worst_c = max(worst_f, f), max(worst_c, c)
        print(f"hold {h:g}: branches {total:.1f} s ({base / total:.2f}x the first hold's "
              f"speed); worst state against the first hold: forces {worst_f:.3f} % "
              f"of |F|, camera field {worst_c:.3f} % of its RMS: "
              f"{verdict(worst_f, worst_c)} (rule: 0.5 %, 1 %)")


if __name__ == "__main__":
    main()
