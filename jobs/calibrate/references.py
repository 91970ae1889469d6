"""Force-deflection reference points a calibration matches.

The thesis' own points (the defaults): the reduced model's 359 N at 30 mm (§3.3.1) and
the full model's 3933 N at 25 mm / 80 kPa (§3.4) and 4476 N at 30 mm / 200 kPa
(§3.3.2/§3.4, read from the thesis' Fig. 3.3 model curve). A CSV gives others::

    model,deflection_mm,pressure_kpa,force_n
    full,25,80,3933
    full,30,200,4476
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from jobs.errors import StudyError

COLUMNS = ("model", "deflection_mm", "pressure_kpa", "force_n")


@dataclass(frozen=True)
class ReferencePoint:
    """One point: model kind, deflection (mm), pressure (MPa) and vertical force (N)."""

    model: str
    deflection: float
    pressure: float
    force: float
    source: str = ""


THESIS_POINTS = (
    ReferencePoint("reduced", 30.0, 0.0, 359.0, "thesis §3.3.1: reduced model, 30 mm"),
    ReferencePoint("full", 25.0, 0.08, 3933.0, "thesis §3.4: full model, 25 mm, 80 kPa"),
    ReferencePoint("full", 30.0, 0.2, 4476.0, "thesis Fig. 3.3: full model, 30 mm, 200 kPa"),
)


def thesis_points(model: str) -> tuple[ReferencePoint, ...]:
    return tuple(p for p in THESIS_POINTS if p.model == model)


def _number(row: dict, key: str, where: str, positive: bool) -> float:
    try:
        v = float(row[key])
    except (TypeError, ValueError) as e:
        raise StudyError(f"{where}: {key} must be a number, got {row[key]!r}") from e
    if not math.isfinite(v) or v < 0 or (positive and v == 0):
        raise StudyError(f"{where}: {key} must be {'> 0' if positive else '>= 0'}, got {v!r}")
    return v


def read_points(path: str | Path, model: str) -> tuple[ReferencePoint, ...]:
    """The CSV's points of ``model`` (raises :class:`StudyError` naming the bad row)."""
    path = Path(path)
    try:
        with path.open(newline="") as f:
            rows = list(csv.DictReader(f))
            header = set(rows[0]) if rows else set()
    except OSError as e:
        raise StudyError(f"cannot read references {path}: {e.strerror or e}") from e
    missing = [c for c in COLUMNS if c not in header]
    if not rows or missing:
        raise StudyError(f"{path}: needs a header with {', '.join(COLUMNS)} and at least one "
                         f"row{'; missing ' + missing[0] if rows else ''}")
    points = []
    for k, row in enumerate(rows, start=2):
        where = f"{path} line {k}"
        kind = (row["model"] or "").strip()
        if kind not in ("reduced", "full"):
            raise StudyError(f"{where}: model must be reduced or full, got {kind!r}")
        if kind != model:
            continue
        pressure = _number(row, "pressure_kpa", where, positive=False) / 1000.0
        if (pressure > 0) != (kind == "full"):
            need = ("inflated: give pressure_kpa > 0" if kind == "full"
                    else "not inflated: pressure_kpa must be 0")
            raise StudyError(f"{where}: the {kind} model is {need}")
        points.append(ReferencePoint(kind, _number(row, "deflection_mm", where, True), pressure,
                                     _number(row, "force_n", where, True), str(path)))
    if not points:
        raise StudyError(f"{path} has no reference point for the {model} model")
    return tuple(points)
