"""The thesis reproduction's simulations (``farm reproduce``) as plain functions.

``validation.run`` solves the chapter-3 force-deflection sweeps and ``inverse.run`` the
chapter-4 inverse study; each returns a :class:`StageRun` (the study texts and parsed
studies, the farm's reports, ccx runs, solver and wall seconds, notes about failures).
Tables and figures are drawn from the store by ``analysis.report``; the CLI wires both.
Nothing here prints: progress lines go to an optional ``log`` callback, else to logging.
"""

from jobs.reproduce.options import COARSE_MESH, Options
from jobs.reproduce.stage import StageRun

__all__ = ["COARSE_MESH", "Options", "StageRun"]
