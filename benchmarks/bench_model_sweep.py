"""Mesh reuse in model-space studies (issue 15): ccx + mesh seconds per experiment in a
material sweep vs a geometry sweep of the same small model, side by side in one run.

Run: .venv/bin/python benchmarks/bench_model_sweep.py [--models 6] [--workers 2]

Both sweeps are ``[models]`` grids of ``--models`` values over one field of the coarse
reduced model (two deflections, one load path per model): the tread's Young's modulus
(material only: every model has the same mesh) and the sidewall thickness (every model a
new mesh). Each sweep starts from an empty mesh cache.

- serial: in this process, per model (the two sweeps interleaved), the mesh
  (``farm.mesh.mesh_for``: built, or a hit of the in-process memo) and the load path's
  ccx run (``farm.run_load_path``), timed apart; per experiment = (mesh + ccx +
  measurement) / experiments.
- farm: ``jobs.sweep.run_sweep`` on the embedded cluster (``--workers``), wall seconds
  per experiment, cluster start included; the client meshes each group's model once
  (``ensure_group``) and the workers load it from the shared disk cache.

Prints measured figures only, and the geometry/material ratio of each.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

STUDY = """
[study]
name = "bench-model-{kind}"
store = "{store}"
[model]
kind = "reduced"
road = "contact"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 8
[loads]
deflection_mm = [10, 20]
[models]
method = "grid"
[models.parameters]
"{field}" = {values}
"""
FIELDS = {"material": ("materials.tread.youngs_modulus", (5.0, 15.0)),
          "geometry": ("geometry.sidewall_thickness", (8.0, 12.0))}


def study_text(kind: str, models: int, store: Path) -> str:
    field, (low, high) = FIELDS[kind]
    values = [round(float(x), 6) for x in np.linspace(low, high, models)]
    return STUDY.format(kind=kind, store=store, field=field, values=values)


def serial(models: int, folder: Path) -> dict[str, dict]:
    """Both sweeps model by model, interleaved (material 1, geometry 1, material 2, ...)
    so that a load change on a shared machine hits both alike."""
    from farm.experiment import run_load_path
    from farm.mesh import cache
    from farm.specs import LoadPath
    from jobs.design import model_design
    from jobs.study import parse_study

    studies = {k: parse_study(study_text(k, models, folder / f"{k}.zarr")) for k in FIELDS}
    todo = {k: list(model_design(s).distinct().values()) for k, s in studies.items()}
    cache._MEMO.clear()  # an empty cache: what a fresh worker has
    sums = {k: {"mesh_s": 0.0, "ccx_s": 0.0, "wall_s": 0.0, "meshes": 0} for k in FIELDS}
    for i in range(models):
        for k in FIELDS:
            model, acc = todo[k][i], sums[k]
            start = time.perf_counter()
            before = len(cache._MEMO)
            cache.mesh_for(model, folder / f"cache-{k}")
            acc["meshes"] += len(cache._MEMO) > before
            acc["mesh_s"] += time.perf_counter() - start
            result = run_load_path(model, LoadPath(studies[k].deflections, 0.0))
            acc["ccx_s"] += result.solve_seconds
            acc["wall_s"] += result.wall_seconds
    out = {}
    for k, acc in sums.items():
        n = len(todo[k]) * len(studies[k].deflections)
        out[k] = {"models": len(todo[k]), "experiments": n, "meshes": acc["meshes"],
                  "mesh_s": acc["mesh_s"] / n, "ccx_s": acc["ccx_s"] / n,
                  "total_s": (acc["mesh_s"] + acc["wall_s"]) / n}
    return out


def farm(kind: str, models: int, folder: Path, workers: int) -> dict:
    from jobs.study import parse_study
    from jobs.sweep import run_sweep

    os.environ["FARM_CACHE_DIR"] = str(folder / f"farm-cache-{kind}")  # workers inherit it
    study = parse_study(study_text(kind, models, folder / f"farm-{kind}.zarr"))
    report = run_sweep(study, workers=workers)
    meshes = len(list((folder / f"farm-cache-{kind}" / "meshes").glob("*.npz")))
    return {"experiments": report.total, "ok": report.ok, "meshes": meshes,
            "ccx_s": report.solve_seconds / report.total,
            "wall_s": report.wall_seconds / report.total}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=int, default=6, help="models per sweep")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--skip-farm", action="store_true", help="serial figures only")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = serial(args.models, folder)
        print(f"serial, one process, per experiment ({args.models} models x 2 deflections):")
        print(f"{'sweep':10} {'meshes':>6} {'mesh s':>8} {'ccx s':>8} {'mesh+ccx+measure s':>19}")
        for k, r in rows.items():
            print(f"{k:10} {r['meshes']:6d} {r['mesh_s']:8.3f} {r['ccx_s']:8.3f} "
                  f"{r['total_s']:19.3f}")
        g, m = rows["geometry"], rows["material"]
        print(f"geometry / material: mesh {g['mesh_s'] / m['mesh_s']:.1f}x, "
              f"total {g['total_s'] / m['total_s']:.2f}x")
        if args.skip_farm:
            return
        runs = {k: farm(k, args.models, folder, args.workers) for k in FIELDS}
        print(f"farm, embedded cluster, {args.workers} workers, per experiment:")
        print(f"{'sweep':10} {'meshes':>6} {'ccx s':>8} {'wall s':>8} ok")
        for k, r in runs.items():
            print(f"{k:10} {r['meshes']:6d} {r['ccx_s']:8.3f} {r['wall_s']:8.3f} {r['ok']}")
        ratio = runs["geometry"]["wall_s"] / runs["material"]["wall_s"]
        print(f"geometry / material: wall {ratio:.2f}x")


if __name__ == "__main__":
    main()
