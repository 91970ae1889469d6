"""How a bad input reads: one StudyError line naming the key path, the value and the rule.

Every check of :mod:`jobs.validate` takes the value and ``where``, the key path it came
from (``loads.deflection_mm.step``, ``conditions[1].repeats``), and raises one
:class:`~jobs.errors.StudyError` made here::

    loads.deflection_mm.step: must be > 0, got -5
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from farm.errors import shown  # noqa: F401 (re-exported: the study checks' messages)
from jobs.errors import StudyError


def fail(where: str, message: str) -> StudyError:
    """The error for the value at key path ``where``: ``"<where>: <message>"``."""
    return StudyError(f"{where}: {message}")


@contextmanager
def located(source: str) -> Iterator[None]:
    """Prefix every :class:`StudyError` raised inside with ``source`` (the file name)."""
    try:
        yield
    except StudyError as e:
        raise StudyError(f"{source}: {e}") from e.__cause__
