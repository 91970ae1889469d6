"""Practical limits of input (docs/limits.md is their one table), some raisable by the user.

Counts are computed before anything is expanded: a study has at most :data:`EXPERIMENTS`
experiments, a limit that a researcher may raise through its environment variable
(:class:`~farm.specs.bounds.Limit`). The other numbers bound what one
file, list or loop may hold. The bounds of the specs (moduli, pressures, threads,
timeouts, and the practical limit of a model's mesh nodes,
:data:`farm.specs.model.MESH_NODES`) live with the specs in :mod:`farm.specs`.
"""

from __future__ import annotations

from farm.specs.bounds import Limit
from jobs.errors import StudyError

MAX_VALUES = 100_000  # values one list or range may expand to
DECIMALS = 9  # rounding of range values (a nanometre in mm)
MAX_FILE_BYTES = 1 << 20  # study files and reference tables: 1 MiB (the thesis' are < 2 KiB)
MAX_DEPTH = 8  # tables and lists in a study nest at most this deep (the deepest needs 4)
MAX_PATH_CHARS = 4096  # a path or URL (Linux' PATH_MAX)
MAX_SEED = 2 ** 32 - 1  # seeds of designs and noise draws (numpy's legacy range)
MAX_EVALUATIONS = 100_000  # evaluations of one optimisation loop
MAX_REPEATS = 1_000  # repeats of one inverse condition
MAX_LOOPS = 10_000  # optimisation loops of one inverse study
EXPERIMENTS = Limit("experiments", "FARM_MAX_EXPERIMENTS", 10_000, StudyError)
