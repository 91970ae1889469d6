"""Static slides of a load-path tree under two increment controls, side by side in one
run (issue 45: "the static study's slowest branches", "every speed-up shown equal").

    .venv/bin/python benchmarks/bench_static_branch.py [--study FILE]
        [--experiment I] [--branches all|J,J] [--values 4,10] [--timeout S]
        [--whole K,K,..]

The 1024-experiment study (``examples/combined_patch.toml``, docs/combined-loads.md)
spent its time in a few slides that ran 30-60 min: every increment took ccx's 9
iterations, and ccx grows an increment only after two in a row of at most IG
(``SolverSettings.grow_after``, default 4), so they stayed at 1/640-1/3000 of the slide.
A copied stalled slide went through in 98 s with IG 10, checked at its first output only.
This solves one tree's trunk once (the study's model, pressure, friction, tilt and
deflections) and then slides of it under each IG of ``--values`` (``G/Q``: IG G with the
largest increment divided by Q, as the guard's retry divides it by 4: whether the
answer depends on the increments at all), alternating: by default the level of
``--experiment`` (index in the study's order; 487 is the stalled slide's first fifth)
and every slide from it.

Printed per slide and value: ccx seconds, increments and how far it got (a slide that
passes ``--timeout`` keeps the fractions it reached), and against the first value at every
fraction both reached the largest force difference (% of |F|: the road's reaction) and
the camera field's (displacement, % of its RMS); "same" where every state is within the
issue's rule (0.5 % and 1 %). Nothing is asserted (noisy machines).

``--whole K,K,..`` (issue 45: "the 1024-experiment study's time extrapolated from a
benchmark subset of at least 4 trunks"): the trees K of the study (0-based, the study's
order), each trunk and every slide of it, one process, under the first of ``--values``
(or the farm's own with ``--values study``: IG ``farm.solve.tree.SLIDE_GROW_AFTER`` in
slides). Printed: each trunk's and slide's ccx seconds, the slowest slide, the subset's
total, and the study's time extrapolated to two workers (the subset's ccx seconds x
trees / subset trees / 2: trees keep two workers busy, so this is what two idle cores
take, load aside).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import answer_rule
from answer_rule import differences

import farm.solve.tree as tree_module
from farm.errors import SolverError
from farm.mesh import mesh_for
from farm.solve.states import SolvedState
from farm.solve.tree import solve_branch, solve_trunk
from farm.specs import LoadPath, SolverSettings
from jobs.expand import TreePlan, tree_plan
from jobs.study import load_study


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--study", default="examples/combined_patch.toml")
    p.add_argument("--experiment", type=int, default=487,
                   help="its tree and level are solved (index in the study's order)")
    p.add_argument("--branches", default="all",
                   help="slides of that level to solve, 0-based, or all")
    p.add_argument("--values", default="4,10", help="IG values, the first the reference")
    p.add_argument("--timeout", type=float, default=900.0, help="per slide, seconds")
    p.add_argument("--whole", default="", help="trees to solve whole, 0-based, comma list")
    return p.parse_args()


def _locate(plans: list[TreePlan], index: int) -> tuple[TreePlan, int]:
    """The tree holding experiment ``index`` and its level (a trunk's or a slide's)."""
    seen = 0
    for tree in plans:
        exps = tree.experiments
        if index < seen + len(exps):
            exp = exps[index - seen]
            return tree, tree.deflections.index(exp.deflection)
        seen += len(exps)
    raise SystemExit(f"--experiment {index}: the study has {seen} experiments")


def _compare(ref: tuple[SolvedState, ...], other: tuple[SolvedState, ...]) -> str:
    """Largest force and field differences over the states both reached."""
    if not ref or not other:
        return "nothing to compare"
    force = field = 0.0
    for a, b in zip(ref, other, strict=False):
        f, c = differences(a.road_reaction, b.road_reaction, a.displacement, b.displacement)
        force, field = max(force, f), max(field, c)
    same = "same" if answer_rule.same(force, field) else "NOT the same"
    return (f"{min(len(ref), len(other))} states: forces {force:.3f} % of |F|, field "
            f"{field:.3f} % of RMS: {same}")


def _slide(spec, mesh, trunk, level, shift, settings) -> tuple[tuple[SolvedState, ...],
                                                                float, str]:
    """(states reached, ccx seconds, how it ended) of one slide."""
    start = time.perf_counter()
    try:
        s = solve_branch(spec, mesh, trunk, level, shift, settings)
        return s.states, s.solve_seconds, f"{s.increments} increments"
    except SolverError as e:
        reached = e.partial if isinstance(e.partial, tuple) else ()
        return (reached, time.perf_counter() - start,
                f"STOPPED ({e.outcome}) at {e.reached or 0:.4g} of its time, "
                f"{len(reached)} states kept")


def _trunk(spec, mesh, tree: TreePlan, settings):
    motion = tree.motion
    print(f"tree {tree.key[:40]}, {tree.pressure * 1000:.1f} kPa, mu "
          f"{motion.friction if motion else 0:.3f}, tilt {motion.tilt if motion else 0:.2f}"
          f" deg, deflections {[round(d, 1) for d in tree.deflections]}")
    trunk = solve_trunk(spec, mesh, LoadPath(tree.deflections, tree.pressure, motion),
                        settings, fractions=tree.fractions)
    print(f"  trunk: {trunk.solution.solve_seconds:.0f} s of ccx", flush=True)
    return trunk


def _whole(study, plans: list[TreePlan], picked: list[int], settings) -> None:
    """Every trunk and slide of the trees ``picked``; the extrapolated study time."""
    spec = study.model
    mesh = mesh_for(spec)
    total, slowest, runs = 0.0, (0.0, ""), 0
    for k in picked:
        trunk = _trunk(spec, mesh, plans[k], settings)
        total += trunk.solution.solve_seconds
        for j, b in enumerate(plans[k].branches):
            _, seconds, how = _slide(spec, mesh, trunk, b.level, b.shift, settings)
            print(f"  slide {j} (level {b.level}, {b.shift[0]:+.2f}, {b.shift[1]:+.2f} mm):"
                  f" {seconds:7.1f} s, {how}", flush=True)
            total, runs = total + seconds, runs + 1
            slowest = max(slowest, (seconds, f"tree {k} slide {j}"))
    share = len(plans) / len(picked)
    ig = max(settings.grow_after, tree_module.SLIDE_GROW_AFTER)
    print(f"subset: {len(picked)} trees, {runs} slides, {total:.0f} s of ccx; slowest slide "
          f"{slowest[0]:.0f} s ({slowest[1]}); IG {ig} in slides")
    print(f"the study's {len(plans)} trees extrapolated: {total * share:.0f} s of ccx, "
          f"{total * share / 2 / 3600:.2f} h on two workers")


def _side_by_side(study, plans: list[TreePlan], a: argparse.Namespace) -> None:
    """The slides of ``--experiment``'s level under each IG of ``--values``."""
    tree, level = _locate(plans, a.experiment)
    spec, settings = study.model, study.settings
    tree_module.SLIDE_GROW_AFTER = 1  # the IG of --values, not the farm's floor
    mesh = mesh_for(spec)
    trunk = _trunk(spec, mesh, tree, settings)
    slides = [b for b in tree.branches if b.level == level]
    picked = range(len(slides)) if a.branches == "all" else [int(j) for j in
                                                               a.branches.split(",")]
    values = a.values.split(",")
    for j in picked:
        shift = slides[j].shift
        runs = {}
        for v in values:
            runs[v] = _slide(spec, mesh, trunk, level, shift, _controls(settings, v, a.timeout))
            print(f"  slide {j} of level {level} ({shift[0]:+.2f}, {shift[1]:+.2f}) mm, "
                  f"IG {v:>4}: {runs[v][1]:7.1f} s, {runs[v][2]}", flush=True)
        for v in values[1:]:
            print(f"    IG {v} against IG {values[0]}: {_compare(runs[values[0]][0], runs[v][0])}",
                  flush=True)


def _controls(settings: SolverSettings, value: str, timeout: float) -> SolverSettings:
    """``settings`` with IG (and the largest increment) of ``value``: ``G`` or ``G/Q``."""
    grow, _, q = value.partition("/")
    most = settings.max_increment / float(q or 1)
    return dataclasses.replace(settings, grow_after=int(grow), timeout=timeout,
                               max_increment=most,
                               initial_increment=min(settings.initial_increment, most))


def main() -> None:
    a = _args()
    study = load_study(a.study)
    plans = tree_plan(study, "ccx")
    print(f"{a.study}: {len(plans)} trees")
    if not a.whole:
        _side_by_side(study, plans, a)
        return
    first = a.values.split(",")[0]
    settings = study.settings  # "study": the farm's own choice (SLIDE_GROW_AFTER)
    if first != "study":
        tree_module.SLIDE_GROW_AFTER = 1
        settings = _controls(settings, first, settings.timeout)
    _whole(study, plans, [int(k) for k in a.whole.split(",")], settings)


if __name__ == "__main__":
    main()
