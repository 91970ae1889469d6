"""The ``farm`` command (typer): the top floor, the only code that reaches across packages.

``main`` is the console entry point. It runs the typer app and is the error boundary:
any error of the farm's packages, and any usage error, becomes ONE line on stderr and a
non-zero exit code; ``--debug`` shows the traceback instead. Exit codes:

- 0: everything asked for succeeded;
- 1: something failed: a solve, a damaged store, a missing solver, and the content of a
  file the user gave (a study file, a references CSV) - the file is data, not usage;
- 2: usage: an unknown command or option, a missing argument, or a value typed on the
  command line that was refused (``--workers -3``, ``--model bogus``, ``--pressure nan``,
  an ``--out`` that cannot be written) - click's rule, extended to the farm's own checks
  of option values (:func:`tyre_farm_cli.errors.usage` marks their errors);
- 130: interrupted.

Streams: results (tables, summaries, ``--json`` documents) on stdout; progress,
dashboard addresses and errors on stderr (:mod:`tyre_farm_cli.progress`). Pressure is kPa in every
option and table (the store keeps MPa; the CLI converts at its edge).
"""

from __future__ import annotations

import functools
import logging
import sys
import warnings
from typing import Protocol, runtime_checkable

import typer

from tyre_farm_cli import (
    analyse,
    calibrate,
    compare,
    converge,
    export,
    invert,
    invocation,
    predict,
    reproduce,
    roll,
    run,
    sweep,
)
from tyre_farm_cli.errors import USER_ERRORS, exit_code, fail
from tyre_farm_cli.options import APP_SETTINGS, use_panels

app = typer.Typer(
    name="farm",
    help="Batch simulation farm for intelligent-tyre virtual experiments "
    "(gmsh + CalculiX on Dask, results in Zarr).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
    **APP_SETTINGS,
)


def version_text() -> str:
    """``farm <version>, CalculiX <version>`` (the solver's only if it is found)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        text = f"farm {version('tyre-farm')}"
    except PackageNotFoundError:
        text = "farm (not installed: no package metadata)"
    try:
        from farm.ccx.runner import ccx_version

        return f"{text}, CalculiX {ccx_version()}"
    except Exception:  # no solver here is not an error of --version
        return f"{text}, CalculiX not found"


def _version(value: bool) -> None:
    if value:
        typer.echo(version_text())
        raise typer.Exit(0)


@app.callback()
def _root(
    debug: bool = typer.Option(False, "--debug", help="Show tracebacks, not one-line errors."),
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the package and solver versions and exit."),
) -> None:
    """gmsh + CalculiX virtual experiments of the TM700 280/70R16 tyre."""


# The parent imports its children and mounts them: the children never import the parent.
app.command("run")(run.run)
app.command("roll")(roll.roll)
app.add_typer(sweep.app, name="sweep")
app.command("invert")(invert.invert)
app.command("calibrate")(calibrate.calibrate)
app.command("export")(export.export)
app.command("reproduce")(reproduce.reproduce)
app.command("converge")(converge.converge)
app.command("compare")(compare.compare)
app.command("fit")(predict.fit)
app.command("measure")(predict.measure)
app.command("predict")(predict.predict)
app.command("mismatch")(predict.mismatch)
app.add_typer(analyse.app, name="analyse", help="Chapter-5 analyses of a store: "
              "cross-covariance PCA, PCR, PLSR, Monte Carlo noise.")
use_panels(app)  # the cluster options in sections of their own, after each command's

#: Known-harmless warnings of the libraries, kept from users (each with its reason).
HARMLESS = (
    # zarr v3: consolidated metadata is not in the v3 spec yet; the farm reads and writes
    # it on purpose (storage.paths), and a stale copy is handled by storage.read
    (r".*[Cc]onsolidated metadata.*", UserWarning),
    # numcodecs/zarr: the v3 spec of a codec we do not choose (e.g. vlen strings)
    (r".*is currently not part in the Zarr format 3 specification.*", UserWarning),
)


class _UnretrievedTasks(logging.Filter):
    """Drop asyncio's "Task exception was never retrieved" reports. zarr reads a group's
    members as concurrent tasks; when one member's metadata is damaged, the error that
    was awaited becomes the CLI's one line, and the siblings still pending are reported
    at exit by asyncio's garbage collector: 46 lines of noise after the line that
    matters (issue 26). Nothing in them is the user's to act on."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith("Task exception was never retrieved")


@functools.cache
def command():
    """The click command of :data:`app`, built once: typer builds it anew on every call,
    which was most of the time of a refused input."""
    return typer.main.get_command(app)


def main(argv: list[str] | None = None) -> None:
    """Console entry point: run the app and turn errors into one line and an exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    invocation.ARGS[:] = args  # what a study's provenance names
    debug = args[:1] == ["--debug"]  # a root option: `farm --debug run ...`
    if not debug:
        logging.getLogger("asyncio").addFilter(_UnretrievedTasks())
    with warnings.catch_warnings():
        for message, category in HARMLESS:
            warnings.filterwarnings("ignore", message=message, category=category)
        _main(args, debug)


@runtime_checkable
class _ClickError(Protocol):
    """Click's usage errors, by interface: typer vendors click as typer._click in recent
    versions, so no one class matches them all (isinstance checks both attributes)."""

    exit_code: int

    def format_message(self) -> str: ...


def _main(args: list[str], debug: bool) -> None:
    try:
        code = command().main(args=args, prog_name="farm", standalone_mode=False)
        if isinstance(code, int) and code != 0:  # click returns typer.Exit's code here
            raise SystemExit(code)
    except typer.Exit as e:
        raise SystemExit(e.exit_code) from None
    except (typer.Abort, KeyboardInterrupt):
        fail("interrupted", code=130)
    except USER_ERRORS as e:
        if debug:
            raise
        fail("; ".join([str(e), *getattr(e, "__notes__", ())]), code=exit_code(e))
    except Exception as e:
        # Click's usage errors (typer vendors click as typer._click in recent versions,
        # so match the interface rather than a class).
        if debug:
            raise
        if not isinstance(e, _ClickError):
            # a store that cannot be reached or written (credentials, a full disk) is the
            # user's to fix, wherever in the libraries it surfaced (issue 26)
            from storage.errors import access_error

            access = access_error(e)
            if access is None:
                raise
            fail(str(access))
        message = e.format_message()
        if not message:  # e.g. help shown because no command was given
            raise SystemExit(e.exit_code) from None
        fail(f"{message} (see `farm --help`)", code=e.exit_code or 2)
