"""The model a rolling benchmark solves, from its command line: a mesh preset
(``--mesh patch``) or the coarse counts (``--circumferential``, ``--wall``), with
``--materials``. Benchmarks import this as a sibling module (a script's own folder is
on its path)."""

from __future__ import annotations

import argparse

from farm.presets import default_model
from farm.specs import MeshDensity, ModelSpec


def add_model_args(p: argparse.ArgumentParser, circumferential: int = 16,
                   radius: float = 403.8) -> None:
    """``--mesh``, ``--circumferential``, ``--materials`` and ``--radius`` (mm)."""
    p.add_argument("--mesh", default="", help="a mesh preset (e.g. patch)")
    p.add_argument("--circumferential", type=int, default=circumferential)
    p.add_argument("--materials", default="table-3.1")
    p.add_argument("--radius", type=float, default=radius, help="rolling radius, mm")


def model(a: argparse.Namespace) -> ModelSpec:
    """The full model of ``a``'s mesh preset, or of its counts (``--wall`` tread,
    sidewall, bead; 4,2,1 where the benchmark has no such option)."""
    if a.mesh:
        return default_model("full", mesh=a.mesh, materials=a.materials)
    tread, sidewall, bead = (int(n) for n in getattr(a, "wall", "4,2,1").split(","))
    return default_model("full", materials=a.materials, mesh=MeshDensity(
        tread=tread, sidewall=sidewall, bead=bead, circumferential=a.circumferential))
