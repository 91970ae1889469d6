"""Tables as the reproduction report shows them: human headers with units, one mark for a
missing value, round-off printed as ``~0``.

The stages' tables keep their machine-friendly columns (``thesis_cum_pct``) and exact
values: they are written as CSV beside the report. Only the Markdown goes through here.
"""

from __future__ import annotations

import math
import numbers
import re

import pandas as pd

from analysis.render.markdown import table as md_table

#: what the report prints where a value does not exist: not computed, not applicable, or
#: not given by the thesis (stages hand in NaN, None, "" or "-" for it)
MISSING = "n/a"
#: a value smaller than this times the largest magnitude in its table is floating-point
#: round-off (a moment of symmetric forces: 1e-14 N m beside 4476 N) and printed as ``~0``
ROUND_OFF = 1e-9
DIGITS = 4
NOTE = (f"Numbers have {DIGITS} significant digits. A value smaller than {ROUND_OFF:g} x "
        "the largest magnitude in its table is floating-point round-off and printed as ~0; "
        f"{MISSING} marks a value that does not exist (not computed, not applicable, or not "
        "given by the thesis). The CSV files in tables/ hold every value as computed.")

#: headers that need more than underscores turned into spaces (units, symbols)
HEADERS = {
    "thesis_cum_pct": "thesis cumulative %",
    "measured_cum_pct": "measured cumulative %",
    "sigma1": "σ1 (largest singular value)",
    "std_over_max_force": "std / max reference force",
    "thesis_std": "thesis std N",
    "thesis_std_over_max_force": "thesis std / max reference force",
    "guess_std": "guess std N",
    "guess_rms": "guess RMS N",
    "nodal_std": "nodal std N",
    "nodal_rms": "nodal RMS N",
    "thesis_nodal_std": "thesis nodal std N",
    "Fz": "Fz N",
    "thesis_Fz": "thesis Fz N",
    "thesis Fz": "thesis Fz N",
    "thesis Mx": "thesis Mx N m",
    "thesis My": "thesis My N m",
    "Fz_err_pct": "Fz error %",
    "wall_s": "wall s",
    "solver_s": "solver s",
    "n_components": "components",
    "thesis_sigma": "thesis σ",
}
_WORDS = {"pct": "%", "cum": "cumulative", "avg": "average", "err": "error", "rms": "RMS",
          "rmse": "RMSE", "over": "/", "s": "s"}
_MISSING_TEXT = {"", "-", "nan", "none", "n/a"}


def header(column) -> str:
    """A column name as a reader's header: ``thesis_cum_pct`` -> ``thesis cumulative %``."""
    name = str(column)
    if name in HEADERS:
        return HEADERS[name]
    return " ".join(_WORDS.get(w, w) for w in name.split("_") if w)


def _is_float(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool | numbers.Integral)


def _scale(frame: pd.DataFrame) -> float:
    """The largest finite magnitude among the table's floats (0 if none)."""
    values = [abs(float(v)) for row in frame.itertuples(index=False) for v in row
              if _is_float(v) and math.isfinite(v)]
    return max(values, default=0.0)


def cell(value, scale: float = 0.0) -> str:
    """One value as printed; ``scale`` is the table's largest magnitude (round-off)."""
    if value is None or value is pd.NA:
        return MISSING
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if _is_float(value):
        v = float(value)
        if not math.isfinite(v):
            return MISSING
        if v != 0 and abs(v) < ROUND_OFF * scale:
            return "~0"
        return f"{v:.{DIGITS}g}"
    text = str(value)
    if text.strip().lower() in _MISSING_TEXT:
        return MISSING
    return re.sub(r"\((?:-|nan)\)", f"({MISSING})", text)  # "0.01 (-)": thesis value absent


def table(frame: pd.DataFrame) -> str:
    """``frame`` as a Markdown table for the report."""
    scale = _scale(frame)
    rows = [[cell(v, scale) for v in row] for row in frame.itertuples(index=False)]
    return md_table(pd.DataFrame(rows, columns=[header(c) for c in frame.columns]))
