"""Parsing of command-line values into typed specs (errors are SpecErrors, one line).

The rules are the ones study files follow (:mod:`jobs.validate.lists`,
:mod:`farm.overrides`): ``10:40:5`` is the study's ``{ start = 10, stop = 40, step = 5 }``
and ``--set mesh.tread=4`` its ``[model.mesh] tread = 4``. Only the command-line syntax is
parsed here.
"""

from __future__ import annotations

from typing import Any

import typer

from farm.errors import SpecError
from farm.overrides import override_model
from farm.presets import default_model
from farm.specs import ModelSpec
from jobs.errors import StudyError
from jobs.validate import lists
from jobs.validate.messages import shown

RANGE_HINT = "give start:stop:step (e.g. 10:40:5) or a list (10,20,30)"


def parse_range(text: str, what: str = "deflection") -> tuple[float, ...]:
    """``"10:40:5"`` (inclusive start:stop:step), ``"10,20,30"`` or ``"30"`` -> sorted floats:
    the command line's form of a study's value list (:func:`jobs.validate.lists.values`),
    ``10:40:5`` its range ``{start = 10, stop = 40, step = 5}``.

    Bounds (a deflection > 0) are the load path's to check (:class:`farm.specs.LoadPath`).
    """
    parts = text.split(":") if ":" in text else text.split(",")
    try:
        numbers = [float(p) for p in parts]
    except ValueError as e:
        raise SpecError(f"cannot read {what} {shown(text)}: {RANGE_HINT}") from e
    if ":" in text and len(numbers) != 3:
        raise SpecError(f"{what} range {shown(text)} needs three numbers: start:stop:step")
    value = dict(zip(("start", "stop", "step"), numbers, strict=True)) if ":" in text else numbers
    try:
        return lists.values(value, what)
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
    if text.lower() in ("true", "false"):  # switches, e.g. reinforcement.tension_only
        return text.lower() == "true"
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            continue
    return text


MATERIALS_HELP = ("Material preset: table-3.1 (the thesis' Table 3.1), thesis-calibrated, "
                  "cord-reinforced, reinforced-calibrated (full model, fitted on the patch "
                  "mesh), reinforced-converged (full model, fitted on the converged mesh), "
                  "reinforced-lean (full model, fitted on the lean mesh: the one for "
                  "results; docs/reinforcement.md).")
MESH_HELP = ("Mesh preset: thesis (Table 3.1's element counts), patch (full model only: "
             "refined over +-32 degrees about the road), converged (full model only: patch "
             "with the sidewall and the wall's depth refined) or lean (full model only: "
             "converged with one element through the wall, belts at depth by equations, "
             "1.7-1.8x patch's cost: the one for results; docs/mesh-convergence.md).")
#: The model options ``farm run`` and ``farm roll`` share (typer reads them per command).
MATERIALS_OPTION = typer.Option("table-3.1", "--materials", help=MATERIALS_HELP)
MESH_OPTION = typer.Option("thesis", "--mesh", help=MESH_HELP)
THREADS_OPTION = typer.Option(1, "--threads", help="Solver threads.")
KPA_HINT_BELOW = 5.0  # no tyre is inflated to under 5 kPa; 0.08-0.4 is a pressure in MPa


def kpa_hint(kpa: float) -> str:
    """A warning line when a pressure in kPa looks like one in MPa (issue 48: ``--pressure
    0.2`` was taken as 0.2 kPa without a word), else ''."""
    if not 0 < kpa < KPA_HINT_BELOW:
        return ""
    return (f"note: --pressure {kpa:g} is {kpa:g} kPa (a nearly flat tyre); pressures are "
            f"kPa, so {kpa * 1000:g} kPa is --pressure {kpa * 1000:g}")


def check_materials(name: str) -> str:
    """``name`` if it is a material preset, else one :class:`SpecError` line naming them."""
    from farm.presets import MATERIAL_PRESETS

    if name not in MATERIAL_PRESETS:
        raise SpecError(f"unknown material preset {shown(name)}: choose one of "
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
    # farm.overrides raises SpecError itself: the walk stays in farm (issue 49)
    return override_model(base, table)
