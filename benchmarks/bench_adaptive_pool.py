"""Does the surrogate's batch choice beat random picks at equal ccx runs? A retrospective
benchmark on a store the farm already filled (issue 28; the live comparison with new ccx
runs is benchmarks/bench_adaptive.py).

Run ``.venv/bin/python benchmarks/bench_adaptive_pool.py [--store results/sensor_window.zarr]``.
The group's done experiments are split once (seeded) into a test set and a pool. Both
strategies start from the same random picks of the pool; then, batch by batch, "adaptive"
adds the pool rows :meth:`analysis.surrogate.FieldSurrogate.next_batch` chooses and
"random" adds random ones. After each batch a surrogate of the six totals (no field: the
forces are what the analyses predict) is refitted and scored on the test set. Printed:
held-out RMSE of Fx, Fy, Fz, Mz in % of range per number of runs, for both, and their
ratio (adaptive / random, below 1 is better), averaged over seeds.

A pool of finished experiments is not the issue's comparison (an adaptive study chooses
from the whole load space and pays for new ccx runs; LHS and Sobol' designs are drawn, not
picked): it says whether the acquisition ranks the experiments usefully, on real farm data.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning

from analysis import data
from analysis.studies.combined import totals, varying_parameters
from analysis.surrogate import FieldSurrogate

SHOWN = {"Fx": 0, "Fy": 1, "Fz": 2, "Mz": 5}


def _errors(P, Y, train, test, seed) -> np.ndarray:
    model = FieldSurrogate(n_field=0, restarts=1, seed=seed).fit(P[train], Y[train])
    err = model.predict(P[test]) - Y[test]
    span = np.ptp(Y[test], axis=0)
    return 100 * np.sqrt((err**2).mean(axis=0)) / np.where(span > 0, span, np.nan)


def _curve(P, Y, pool, test, start, batch, adaptive: bool, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng([seed, 1])
    chosen = list(start)
    curve = [_errors(P, Y, chosen, test, seed)]
    while len(chosen) + batch <= len(pool):
        left = np.array([i for i in pool if i not in chosen])
        if adaptive:
            model = FieldSurrogate(n_field=0, restarts=1, seed=seed).fit(P[chosen], Y[chosen])
            picks = left[model.next_batch(P[left], batch)]
        else:
            picks = rng.choice(left, batch, replace=False)
        chosen += [int(i) for i in picks]
        curve.append(_errors(P, Y, chosen, test, seed))
    return curve


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--store", default="results/sensor_window.zarr")
    parser.add_argument("--group", default=None)
    parser.add_argument("--test", type=int, default=12, help="held-out experiments")
    parser.add_argument("--start", type=int, default=8, help="random runs to start from")
    parser.add_argument("--batch", type=int, default=4, help="runs per batch")
    parser.add_argument("--seeds", type=int, default=3, help="splits averaged")
    args = parser.parse_args()
    warnings.simplefilter("ignore", ConvergenceWarning)
    ds = data.load(args.store, args.group)
    params = varying_parameters(ds)
    P = np.column_stack([np.asarray(ds[p].values, dtype=float) for p in params])
    Y = totals(ds)
    print(f"{args.store}: {len(P)} done experiments, parameters {', '.join(params)}; "
          f"test {args.test}, start {args.start}, batch {args.batch}, {args.seeds} seeds")
    curves = {True: [], False: []}
    for seed in range(args.seeds):
        perm = np.random.default_rng(seed).permutation(len(P))
        test, pool = perm[: args.test], perm[args.test:]
        start = pool[: args.start]
        for adaptive in (True, False):
            curves[adaptive].append(_curve(P, Y, list(pool), test, start, args.batch,
                                           adaptive, seed))
    runs = [args.start + k * args.batch for k in range(len(curves[True][0]))]
    mean = {a: np.nanmean(np.array(c), axis=0) for a, c in curves.items()}
    head = "".join(f"{name:>16}" for name in SHOWN)
    print(f"{'runs':>5} {head}   (adaptive / random, held-out RMSE % of range)")
    for k, n in enumerate(runs):
        cells = "".join(f"{mean[True][k, j]:6.2f}/{mean[False][k, j]:6.2f}  " + " "
                        for j in SHOWN.values())
        print(f"{n:>5} {cells}")
    ratio = mean[True][1:, list(SHOWN.values())] / mean[False][1:, list(SHOWN.values())]
    print(f"mean ratio adaptive / random after the first batch: {np.nanmean(ratio):.2f} "
          "(below 1: the acquisition picks better experiments than chance)")


if __name__ == "__main__":
    main()
