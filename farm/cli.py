"""The ``farm`` command (typer). The only module that reaches across all packages.

Errors of the farm become one line on stderr and a non-zero exit code; ``--debug``
shows the traceback instead.
"""

from __future__ import annotations

import typer

app = typer.Typer(
    name="farm",
    help="Batch simulation farm for intelligent-tyre virtual experiments.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)


@app.callback()
def main() -> None:
    """gmsh + CalculiX virtual experiments of the TM700 280/70R16 tyre, on Dask."""
