"""The wide-data reduction of :mod:`analysis.moments` side by side in one run: the thin
SVD against the Gram-matrix route (``GRAM_ROWS``), and a PLSR fit with its 5-fold CV
(:class:`analysis.camera.learners.PLSCV`) on each, at a sensor study's sizes (issue 46:
the answer's store gives about 1,900 training rows of 3 noisy draws, 3,400 features).

    .venv/bin/python benchmarks/bench_moments_reduce.py [--rows 800,1900] [--features 3400]
        [--repeats 3]

Prints, per size, the seconds of each route (best of ``--repeats``, alternating), their
ratio, and the largest difference of the centred products X̄ᵀX̄ the two reductions give
(relative to its largest entry). BLAS threads are as the environment sets them: run it
with ``OPENBLAS_NUM_THREADS=1`` beside a sweep (two threads against two ccx runs were 4x
slower on a 2-core machine).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from analysis import moments  # noqa: E402
from analysis.camera.learners import PLSCV  # noqa: E402


def _seconds(fn) -> float:
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _products(A: np.ndarray, gram_rows: int) -> np.ndarray:
    moments.GRAM_ROWS = gram_rows
    Xt, basis = moments._reduce(A)
    return basis @ (Xt.T @ Xt) @ basis.T


def one_size(rows: int, features: int, repeats: int) -> dict[str, float]:
    rng = np.random.default_rng(0)
    X = rng.standard_normal((rows, features))
    Y = X[:, :9] + 0.1 * rng.standard_normal((rows, 9))
    groups = np.repeat(np.arange(rows // 3 + 1), 3)[:rows]
    A = X - X.mean(0)
    saved = moments.GRAM_ROWS
    try:
        times = {"svd": [], "gram": [], "pls_svd": [], "pls_gram": []}
        for _ in range(repeats):  # alternating, so that load drifts hit both
            for route, limit in (("svd", rows + 1), ("gram", 1)):
                moments.GRAM_ROWS = limit
                times[route].append(_seconds(lambda: moments._reduce(A)))
                times[f"pls_{route}"].append(_seconds(
                    lambda: PLSCV(folds=5).fit(X, Y, groups=groups)))
        diff = np.abs(_products(A, rows + 1) - _products(A, 1)).max()
        scale = np.abs(A.T @ A).max()
    finally:
        moments.GRAM_ROWS = saved
    best = {k: min(v) for k, v in times.items()}
    return best | {"rel_diff": float(diff / scale)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", default="800,1900")
    parser.add_argument("--features", type=int, default=3400)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"{'rows':>6} {'svd s':>8} {'gram s':>8} {'ratio':>6} {'PLSCV svd s':>12} "
          f"{'PLSCV gram s':>13} {'ratio':>6} {'max diff':>9}")
    for rows in (int(r) for r in args.rows.split(",")):
        b = one_size(rows, args.features, args.repeats)
        print(f"{rows:>6} {b['svd']:>8.2f} {b['gram']:>8.2f} {b['svd'] / b['gram']:>6.1f} "
              f"{b['pls_svd']:>12.1f} {b['pls_gram']:>13.1f} "
              f"{b['pls_svd'] / b['pls_gram']:>6.1f} {b['rel_diff']:>9.1e}")


if __name__ == "__main__":
    main()
