"""Practical limits of input (docs/limits.md is their one table), some raisable by the user.

Counts are computed before anything is expanded: a study has at most :data:`EXPERIMENTS`
experiments and a model at most :data:`MESH_NODES` mesh nodes, limits that a researcher
may raise through their environment variables (:class:`Limit`). The other numbers bound
what one file, list or loop may hold. Physical bounds of the specs (moduli, pressures,
threads, timeouts) live in :mod:`farm.specs`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from jobs.errors import StudyError
from jobs.validate.messages import fail, shown

MAX_VALUES = 100_000  # values one list or range may expand to
DECIMALS = 9  # rounding of range values (a nanometre in mm)
MAX_FILE_BYTES = 1 << 20  # study files and reference tables: 1 MiB (the thesis' are < 2 KiB)
MAX_DEPTH = 8  # tables and lists in a study nest at most this deep (the deepest needs 4)
MAX_PATH_CHARS = 4096  # a path or URL (Linux' PATH_MAX)
MAX_SEED = 2 ** 32 - 1  # seeds of designs and noise draws (numpy's legacy range)
MAX_EVALUATIONS = 100_000  # evaluations of one optimisation loop
MAX_REPEATS = 1_000  # repeats of one inverse condition
MAX_LOOPS = 10_000  # optimisation loops of one inverse study


@dataclass(frozen=True)
class Limit:
    """A practical limit (not a physical one) that a researcher may raise: the
    environment variable ``env`` overrides ``default`` (docs/limits.md)."""

    name: str  # what is counted, plural ("experiments")
    env: str
    default: int

    def value(self) -> int:
        text = os.environ.get(self.env)
        if text is None or not text.strip():
            return self.default
        try:
            value = int(text)
        except ValueError:
            value = 0
        if not 1 <= value <= 10 ** 12:
            raise StudyError(f"{self.env} must be a whole number of {self.name} in [1, 1e12], "
                             f"got {shown(text)}")
        return value

    def check(self, count: int, where: str, what: str) -> int:
        """``count`` if within the limit, else one error naming ``where`` and ``what``."""
        limit = self.value()
        if count > limit:
            raise fail(where, f"{what} is {count} {self.name}, above the limit of {limit} "
                       f"(set {self.env} to raise it; docs/limits.md)")
        return count


# Mesh nodes: the default full model has 1760; 200 000 nodes is a day of ccx per load path
# on one core (ccx's time grows faster than linearly in the node count).
EXPERIMENTS = Limit("experiments", "FARM_MAX_EXPERIMENTS", 10_000)
MESH_NODES = Limit("mesh nodes", "FARM_MAX_MESH_NODES", 200_000)
