"""Command-line options shared by every command that runs on a Dask cluster."""

from __future__ import annotations

import typer

SCHEDULER = typer.Option(None, "--scheduler", help="Address of a running Dask scheduler, "
                         "e.g. tcp://host:8786 [default: an embedded LocalCluster].")
WORKERS = typer.Option(None, "--workers", help="Embedded cluster: worker processes "
                       "[default: one per core]. External: wait for this many workers.")
