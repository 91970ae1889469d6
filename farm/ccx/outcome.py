"""Classify how a ccx run ended, from its exit code AND its output.

ccx's ``stop()`` exits with 201 on errors, but some error paths return 0 after printing
``*ERROR``, and a crash can exit 0 without writing ``Job finished``. So a run counts as
converged only when it exited 0, printed ``Job finished`` and printed no ``*ERROR``.
"""

from __future__ import annotations

import re
from enum import StrEnum


class Outcome(StrEnum):
    """How a ccx run ended. Everything but ``CONVERGED`` is a failure.

    The outcome owns the failure policy every job applies (sweeps and loops alike):

    - :attr:`retry_smaller`: worth ONE more run with four times smaller increments.
      Non-convergence often gets through a difficult touch-down that way, and a crash is
      retried too: one forward evaluation of the reproduction crashed spooles (exit 255)
      every time at its first increment size and converged with smaller ones.
    - :attr:`transient`: says nothing about the input (a timeout on a busy machine, a
      cancellation): never cached, never recorded as a property of the experiment's input.
    - everything else that still fails after the retry is deterministic: the same input
      fails the same way, so it is recorded (sweeps) or cached (loops) as data.
    """

    CONVERGED = "converged"
    TOO_MANY_CUTBACKS = "too_many_cutbacks"
    INCREMENT_BELOW_MINIMUM = "increment_below_minimum"
    MAX_INCREMENTS = "max_increments"
    DIVERGED = "diverged"
    NONPOSITIVE_JACOBIAN = "nonpositive_jacobian"
    INPUT_ERROR = "input_error"
    TIMEOUT = "timeout"
    CANCELLED = "cancelled"
    CRASH = "crash"

    @property
    def retry_smaller(self) -> bool:
        """True when one retry with smaller increments may succeed."""
        return self in _RETRY_SMALLER

    @property
    def transient(self) -> bool:
        """True when the failure is not a property of the input (not cached, not final)."""
        return self in (Outcome.TIMEOUT, Outcome.CANCELLED)


_RETRY_SMALLER = frozenset({Outcome.TOO_MANY_CUTBACKS, Outcome.INCREMENT_BELOW_MINIMUM,
                            Outcome.MAX_INCREMENTS, Outcome.DIVERGED, Outcome.CRASH})


# First match wins; patterns are ccx 2.20's own messages (strings in the binary).
_PATTERNS: tuple[tuple[Outcome, re.Pattern[str]], ...] = (
    (Outcome.NONPOSITIVE_JACOBIAN, re.compile(r"nonpositive jacobian", re.I)),
    (Outcome.TOO_MANY_CUTBACKS, re.compile(r"too many cutbacks", re.I)),
    (Outcome.INCREMENT_BELOW_MINIMUM, re.compile(r"increment size smaller than", re.I)),
    (Outcome.MAX_INCREMENTS, re.compile(r"max\. # of increments reached", re.I)),
    (Outcome.DIVERGED, re.compile(r"solution seems to diverge|the solution diverged", re.I)),
    (Outcome.INPUT_ERROR, re.compile(
        r"\*ERROR (reading|in .*(input|deck))|does not exist|not defined|unknown keyword"
        r"|\*ERROR in (nodes|elements|materials|boundaries|dloads|surfaces|sets)", re.I)),
)

HINTS = {
    Outcome.TOO_MANY_CUTBACKS: "The load step did not converge; try smaller increments "
    "(solver.max_increment) or a smaller deflection",
    Outcome.INCREMENT_BELOW_MINIMUM: "The increment shrank below solver.min_increment; "
    "the load may be beyond what the model can carry",
    Outcome.MAX_INCREMENTS: "Raise solver.max_increments or solver.initial_increment",
    Outcome.DIVERGED: "Use automatic incrementation with smaller increments",
    Outcome.NONPOSITIVE_JACOBIAN: "An element inverted: the deflection is too large for "
    "this mesh, or the mesh is too coarse",
    Outcome.INPUT_ERROR: "The deck is invalid; this is a bug in the deck writer, please report it",
    Outcome.TIMEOUT: "Raise solver.timeout or use a coarser mesh",
    Outcome.CRASH: "ccx crashed; keep the scratch directory (--keep) and inspect its output",
}


def classify(returncode: int | None, output: str) -> Outcome:
    """Outcome of a finished run from its exit status and combined stdout/stderr."""
    for outcome, pattern in _PATTERNS:
        if pattern.search(output):
            return outcome
    if returncode == 0 and "*ERROR" not in output and "Job finished" in output:
        return Outcome.CONVERGED
    return Outcome.CRASH
