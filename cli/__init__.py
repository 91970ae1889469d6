"""The ``farm`` command (typer): the top floor, the only code that reaches across packages.

``main`` is the console entry point. It runs the typer app and is the error boundary:
any error of the farm's packages, and any usage error, becomes ONE line on stderr and a
non-zero exit code (1 for failures, 2 for bad usage, 130 when interrupted); ``--debug``
shows the traceback instead.
"""

from __future__ import annotations

import sys

import typer

from cli import analyse, calibrate, export, invert, reproduce, run, sweep
from cli.errors import USER_ERRORS, fail

app = typer.Typer(
    name="farm",
    help="Batch simulation farm for intelligent-tyre virtual experiments "
    "(gmsh + CalculiX on Dask, results in Zarr).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


@app.callback()
def _root(
    debug: bool = typer.Option(False, "--debug", help="Show tracebacks, not one-line errors."),
) -> None:
    """gmsh + CalculiX virtual experiments of the TM700 280/70R16 tyre."""


# The parent imports its children and mounts them: the children never import the parent.
app.command("run")(run.run)
app.add_typer(sweep.app, name="sweep")
app.command("invert")(invert.invert)
app.command("calibrate")(calibrate.calibrate)
app.command("export")(export.export)
app.command("reproduce")(reproduce.reproduce)
app.add_typer(analyse.app, name="analyse", help="Chapter-5 analyses of a store: "
              "cross-covariance PCA, PCR, PLSR, Monte Carlo noise.")


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app and turn errors into one line and an exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    debug = args[:1] == ["--debug"]  # a root option: `farm --debug run ...`
    try:
        code = app(args=args, prog_name="farm", standalone_mode=False)
        if isinstance(code, int) and code != 0:  # click returns typer.Exit's code here
            raise SystemExit(code)
    except typer.Exit as e:
        raise SystemExit(e.exit_code) from None
    except (typer.Abort, KeyboardInterrupt):
        fail("interrupted", code=130)
    except USER_ERRORS as e:
        if debug:
            raise
        fail(str(e))
    except Exception as e:
        # Click's usage errors (typer vendors click as typer._click in recent versions,
        # so match the interface rather than a class).
        if debug or not (hasattr(e, "format_message") and hasattr(e, "exit_code")):
            raise
        message = e.format_message()
        if not message:  # e.g. help shown because no command was given
            raise SystemExit(e.exit_code) from None
        fail(f"{message} (see `farm --help`)", code=e.exit_code or 2)
