"""Deprecated: the chapter-4 tables moved to :mod:`analysis.report.ch4`, which reads them
from the inverse-solves group (:func:`storage.solves.open_solves`).

This shim only keeps ``cli/reproduce.py`` working until it reads the group back; it
builds the group's Dataset in memory and hands it over. Its import of ``analysis``
runs upward (jobs must not depend on analysis), hence lazy and temporary: delete this
module once nothing imports it.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from jobs.inverse.loop import LoopResult
from jobs.inverse.problem import Problem
from jobs.inverse.store import to_dataset
from storage.solves import DIRECTIONS

__all__ = ["DIRECTIONS", "cost", "forces", "histograms", "nodal_errors", "per_solve", "rmse",
           "views"]

warnings.warn("jobs.inverse.tables is deprecated: use analysis.report.ch4 on "
              "storage.solves.open_solves(store, group)", DeprecationWarning, stacklevel=2)


def _ch4():
    from analysis.report import ch4

    return ch4


def per_solve(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    return _ch4().per_solve(to_dataset(problem, results))


def forces(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    return _ch4().forces(to_dataset(problem, results))


def rmse(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    return _ch4().rmse(to_dataset(problem, results))


def nodal_errors(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    return _ch4().nodal_errors(to_dataset(problem, results))


def cost(results: Sequence[LoopResult], problem: Problem) -> pd.DataFrame:
    return _ch4().cost(to_dataset(problem, results))


def views(results: Sequence[LoopResult], problem: Problem) -> dict[str, pd.DataFrame]:
    return _ch4().views(to_dataset(problem, results))


def histograms(results: Sequence[LoopResult], problem: Problem, folder: Path) -> list[Path]:
    return _ch4().histograms(to_dataset(problem, results), folder)
