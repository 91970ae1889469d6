"""A roll's restart points: what the cuts cost, what they change, and what a retry from
the last point saves against a roll from rest, side by side in one run (issue 45: "a
roll that still fails ... resumes from its last restart file when retried").

    .venv/bin/python benchmarks/bench_restart_points.py [--mesh PRESET | --circumferential N]
        [--materials NAME] [--radius MM] [--distance MM] [--every MM] [--states N]
        [--cases MU:K:A,..] [--stop-after K]

For each case of ``--cases`` (friction : slip ratio : slip angle in degrees), at 200 kPa
and 15 mm: the roll in one step; the same roll cut every ``--every`` mm
(:attr:`farm.specs.SolverSettings.restart_every_mm`); that cut roll stopped once it has
written ``--stop-after`` restart blocks (cancelled, as a job being stopped is; default:
the last point before the roll's end); and its next run, which goes on from that point
(:mod:`farm.solve.roll_restart`). Printed: wall seconds of each, the cut roll's against
the uncut (ratio, and every state by the issue's rule: 0.5 % of |F|, 1 % of the camera
field's RMS), and the resumed run's seconds against the cut roll from rest (what a retry
saves) with its states against the whole cut roll's. Points live in a temporary cache.
Nothing is asserted (noisy machines).
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

from answer_rule import differences, verdict
from rolled_model import add_model_args, model

from farm.errors import ResultsError, SolverError
from farm.mesh import mesh_for
from farm.solve import rolling
from farm.solve.contact import touch_height
from farm.solve.tree import split_restart
from farm.specs import Roll, SolverSettings

PRESSURE, DEFLECTION = 0.2, 15.0


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_model_args(p, radius=402.9)
    p.add_argument("--distance", type=float, default=100.0, help="the roll, mm")
    p.add_argument("--every", type=float, default=40.0, help="restart points, mm")
    p.add_argument("--states", type=int, default=5, help="states along the roll")
    p.add_argument("--cases", default="0.6:0.01:1,0.5:0.01:2",
                   help="friction:slip ratio:slip angle (degrees), comma list")
    p.add_argument("--stop-after", type=int, default=0,
                   help="restart blocks written before the stop (0: the last point)")
    return p.parse_args()


def _blocks(scratch: Path) -> int:
    """Restart blocks the running roll has written (0 while one is half written)."""
    try:
        return max((len(split_restart(f.read_bytes())) for f in scratch.glob("*/roll.rout")),
                   default=0)
    except (OSError, ResultsError):  # a block being written is not one yet
        return 0


def _timed(solve):
    start = time.perf_counter()
    try:
        return solve(), time.perf_counter() - start
    except SolverError as e:
        return e, time.perf_counter() - start


def _stopped(spec, mesh, roll, settings, fractions, blocks: int, scratch: Path):
    """The cut roll cancelled once it has written ``blocks`` restart blocks."""

    def stop() -> bool:
        return _blocks(scratch) >= blocks

    return _timed(lambda: rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, roll, settings,
                                             fractions, should_stop=stop))


def _compare(ref, other) -> str:
    if isinstance(ref, Exception) or isinstance(other, Exception):
        return "nothing to compare (a roll stopped)"
    worst = (0.0, 0.0)
    for a, b in zip(ref, other, strict=True):
        f, c = differences(a.force, b.force, a.camera, b.camera)
        worst = (max(worst[0], f), max(worst[1], c))
    return (f"worst state: forces {worst[0]:.4f} % of |F|, camera field {worst[1]:.4f} % of "
            f"its RMS: {verdict(*worst)}")


def _case(spec, mesh, a, mu: float, kappa: float, alpha: float, scratch: Path) -> None:
    roll = Roll(friction=mu, slip_ratio=kappa, slip_angle=alpha, distance=a.distance,
                rolling_radius=a.radius)
    fractions = tuple(k / a.states for k in range(1, a.states + 1))
    cut = SolverSettings(restart_every_mm=a.every)
    points = math.ceil((a.distance - rolling.CUT_AFTER_MM) / a.every - 1e-9) - 1
    blocks = a.stop_after or points
    print(f"mu {mu:g}, kappa {kappa:g}, alpha {alpha:g} deg: {a.distance:g} mm, "
          f"{a.states} states, a point every {a.every:g} mm ({points}); stop after {blocks}")
    one, one_s = _timed(lambda: rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, roll,
                                                   SolverSettings(), fractions))
    whole, whole_s = _timed(lambda: rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, roll,
                                                       cut, fractions))
    print(f"  one step {one_s:.1f} s{'' if isinstance(one, list) else ' (STOPPED)'}; cut "
          f"{whole_s:.1f} s{'' if isinstance(whole, list) else ' (STOPPED)'} "
          f"({whole_s / one_s:.2f}x); cut against one step: {_compare(one, whole)}")
    stopped, stop_s = _stopped(spec, mesh, roll, cut, fractions, blocks, scratch)
    resumed, resume_s = _timed(lambda: rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE,
                                                          roll, cut, fractions))
    print(f"  stopped after {stop_s:.1f} s ({type(stopped).__name__}); resumed "
          f"{resume_s:.1f} s, {resume_s / whole_s:.2f} of the cut roll from rest; resumed "
          f"against the whole cut roll: {_compare(whole, resumed)}")


def main() -> None:
    a = _args()
    spec = model(a)
    work = Path(tempfile.mkdtemp(prefix="bench-restart-"))
    os.environ["FARM_CACHE_DIR"] = str(work / "cache")  # points of this run alone
    os.environ["FARM_SCRATCH_DIR"] = str(work / "scratch")
    mesh = mesh_for(spec)
    touch_height(spec, mesh, PRESSURE, SolverSettings())  # cached, not timed
    print(f"{spec.mesh}, {a.materials}, r = {a.radius:g} mm, 200 kPa, 15 mm")
    for case in a.cases.split(","):
        mu, kappa, alpha = (float(x) for x in case.split(":"))
        _case(spec, mesh, a, mu, kappa, alpha, work / "scratch")


if __name__ == "__main__":
    main()
