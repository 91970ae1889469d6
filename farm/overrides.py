"""Model overrides: a preset model and a table of changed keys, merged into one ModelSpec.

The one merge behind a study's ``[model]`` table (:mod:`jobs.validate.spec_tables`),
``farm run --set`` (:mod:`tyre_farm_cli.params`) and the rows of a model-space design
(:mod:`jobs.design`): the overrides go onto the preset's
:meth:`~farm.specs.ModelSpec.editable_dict` key by key, nested tables merged, and
:meth:`~farm.specs.ModelSpec.from_dict` checks the result (and
:meth:`~farm.specs.ModelSpec.check_mesh_nodes` its size). The keys and kinds a
``[model]`` table takes are read off :class:`~farm.specs.ModelSpec` and
:data:`~farm.specs.ModelKind`, so a field is accepted the day it is added. Errors are one
:class:`SpecError` line naming the key path::

    model.mesh.treads: unknown key; allowed: bead, circumferential, ...
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from collections.abc import Set as AbstractSet
from typing import Any, get_args, get_type_hints

from farm.errors import SpecError, shown
from farm.presets import MATERIAL_PRESETS, default_model, mesh_presets
from farm.specs import ModelKind, ModelSpec

MODEL_KEYS = frozenset(f.name for f in dataclasses.fields(ModelSpec))
MODEL_KINDS: tuple[str, ...] = get_args(ModelKind)


def _optional_parts() -> dict[str, type]:
    """Fields of :class:`ModelSpec` that hold a dataclass or ``None`` (``reinforcement``:
    ``None`` is the cordless wall), by name."""
    hints = get_type_hints(ModelSpec)
    parts: dict[str, type] = {}
    for f in dataclasses.fields(ModelSpec):
        args = [a for a in get_args(hints[f.name]) if a is not type(None)]
        if f.default is None and len(args) == 1:
            hint = args[0]
            if isinstance(hint, type) and dataclasses.is_dataclass(hint):
                parts[f.name] = hint
    return parts


#: A preset without one of these (the cordless ``table-3.1``) has no table to merge into;
#: a table given for it changes the part's defaults, as :meth:`ModelSpec.from_dict` reads
#: it: ``[model.reinforcement]`` alone gives the default cords.
OPTIONAL_PARTS = _optional_parts()


def model(data: Any, where: str = "model") -> ModelSpec:
    """A ``[model]`` table -> :class:`ModelSpec`: ``kind``, a ``materials`` preset name (or
    a table per region over ``table-3.1``) and overrides of the preset's other keys."""
    t = table(data, where, MODEL_KEYS, {"kind"})
    kind = t["kind"]
    if kind not in MODEL_KINDS:
        raise _fail(f"{where}.kind", f"unknown model {shown(kind)}: choose "
                    f"{' or '.join(map(repr, MODEL_KINDS))}")
    materials = t.get("materials", "table-3.1")
    if isinstance(materials, str) and materials not in MATERIAL_PRESETS:
        raise _fail(f"{where}.materials", f"unknown preset {shown(materials)}; presets: "
                    f"{', '.join(MATERIAL_PRESETS)} (or give a table per region)")
    mesh = t.get("mesh", "thesis")
    if isinstance(mesh, str) and mesh not in mesh_presets(kind):
        raise _fail(f"{where}.mesh", f"unknown mesh preset {shown(mesh)} for the {kind} "
                    f"model; presets: {', '.join(mesh_presets(kind))} (or give a table of "
                    "counts)")
    base = default_model(kind, materials if isinstance(materials, str) else "table-3.1",
                         mesh if isinstance(mesh, str) else "thesis")
    overrides = {k: v for k, v in t.items()
                 if k != "kind" and not (k in ("materials", "mesh") and isinstance(v, str))}
    return override_model(base, overrides, where)


def override_model(base: ModelSpec, overrides: dict[str, Any], where: str = "model"
                   ) -> ModelSpec:
    """``base`` with ``overrides``: nested tables merged key by key, unknown keys named;
    an optional part ``base`` lacks (:data:`OPTIONAL_PARTS`) merged onto its defaults.
    The result is a mesh of at most :data:`farm.specs.model.MESH_NODES` nodes
    (:meth:`~farm.specs.ModelSpec.check_mesh_nodes`)."""
    editable = base.editable_dict()
    for name, part in OPTIONAL_PARTS.items():
        if isinstance(overrides, dict) and name in overrides and editable.get(name) is None:
            editable[name] = dataclasses.asdict(part())
    spec = ModelSpec.from_dict(merge(editable, overrides, where))
    spec.check_mesh_nodes(where)
    return spec


def merge(base: dict, override: dict, where: str) -> dict:
    """``base`` with the keys of ``override`` (each one of ``base``'s), tables merged."""
    out = dict(table(override, where, set(base)))
    for key, value in override.items():
        if isinstance(base[key], dict):
            out[key] = merge(base[key], value, f"{where}.{key}")
    return {**base, **out}


def _fail(where: str, message: str) -> SpecError:
    return SpecError(f"{where}: {message}")


def table(data: Any, where: str, allowed: AbstractSet[str],
          required: AbstractSet[str] = frozenset(),
          fail: Callable[[str, str], Exception] = _fail) -> dict[str, Any]:
    """``data`` if it is a table with only ``allowed`` keys and every ``required`` one;
    otherwise ``fail(where, message)`` is raised (a :class:`SpecError` here; the study
    checks, :func:`jobs.validate.scalars.table`, pass their own)."""
    if not isinstance(data, dict):
        raise fail(where, f"must be a table, got {type(data).__name__} {shown(data)}")
    unknown = sorted(set(data) - allowed)
    if unknown:
        raise fail(f"{where}.{unknown[0]}",
                   f"unknown key; allowed: {', '.join(sorted(allowed))}")
    missing = sorted(required - set(data))
    if missing:
        raise fail(f"{where}.{missing[0]}", "is required")
    return data
