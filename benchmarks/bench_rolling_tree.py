"""Rolling load cases per hour: a rolling tree against rolls from rest, side by side in
one run (issue 45: "distinct load cases per hour at least 5x today's").

    .venv/bin/python benchmarks/bench_rolling_tree.py [--mesh PRESET | --circumferential N
        --wall T,S,B] [--distance MM] [--branch-from MM] [--kappas K,..] [--alphas A,..]
        [--materials NAME] [--radius MM]

The same load cases (full model, 200 kPa, 15 mm, mu 0.6, a prescribed rolling radius;
every slip ratio x slip angle of the lists) solved two ways, one core, one after the
other: each as a roll from rest over ``--distance`` at its slips (today's rolling study),
and as a tree: one trunk rolled straight at kappa 0 over ``--branch-from`` mm, then each
case a branch that rolls the rest at its slips from the trunk's end
(:mod:`farm.solve.rolling_tree`). The two are different load histories (the tree's slips
start after the roll-in), each a distinct load case; the straight case (kappa 0, alpha 0,
when listed) is the same roll both ways and is checked against the issue's rule (forces
within 0.5 % of |F|, the camera field within 1 % of its RMS). Each solve is tried as a
study tries it: once, and after a solver failure again with the guard's smaller
increments (both tries' time counted). Printed: the solver calls' wall seconds, load
cases per hour each way (cases done) and their ratio. The inflation is cached
before timing. Nothing is asserted (noisy machines).
"""

from __future__ import annotations

import argparse
import itertools
import time

from answer_rule import differences, verdict
from rolled_model import model

from farm.errors import SolverError
from farm.mesh import mesh_for
from farm.solve.contact import touch_height
from farm.solve.rolling import solve_roll
from farm.solve.rolling_tree import solve_rolling_branch, solve_rolling_trunk
from farm.specs import Roll, SolverSettings
from jobs.guard import smaller_increments

PRESSURE, DEFLECTION, MU = 0.2, 15.0, 0.6


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mesh", default="", help="a mesh preset (e.g. patch) instead of the "
                   "counts below")
    p.add_argument("--circumferential", type=int, default=32)
    p.add_argument("--wall", default="4,2,1", help="elements: tread, sidewall, bead")
    p.add_argument("--distance", type=float, default=165.0, help="road travel, mm")
    p.add_argument("--branch-from", type=float, default=135.0,
                   help="the trunk's straight roll, mm (Fx steady after about 135 mm on "
                   "32 round: docs/rolling.md)")
    p.add_argument("--kappas", default="-0.05,0,0.05")
    p.add_argument("--alphas", default="0,2")
    p.add_argument("--radius", type=float, default=403.8, help="rolling radius, mm")
    p.add_argument("--materials", default="table-3.1")
    return p.parse_args()


def _timed(f, *args, **kw):
    """``f(*args, settings, **kw)`` as a study runs it: a try, and on a solver failure
    the guard's retry with smaller increments (:func:`jobs.guard.smaller_increments`);
    (result or the last error, wall seconds of both tries, tries)."""
    start = time.perf_counter()
    settings = SolverSettings()
    for tries in (1, 2):
        try:
            return f(*args, settings, **kw), time.perf_counter() - start, tries
        except SolverError as e:  # a failed roll is a result here: counted, not fatal
            error, settings = e, smaller_increments(settings)
    return error, time.perf_counter() - start, 2


def main() -> None:
    a = _args()
    spec = model(a)
    mesh = mesh_for(spec)
    touch_height(spec, mesh, PRESSURE, SolverSettings())  # cached, not timed
    cases = list(itertools.product((float(k) for k in a.kappas.split(",")),
                                   (float(x) for x in a.alphas.split(","))))
    branch = a.distance - a.branch_from
    print(f"{spec.mesh}, {a.materials}, {len(cases)} cases (kappa x alpha), "
          f"{a.distance:g} mm each; tree: {a.branch_from:g} mm trunk + {branch:g} mm branches")

    def roll(distance: float, kappa: float = 0.0, alpha: float = 0.0) -> Roll:
        return Roll(friction=MU, slip_ratio=kappa, slip_angle=alpha, distance=distance,
                    rolling_radius=a.radius)

    rest, tree = {}, {}
    rest_s = 0.0
    for k, x in cases:
        rest[(k, x)], s, n = _timed(solve_roll, spec, mesh, DEFLECTION, PRESSURE,
                                    roll(a.distance, k, x))
        rest_s += s
        print(f"  from rest  kappa {k:+.3f} alpha {x:+.1f}: {s:7.1f} s, {n} tries"
              + ("" if isinstance(rest[(k, x)], list) else f"  FAILED {rest[(k, x)]}"[:160]))
    trunk, tree_s, n = _timed(solve_rolling_trunk, spec, mesh, DEFLECTION, PRESSURE,
                              roll(a.branch_from), branch_mm=branch)
    print(f"  trunk      {a.branch_from:g} mm straight: {tree_s:7.1f} s, {n} tries")
    if isinstance(trunk, Exception):
        print(f"  the trunk FAILED: {trunk}"[:300])
        return
    for k, x in cases:
        tree[(k, x)], s, n = _timed(solve_rolling_branch, trunk, roll(branch, k, x))
        tree_s += s
        print(f"  branch     kappa {k:+.3f} alpha {x:+.1f}: {s:7.1f} s, {n} tries"
              + ("" if isinstance(tree[(k, x)], list) else f"  FAILED {tree[(k, x)]}"[:160]))
    ok_rest = sum(isinstance(v, list) for v in rest.values())
    ok_tree = sum(isinstance(v, list) for v in tree.values())
    per_hour = (3600.0 * ok_rest / rest_s, 3600.0 * ok_tree / tree_s)
    print(f"load cases per hour of ccx: from rest {per_hour[0]:.0f} ({ok_rest} of "
          f"{len(cases)} in {rest_s:.0f} s), tree {per_hour[1]:.0f} ({ok_tree} of "
          f"{len(cases)} in {tree_s:.0f} s); ratio {per_hour[1] / per_hour[0]:.2f}x")
    one, two = rest.get((0.0, 0.0)), tree.get((0.0, 0.0))
    if isinstance(one, list) and isinstance(two, list):
        r, b = one[-1], two[-1]
        force, field = differences(r.force, b.force, r.camera, b.camera)
        print(f"the straight case, branch against the roll from rest: forces "
              f"{force:.3f} % of |F|, camera field {field:.3f} % of its RMS: "
              f"{verdict(force, field)} (rule: 0.5 %, 1 %)")


if __name__ == "__main__":
    main()
