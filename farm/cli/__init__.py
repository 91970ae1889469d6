"""The ``farm`` command (typer): the only code that reaches across all packages.

``main`` is the console entry point. It runs the typer app and is the error boundary:
any error of the farm's packages, and any usage error, becomes ONE line on stderr and a
non-zero exit code (1 for failures, 2 for bad usage, 130 when interrupted); ``--debug``
shows the traceback instead.
"""

from __future__ import annotations

import sys

import typer

from farm.cli.errors import USER_ERRORS, fail

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


def _register() -> None:
    from analysis.cli import app as analyse
    from farm.cli import calibrate, export, invert, reproduce, run, sweep  # noqa: F401

    app.add_typer(analyse, name="analyse", help="Chapter-5 analyses of a store: "
                  "cross-covariance PCA, PCR, PLSR, Monte Carlo noise.")


_register()


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
