"""Every statement the thesis makes that a full tyre model can be held to (issue 24).

Each :class:`Statement` quotes its source, says whether it describes the thesis' *model*
or the *measured* TM700 (Becker and Els, 2022, the rig data of Fig. 3.3), and, when it
is derived rather than printed, how. Two readings of the thesis conflict, and neither
is chosen silently (DEVELOPERS.md): the 4475.5 N of §3.3.2 is at 30 mm and **80 kPa**
(the text and the caption of Fig. 3.2 both say 80 kPa), while chapter 5 reports the
same experiment (Table 5.1: 4475.70 N; §5.4/§5.5: "30mm ... at 200kPa") at **200 kPa**.
:data:`READINGS` names them; a statement tagged with one reading belongs to it only,
untagged ones to both.

Derived measured points (each derivation is an assumption, stated):

- ``measured-25mm-80kPa``: §3.4 gives the largest error, 262 N at 25 mm / 80 kPa where
  the model gave 3933 N, and mean stiffnesses of 0.81 (model) against 0.99 (measured) at
  80 kPa: the model is the softer one, so the measured force there is 3933 + 262 =
  4195 N (it cannot be 3933 - 262 unless the model were stiffer at its worst point).
- ``stiffness-ratio``: the measured mean stiffnesses, 1.62 at 200 kPa over 0.99 at
  80 kPa, make 1.636 (the thesis' model: 1.46 / 0.81 = 1.80). The thesis prints them
  as "kN/m", which no force-deflection curve of this tyre fits (4.5 kN at 30 mm is
  150 kN/m): only the ratio is used, computed here as the ratio of the least-squares
  slopes through the origin of each pressure's curve over 5-40 mm
  (:func:`mean_stiffness`), a definition the thesis does not give.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

Describes = Literal["thesis model", "measured tyre"]
Quantity = Literal["Fz", "stiffness ratio", "growth", "nodal mean", "nodal std"]

READINGS = {
    "80kPa": "§3.3.2 and the caption of Fig. 3.2: the 4475.5 N experiment is at 30 mm, 80 kPa",
    "200kPa": "chapter 5 (Table 5.1, §5.4-5.5): the same 4475.7 N experiment at 30 mm, "
              "200 kPa",
}


@dataclass(frozen=True)
class Statement:
    """One target: ``value`` of ``quantity`` (N, mm or a ratio) at ``deflection`` mm and
    ``pressure`` MPa (None where it is not a point), with ``tolerance_pct`` the goal."""

    key: str
    quantity: Quantity
    value: float
    describes: Describes
    source: str
    deflection: float | None = None
    pressure: float | None = None
    reading: str | None = None
    derivation: str = ""
    bound: Literal["equal", "at most"] = "equal"
    tolerance_pct: float = 10.0


STATEMENTS = (
    Statement("model-30mm-80kPa", "Fz", 4475.5, "thesis model",
              "§3.3.2: 'displaced by 30mm ... inflated to 80kPa ... the total force was "
              "4475.5N'", 30.0, 0.08, reading="80kPa"),
    Statement("model-30mm-200kPa", "Fz", 4475.7, "thesis model",
              "Table 5.1 'Reference 4475.70' for §5.4-5.5's 'total displacement of 30mm at "
              "200kPa'", 30.0, 0.2, reading="200kPa"),
    Statement("model-25mm-80kPa", "Fz", 3933.0, "thesis model",
              "§3.4: 'a maximum of 262N at a 25mm displacement for an 80kPa simulation "
              "where the corresponding total force predicted was 3933N'", 25.0, 0.08),
    Statement("measured-25mm-80kPa", "Fz", 4195.0, "measured tyre",
              "§3.4 (largest error 262 N at 25 mm / 80 kPa; mean stiffness 0.81 model, "
              "0.99 measured)", 25.0, 0.08,
              derivation="3933 N + 262 N: the model is the softer at 80 kPa"),
    Statement("stiffness-ratio", "stiffness ratio", 1.62 / 0.99, "measured tyre",
              "§3.4: 'mean stiffness ... 0.81kN/m and 1.46 kN/m compared to ... 0.99kN/m "
              "and 1.62kN/m for the experiments'",
              derivation="1.62 / 0.99, mean stiffness at 200 kPa over 80 kPa"),
    Statement("model-stiffness-ratio", "stiffness ratio", 1.46 / 0.81, "thesis model",
              "§3.4 (as above)", derivation="1.46 / 0.81"),
    Statement("nodal-mean-30mm-80kPa", "nodal mean", 263.3, "thesis model",
              "§3.3.2: 'an average nodal force of 263.3N' (on the thesis' own mesh)",
              30.0, 0.08, reading="80kPa"),
    Statement("nodal-std-30mm-80kPa", "nodal std", 227.4, "thesis model",
              "§3.3.2: 'standard deviation of 227.4N' (on the thesis' own mesh)",
              30.0, 0.08, reading="80kPa"),
    Statement("growth-200kPa", "growth", 4.0, "measured tyre",
              "§3.3.2: 'The bulging due to pressure on the real tyre is at most 4mm at "
              "200kPa'", pressure=0.2, bound="at most"),
    Statement("model-growth-200kPa", "growth", 8.0, "thesis model",
              "§3.3.2: 'the corresponding virtual experiment bulges by 8mm'", pressure=0.2),
)

CURVE_MM = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0)
"""Deflections of each pressure's curve: every point statement and the mean stiffness."""


def statements(reading: str | None = None) -> tuple[Statement, ...]:
    """The statements of one reading (with the untagged ones), or all of them."""
    if reading is not None and reading not in READINGS:
        raise ValueError(f"unknown reading {reading!r}: choose one of {', '.join(READINGS)}")
    return tuple(s for s in STATEMENTS if reading is None or s.reading in (None, reading))


def mean_stiffness(deflections: np.ndarray, forces: np.ndarray) -> float:
    """Least-squares slope through the origin of a force-deflection curve, N/mm."""
    d, f = np.asarray(deflections, dtype=float), np.asarray(forces, dtype=float)
    return float(d @ f / (d @ d))
