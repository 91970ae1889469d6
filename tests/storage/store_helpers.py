"""Helpers of the store's tests: synthetic meshes and results, fresh interpreters.

Results are a pure function of the experiment id and the mesh sizes, so that a test and
a writer process can compute the same arrays independently and compare them bit for bit.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import storage

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
GROUP = "mesh-a"


def run_python(*args: str, timeout: float = 120, check: bool = True) -> subprocess.CompletedProcess:
    """Run ``python args...`` in a fresh interpreter that imports this checkout."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(HERE)])}
    proc = subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=timeout, env=env,
        cwd=ROOT,
    )
    if check and proc.returncode != 0:
        raise AssertionError(f"python {' '.join(args)} failed:\n{proc.stdout}\n{proc.stderr}")
    return proc


def make_mesh(n_inner: int = 12, n_tread: int = 5, seed: int = 0) -> storage.MeshNodes:
    rng = np.random.default_rng(seed)
    return storage.MeshNodes(
        inner_ids=np.arange(n_inner) * 3 + 7,
        inner_xyz=rng.normal(scale=200.0, size=(n_inner, 3)),
        inner_row=np.arange(n_inner) // 4,
        inner_col=np.arange(n_inner) % 4,
        tread_ids=np.arange(n_tread) + 5000,
        tread_xyz=rng.normal(scale=300.0, size=(n_tread, 3)),
        tread_row=np.arange(n_tread) // 2,
        tread_col=np.arange(n_tread) % 2,
    )


def make_attrs(mesh_key: str = "mesh-a") -> storage.GroupAttrs:
    return storage.GroupAttrs(
        model_spec=json.dumps({"kind": "reduced", "mesh": {"tread": 8}}),
        mesh_key=mesh_key,
        solver="CalculiX 2.20",
        package_versions={"tyre-farm": "0.1.0", "numpy": np.__version__},
    )


def _rng(experiment_id: str) -> np.random.Generator:
    return np.random.default_rng(int(hashlib.sha256(experiment_id.encode()).hexdigest()[:16], 16))


def make_result(experiment_id: str, n_inner: int, n_tread: int) -> dict[str, np.ndarray]:
    """The result arrays of one experiment, shapes as write_experiment wants them."""
    rng = _rng(experiment_id)
    return {
        "displacement": rng.normal(size=(n_inner, 3)),
        "strain": rng.normal(scale=1e-2, size=(n_inner, 3)),
        "surface_strain": rng.normal(scale=1e-2, size=(n_inner, 3)),
        "reaction_force": rng.normal(scale=50.0, size=(n_tread, 3)),
        "total_force": rng.normal(scale=1e3, size=3),
        "moment": rng.normal(scale=1e4, size=3),
    }


def make_info(experiment_id: str) -> dict[str, float | int]:
    rng = _rng(experiment_id + "/info")
    return {
        "solve_seconds": float(rng.uniform(2, 15)),
        "increments": int(rng.integers(1, 50)),
        "ccx_runs": int(rng.integers(1, 4)),
        "contact_nodes": int(rng.integers(0, 100)),
        **make_patch(experiment_id),
    }


def make_patch(experiment_id: str) -> dict[str, float]:
    """Contact patch and inflation growth of one experiment (issue 24), by store name."""
    rng = _rng(experiment_id + "/patch")
    return {name: float(rng.uniform(0.1, 100)) for name in storage.schema.PATCH_NAMES}


def make_params(ids: list[str]) -> dict[str, np.ndarray]:
    """Load-case parameters that are a function of the id (so re-reserving agrees)."""
    rng = [_rng(e + "/params") for e in ids]
    return {
        "deflection": np.array([r.uniform(1, 40) for r in rng]),
        "pressure": np.array([0.1 * r.integers(0, 3) for r in rng]),
    }
