"""The study tables that become farm specs: ``[model]`` and ``[solver]``.

A ``[model]`` table is a preset with overrides, merged and checked by
:mod:`farm.overrides` (the rule ``farm run --set`` follows too), its mesh held to
:data:`farm.specs.model.MESH_NODES` there; here its errors become the study's
:class:`~jobs.errors.StudyError`. A ``[solver]`` table is ccx's
:class:`~farm.specs.SolverSettings` plus how a sweep splits and retries load paths.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from farm import overrides
from farm.errors import SpecError
from farm.specs import TIMEOUT_S, ModelSpec, SolverSettings
from jobs.errors import StudyError
from jobs.validate.scalars import boolean, integer, number, table

SOLVER_KEYS = {"timeout_s", "threads", "initial_increment", "min_increment", "max_increment",
               "max_increments", "max_path_length", "retry_smaller_increments", "split_rise",
               "grow_after", "restart_every_mm"}


def model(data: Any, where: str = "model") -> ModelSpec:
    """A ``[model]`` table -> :class:`ModelSpec` (:func:`farm.overrides.model`), a mesh of
    at most :data:`farm.specs.model.MESH_NODES` nodes."""
    try:
        return overrides.model(data, where)
    except SpecError as e:  # its messages name the key (model.mesh.tread ...)
        raise StudyError(str(e)) from e


def override_model(base: ModelSpec, changes: dict[str, Any], where: str = "model"
                   ) -> ModelSpec:
    """``base`` with ``changes`` (:func:`farm.overrides.override_model`), a mesh of at most
    :data:`farm.specs.model.MESH_NODES` nodes."""
    try:
        return overrides.override_model(base, changes, where)
    except SpecError as e:
        raise StudyError(str(e)) from e


@dataclass(frozen=True)
class SolverTable:
    """A ``[solver]`` table: ccx settings and how the sweep splits and retries paths."""

    settings: SolverSettings
    max_path_length: int = 0  # split load paths longer than this (0: never)
    retry_smaller_increments: bool = True


def solver(data: Any, where: str = "solver") -> SolverTable:
    """A ``[solver]`` table (keys :data:`SOLVER_KEYS`; ``timeout_s`` in seconds)."""
    t = table(data, where, SOLVER_KEYS)
    kwargs: dict[str, Any] = {}
    if "timeout_s" in t:
        kwargs["timeout"] = number(t["timeout_s"], f"{where}.timeout_s", low=TIMEOUT_S[0],
                                   high=TIMEOUT_S[1])
    for k in ("threads", "max_increments", "grow_after"):
        if k in t:
            kwargs[k] = integer(t[k], f"{where}.{k}", low=1)
    for k in ("initial_increment", "min_increment", "max_increment"):
        if k in t:
            kwargs[k] = number(t[k], f"{where}.{k}", low=0, strict=True)
    if "restart_every_mm" in t:
        kwargs["restart_every_mm"] = number(t["restart_every_mm"], f"{where}.restart_every_mm",
                                            low=0)
    if "split_rise" in t:
        kwargs["split_rise"] = boolean(t["split_rise"], f"{where}.split_rise")
    try:
        settings = SolverSettings(**kwargs)
    except SpecError as e:
        raise StudyError(str(e)) from e
    return SolverTable(settings,
                       integer(t.get("max_path_length", 0), f"{where}.max_path_length", low=0),
                       boolean(t.get("retry_smaller_increments", True),
                               f"{where}.retry_smaller_increments"))
