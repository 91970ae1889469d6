"""Nelder-Mead (thesis) vs least squares with parallel Jacobian columns, ideal inverse case.

Run: .venv/bin/python benchmarks/bench_inverse.py [--quick] [--workers 2]
     .venv/bin/python benchmarks/bench_inverse.py --study [--coarse] [--workers 2]
     .venv/bin/python benchmarks/bench_inverse.py --guesses|--regularisation [--coarse]
                                                  [--out DIR]

``--study`` is the other benchmark (issue 16): the chapter-4 study of ``farm reproduce
--quick`` (``--coarse``: on its test-sized mesh), run twice in one process, with
``jacobian = "full"`` (a finite-difference Jacobian at every accepted point) and with
the reproduction's Jacobian reuse, each with a fresh evaluation cache; see
:mod:`benchmarks.bench_inverse_study`. ``--guesses`` (evaluations to converge and final
nodal error per initial guess, the "tyre distribution" of §6.2 included) and
``--regularisation`` (Tikhonov, smoothness and PCA masks on the noisy conditions, weights
by the discrepancy principle) are in :mod:`benchmarks.bench_inverse_extras`.

The thesis' ideal case (§4.3): the reduced model at 30 mm, no noise, initial guess 90 %
of the true nodal forces, displacement objective (eq. 4.1). Both optimisers run on the
same embedded cluster, one after the other, each with a fresh in-memory cache (the
reference experiment is solved once, before either). Two milestones of a loop's best
point are timed:

1. the targets: total force within 0.5 % of the reference's AND the nodal force error
   at the thesis' level, RMS error <= 5.6 % of the largest reference nodal force (the
   thesis' 2.0 N std for the displacement method, Fig. 4.2, over its largest nodal
   force of 35.5 N; §4.4-4.5);
2. convergence: the objective down to 0.1 % of its start (the thesis' ideal solves
   "converged to a zero error"); the loop stops there, or at its budget.

"Sequential evaluations" are the loop's rounds: batches it had to wait for one after
the other (Nelder-Mead's initial simplex is one batch of n + 1; each later step is one
evaluation; least squares waits once per trial point and once per Jacobian, whose n
columns are one batch, the first together with x0). Wall time is the loop's own,
cluster start excluded. Targets: >= 10x fewer sequential evaluations and >= 5x less
wall time. A milestone Nelder-Mead does not reach within its budget gives a lower
bound (">="). Prints measured figures only.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

from jobs.cluster import connect
from jobs.driver import solver_version
from jobs.inverse.loop import LoopState, expand_loops, run_loop
from jobs.inverse.problem import build_problem
from jobs.inverse.study import parse_inverse_study
from jobs.loops.cache import EvaluationCache
from jobs.loops.evaluator import Evaluator

FZ_TOLERANCE = 0.005
NODAL_LEVEL = 2.0 / 35.5  # thesis: 2.0 N error std, 35.5 N largest nodal force
CONVERGED = 1e-3  # "converged": the objective down to 0.1 % of its start

STUDY = """
[study]
name = "bench-inverse"
store = "{tmp}/store.zarr"
cache = "{tmp}/cache"
[model]
kind = "reduced"
materials = "{materials}"
{mesh}
[optimizers.nelder-mead]
max_evaluations = {nm_budget}
xatol = 1e-4
fatol = 1e-9
[optimizers.least-squares]
max_evaluations = {lsq_budget}
fd_step_n = {step}
[[conditions]]
name = "ideal"
methods = ["displacement"]
noise = false
"""
COARSE = "[model.mesh]\ntread = 4\nsidewall = 2\nbead = 1\ncircumferential = 8"


class Milestones:
    """The stop condition of a loop: records when the targets are first met (milestone
    1) and stops at convergence (milestone 2: the objective at CONVERGED x its start)."""

    def __init__(self, problem, state) -> None:
        self.problem, self.state = problem, state
        self.fz, self.peak = problem.x_true.sum(), np.abs(problem.x_true).max()
        self.start = time.perf_counter()
        self.f0: float | None = None
        self.targets: dict | None = None
        self.converged: dict | None = None

    def mark(self, x: np.ndarray) -> dict:
        s = self.state.stats
        err = x - self.problem.x_true
        return {"rounds": s.rounds, "evaluations": s.evaluations,
                "wall": time.perf_counter() - self.start,
                "fz_error": abs(x.sum() / self.fz - 1),
                "nodal_rms": float(np.sqrt(np.mean(err**2)))}

    def __call__(self, x: np.ndarray, f: float) -> bool:
        self.f0 = f if self.f0 is None else self.f0  # the first best is the start point
        if self.targets is None and (
                abs(x.sum() - self.fz) <= FZ_TOLERANCE * abs(self.fz)
                and np.sqrt(np.mean((x - self.problem.x_true) ** 2)) <= NODAL_LEVEL * self.peak):
            self.targets = self.mark(x)
        if f <= CONVERGED * self.f0:
            self.converged = self.mark(x)
            return True
        return False


def run_one(study, problem, spec, client) -> dict:
    evaluator = Evaluator(client, EvaluationCache(None))  # nothing shared between the two
    state = LoopState(spec.label, spec.optimizer.max_evaluations)
    marks = Milestones(problem, state)
    result = run_loop(study, problem, spec, evaluator, state, stop=marks)
    return {"name": spec.optimizer.name, "status": result.status, "targets": marks.targets,
            "converged": marks.converged, "evaluations": len(result.f_history),
            "rounds": state.stats.rounds - 1,  # the final re-evaluation is a cache hit
            "wall": time.perf_counter() - marks.start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="coarse mesh (6 unknowns) and small budgets")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--materials", default="thesis-calibrated")
    parser.add_argument("--nm-budget", type=int, default=None)
    parser.add_argument("--study", action="store_true",
                        help="the quick chapter-4 study, full vs reused Jacobians")
    parser.add_argument("--coarse", action="store_true", help="--study on the coarse mesh")
    parser.add_argument("--jacobians", default="full-cold,shared",
                        help="--study: the Jacobian modes to run, comma-separated, with "
                             "warm starts; MODE-cold without (full-cold: the path before "
                             "issue 16); MODE:P adds jacobian_patience = P (e.g. shared:2)")
    parser.add_argument("--guesses", action="store_true",
                        help="initial guesses compared on the quick chapter-4 setup")
    parser.add_argument("--regularisation", action="store_true",
                        help="regularisation measured on the noisy conditions")
    parser.add_argument("--out", default=None,
                        help="--guesses/--regularisation: folder of the store and cache "
                             "[default: a temporary one]")
    parser.add_argument("--tau", type=float, default=1.0,
                        help="--regularisation: τ of the discrepancy principle")
    parser.add_argument("--settings", default=None,
                        help="--regularisation: comma-separated subset of none, tikhonov, "
                             "smoothness, guess, mask")
    parser.add_argument("--repeats", type=int, default=None,
                        help="noisy repeats [default: 3 for --guesses, 2 --regularisation]")
    args = parser.parse_args()
    if args.guesses or args.regularisation:
        from pathlib import Path

        import bench_inverse_extras as extras

        with tempfile.TemporaryDirectory() as tmp:
            out = Path(args.out or tmp).resolve()
            out.mkdir(parents=True, exist_ok=True)
            if args.guesses:
                extras.compare_guesses(args.coarse, args.workers, out, args.repeats or 3)
            if args.regularisation:
                settings = (tuple(args.settings.split(",")) if args.settings
                            else tuple(extras.SETTINGS))
                extras.compare_regularisation(args.coarse, args.workers, out,
                                              args.repeats or 2, args.tau, settings)
        return
    if args.study:
        from bench_inverse_study import compare

        compare(args.coarse, args.workers, tuple(args.jacobians.split(",")))
        return
    with tempfile.TemporaryDirectory() as tmp:
        study = parse_inverse_study(STUDY.format(
            tmp=tmp, materials=args.materials, mesh=COARSE if args.quick else "",
            nm_budget=args.nm_budget or (300 if args.quick else 1500),
            lsq_budget=100, step=0.25 if args.quick else 0.1))
        with connect(None, args.workers) as client:
            solver = solver_version(client, True)
            problem = build_problem(study, Evaluator(client, EvaluationCache(None)), solver)
            specs = {s.optimizer.name: s for s in expand_loops(study)}
            rows = [run_one(study, problem, specs[name], client)
                    for name in ("nelder-mead", "least-squares")]
    report(study, problem, rows, args)


def _row(name: str, mark: dict | None, run: dict) -> str:
    if mark is None:  # not reached within the budget
        return (f"{name:<15}{'NO':>8}{'>' + str(run['rounds']):>11}"
                f"{'>' + str(run['evaluations']):>12}{'>' + format(run['wall'], '.1f'):>9}")
    return (f"{name:<15}{'yes':>8}{mark['rounds']:>11}{mark['evaluations']:>12}"
            f"{mark['wall']:>9.1f}{100 * mark['fz_error']:>10.3f}{mark['nodal_rms']:>12.3f}")


def _ratio(nm: dict, ls: dict, key: str, milestone: str) -> str:
    a, b = nm[milestone], ls[milestone]
    if b is None:
        return "n/a (least squares did not reach it)"
    if a is None:  # Nelder-Mead ran out of budget first: a lower bound
        return f">= {nm[key] / b[key]:.1f}x"
    return f"{a[key] / b[key]:.1f}x"


def report(study, problem, rows, args) -> None:
    nm, ls = rows
    print(f"ideal inverse case: reduced model ({'coarse' if args.quick else 'default'} mesh, "
          f"{args.materials}), {study.deflection:g} mm, {problem.n} unknowns, "
          f"Fz_ref = {problem.x_true.sum():.1f} N, {args.workers} workers")
    head = (f"{'optimiser':<15}{'reached':>8}{'sequential':>11}{'evaluations':>12}"
            f"{'wall s':>9}{'Fz err %':>10}{'nodal RMS N':>12}")
    peak = problem.x_true.max()
    for milestone, text in (
            ("targets", f"targets: Fz within {100 * FZ_TOLERANCE:g} % and nodal RMS error <= "
                        f"{100 * NODAL_LEVEL:.1f} % of {peak:.1f} N = "
                        f"{NODAL_LEVEL * peak:.2f} N (the thesis' level)"),
            ("converged", f"converged: objective <= {CONVERGED:g} x its start")):
        print(text)
        print(head)
        for r in rows:
            print(_row(r["name"], r[milestone], r))
        print(f"  sequential evaluations, Nelder-Mead / least squares: "
              f"{_ratio(nm, ls, 'rounds', milestone)}   (target >= 10x)")
        print(f"  wall time, Nelder-Mead / least squares: "
              f"{_ratio(nm, ls, 'wall', milestone)}   (target >= 5x)")


if __name__ == "__main__":
    main()
