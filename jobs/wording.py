"""Counts in messages: "1 ccx run", "2 ccx runs" (issue 25: "1 ccx runs", "1 workers").

Here, the lowest floor that writes counts for people: the job layer's summaries and the
CLI's tables (which sits above it) use the one helper.
"""

from __future__ import annotations


def plural(count: int, noun: str, many: str | None = None) -> str:
    """``"<count> <noun>"``, the noun in the plural unless ``count`` is 1 (``many``
    for an irregular plural, default ``noun + "s"``): ``plural(1, "ccx run")`` is
    "1 ccx run", ``plural(0, "worker")`` "0 workers"."""
    return f"{count} {noun if count == 1 else (many or noun + 's')}"
