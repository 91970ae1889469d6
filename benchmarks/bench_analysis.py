"""Benchmark of the analysis package (not a timed test): prints measured ratios.

1. Monte Carlo noise sweep on thesis-sized data (7 experiments, 1,000 inner nodes,
   400 tread nodes), 100 draws x 20 noise levels: ``analysis.noise.monte_carlo``
   (all draws of a level in one array operation) against a Python loop calling
   scikit-learn's ``PLSRegression.predict`` once per draw, on the same fitted model.
   Target: >= 20x.
2. Out-of-core: a synthetic store of 10,000 experiments x 3,000 inner nodes (400 tread
   nodes, one Zarr chunk per experiment as the schema prescribes). Moments of (Uz, Fz)
   streamed chunk-wise with dask, then cross-covariance PCA and SIMPLS; against the same
   computation on numpy arrays read fully into memory. Each run is a fresh process, so
   its peak RSS is its own. Targets: peak < 2 GiB, time ratio <= 2x.

Usage::

    .venv/bin/python benchmarks/bench_analysis.py           # full sizes (~10 min, 1 GiB disk)
    .venv/bin/python benchmarks/bench_analysis.py --quick   # small sizes, about a minute
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from analysis.noise import monte_carlo, totals_operator  # noqa: E402
from tests.synthetic import geometry, inner_fields, make_store, tread_forces  # noqa: E402


def thesis_sized(rows=20, cols=50, tread_rows=16, tread_cols=25, noise=1e-3, seed=0):
    """In-memory thesis-like data: 7 deflections, Uz on rows*cols nodes, Fz on tread nodes."""
    geo = geometry(rows, cols, tread_rows, tread_cols)
    d, p = np.linspace(10, 40, 7), np.full(7, 0.2)
    X = inner_fields(geo, d, p, "deflection")["displacement"][..., 2]
    X = X + noise * 30.0 * np.random.default_rng(seed).standard_normal(X.shape)
    return X, tread_forces(geo, d, p)[..., 2], totals_operator(geo.tread_xyz[:, :2])


def loop_sweep(model, x_ref, sigmas, draws, G, seed=0):
    """The baseline: one predict() per noisy draw, statistics at the end of each level."""
    rng = np.random.default_rng(seed)
    stats = []
    for sigma in sigmas:
        pred = np.empty((draws, G.shape[0]))
        for i in range(draws):
            pred[i] = model.predict((x_ref + sigma * rng.standard_normal(x_ref.size))[None, :])[0]
        tot = pred @ G
        stats.append((pred.mean(0), pred.std(0, ddof=1), tot.mean(0), tot.std(0, ddof=1)))
    return stats


def best_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def bench_monte_carlo(quick: bool) -> dict:
    from sklearn.cross_decomposition import PLSRegression

    X, Y, G = thesis_sized()
    model = PLSRegression(6, scale=False).fit(X, Y)
    sigmas, draws = np.linspace(0.1, 2.0, 20), 100
    loop_draws = 10 if quick else draws  # quick: time 10 draws per level, scale to 100
    out = {
        "shape": f"K={X.shape[0]}, N={X.shape[1]}, M={Y.shape[1]}, A=6",
        "levels x draws": f"{len(sigmas)} x {draws}",
        "loop_extrapolated": quick,
    }
    for sampling in ("inputs", "subspace"):
        out[sampling] = best_time(
            lambda s=sampling: monte_carlo(
                model, X[4], sigmas, totals=G, n_draws=draws, sampling=s
            ),
            7,
        )
    t_loop = best_time(lambda: loop_sweep(model, X[4], sigmas, loop_draws, G), 1 if quick else 3)
    out["loop_s"] = t_loop * draws / loop_draws
    rng = np.random.default_rng(0)
    out["rng_floor_s"] = best_time(
        lambda: rng.standard_normal((len(sigmas) * draws, X.shape[1])), 7
    )
    res = monte_carlo(model, X[4], sigmas, totals=G, n_draws=draws, seed=1)
    live = Y[4] > 0
    out["mc_over_analytic_std"] = float(
        np.mean(res.node_std[:, live] / res.node_std_analytic[:, live])
    )
    return out


# ---------------------------------------------------------------- out of core

CHILD = r"""
import json, resource, sys, time
import numpy as np, xarray as xr
sys.path.insert(0, {root!r})
from analysis import data
from analysis.crosscov import CrossCovariancePCA
from analysis.moments import compute_moments
from analysis.pls import SIMPLSRegression

mode, store = sys.argv[1], sys.argv[2]
t0 = time.perf_counter()
if mode == "dask":
    ds = data.load(store)
    X, Y = data.inputs(ds, "Uz"), data.outputs(ds)
    t_load = time.perf_counter() - t0
else:
    raw = xr.open_zarr(store, group="synthetic", consolidated=False, chunks=None)
    done = np.flatnonzero(raw["status"].values == 1)
    raw = raw.isel(experiment=done)
    X = raw["displacement"].sel(component="z").values
    Y = raw["reaction_force"].sel(component="z").values
    t_load = time.perf_counter() - t0
m = compute_moments(X, Y)
pca = CrossCovariancePCA(5).fit_moments(m)
pls = SIMPLSRegression(3).fit_moments(m)
total = time.perf_counter() - t0
print(json.dumps({{"total_s": total, "load_s": t_load, "compute_s": total - t_load,
                  "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "sigma1": float(pca.singular_values_[0]), "pctvar_y": pls.pctvar_[1].tolist(),
                  "shape": list(X.shape)}}))
"""


def run_child(mode: str, store: Path) -> dict:
    out = subprocess.run(
        [sys.executable, "-c", CHILD.format(root=str(ROOT)), mode, str(store)],
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def bench_out_of_core(quick: bool, store_dir: Path | None) -> dict:
    K, rows, cols = (2000, 20, 50) if quick else (10000, 30, 100)
    base = store_dir or Path(tempfile.gettempdir())
    store = base / f"bench_ooc_{K}x{rows * cols}.zarr"
    t_write = None
    if not (store / "synthetic" / "status").exists():
        t0 = time.perf_counter()
        make_store(
            store,
            n_experiments=K,
            rows=rows,
            cols=cols,
            tread_rows=16,
            tread_cols=25,
            include_strain=False,
            noise=1e-3,
            block=250,
        )
        t_write = time.perf_counter() - t0
    lazy, eager = run_child("dask", store), run_child("numpy", store)
    assert np.isclose(lazy["sigma1"], eager["sigma1"], rtol=1e-6), (lazy, eager)
    return {
        "store": str(store),
        "experiments x nodes": f"{K} x {rows * cols}",
        "write_s": t_write,
        "dask": lazy,
        "numpy": eager,
        "time_ratio": lazy["total_s"] / eager["total_s"],
        "time_ratio_vs_numpy_compute_only": lazy["total_s"] / eager["compute_s"],
    }


def report(mc: dict, ooc: dict) -> None:
    gib = 1024.0
    print("\nMonte Carlo noise sweep (thesis-sized)")
    print(f"  data: {mc['shape']}; {mc['levels x draws']} (levels x draws)")
    loop_note = " (extrapolated from 10 draws/level)" if mc["loop_extrapolated"] else ""
    print(f"  loop of PLSRegression.predict : {mc['loop_s'] * 1e3:8.1f} ms{loop_note}")
    for sampling, what in (
        ("inputs", "noise on all N inputs"),
        ("subspace", "same law, A-dim draws"),
    ):
        t = mc[sampling]
        print(
            f"  vectorised, {sampling:8s}          : {t * 1e3:8.1f} ms   speed-up "
            f"{mc['loop_s'] / t:6.1f} x   ({what})"
        )
    print(f"  (drawing the D x N normals alone: {mc['rng_floor_s'] * 1e3:.1f} ms; target >= 20 x)")
    ratio = mc["mc_over_analytic_std"]
    print(f"  MC / analytic nodal std       : {ratio:8.3f}  (mean over nodes, levels)")
    print(f"\nOut-of-core ({ooc['experiments x nodes']} experiments x inner nodes, Uz -> Fz)")
    if ooc["write_s"] is not None:
        print(f"  writing the store      : {ooc['write_s']:9.1f} s   ({ooc['store']})")
    for name in ("dask", "numpy"):
        r = ooc[name]
        print(
            f"  {name:6s}: total {r['total_s']:7.1f} s (open/read {r['load_s']:6.1f} s, "
            f"compute {r['compute_s']:6.1f} s), peak RSS {r['peak_rss_mib'] / gib:5.2f} GiB"
        )
    ratio = ooc["time_ratio"]
    print(f"  dask / numpy time      : {ratio:9.2f}     (target <= 2; numpy incl. reading)")
    print(
        f"  dask / numpy compute   : {ooc['time_ratio_vs_numpy_compute_only']:9.2f}     "
        "(numpy with data already in memory)"
    )
    ok = ooc["dask"]["peak_rss_mib"] / gib < 2.0
    print(f"  dask peak RSS < 2 GiB  : {'yes' if ok else 'NO'}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="small sizes, about a minute")
    parser.add_argument(
        "--store-dir",
        type=Path,
        default=None,
        help="where the out-of-core store is written (reused if present)",
    )
    args = parser.parse_args(argv)
    mc = bench_monte_carlo(args.quick)
    ooc = bench_out_of_core(args.quick, args.store_dir)
    report(mc, ooc)


if __name__ == "__main__":
    main()
