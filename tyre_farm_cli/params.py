"""Parsing of command-line values into typed specs (errors are SpecErrors, one line).

The rules are :mod:`jobs.validate`'s, the ones study files follow: ``10:40:5`` is the
study's ``{ start = 10, stop = 40, step = 5 }`` and ``--set mesh.tread=4`` its
``[model.mesh] tread = 4``. Only the command-line syntax is parsed here.
"""

from __future__ import annotations

from typing import Any

from farm.errors import SpecError
from farm.presets import default_model
from farm.specs import ModelSpec
from jobs import validate
from jobs.errors import StudyError


def parse_range(text: str, what: str = "deflection") -> tuple[float, ...]:
    """``"10:40:5"`` (inclusive start:stop:step), ``"10,20,30"`` or ``"30"`` -> sorted floats.

    Bounds (a deflection > 0) are the load path's to check (:class:`farm.specs.LoadPath`).
    """
    try:
        return validate.values_from_text(text, what)
    except StudyError as e:
        raise SpecError(str(e)) from e


def _set_dotted(table: dict[str, Any], key: str, value: Any, item: str) -> None:
    """``a.b.c`` = value into nested tables; the keys are checked with the model's."""
    *parents, leaf = key.split(".")
    node = table
    for p in parents:
        node = node.setdefault(p, {})
        if not isinstance(node, dict):
            raise SpecError(f"--set {item!r} conflicts with an earlier --set {p}=...")
    node[leaf] = value


def _literal(text: str) -> Any:
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            continue
    return text


MATERIALS_HELP = ("Material preset: table-3.1 (the thesis' Table 3.1), thesis-calibrated, "
                  "cord-reinforced.")
MESH_HELP = ("Mesh preset: thesis (Table 3.1's element counts) or patch (full model only: "
             "refined over +-32 degrees about the road, docs/mesh-convergence.md).")


def check_materials(name: str) -> str:
    """``name`` if it is a material preset, else one :class:`SpecError` line naming them."""
    from farm.presets import MATERIAL_PRESETS

    if name not in MATERIAL_PRESETS:
        raise SpecError(f"unknown material preset {validate.shown(name)}: choose one of "
                        f"{', '.join(MATERIAL_PRESETS)}")
    return name


def build_model(kind: str, materials: str, road: str | None, overrides: list[str],
                mesh: str = "thesis") -> ModelSpec:
    """A preset model with ``key=value`` overrides (dotted keys, e.g. mesh.circumferential=80)."""
    base = default_model(kind, materials=materials, mesh=mesh)
    table: dict[str, Any] = {} if road is None else {"road": road}
    for item in overrides:
        key, sep, value = item.partition("=")
        if not sep:
            raise SpecError(f"--set expects key=value (e.g. mesh.circumferential=80), got {item!r}")
        _set_dotted(table, key.strip(), _literal(value.strip()), item)
    try:
        return validate.override_model(base, table)
    except StudyError as e:
        raise SpecError(str(e)) from e
