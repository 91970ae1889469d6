"""The canonical form of specs: content hashes and dataclasses read from plain data.

``to_dict``/``from_dict`` of the specs give the canonical form used for content hashes
(jobs) and for study files; :func:`spec_from_dict` rejects unknown keys so that a typo is
never ignored. Knows no spec family: the families import it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import typing
from typing import Any, get_args, get_type_hints

from farm.errors import SpecError, shown


def content_hash(data: Any) -> str:
    """SHA-256 of the canonical (sorted-key, compact) JSON form of ``data``."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def spec_from_dict(cls: type, data: Any, where: str) -> Any:
    """Build a (nested) frozen dataclass from plain data, rejecting unknown keys."""
    if not isinstance(data, dict):
        raise SpecError(f"{where} must be a table of keys, got {type(data).__name__} "
                        f"{shown(data)}")
    hints = get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise SpecError(
            f"unknown key {where}.{unknown[0]}; allowed keys: {', '.join(sorted(names))}"
        )
    kwargs = {}
    for name, value in data.items():
        hint = _optional_dataclass(hints[name]) if value is not None else hints[name]
        if isinstance(hint, type) and dataclasses.is_dataclass(hint):
            value = spec_from_dict(hint, value, f"{where}.{name}")
        elif typing.get_origin(hint) is tuple:
            if not isinstance(value, list | tuple):
                raise SpecError(f"{where}.{name} must be a list, got {shown(value)}")
            value = tuple(value)
        elif hint is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        elif hint in (float, int) and not _is_number(value, hint):
            raise SpecError(f"{where}.{name} must be a {hint.__name__}, "
                            f"got {shown(value)}")
        kwargs[name] = value
    try:
        return cls(**kwargs)
    except TypeError as e:  # a required key is missing
        raise SpecError(f"{where}: {e}") from e
    except SpecError as e:  # name the key where it is: model.materials.tread.youngs_modulus
        prefix = getattr(cls, "_prefix", None)
        if prefix is None or not str(e).startswith(f"{prefix}."):
            raise
        raise SpecError(where + str(e).removeprefix(prefix)) from e


def _optional_dataclass(hint: Any) -> Any:
    """``X`` for a hint ``X | None`` with ``X`` a dataclass, else ``hint``."""
    args = [a for a in get_args(hint) if a is not type(None)]
    return args[0] if len(args) == 1 and dataclasses.is_dataclass(args[0]) else hint


def _is_number(value: Any, hint: type) -> bool:
    if isinstance(value, bool):
        return False
    if hint is int:
        return isinstance(value, int)
    return isinstance(value, int | float)

