"""Every key the farm derives, from one recipe (docs/architecture.md, "Identity").

A key is the SHA-256 of canonical JSON (sorted keys, :func:`farm.specs.content_hash`) of
the same ingredients everywhere:

- the model spec (``ModelSpec.to_dict()``);
- the mesh key (:func:`farm.mesh.version.mesh_key`: the spec's geometry and density AND
  the mesher's version and gmsh's - a geometry fix once answered for hours from stale
  caches because keys left the mesher out);
- the solver version (``"CalculiX 2.20"``);
- what is solved: a load case for an experiment, a task body for a loop evaluation.

Experiments (sweeps), evaluations (inverse and calibration loops), load paths and loop
solves all take their keys from here, so two parts of the farm can never disagree on
what "the same input" means.

Compatibility: stores written before this module (recipe 1) hold experiment ids that
leave the mesher out. Their groups are guarded by the group's ``mesh_key`` (a group
refuses a mesh from other code), so within such a group the old id still names exactly
one experiment: :func:`resolve_ids` keeps the id a group already holds, and a resumed
old store skips what it has instead of solving it again.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from farm.mesh.version import mesh_key
from farm.specs import ModelSpec, RoadMotion, content_hash

RECIPE = 2  # 1: experiment ids without the mesh key (stores written before 2026-11)
DIGITS = 9  # forces (N) and displacements (mm) in keys and decks are rounded to 1e-9


def canonical(values) -> tuple[float, ...]:
    """Values rounded to :data:`DIGITS` decimals, -0.0 made 0.0 (hash- and deck-stable)."""
    return tuple(float(v) + 0.0 for v in np.round(np.asarray(values, dtype=float), DIGITS))


def model_hash(model: ModelSpec) -> str:
    """Content hash of a model spec alone (default group names)."""
    return content_hash(model.to_dict())


def ingredients(model: ModelSpec, solver: str) -> dict:
    """What every key of a solve of ``model`` hashes."""
    return {"model": model.to_dict(), "mesh": mesh_key(model), "solver": solver}


def _load(deflection: float, pressure: float, motion: RoadMotion | None = None) -> dict:
    load: dict[str, Any] = {"deflection_mm": round(float(deflection), 9),
            "pressure_mpa": round(float(pressure), 12)}
    # Combined loads (issue 13, docs/combined-loads.md): the motion's canonical dict joins
    # the load case only when there is a motion, as ModelSpec.reinforcement joins the
    # model's, so every vertical experiment keeps the id it had before. A motion at its
    # defaults is no motion (LoadPath normalises it to None): same id as vertical.
    if motion is not None and not motion.is_identity:
        load["motion"] = motion.to_dict()
    return load


def experiment_id(model: ModelSpec, deflection: float, pressure: float, solver: str,
                  motion: RoadMotion | None = None) -> str:
    """Id of one virtual experiment: model, mesh, solver and load case (with its road
    motion, for a combined-load experiment)."""
    return content_hash({**ingredients(model, solver),
                         "load": _load(deflection, pressure, motion)})


def legacy_experiment_id(model: ModelSpec, deflection: float, pressure: float,
                         solver: str) -> str:
    """Recipe 1 (without the mesh key): the ids of stores written before :data:`RECIPE` 2."""
    return content_hash({"model": model.to_dict(), "load": _load(deflection, pressure),
                         "solver": solver})


def evaluation_key(kind: str, model: ModelSpec, solver: str, outputs: int,
                   task: Mapping) -> str:
    """Key of one loop evaluation: its kind, the version of its outputs and its task."""
    return content_hash({**ingredients(model, solver), "kind": kind, "outputs": outputs,
                         "task": dict(task)})


def path_key(experiment_ids: Iterable[str], label: str = "", kind: str = "path") -> str:
    """Dask key of a load-path task: the same experiments are never run twice at once.

    ``label`` (:func:`load_label`) names the load case where the dashboard shows the key
    (issue 48); the hash of the ids alone makes the key unique. ``kind`` is the first
    word, which Dask groups tasks by (``path``, ``trunk``, ``slide``)."""
    return "-".join(x for x in (kind, label, content_hash(list(experiment_ids))[:24]) if x)


def load_label(pressure: float, deflections: Iterable[float], motion=None) -> str:
    """A load case as a key's words: ``200kPa-10to40mm-mu0.6-sx3-tilt2``; pressure in
    MPa, deflections in mm, a :class:`farm.specs.RoadMotion` or None. Only characters
    safe in a file name (a path's claim is a file named by its key)."""
    ds = sorted(float(d) for d in deflections)
    span = f"{ds[0]:g}mm" if len(ds) == 1 or ds[0] == ds[-1] else f"{ds[0]:g}to{ds[-1]:g}mm"
    words = [f"{1000 * pressure:g}kPa", span] if ds else [f"{1000 * pressure:g}kPa"]
    if motion is not None:
        for name, short in (("friction", "mu"), ("shift_x", "sx"), ("shift_y", "sy"),
                            ("tilt", "tilt"), ("slip_ratio", "kappa"),
                            ("slip_angle", "alpha"), ("roll", "roll")):
            value = getattr(motion, name, 0.0)
            if value:
                words.append(f"{short}{value:.4g}")
    return "-".join(words)


def value_key(body: Mapping) -> str:
    """Key of a plain value that names no solve itself (an inverse problem, a loop)."""
    return content_hash(dict(body))


def resolve_ids(new: list[str], legacy: list[str], held: Iterable[str]) -> list[str]:
    """The ids to use in a group that already holds ``held`` (the compatibility rule).

    Each experiment keeps the recipe-1 id its group holds; anything else (a new group, a
    new load case) gets the current id.
    """
    held = set(held)
    return [old if new_id not in held and old in held else new_id
            for new_id, old in zip(new, legacy, strict=True)]
