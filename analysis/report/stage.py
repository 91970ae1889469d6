"""What one stage of the reproduction hands the report: its tables, figures and costs.

A module of its own so that the chapters and the report's writer (:mod:`.reproduction`,
which also reads the chapters' table names) can both import it without a cycle.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd


@dataclass
class StageResult:
    """Tables, figures and notes of one stage, with what it cost."""

    name: str
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    figures: dict[str, Path] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    wall_seconds: float = 0.0
    ccx_runs: int = 0
    solver_seconds: float = 0.0
    studies: dict[str, str] = field(default_factory=dict)
