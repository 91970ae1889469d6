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

STORAGE_OPTION_HELP = ("fsspec option of a store URL, KEY=VALUE, repeatable (e.g. "
                       "endpoint_url=http://minio:9000); credentials stay in the environment "
                       "[default: none; a study file's [study.storage_options]].")
STORAGE_OPTION = typer.Option(None, "--storage-option", help=STORAGE_OPTION_HELP)


def _option_value(text: str) -> Any:
    lowered = text.lower()
    return {"true": True, "false": False}.get(lowered, text)


def open_target(store: str, options: list[str] | None) -> Any:
    """``store`` as given, or opened with the ``--storage-option`` pairs (checked as a
    study file's table is: URL stores only, no secrets); bad pairs are usage errors."""
    if not options:
        return store
    import storage

    pairs = {}
    for text in options:
        key, sep, value = text.partition("=")
        if not sep or not key:
            raise typer.BadParameter(f"{text!r}: give KEY=VALUE", param_hint="--storage-option")
        pairs[key.strip()] = _option_value(value.strip())
    try:
        checked_options = validate.storage_options(pairs, "--storage-option", store)
    except StudyError as e:
        raise typer.BadParameter(str(e).removeprefix("--storage-option: "),
                                 param_hint="--storage-option") from e
    return storage.open_store(store, storage_options=checked_options)
