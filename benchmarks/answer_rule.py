"""Issue 45's rule for a change to how a state is solved, as every benchmark prints it.

Two solves of one state give the same answer when the largest force component differs
by at most 0.5 % of |F| and the camera field (or displacement) by at most 1 % of its
RMS. Benchmarks import this as a sibling module (``from answer_rule import ...``: a
script's own folder is on its path).
"""

from __future__ import annotations

import numpy as np

#: The rule's bounds, in %: force (of |F|) and field (of its RMS).
FORCE_PCT, FIELD_PCT = 0.5, 1.0


def rms(x: np.ndarray) -> float:
    """Root mean square, NaNs (a store's missing values) left out."""
    return float(np.sqrt(np.nanmean(np.square(x))))


def differences(force_ref: np.ndarray, force: np.ndarray, field_ref: np.ndarray,
                field: np.ndarray) -> tuple[float, float]:
    """(largest force difference in % of |F_ref|, field difference RMS in % of the
    reference field's RMS)."""
    f = 100 * float(np.abs(np.asarray(force) - force_ref).max()) / float(
        np.linalg.norm(force_ref))
    return f, 100 * rms(np.asarray(field) - field_ref) / rms(field_ref)


def same(force_pct: float, field_pct: float) -> bool:
    """Whether differences of ``force_pct`` and ``field_pct`` keep the answer."""
    return force_pct <= FORCE_PCT and field_pct <= FIELD_PCT


def verdict(force_pct: float, field_pct: float) -> str:
    """The rule's words for a pair of differences."""
    return "the same answer" if same(force_pct, field_pct) else "NOT the same"
