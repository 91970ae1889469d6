"""Benchmark: Sobol' base sample size N against confidence-interval width (issue 15).

On the Ishigami function (D = 3, a = 7, b = 0.1; analytic S1 = 0.3139, 0.4424, 0; ST =
0.5576, 0.4424, 0.2437), for N = 64 ... 4096 base samples (N (D + 2) model runs, what a
model-space study with ``method = "sobol"`` costs in ccx runs per load path), and
``--repeats`` independently scrambled designs per N:

- the mean full width (2 x half-width) of the 95 % bootstrap intervals of S1 and ST
  that :class:`analysis.sensitivity.SobolIndices` reports (1000 resamples);
- the actual RMS error of S1 and ST against the analytic values, and the coverage:
  the fraction of the 6 x repeats indices whose interval holds the analytic value;
- the analysis time (all bootstrap resamples) per design.

The width should fall like N^-1/2 (x 0.71 per doubling of N); read the table to choose
the N (hence ccx runs) that a wanted CI width costs.

Usage::

    .venv/bin/python benchmarks/bench_sobol.py            # N = 64..4096, 5 repeats (~1 min)
    .venv/bin/python benchmarks/bench_sobol.py --quick    # N = 64..512, 2 repeats
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from SALib.sample import sobol as sobol_sample  # noqa: E402
from SALib.test_functions import Ishigami  # noqa: E402

from analysis.sensitivity import SobolIndices, sobol_rows  # noqa: E402

PROBLEM = {"num_vars": 3, "names": ["x1", "x2", "x3"], "bounds": [[-np.pi, np.pi]] * 3}
S1 = np.array([0.3139, 0.4424, 0.0])
ST = np.array([0.5576, 0.4424, 0.2437])


def one(n: int, seed: int, resamples: int) -> dict:
    X = sobol_sample.sample(PROBLEM, n, calc_second_order=False, seed=seed)
    y = Ishigami.evaluate(X)
    start = time.perf_counter()
    est = SobolIndices(PROBLEM["names"], PROBLEM["bounds"], num_resamples=resamples,
                       seed=seed).fit(X, y)
    seconds = time.perf_counter() - start
    s1, st = est.first_order_[0], est.total_order_[0]
    c1, ct = est.first_order_conf_[0], est.total_order_conf_[0]
    return {
        "w1": 2 * c1.mean(), "wt": 2 * ct.mean(),
        "e1": np.mean((s1 - S1) ** 2), "et": np.mean((st - ST) ** 2),
        "covered": np.sum(np.abs(s1 - S1) <= c1) + np.sum(np.abs(st - ST) <= ct),
        "seconds": seconds,
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="N up to 512, 2 repeats")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--resamples", type=int, default=1000)
    args = parser.parse_args(argv)
    sizes = [64, 128, 256, 512] if args.quick else [64, 128, 256, 512, 1024, 2048, 4096]
    repeats = args.repeats or (2 if args.quick else 5)
    print(f"Ishigami, D = 3, {repeats} scrambled designs per N, {args.resamples} bootstrap "
          "resamples, 95 % intervals")
    head = (f"{'N':>6} {'runs N(D+2)':>12} {'S1 CI width':>12} {'ST CI width':>12} "
            f"{'S1 RMS err':>11} {'ST RMS err':>11} {'coverage':>9} {'fit s':>7}")
    print(head)
    print("-" * len(head))
    previous = None
    for n in sizes:
        runs = [one(n, seed, args.resamples) for seed in range(1, repeats + 1)]
        mean = {k: float(np.mean([r[k] for r in runs])) for k in runs[0]}
        coverage = sum(r["covered"] for r in runs) / (6 * repeats)
        print(f"{n:>6} {sobol_rows(n, 3):>12} {mean['w1']:>12.4f} {mean['wt']:>12.4f} "
              f"{np.sqrt(mean['e1']):>11.4f} {np.sqrt(mean['et']):>11.4f} "
              f"{coverage:>9.0%} {mean['seconds']:>7.2f}")
        if previous is not None:
            ratio = (mean["w1"] + mean["wt"]) / previous
            print(f"{'':>6} {'':>12} width ratio to N/2: {ratio:.2f} (N^-1/2: 0.71)")
        previous = mean["w1"] + mean["wt"]


if __name__ == "__main__":
    main()
