"""Load-path trees vs one run per experiment (issue 29): combined-load experiments per
hour on the same nested design, side by side in one run.

Run: ``.venv/bin/python benchmarks/bench_throughput.py [--mesh patch|thesis]
[--materials NAME] [--trunks N] [--levels N] [--slides N] [--fractions 0.5,1]
[--workers 2]``.

One ``[loads.tree]`` design (jobs/nested.py) over the issue's ranges (deflection 5-40 mm,
pressure 80-200 kPa, mu 0.3-1.0, slides +-8 mm, tilt +-4 degrees) is swept twice, each
on its own embedded cluster of ``--workers`` workers and into its own store:

- ``solve = "rest"``: every case as the plain sweep plans it - each trunk's unslid
  states as one path, every slide fraction a ccx run of its own from rest (inflate,
  tilt, rise, slide);
- ``solve = "tree"``: one trunk run per trunk (restart state at every level) and one
  slide run per slide, continued from the trunk's state, results at every fraction.

The inflation pre-runs are cached before either sweep (both would share them).
Printed: experiments done and failed, ccx runs, wall seconds, experiments per hour and
ccx runs per experiment of each, the ratio of experiments per hour, and how far the two
stores' results of the same experiment ids are apart (the road's reaction and the sum of
the tread forces, Fx, Fy, Fz: the largest difference over the experiments, in N and
relative to |F|). Nothing is asserted.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import storage
from farm.mesh import mesh_for
from farm.solve.contact import touch_height
from farm.specs import SolverSettings
from jobs.nested import trunk_points
from jobs.study import parse_study
from jobs.sweep import run_sweep

STUDY = """
[study]
name = "throughput-{solve}"
store = "{store}"

[model]
kind = "full"
materials = "{materials}"
mesh = "{mesh}"

[loads.tree]
solve = "{solve}"
method = "lhs"
seed = {seed}
trunks = {trunks}
levels = {levels}
slides = {slides}
fractions = [{fractions}]
pressure_kpa = [80, 200]
friction = [0.3, 1.0]
tilt_deg = [-4, 4]
deflection_mm = [5, 40]
shift_x_mm = [-8, 8]
shift_y_mm = [-8, 8]
"""


def _forces(store: str, name: str) -> dict[str, np.ndarray]:
    """``name`` (a force, N) of every done experiment of the store's one group."""
    (group,) = storage.list_groups(store)
    ds = storage.done(storage.open_dataset(store, group))
    ids = [str(i) for i in ds["experiment"].values]
    return dict(zip(ids, np.asarray(ds[name]), strict=True))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default="patch")
    ap.add_argument("--materials", default="reinforced-calibrated")
    ap.add_argument("--trunks", type=int, default=1)
    ap.add_argument("--levels", type=int, default=2)
    ap.add_argument("--slides", type=int, default=2)
    ap.add_argument("--fractions", default="0.5,1")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="bench-throughput-"))
    fmt = dict(materials=args.materials, mesh=args.mesh, seed=args.seed, trunks=args.trunks,
               levels=args.levels, slides=args.slides, fractions=args.fractions)
    studies = {solve: parse_study(STUDY.format(solve=solve, store=tmp / f"{solve}.zarr",
                                               **fmt), f"{solve}.toml")
               for solve in ("rest", "tree")}
    model = studies["tree"].model
    mesh = mesh_for(model)
    assert studies["tree"].tree is not None
    for t in trunk_points(studies["tree"].tree):  # shared inflation pre-runs, cached
        touch_height(model, mesh, t.pressure, SolverSettings())
    print(f"mesh {args.mesh!r} ({mesh.n_nodes} nodes), materials {args.materials!r}, "
          f"{args.trunks} trunks x {args.levels} levels x (1 + {args.slides} slides x "
          f"{len(args.fractions.split(','))} fractions), {args.workers} workers")
    rates = {}
    for solve, study in studies.items():
        r = run_sweep(study, workers=args.workers)
        done = r.skipped + len(r.done)
        rates[solve] = done / r.wall_seconds * 3600
        print(f"{solve:>4}: {done} done, {len(r.failed)} failed, {r.ccx_runs} ccx runs "
              f"({r.ccx_runs / max(done, 1):.2f} per experiment), {r.wall_seconds:.0f} s wall, "
              f"{rates[solve]:.0f} experiments/h")
        for i, why in list(r.failed.items())[:3]:
            print(f"      failed {i[:12]}: {why[:160]}")
    print(f"ratio tree / rest: {rates['tree'] / rates['rest']:.2f}x experiments per hour")
    for name in ("road_reaction", "total_force"):
        rest, tree = (_forces(str(tmp / f"{k}.zarr"), name) for k in ("rest", "tree"))
        both = sorted(set(rest) & set(tree))
        if not both:
            continue
        diff = np.array([np.abs(tree[i] - rest[i]).max() for i in both])
        rel = diff / np.array([np.linalg.norm(rest[i]) for i in both])
        print(f"{name}, same ids in both: {len(both)}; largest |F_tree - F_rest| "
              f"{diff.max():.2f} N, {100 * rel.max():.3f} % of |F| (median "
              f"{100 * np.median(rel):.3f} %)")


if __name__ == "__main__":
    main()
