"""Lists of values: a number, a list or a ``{start, stop, step}`` range, by one rule.

Ranges have one rule (:func:`inclusive_range`): ``start`` to ``stop`` inclusive in steps
of ``step``, at most :data:`~jobs.validate.limits.MAX_VALUES` values, each rounded to
:data:`~jobs.validate.limits.DECIMALS` decimals so that 0.1 steps do not leave
0.30000000000000004 in a store coordinate. A study writes it
``{ start = 10, stop = 40, step = 5 }``, the CLI ``10:40:5``
(:func:`tyre_farm_cli.params.parse_range`); a list is ``[10, 20, 30]`` or ``10,20,30``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from jobs.validate.limits import DECIMALS, MAX_VALUES
from jobs.validate.messages import fail, shown
from jobs.validate.scalars import number, table

RANGE_KEYS = {"start", "stop", "step"}


def inclusive_range(start: float, stop: float, step: float, where: str) -> tuple[float, ...]:
    """``start, start + step, ...`` up to ``stop`` inclusive, rounded to :data:`DECIMALS`.

    The one range rule of study files and the CLI. ``stop`` is included when it is
    within 1e-9 steps of the grid (so 0.1 steps reach 0.3); at most :data:`MAX_VALUES`,
    counted before anything is made (a step of 1e-308 is a count, not an allocation).
    """
    if not (math.isfinite(step) and step > 0):
        raise fail(f"{where}.step", f"must be > 0, got {shown(step)}")
    if stop < start:
        raise fail(where, f"stop ({stop:g}) must not be below start ({start:g})")
    steps = (stop - start) / step
    if not steps < MAX_VALUES:  # also an infinite count, which has no integer
        count = f"{math.floor(steps + 1e-9) + 1}" if math.isfinite(steps) else "too many:"
        raise fail(where, f"{count} values is too many (at most {MAX_VALUES}): step {step:g} "
                   f"over {start:g} to {stop:g}")
    n = math.floor(steps + 1e-9) + 1
    return tuple(round(start + k * step, DECIMALS) for k in range(n))


def values(value: Any, where: str, *, low: float | None = None, high: float | None = None,
           strict: bool = False) -> tuple[float, ...]:
    """A number, a non-empty list of numbers or a ``{start, stop, step}`` range table ->
    the sorted distinct values, each ``>= low`` (``> low`` if ``strict``) and ``<= high``,
    also once rounded to :data:`DECIMALS` (5e-324 is not a deflection > 0)."""
    def bounded(v: Any, at: str) -> float:
        return number(v, at, low=low, high=high, strict=strict)

    out: Sequence[float]
    if isinstance(value, dict):
        r = table(value, where, RANGE_KEYS, RANGE_KEYS)
        start, stop = (bounded(r[k], f"{where}.{k}") for k in ("start", "stop"))
        out = inclusive_range(start, stop, number(r["step"], f"{where}.step", low=0,
                                                  strict=True), where)
        smallest = start
    elif isinstance(value, list):
        if not value:
            raise fail(where, "must not be empty")
        if len(value) > MAX_VALUES:
            raise fail(where, f"{len(value)} values is too many (at most {MAX_VALUES})")
        out = [bounded(v, f"{where}[{k}]") for k, v in enumerate(value)]
        smallest = min(out)
    else:
        out = [smallest := bounded(value, where)]
    rounded = sorted({round(v, DECIMALS) for v in out})
    if low is not None and strict and rounded[0] <= low:
        raise fail(where, f"must be > {low:g}, got {shown(smallest)} (rounds to "
                   f"{rounded[0]:g} at {DECIMALS} decimals)")
    return tuple(rounded)
