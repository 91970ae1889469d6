"""Mesh once per model: an in-process memo in front of an on-disk cache.

Meshes depend only on geometry, density and sector, and on the mesher's code
(:func:`farm.mesh.version.mesh_key`), not on materials or loads, so a sweep meshes each
model once per machine. Files are written
atomically, so workers sharing a cache directory never see a partial mesh.
"""

from __future__ import annotations

import os
from pathlib import Path

from farm.mesh.build import build_mesh
from farm.mesh.tyremesh import TyreMesh
from farm.mesh.version import mesh_key
from farm.specs import ModelSpec

_MEMO: dict[str, TyreMesh] = {}


def cache_dir() -> Path:
    """``$FARM_CACHE_DIR``, else ``$XDG_CACHE_HOME/tyre-farm``, else ``~/.cache/tyre-farm``."""
    if env := os.environ.get("FARM_CACHE_DIR"):
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "tyre-farm"


def mesh_for(spec: ModelSpec, directory: str | Path | None = None) -> TyreMesh:
    """The mesh of ``spec``, built at most once per process and cache directory."""
    key = mesh_key(spec)
    if key in _MEMO:
        return _MEMO[key]
    folder = Path(directory) if directory is not None else cache_dir()
    path = folder / "meshes" / f"{key[:32]}.npz"
    try:
        mesh = TyreMesh.load(path)
    except (OSError, KeyError, ValueError):
        mesh = build_mesh(spec)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            mesh.save(path)
        except OSError:
            pass  # a read-only cache only costs a re-mesh next time
    _MEMO[key] = mesh
    return mesh
