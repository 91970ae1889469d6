"""Force-deflection reference points a calibration matches.

The thesis' own points (the defaults): the reduced model's 359 N at 30 mm (§3.3.1) and
the full model's 3933 N at 25 mm / 80 kPa (§3.4) and its 4476 N experiment at 30 mm,
whose pressure the thesis gives twice, differently (:mod:`jobs.calibrate.statements`):
80 kPa in §3.3.2 and Fig. 3.2, 200 kPa in chapter 5 (Table 5.1). The full model's
points therefore come in two *readings*, ``"200kPa"`` (the default, what this module
always used) and ``"80kPa"``; ``farm calibrate --reading`` chooses and says which, and
``farm compare`` holds a model to both. A CSV gives others::

    model,deflection_mm,pressure_kpa,force_n
    full,25,80,3933
    full,30,200,4476

The file is read as :func:`jobs.validate.reading.read_text` reads study files (a regular UTF-8
file of at most 1 MiB); given the model spec, every point is checked against it as a
load path is (pressures up to 1000 kPa, deflections the tyre can take).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

from farm.errors import SpecError
from farm.specs import MAX_PRESSURE_MPA, LoadPath, ModelSpec
from jobs.calibrate.statements import STATEMENTS
from jobs.errors import StudyError
from jobs.validate import reading
from jobs.validate.messages import shown

MAX_FORCE_N = 1e6  # a reference force: 100 t on one tyre

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
    ReferencePoint("full", 30.0, 0.2, 4476.0,
                   "thesis ch. 5 (Table 5.1, §5.4-5.5): full model, 30 mm, 200 kPa"),
)
READING_POINTS = {
    "200kPa": THESIS_POINTS[1:],
    "80kPa": (THESIS_POINTS[1], ReferencePoint(
        "full", 30.0, 0.08, 4475.5, "thesis §3.3.2, Fig. 3.2: full model, 30 mm, 80 kPa")),
}
DEFAULT_READING = "200kPa"
MEASURED_RATIO = next(s.value for s in STATEMENTS if s.key == "stiffness-ratio")
"""The measured tyre's mean stiffness at 200 kPa over 80 kPa, 1.62 / 0.99 (§3.4; the
statement ``stiffness-ratio`` of :mod:`jobs.calibrate.statements`)."""
PRESSURE_PAIR = (0.08, 0.2)


def thesis_points(model: str, reading: str = DEFAULT_READING) -> tuple[ReferencePoint, ...]:
    """The thesis' points of ``model``; the full model's under ``reading`` (a key of
    :data:`READING_POINTS`; the reduced model has one point and no ambiguity)."""
    if reading not in READING_POINTS:
        raise SpecError(f"unknown reading {reading!r} of the thesis' 4475.5 N point: choose "
                        f"one of {', '.join(READING_POINTS)}")
    if model == "full":
        return READING_POINTS[reading]
    return tuple(p for p in THESIS_POINTS if p.model == model)


MEASURED_POINTS = tuple(
    ReferencePoint("full", s.deflection, s.pressure, s.value,
                   f"{s.key}, derived: {s.derivation}; {s.source}")
    for s in STATEMENTS
    if s.describes == "measured tyre" and s.quantity == "Fz"
    and s.deflection is not None and s.pressure is not None)
"""The measured tyre's points the thesis lets one derive: its Fz statements that
describe the measured tyre (today 4195 N at 25 mm / 80 kPa); ``farm calibrate
--measured`` adds them."""


def with_ratio(points: tuple[ReferencePoint, ...], ratio: float = MEASURED_RATIO
               ) -> tuple[ReferencePoint, ...]:
    """``points`` and, for the 30 mm point of the reading, a derived partner at the other
    thesis pressure: its force times ``ratio`` (at 200 kPa) or divided by it (at 80 kPa).

    Why: the thesis' Fz points of one reading constrain one pressure (80 kPa reading) or
    contradict the measured ratio (200 kPa reading: 3933 N at 25 mm / 80 kPa against
    4476 N at 30 mm / 200 kPa is a ratio near 1); a fit to the points alone leaves the
    pressure stiffening free. The derivation assumes the curve at the other pressure is
    this curve scaled by the ratio of mean stiffnesses, an assumption the thesis does not
    make; ``farm compare`` checks the ratio itself on the whole curves.
    """
    anchor = max((p for p in points if p.model == "full"), key=lambda p: p.deflection)
    other = PRESSURE_PAIR[1] if anchor.pressure == PRESSURE_PAIR[0] else PRESSURE_PAIR[0]
    factor = ratio if other > anchor.pressure else 1.0 / ratio
    derived = ReferencePoint(
        "full", anchor.deflection, other, round(anchor.force * factor, 1),
        f"derived: {anchor.force:g} N at {anchor.deflection:g} mm / "
        f"{1000 * anchor.pressure:g} kPa {'x' if factor > 1 else '/'} {ratio:.3f}, the measured "
        "mean-stiffness ratio 1.62/0.99 of §3.4 (assumes proportional curves)")
    return (*points, derived)


def _number(row: dict, key: str, where: str, positive: bool, high: float) -> float:
    try:
        v = float(row[key])
    except (TypeError, ValueError) as e:
        raise StudyError(f"{where}: {key} must be a number, got {shown(row[key])}"
                         ) from e
    if not math.isfinite(v) or v < 0 or (positive and v == 0) or v > high:
        raise StudyError(f"{where}: {key} must be {'> 0' if positive else '>= 0'} and "
                         f"<= {high:g}, got {v!r}")
    return v


def read_points(path: str | Path, model: str | ModelSpec) -> tuple[ReferencePoint, ...]:
    """The CSV's points of ``model`` - a kind, or a spec that every point is checked
    against (raises :class:`StudyError` naming the file, the line and the value)."""
    path = Path(path)
    spec = model if isinstance(model, ModelSpec) else None
    model = spec.kind if spec else model
    text = reading.read_text(path, "references")
    try:
        rows = list(csv.DictReader(io.StringIO(text, newline="")))
    except csv.Error as e:
        raise StudyError(f"cannot read references {path}: {e}") from e
    header = set(rows[0]) if rows else set()
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
        pressure = _number(row, "pressure_kpa", where, False, 1000 * MAX_PRESSURE_MPA) / 1000
        if (pressure > 0) != (kind == "full"):
            need = ("inflated: give pressure_kpa > 0" if kind == "full"
                    else "not inflated: pressure_kpa must be 0")
            raise StudyError(f"{where}: the {kind} model is {need}")
        point = ReferencePoint(kind, _number(row, "deflection_mm", where, True, math.inf),
                               pressure, _number(row, "force_n", where, True, MAX_FORCE_N),
                               str(path))
        if spec is not None:
            try:
                LoadPath((point.deflection,), pressure).check_against(spec)
            except SpecError as e:
                raise StudyError(f"{where}: {e}") from e
        points.append(point)
    if not points:
        raise StudyError(f"{path} has no reference point for the {model} model")
    return tuple(points)
