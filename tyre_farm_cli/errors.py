"""The CLI's error boundary: which errors are the user's to read, and how they look."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import NoReturn

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


#: The libraries' advice to Python callers, and what a user of the CLI does instead
#: (issue 25: a missing store said "create the store with storage.create_group(...)").
CLI_ADVICE = (
    ("create the store with storage.create_group(...)",
     "create it with `farm sweep submit STUDY.toml` (the study's [study] store)"),
    ("create it with storage.create_group(...)",
     "`farm sweep submit STUDY.toml` creates a study's group"),
)


def for_the_cli(message: str) -> str:
    """``message`` with the libraries' Python advice replaced by the farm command."""
    for library, command in CLI_ADVICE:
        message = message.replace(library, command)
    return message


def fail(message: str, code: int = 1) -> NoReturn:
    """Print ``farm: error: <message>`` as one line on stderr and exit with ``code``."""
    line = " ".join(for_the_cli(str(message)).split())
    print(f"farm: error: {line}", file=sys.stderr)
    raise SystemExit(code)


USAGE = "farm_usage_error"  # the mark of an error that :func:`usage` let through


@contextmanager
def usage() -> Iterator[None]:
    """Checks of command-line values: their errors are marked as usage errors (exit 2),
    their type unchanged (callers and tests still catch e.g. ``ParameterError``).

    Wrap only what checks what the user typed; a study file's content and the world
    (the store, the solver) are not usage errors (exit 1).
    """
    try:
        yield
    except USER_ERRORS as e:
        setattr(e, USAGE, True)
        raise


def exit_code(error: BaseException) -> int:
    """2 for an error marked by :func:`usage`, else 1."""
    return 2 if getattr(error, USAGE, False) else 1
