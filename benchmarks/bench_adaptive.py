"""Adaptive vs LHS vs Sobol' at equal ccx runs, with new ccx runs (issue 28).

Run ``.venv/bin/python benchmarks/bench_adaptive.py [STUDY] [--out DIR] [--workers 2]``
(default STUDY: examples/combined_quick.toml, the combined-load space on the coarse full
model). From the study's model, ranges and solver settings it runs, on the embedded
cluster:

- a test set: an independent LHS of ``--test`` points (another seed), never trained on;
- LHS designs of ``--start``, ``--start + k --batch``, ... points (an LHS of n is not part
  of an LHS of 2n, so each size is a design of its own, as a researcher would draw it);
- one scrambled Sobol' sequence, whose first n points (each a balanced design at n = 2^k)
  are the designs of each size;
- the adaptive study (``[study.adaptive]``: ``--start`` LHS points, then rounds of
  ``--batch`` chosen by the surrogate), through :func:`jobs.adaptive.loop.run_adaptive`.

At every size n each design's done experiments train :class:`analysis.surrogate.FieldSurrogate`
(load parameters -> displacement field and totals) and a PLS regression (displacement
field -> totals, components by 5-fold CV: the combined-load analysis' noise-free model);
both are scored on the test set. Printed: held-out RMSE in % of range per output and
design, side by side, and "runs to reach LHS's final error": the fewest runs at which
the adaptive design is at or below the error of LHS at the largest size (issue 28's
goal: <= 50 % of LHS's runs). Runs count attempted experiments: a failed ccx run is paid
for and trains nothing. Designs share one store (test, LHS, Sobol': experiments selected
by id), the adaptive study has its own (its chooser fits everything in its group).
"""

from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from sklearn.cross_decomposition import PLSRegression
from sklearn.exceptions import ConvergenceWarning
from sklearn.model_selection import GridSearchCV

from analysis.adaptive import SurrogateChooser
from analysis.studies.combined import field_matrix, totals
from analysis.studies.surrogate import rmse_pct
from analysis.surrogate import FieldSurrogate
from jobs.adaptive import log as rounds_log
from jobs.adaptive.loop import run_adaptive
from jobs.driver import solver_version
from jobs.expand import experiments, plan
from jobs.study import Study, load_study
from jobs.sweep import run_sweep
from jobs.validate.adaptive import AdaptiveSpec

SHOWN = ("displacement", "Fx", "Fy", "Fz", "Mz")


def designs(base: Study, out: Path, sizes: list[int], test: int, seed: int):
    """The test study, an LHS study per size, the Sobol' study of the largest size."""
    s = base.sampling
    assert s is not None, "the study needs a [loads.sample] design"

    def study(name: str, store: str, method: str, n: int, seed_: int) -> Study:
        return replace(base, name=name, store=str(out / store), adaptive=None,
                       sampling=replace(s, method=method, n=n, seed=seed_, points=()))

    return (study("test", "designs.zarr", "lhs", test, seed + 1000),
            {n: study(f"lhs{n}", "designs.zarr", "lhs", n, seed) for n in sizes},
            study("sobol", "designs.zarr", "sobol", sizes[-1], seed))


def load(study: Study, solver: str, n: int | None = None):
    """(P, Y, n_field, attempted) of the first ``n`` design points of ``study`` that are
    done: P the sampled parameters, Y the displacement field then the six totals."""
    import analysis

    exps = experiments(plan(study, solver))
    if n is not None:  # a Sobol' prefix: the first n cases, in design order
        order = {e: k for k, e in enumerate(_case_ids(study, solver))}
        exps = sorted(exps, key=lambda e: order[e.id])[:n]
    ds = analysis.load(study.store, study.group_name)
    held = set(map(str, ds["experiment"].values))
    ids = [e.id for e in exps if e.id in held]
    ds = ds.sel(experiment=ids)
    names = [name for name, _, _ in study.sampling.ranges]
    P = np.column_stack([np.asarray(ds[p].values, dtype=float) for p in names])
    F = field_matrix(ds, "displacement")
    return P, np.hstack([F, totals(ds)]), F.shape[1], len(exps)


def _case_ids(study: Study, solver: str) -> list[str]:
    from jobs.expand import cases
    from jobs.identity import experiment_id

    return [experiment_id(study.model, d, p, solver, m) for d, p, m in cases(study)]


def scores(train, test) -> dict[str, float]:
    """Held-out % of range: the surrogate's outputs, and PLS' totals from the field."""
    (P, Y, nf, _), (Pt, Yt, _, _) = train, test
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        model = FieldSurrogate(n_field=nf, restarts=2).fit(P, Y)
    out = {k: v for k, (_, v) in rmse_pct(Yt, model.predict(Pt), nf, "displacement").items()}
    folds = 5 if len(P) >= 10 else 3
    cap = max(1, min(10, len(P) - -(-len(P) // folds) - 1))  # below the smallest fold
    pls = GridSearchCV(PLSRegression(scale=False), {"n_components": range(1, cap + 1)},
                       cv=folds, scoring="neg_mean_squared_error")
    span = np.ptp(Y[:, nf:], axis=0)
    span = np.where(span > 0, span, 1.0)  # each total in units of its range: equal weight
    pls.fit(Y[:, :nf], Y[:, nf:] / span)
    pred = np.hstack([Yt[:, :nf], pls.predict(Yt[:, :nf]) * span])
    out |= {f"PLS {k}": v for k, (_, v) in rmse_pct(Yt, pred, nf, "displacement").items()
            if k != "displacement"}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("study", nargs="?", default="examples/combined_quick.toml")
    parser.add_argument("--out", default="results/bench_adaptive")
    parser.add_argument("--start", type=int, default=8)
    parser.add_argument("--batch", type=int, default=4)
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--test", type=int, default=24)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--criterion", default="variance", choices=("variance", "integrated"),
                        help="the adaptive batch's acquisition")
    parser.add_argument("--adaptive-store", default="adaptive.zarr",
                        help="the adaptive study's store in --out (another name reruns it alone: "
                        "the other designs' experiments are in the store already)")
    args = parser.parse_args()
    # one cluster for every sweep (a study's sweep would start and stop one each time)
    from distributed import LocalCluster

    with LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        run(args, cluster.scheduler_address)


def run(args, scheduler: str) -> None:
    """Sweep every design on the cluster at ``scheduler``, then score and print."""
    out = Path(args.out)
    base = load_study(args.study)
    sizes = [args.start + k * args.batch for k in range(args.rounds + 1)]
    lhs_sizes = sorted({sizes[0], sizes[len(sizes) // 2], sizes[-1]})
    test, lhs, sobol = designs(base, out, lhs_sizes, args.test, args.seed)
    solver = solver_version(None, embedded=True)
    start = time.perf_counter()
    for s in (test, *lhs.values(), sobol):
        report = run_sweep(s, scheduler=scheduler)
        print(f"{s.name}: {report.summary()}", flush=True)
    adaptive = replace(base, name="adaptive", store=str(out / args.adaptive_store),
                       sampling=replace(base.sampling, method="lhs", n=args.start,
                                        seed=args.seed, points=()),
                       adaptive=AdaptiveSpec(args.rounds, args.batch, 512, args.seed))
    report = run_adaptive(adaptive, SurrogateChooser(criterion=args.criterion),
                          scheduler=scheduler)
    print(f"adaptive: {report.sweeps[-1].summary()}; {time.perf_counter() - start:.0f} s "
          "for every design", flush=True)
    held_out = load(test, solver)
    rows: dict[str, dict[int, dict[str, float]]] = {"adaptive": {}, "lhs": {}, "sobol": {}}
    for k, n in enumerate(sizes):
        chosen = rounds_log.Log(report.log.design, report.log.rounds[:k])
        rows["adaptive"][n] = scores(load(rounds_log.with_points(adaptive, chosen), solver),
                                     held_out)
        rows["sobol"][n] = scores(load(sobol, solver, n), held_out)
        if n in lhs:
            rows["lhs"][n] = scores(load(lhs[n], solver), held_out)
    _print(rows, sizes, held_out)


def _print(rows, sizes, held_out) -> None:
    names = [*SHOWN, *(f"PLS {k}" for k in SHOWN[1:])]
    print(f"\nheld-out RMSE, % of range, on {len(held_out[0])} test experiments "
          "(adaptive / LHS / Sobol'; '-': LHS not drawn at that size)")
    print(f"{'runs':>5} " + "".join(f"{n:>22}" for n in names))
    for n in sizes:
        cells = []
        for name in names:
            a, s = rows["adaptive"][n].get(name), rows["sobol"][n].get(name)
            lh = rows["lhs"].get(n, {}).get(name)
            cells.append(f"{_f(a)}/{_f(lh)}/{_f(s)}")
        print(f"{n:>5} " + "".join(f"{c:>22}" for c in cells))
    top = sizes[-1]
    for name in names:
        goal = rows["lhs"][top].get(name)
        reach = next((n for n in sizes if _le(rows["adaptive"][n].get(name), goal)), None)
        print(f"{name}: LHS at {top} runs {_f(goal)} %; adaptive reaches it at "
              f"{reach if reach is not None else f'> {top}'} runs"
              + (f" ({100 * reach / top:.0f} % of LHS's runs)" if reach else ""))


def _f(x) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.2f}"


def _le(a, b) -> bool:
    return a is not None and b is not None and np.isfinite(a) and np.isfinite(b) and a <= b


if __name__ == "__main__":
    main()
