"""Parsing of command-line values into typed specs (errors are SpecErrors, one line)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from farm.errors import SpecError
from farm.presets import default_model
from farm.specs import ModelSpec


def _floats(parts: list[str], text: str, what: str) -> list[float]:
    try:
        return [float(v) for v in parts]
    except ValueError as e:
        raise SpecError(
            f"cannot read {what} {text!r}: give start:stop:step (e.g. 10:40:5) or a list (10,20,30)"
        ) from e


def parse_range(text: str, what: str = "deflection") -> tuple[float, ...]:
    """``"10:40:5"`` (inclusive start:stop:step), ``"10,20,30"`` or ``"30"`` -> floats."""
    if ":" not in text:
        return tuple(_floats(text.split(","), text, what))
    parts = _floats(text.split(":"), text, what)
    if len(parts) != 3:
        raise SpecError(f"{what} range {text!r} needs three numbers: start:stop:step")
    start, stop, step = parts
    if not (math.isfinite(step) and step > 0):
        raise SpecError(f"{what} step must be positive, got {text!r}")
    if not stop >= start:
        raise SpecError(f"{what} range {text!r} is empty: give start:stop:step with stop >= start")
    n = math.floor((stop - start) / step + 1e-9) + 1
    return tuple(float(v) for v in np.round(start + step * np.arange(n), 10))


def _set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    *parents, leaf = key.split(".")
    node = data
    for p in parents:
        if not isinstance(node.get(p), dict):
            raise SpecError(f"unknown setting {key!r}: {p!r} is not a table of the model spec")
        node = node[p]
    if leaf not in node:
        raise SpecError(f"unknown setting {key!r}; known keys here: {', '.join(sorted(node))}")
    node[leaf] = value


def _literal(text: str) -> Any:
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            continue
    return text


def build_model(kind: str, materials: str, road: str | None, overrides: list[str]) -> ModelSpec:
    """A preset model with ``key=value`` overrides (dotted keys, e.g. mesh.circumferential=80)."""
    base = default_model(kind, materials=materials)
    data = base.to_dict()
    if road is not None:
        data["road"] = road
    for item in overrides:
        key, sep, value = item.partition("=")
        if not sep:
            raise SpecError(f"--set expects key=value (e.g. mesh.circumferential=80), got {item!r}")
        _set_dotted(data, key.strip(), _literal(value.strip()))
    return ModelSpec.from_dict(data)
