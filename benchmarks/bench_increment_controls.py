"""Increment controls on frictional paths, side by side in one run (issue 45: increments
that grow).

    .venv/bin/python benchmarks/bench_increment_controls.py [--vary grow|roll-unit|stick]
        [--values 4,8,12] [--mesh PRESET] [--materials NAME] [--cases roll,roll-mu1,slide]
        [--repeat R]

``--vary grow`` (default): ccx grows an increment only after two in a row that converged
within IG iterations (its default 4); contact under friction takes 5-9, so after a
cutback its increments stay small. The values are IG (``farm.specs.SolverSettings.
grow_after``). ``--vary roll-unit``: the road travel (mm) that lasts one unit of step
time in a roll (``farm.solve.rolling.ROLL_UNIT_MM``): a roll's increments are capped at
5 mm of travel, a cap in step time that also holds for the inflation and the rise before
it, so the shorter the unit the fewer increments those take (rolls only). ``--vary
stick``: the stick slope lambda of ``*FRICTION`` in N/mm^3 (``RoadMotion.stick_slope``;
the default is 4.605, :func:`farm.ccx.deck.stick_slope`), a physics setting, not a
control: whether a softer one saves the rolls that stop, and what it costs in answers.
Each case is solved with every value, the values alternating, the inflation cached
before timing:

- ``roll``: 160 mm at 2 degrees of slip angle, mu 0.6, 200 kPa, 15 mm, 8 states;
- ``roll-mu1``: 160 mm at kappa 0.02 and 3 degrees, mu 1.0 (the corner where rolls
  failed), 8 states;
- ``slide``: a lateral slide of 4 mm at mu 0.9, 80 kPa, 20 mm, five fractions of it;
- ``lost-start``, ``lost-end``: two rolls of ``examples/rolling_coarse.toml``'s kind
  (100 mm at r_e 402.9 mm, 200 kPa, 15 mm, the end state) that stop "increment below
  minimum" on the coarse model, at the roll's start (mu 0.6824, kappa 0.0171, -2.0312
  degrees: a case of that example's design) and in its last 0.2 mm (mu 0.5, kappa
  0.01, 2 degrees); ``kept``: one that rolls through (mu 0.4, kappa 0.01, 1 degree);
  ``lost-1`` ... ``lost-7``: the seven cases of that example's design that stopped on
  the coarse model (2026-11-29, commit 8c3947a), to roll on another mesh.

Printed per case and value: ccx seconds and increments, and against the first value at
every stored state the largest force difference (% of |F|) and the camera's (or the
standing tyre's) displacement field difference (% of its RMS); "same" where every state
is within the issue's rule (0.5 % and 1 %). Nothing is asserted (noisy machines); a
failed solve is printed with its reason.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import answer_rule
from answer_rule import differences

from farm.errors import SolverError
from farm.experiment import PathResult, run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve import rolling
from farm.solve.contact import touch_height
from farm.specs import LoadPath, MeshDensity, RoadMotion, SolverSettings

COARSE = MeshDensity(tread=4, sidewall=2, bead=1, circumferential=16)
EIGHTHS = tuple(k / 8 for k in range(1, 9))
#: (mu, kappa, slip angle) of the rolls of examples/rolling_coarse.toml that stopped on the
#: coarse model: three at the roll's start (mu 0.68-0.70), four at mu 0.91-0.98
LOST = ((0.6824, 0.0171, -2.0312), (0.6866, 0.0068, 2.6065), (0.7003, 0.0003, 1.7024),
        (0.9136, 0.0195, 1.9606), (0.9311, 0.0037, -2.4587), (0.9558, -0.0065, -2.8137),
        (0.9814, 0.0141, -2.2588))
CASES = {
    "roll": LoadPath((15.0,), 0.2, RoadMotion(friction=0.6, roll=160.0, slip_angle=2.0,
                                              rolling_radius=403.8), EIGHTHS),
    "roll-mu1": LoadPath((15.0,), 0.2, RoadMotion(friction=1.0, roll=160.0, slip_ratio=0.02,
                                                  slip_angle=3.0, rolling_radius=403.8),
                         EIGHTHS),
    "slide": LoadPath((20.0,), 0.08, RoadMotion(friction=0.9, shift_y=4.0),
                      (0.2, 0.4, 0.6, 0.8, 1.0)),
    **{name: LoadPath((15.0,), 0.2, RoadMotion(friction=mu, roll=100.0, slip_ratio=kappa,
                                               slip_angle=alpha, rolling_radius=402.9))
       for name, (mu, kappa, alpha) in (("lost-start", (0.6824, 0.0171, -2.0312)),
                                        ("lost-end", (0.5, 0.01, 2.0)),
                                        ("kept", (0.4, 0.01, 1.0)),
                                        *((f"lost-{k + 1}", case) for k, case in
                                          enumerate(LOST)))},
}


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--vary", choices=("grow", "roll-unit", "stick"), default="grow")
    p.add_argument("--values", default="4,8,12", help="the values, the first the reference")
    p.add_argument("--mesh", default="", help="a mesh preset (default: the coarse model)")
    p.add_argument("--materials", default="table-3.1")
    p.add_argument("--cases", default=",".join(CASES))
    p.add_argument("--repeat", type=int, default=1)
    return p.parse_args()


def _compare(ref: PathResult, other: PathResult) -> tuple[float, float]:
    """Largest force and field differences over the states, in % of |F| and of RMS."""
    force = field = 0.0
    for a, b in zip(ref.measurements, other.measurements, strict=True):
        fa, fb = (m.road_reaction if m.road_reaction is not None else m.total_force
                  for m in (a, b))
        f, c = differences(fa, fb, a.displacement, b.displacement)
        force, field = max(force, f), max(field, c)
    return force, field


def _varied(vary: str, value: float, path: LoadPath) -> tuple[LoadPath, SolverSettings]:
    """The case and settings with ``value`` of what ``vary`` names."""
    settings = SolverSettings()
    if vary == "grow":
        settings = dataclasses.replace(settings, grow_after=int(value))
    elif vary == "stick":
        assert path.motion is not None
        path = dataclasses.replace(path, motion=dataclasses.replace(path.motion,
                                                                    stick_slope=value))
    else:
        rolling.ROLL_UNIT_MM = value
    return path, settings


def main() -> None:
    a = _args()
    spec = default_model("full", mesh=a.mesh or COARSE, materials=a.materials)
    grows = [float(v) for v in a.values.split(",")]
    print(f"{spec.mesh}, {a.materials}; {a.vary} values {grows} (the first the reference), "
          f"{a.repeat} run(s) each")
    for name in a.cases.split(","):
        touch_height(spec, mesh_for(spec), CASES[name].pressure, SolverSettings())  # cached
        results: dict[float, PathResult | None] = {}
        times: dict[float, list[float]] = {g: [] for g in grows}
        for _ in range(a.repeat):
            for g in grows:
                path, settings = _varied(a.vary, g, CASES[name])
                start = time.perf_counter()
                try:
                    results[g] = run_load_path(spec, path, settings)
                    times[g].append(results[g].solve_seconds)
                except SolverError as e:
                    results[g] = None
                    print(f"  {name} {g:g}: FAILED after {time.perf_counter() - start:.0f} s:"
                          f" {str(e)[:200]}")
        ref = results[grows[0]]
        for g in grows:
            r = results[g]
            if r is None or not times[g]:
                continue
            line = (f"  {name:9} {g:5g}: {min(times[g]):7.1f} s of ccx (best of "
                    f"{len(times[g])}), {r.increments:4} increments")
            if ref is not None and g != grows[0]:
                force, field = _compare(ref, r)
                speed = min(times[grows[0]]) / min(times[g])
                same = "same" if answer_rule.same(force, field) else "NOT the same"
                line += (f"; {speed:.2f}x faster; forces {force:.3f} % of |F|, field "
                         f"{field:.3f} % of RMS: {same}")
            print(line, flush=True)


if __name__ == "__main__":
    main()
