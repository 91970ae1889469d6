"""The CLI's error boundary: which errors are the user's to read, and how they look."""

from __future__ import annotations

import sys

from farm.errors import FarmError


def _user_errors() -> tuple[type[BaseException], ...]:
    errors: list[type[BaseException]] = [FarmError]
    for module, name in (("storage.errors", "StoreError"), ("analysis.errors", "AnalysisError"),
                         ("jobs.errors", "JobError")):
        try:
            errors.append(getattr(__import__(module, fromlist=[name]), name))
        except (ImportError, AttributeError):
            continue
    return tuple(errors)


USER_ERRORS = _user_errors()


def fail(message: str, code: int = 1) -> None:
    """Print ``farm: error: <message>`` as one line on stderr and exit with ``code``."""
    line = " ".join(str(message).split())
    print(f"farm: error: {line}", file=sys.stderr)
    raise SystemExit(code)
