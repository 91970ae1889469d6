"""What one simulation stage of the reproduction did, and where its progress lines go."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

Log = Callable[[str], None]
#: A study's name -> the progress display of its run (a :class:`jobs.progress.Progress`).
ProgressFor = Callable[[str], Any]

_logger = logging.getLogger("jobs.reproduce")


@dataclass
class StageRun:
    """The studies one stage ran (TOML text and parsed), the farm's reports, the cost.

    ``reports`` holds a :class:`jobs.sweep.SweepReport` per sweep or the
    :class:`jobs.inverse.run.InverseReport`; ``notes`` say what failed (and, for the
    inverse study, what was solved), for the report to print as they are.
    """

    name: str
    texts: dict[str, str] = field(default_factory=dict)
    studies: dict[str, Any] = field(default_factory=dict)
    reports: dict[str, Any] = field(default_factory=dict)
    ccx_runs: int = 0
    solver_seconds: float = 0.0
    wall_seconds: float = 0.0
    notes: list[str] = field(default_factory=list)


def logger(log: Log | None) -> Log:
    """``log`` itself, or the package logger's ``info`` when none is given."""
    return log if log is not None else _logger.info
