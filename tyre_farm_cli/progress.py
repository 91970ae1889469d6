"""Where progress goes: stderr, always; a live bar on a terminal, log lines elsewhere.

Results (tables, summaries, JSON) are the only thing on stdout, so ``farm ... > out``
captures results and ``farm ... 2> log`` captures progress. Off a terminal a bar would
reach a file only when it stops (``farm reproduce 2>log`` once showed nothing for 39
minutes), so there the progress is plain timestamped lines, written and flushed as they
happen, at most one per :data:`EVERY_SECONDS` (the last one always)::

    2026-11-23T19:56:03 sweep ch5: 12/30 done, 0 failed
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

from rich.console import Console

EVERY_SECONDS = 2.0  # a sweep of 10 000 fast experiments must not write 10 000 lines


def interactive() -> bool:
    """Whether stderr is a terminal (then progress is a live rich display)."""
    return sys.stderr.isatty()


def console() -> Console:
    """The console of progress and messages: stderr."""
    return Console(stderr=True)


class LogLines:
    """Timestamped lines on ``stream`` (default: the current ``sys.stderr``), flushed at
    once; :meth:`progress` lines are rate-limited, :meth:`log` lines are not."""

    def __init__(self, stream: TextIO | None = None, every: float = EVERY_SECONDS,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.stream, self.every, self.clock = stream, every, clock
        self.last: float | None = None
        self.pending: str | None = None

    def log(self, text: str) -> None:
        """Write ``text`` now, with the local time in front."""
        stream = self.stream or sys.stderr
        stream.write(f"{time.strftime('%Y-%m-%dT%H:%M:%S')} {text}\n")
        stream.flush()

    def progress(self, text: str, *, last: bool = False) -> None:
        """Write ``text`` unless a line went out less than ``every`` s ago; a line held
        back is written by the next :meth:`progress` with ``last=True``."""
        now = self.clock()
        if last or self.last is None or now - self.last >= self.every:
            self.log(text)
            self.last, self.pending = now, None
        else:
            self.pending = text

    def flush(self) -> None:
        """Write the line held back, if any (at the end of a run)."""
        if self.pending is not None:
            self.progress(self.pending, last=True)
