"""How far a running ccx has got, read from its own ``.sta`` file (issue 48).

ccx appends one row to ``<job>.sta`` per increment attempt: step, increment, attempt
(``U`` when it did not converge), iterations, total time, step time, increment size.
With the time periods of the deck's ``*STEP``s (the second number of each ``*STATIC``
data line; ccx's default is 1) the fraction of the run done is

    (periods of the steps before the current one + its step time) / (all periods),

which for the farm's decks is the fraction of the load path (inflation, rise, slide or
roll, in the step time they were given: farm/ccx/deck.py). A restart deck numbers its
steps after the run it continues; they are matched to the deck's steps in order.

:func:`reporting` installs a callback for the runs made in its ``with`` block (in this
thread or task: a context variable), which :func:`farm.ccx.runner.run_ccx` calls with a
:class:`SolverProgress` whenever the ``.sta`` file grows. Nothing is reported outside it.
"""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class SolverProgress:
    """One look at a running ccx: ``fraction`` of its step time done (0-1), the step (1
    for the deck's first) and converged increments so far, and ``cutbacks`` (attempts
    that did not converge, counted as ccx retried them)."""

    fraction: float
    step: int
    steps: int
    increments: int
    cutbacks: int

    def describe(self) -> str:
        """``'43 % of the path (step 1 of 1, 12 increments, 2 cutbacks)'``."""
        cut = f", {self.cutbacks} cutback{'s' * (self.cutbacks != 1)}" if self.cutbacks else ""
        return (f"{100 * self.fraction:.0f} % of the path (step {self.step} of {self.steps}, "
                f"{self.increments} increment{'s' * (self.increments != 1)}{cut})")


Reporter = Callable[[SolverProgress], None]
_REPORTER: contextvars.ContextVar[Reporter | None] = contextvars.ContextVar(
    "farm_ccx_progress", default=None)


@contextlib.contextmanager
def reporting(callback: Reporter) -> Iterator[None]:
    """Report the progress of every ccx run inside the block to ``callback``."""
    token = _REPORTER.set(callback)
    try:
        yield
    finally:
        _REPORTER.reset(token)


def current_reporter() -> Reporter | None:
    """The callback of the innermost :func:`reporting` block, or None."""
    return _REPORTER.get()


def step_periods(deck: str) -> list[float]:
    """Time period of each ``*STEP`` of ``deck``, in order (ccx's default 1.0 where the
    ``*STATIC`` line gives none)."""
    periods: list[float] = []
    lines = [line.strip() for line in deck.splitlines()]
    for i, line in enumerate(lines):
        if line.upper().startswith("*STEP"):
            periods.append(1.0)
        elif line.upper().startswith("*STATIC") and periods:
            data = next((x for x in lines[i + 1:] if x and not x.startswith("**")), "")
            fields = [] if data.startswith("*") else [f.strip() for f in data.split(",")]
            with contextlib.suppress(IndexError, ValueError):
                periods[-1] = float(fields[1]) if fields[1] else 1.0
    return [p if p > 0 else 1.0 for p in periods]


def progress_of(rows: Sequence[Sequence[str]], periods: Sequence[float]
                ) -> SolverProgress | None:
    """The progress the ``.sta`` rows (split fields, attempts included) show for a deck
    of ``periods``; None before the first row or for a deck without steps."""
    if not rows or not periods:
        return None
    order: list[str] = []
    converged, cutbacks, last = 0, 0, None
    for fields in rows:
        if fields[0] not in order:
            order.append(fields[0])
        if fields[2].endswith("U"):
            cutbacks += 1
            continue
        converged += 1
        last = fields
    if last is None:
        return SolverProgress(0.0, 1, len(periods), 0, cutbacks)
    index = min(order.index(last[0]), len(periods) - 1)
    try:
        step_time = float(last[5])
    except (IndexError, ValueError):
        step_time = 0.0
    done = sum(periods[:index]) + min(max(step_time, 0.0), periods[index])
    return SolverProgress(min(done / sum(periods), 1.0), index + 1, len(periods), converged,
                          cutbacks)
