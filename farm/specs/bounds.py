"""Bounds and checks that more than one family of specs shares.

A spec family's own bounds and checks live in its module (:mod:`farm.specs.model`,
:mod:`farm.specs.loads`, :mod:`farm.specs.solver`); what two families need, the
tangential penalty's range (a contact law's and a road motion's ``stick_slope``) and the
number check every ``__post_init__`` uses, lives here, below them all. Bounds are
generous for research, but no absurdities (E = 1e308 MPa, a 1e-9 s timeout, 2**63
threads) reach the solver; docs/limits.md has the table.

:class:`Limit` is a practical limit, not a physical one, that a researcher may raise
through an environment variable: the model's mesh nodes
(:data:`farm.specs.model.MESH_NODES`) and a study's experiments
(:data:`jobs.validate.limits.EXPERIMENTS`, which raises the study's error).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from farm.errors import SpecError, shown

STICK_SLOPE = (1e-3, 1e4)  # N/mm^3: ContactLaw.stick_slope and RoadMotion.stick_slope


def within(name: str, value: float, bounds: tuple[float, float], unit: str) -> None:
    """Raise :class:`SpecError` unless ``value`` is a finite number (not a boolean) in
    ``bounds``, inclusive; ``unit`` names its unit in the message."""
    low, high = bounds
    if not (isinstance(value, int | float) and not isinstance(value, bool)
            and math.isfinite(value) and low <= value <= high):
        raise SpecError(f"{name} must be a number in [{low:g}, {high:g}] {unit}, "
                        f"got {shown(value)}")


@dataclass(frozen=True)
class Limit:
    """A practical limit (not a physical one) that a researcher may raise: the
    environment variable ``env`` overrides ``default`` (docs/limits.md). Its errors are
    ``error``s: :class:`SpecError` for a spec's limit, the study's error for a study's."""

    name: str  # what is counted, plural ("experiments")
    env: str
    default: int
    error: type[Exception] = SpecError

    def value(self) -> int:
        text = os.environ.get(self.env)
        if text is None or not text.strip():
            return self.default
        try:
            value = int(text)
        except ValueError:
            value = 0
        if not 1 <= value <= 10 ** 12:
            raise self.error(f"{self.env} must be a whole number of {self.name} in [1, 1e12], "
                             f"got {shown(text)}")
        return value

    def check(self, count: int, where: str, what: str) -> int:
        """``count`` if within the limit, else one error naming ``where`` and ``what``:
        ``"<where>: <what> is <count> <name>, above the limit of ..."``."""
        limit = self.value()
        if count > limit:
            raise self.error(f"{where}: {what} is {count} {self.name}, above the limit of "
                             f"{limit} (set {self.env} to raise it; docs/limits.md)")
        return count
