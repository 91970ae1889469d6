"""Checks of single values: tables and their keys, numbers, integers, switches, names.

Each takes the value and ``where``, its key path, and returns the value (typed) or raises
one :class:`~jobs.errors.StudyError` naming the key, the value and what is allowed.
"""

from __future__ import annotations

import math
from collections.abc import Set as AbstractSet
from typing import Any

from farm.overrides import table as checked_table
from jobs.validate.messages import fail, shown
from storage.schema import GROUP_NAME

IDENTIFIER = GROUP_NAME  # names of store groups, studies and conditions: the store's rule
RESERVED_NAMES = frozenset({"zarr.json"})  # Zarr v3's metadata file in every group


def table(data: Any, where: str, allowed: AbstractSet[str],
          required: AbstractSet[str] = frozenset()) -> dict[str, Any]:
    """``data`` if it is a table with only ``allowed`` keys and every ``required`` one."""
    return checked_table(data, where, allowed, required, fail=fail)


def _bounds(low: float | None, high: float | None, strict: bool) -> str:
    if low is not None and high is not None:
        return f"in {'(' if strict else '['}{low:g}, {high:g}]"
    if low is not None:
        return f"{'>' if strict else '>='} {low:g}"
    return f"<= {high:g}"


def number(value: Any, where: str, *, low: float | None = None, high: float | None = None,
           strict: bool = False) -> float:
    """A finite number (not a boolean), ``>= low`` (``> low`` if ``strict``), ``<= high``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise fail(where, f"must be a number, got {shown(value)}")
    if ((low is not None and (value < low or (strict and value == low)))
            or (high is not None and value > high)):
        raise fail(where, f"must be {_bounds(low, high, strict)}, got {shown(value)}")
    return float(value)


def interval(value: Any, where: str, *, low: float | None = None,
             high: float | None = None) -> tuple[float, float]:
    """A ``[low, high]`` pair of numbers within the bounds, low <= high (a design's range)."""
    if not (isinstance(value, list) and len(value) == 2):
        raise fail(where, f"must be [low, high], got {shown(value)}")
    a, b = (number(x, where, low=low, high=high) for x in value)
    if a > b:
        raise fail(where, f"needs low <= high, got {shown(value)}")
    return float(a), float(b)


def integer(value: Any, where: str, *, low: int | None = None, high: int | None = None) -> int:
    """An integer (not a boolean) in ``[low, high]`` (either bound optional)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise fail(where, f"must be an integer, got {shown(value)}")
    if (low is not None and value < low) or (high is not None and value > high):
        raise fail(where, f"must be an integer {_bounds(low, high, False)}, got {shown(value)}")
    return value


def boolean(value: Any, where: str) -> bool:
    """``true`` or ``false`` (not 0 or 1)."""
    if not isinstance(value, bool):
        raise fail(where, f"must be true or false, got {shown(value)}")
    return value


def choice(value: Any, where: str, allowed: tuple[str, ...]) -> str:
    """One of ``allowed``."""
    if not isinstance(value, str) or value not in allowed:
        raise fail(where, f"must be one of {', '.join(allowed)}, got {shown(value)}")
    return value


def choices(value: Any, where: str, allowed: tuple[str, ...]) -> tuple[str, ...]:
    """A non-empty list of ``allowed`` strings, repeats dropped, order kept."""
    if not isinstance(value, list) or not value:
        raise fail(where, f"must be a non-empty list, got {shown(value)}")
    for item in value:
        if not isinstance(item, str) or item not in allowed:
            raise fail(where, f"must list {', '.join(allowed)}; got {shown(item)}")
    return tuple(dict.fromkeys(value))


def string(value: Any, where: str, what: str = "a string", *, blank: bool = True) -> str:
    """A string (a non-blank one unless ``blank``); ``what`` says what it should be."""
    if not isinstance(value, str) or (not blank and not value.strip()):
        raise fail(where, f"must be {what}, got {shown(value)}")
    return value


def identifier(value: Any, where: str) -> str:
    """A name usable as a store group or a file name (:data:`IDENTIFIER`)."""
    if not (isinstance(value, str) and IDENTIFIER.fullmatch(value)):
        raise fail(where, f"must be letters, digits, '_', '.', '-' (at most 128), "
                   f"got {shown(value)}")
    if value in RESERVED_NAMES:  # issue 26: passed here, then failed in create_group
        raise fail(where, f"{shown(value)} is the name of Zarr's own metadata file in every "
                   "group: choose another name")
    return value
