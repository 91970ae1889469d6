"""Command-line options shared by every command that runs on a Dask cluster.

Both are checked when parsed (:func:`jobs.validate.scheduler_address`,
:func:`jobs.validate.workers`), so a bad value is a usage error before anything starts:
``--workers -3`` once waited for ever on a cluster of no workers.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import typer

from jobs import validate
from jobs.errors import StudyError


def checked(check: Callable[[Any, str], Any], name: str) -> Callable[[Any], Any]:
    """A typer callback that runs ``check(value, name)`` and turns its error into a usage
    error (``Invalid value for '--workers': ...``)."""
    def callback(value: Any) -> Any:
        try:
            return check(value, name)
        except StudyError as e:
            raise typer.BadParameter(str(e).removeprefix(f"{name}: ")) from e

    return callback


check_scheduler = checked(validate.scheduler_address, "--scheduler")
check_workers = checked(validate.workers, "--workers")

#: Settings of every typer app of the CLI. Without rich markup: in rich mode, help texts
#: lose every ``[...]``, the ``[default: ...]`` of options whose default is computed
#: among them (issue 12); typer shows the other defaults itself.
APP_SETTINGS = {"rich_markup_mode": None}

SCHEDULER_HELP = ("Address of a running Dask scheduler, e.g. tcp://host:8786 [default: "
                  "$FARM_SCHEDULER, then $DASK_SCHEDULER_ADDRESS, else an embedded "
                  "LocalCluster].")  # the order of jobs.cluster.resolve_scheduler
SCHEDULER = typer.Option(None, "--scheduler", callback=check_scheduler, help=SCHEDULER_HELP)
WORKERS = typer.Option(None, "--workers", callback=check_workers,
                       help="Embedded cluster: worker processes [default: one per core]. "
                       f"External: wait for this many workers. 1-{validate.MAX_WORKERS}.")
