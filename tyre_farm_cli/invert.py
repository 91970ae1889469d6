"""``farm invert``: the virtual inverse problems of thesis chapter 4 as loops on Dask."""

from __future__ import annotations

import math
import statistics
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
)

from jobs.wording import plural
from tyre_farm_cli.errors import usage
from tyre_farm_cli.frames import print_frame
from tyre_farm_cli.jsondoc import JSON, dump, records
from tyre_farm_cli.options import SCHEDULER, WORKERS, with_cluster
from tyre_farm_cli.progress import LogLines, interactive
from tyre_farm_cli.progress import console as stderr_console

if TYPE_CHECKING:  # storage.paths loads zarr: not at `farm --help`
    from storage.paths import StoreLike

STUDY = typer.Argument(..., help="Inverse study file (TOML), e.g. examples/inverse_thesis.toml.")
OUT = typer.Option(None, "--out", help="Folder for the tables (CSV) and histograms (PNG) "
                   "[default: <store>-<group>-report next to the store].")
REPEATS = typer.Option(None, "--repeats", help="Cap every condition's repeats (quick runs) "
                       "[default: the study's repeats].")


class RichLoops:
    """One progress bar per loop (evaluations of its budget, best objective), and a line
    when a loop ends: on a terminal's stderr."""

    def __init__(self, console: Console) -> None:
        self.console = console
        self.bar: Progress | None = None  # made when the loops start
        self.tasks: list[TaskID] = []
        self.reported: set[str] = set()

    def started(self, session, loops) -> None:
        self.console.print(f"{session.where}   workers: {session.workers}   "
                           f"loops: {len(loops)}")
        self.bar = Progress(TextColumn("{task.description}", style="bold"), BarColumn(),
                            MofNCompleteColumn(), TextColumn("best {task.fields[best]}"),
                            TextColumn("{task.fields[status]}"), TimeElapsedColumn(),
                            console=self.console, transient=False)
        self.bar.start()
        self.tasks = [self.bar.add_task(s.label, total=s.budget, best="-", status=s.status)
                      for s in loops]

    def advanced(self, loops) -> None:
        if self.bar is None:
            return
        for task, s in zip(self.tasks, loops, strict=True):
            self.bar.update(task, completed=min(s.stats.evaluations, s.budget),
                            best=f"{s.best:.3g}", status=s.status)
            if (s.result is not None or s.error) and s.label not in self.reported:
                self.reported.add(s.label)
                self._ended(s)

    def _ended(self, state) -> None:
        self.console.print(_ended_text(state), style="red" if state.result is None else None,
                           markup=False)

    def finished(self, report) -> None:
        if self.bar is not None:
            self.bar.stop()


def loop_progress(name: str = "invert"):
    """Bars on a terminal, else log lines: on stderr either way."""
    return RichLoops(stderr_console()) if interactive() else LoopLines()


class LoopLines:
    """Progress of the loops off a terminal: a rate-limited timestamped line when the
    evaluations advance, and one (never held back) when a loop ends."""

    def __init__(self, lines: LogLines | None = None) -> None:
        self.lines, self.evaluations = lines or LogLines(), -1
        self.reported: set[str] = set()

    def started(self, session, loops) -> None:
        self.lines.log(f"invert: dashboard {session.dashboard}, "
                       f"{plural(session.workers, 'worker')}, {plural(len(loops), 'loop')}")

    def advanced(self, loops) -> None:
        evaluations = sum(min(s.stats.evaluations, s.budget) for s in loops)
        ended = [s for s in loops if (s.result is not None or s.error)]
        if evaluations != self.evaluations:
            self.evaluations = evaluations
            self.lines.progress(f"invert: {len(ended)}/{len(loops)} loops ended, "
                                f"{evaluations}/{sum(s.budget for s in loops)} evaluations")
        for s in ended:
            if s.label not in self.reported:
                self.reported.add(s.label)
                self.lines.log(f"invert: {_ended_text(s)}")

    def finished(self, report) -> None:
        self.lines.flush()


def _ended_text(state) -> str:
    result = state.result
    if result is None:
        return f"{state.label}: failed: {state.error}"
    return (f"{state.label}: {result.status}, Fz {result.x.sum():.1f} N, objective "
            f"{result.objective:.3g}, {plural(len(result.f_history), 'evaluation')}, "
            f"{plural(result.stats.rounds, 'round')}, {result.wall_seconds:.0f} s")


def _surrogate(study):
    """The surrogate guess of ``initial = "surrogate"`` conditions (issue 28), trained on
    the [distribution] group without the experiments at the reference load; None when no
    condition uses it."""
    if all(c.initial != "surrogate" for c in study.conditions):
        return None
    from analysis.surrogate_guess import from_group

    spec = study.distribution
    return from_group(spec.store, spec.group, exclude={"deflection": study.deflection},
                      within=spec.exclude_within)


def _default_out(study) -> Path:
    if "://" in study.location:
        return Path(f"{study.group}-report").resolve()
    return Path(f"{study.location.rstrip('/')}-{study.group}-report")


@with_cluster
def invert(study_file: Path = STUDY, scheduler: str = SCHEDULER, workers: int = WORKERS,
           out: Path = OUT, repeats: int = REPEATS, as_json: bool = JSON,
           cluster=None) -> None:
    """Identify tread forces from inner-surface measurements (thesis ch. 4), FEM in the loop.

    Prints and writes Tables 4.1-4.4 beside the thesis' values, histograms of the nodal
    force errors (Figs. 4.2/4.3), and stores every solve's history in the study's group.
    Running it again replays every evaluation from the cache (no ccx): resuming.
    """
    from jobs.inverse.run import run_inverse

    study = _study(study_file, repeats, out, cluster)
    report = run_inverse(study, cluster=cluster, progress=loop_progress(),
                         surrogate=_surrogate(study))
    folder = (out or _default_out(study)).expanduser()
    console = Console(width=None if sys.stdout.isatty() else 180)
    frames, figures = _report(study.store, study.group, folder) if report.results else ({}, [])
    for label, error in report.errors.items():
        stderr_console().print(f"{label}: {error}", style="red", markup=False)
    if as_json:
        dump(_document(study, report, frames, figures, folder))
        raise typer.Exit(0 if report.ok else 1)
    for name, frame in frames.get("views", {}).items():
        print_frame(console, TITLES[name], frame)
    console.print(report.summary())
    console.print(f"results: {study.location} (group {study.group}); tables and "
                  f"{plural(len(figures), 'histogram')} in {folder}" if report.results else
                  "no solve finished: nothing stored, no tables")
    raise typer.Exit(0 if report.ok else 1)


def _study(study_file: Path, repeats: int | None, out: Path | None, cluster):
    """The inverse study file read, ``--repeats`` and ``--out`` checked (and ccx found
    for an embedded cluster): everything is validated before anything runs."""
    from farm.ccx.runner import find_ccx
    from jobs.inverse.study import load_inverse_study, with_repeats
    from jobs.validate import limits, scalars
    from tyre_farm_cli.checks import output_folder

    study = load_inverse_study(study_file)
    with usage():
        if repeats is not None:
            scalars.integer(repeats, "--repeats", low=1, high=limits.MAX_REPEATS)
            study = with_repeats(study, repeats)
        if out is not None:
            output_folder(out, "--out")
    if cluster.embedded:
        find_ccx()
    return study


def _document(study, report, frames: dict, figures: list[Path], folder: Path) -> dict:
    """``farm invert --json``: what the summary line and the tables show, as numbers (the
    tables are those of the CSV files, unformatted: no "mean ± std" text)."""
    t = report.totals
    objectives = [r.objective for r in report.results if math.isfinite(r.objective)]
    return {"study": study.name, "store": study.location, "group": study.group,
            "ok": report.ok, "solves": len(report.results),
            "evaluations": t.evaluations, "solved": t.solved, "cached": t.cached,
            "shared": t.shared, "rounds": t.rounds,
            "median_objective": statistics.median(objectives) if objectives else None,
            "wall_seconds": round(report.wall_seconds, 3), "errors": report.errors,
            "out": folder if report.results else None, "histograms": figures,
            "tables": {name: records(f) for name, f in frames.get("tables", {}).items()}}


TITLES = {"forces": "Forces and moments, mean ± std over repeats (thesis Tables 4.1/4.3)",
          "rmse": "RMSE: U mm, strain microstrain (thesis Tables 4.2/4.4)",
          "nodal_errors": "Nodal force errors [N] (thesis Figs. 4.2/4.3)",
          "cost": "Cost per solve (means)",
          "guesses": "Initial guesses: evaluations to converge, nodal errors of the guess and "
                     "the solution [N] (issue 16)"}


def _report(store: StoreLike, group: str, folder: Path) -> tuple[dict, list[Path]]:
    """Tables (CSV) and histograms (PNG) from the group as stored: the report shows what
    the store holds, and nothing the store lacks. Returns {"tables": the CSVs' frames,
    "views": the terminal's} and the histograms."""
    from analysis.report import ch4, ch4_extra
    from storage.solves import open_solves

    ds = open_solves(store, group)
    folder.mkdir(parents=True, exist_ok=True)
    guesses = ch4_extra.guesses(ds)
    tables = {**ch4.tables(ds), "guesses": guesses}
    for name, frame in tables.items():
        frame.to_csv(folder / f"{name}.csv", index=False)
    views = {**ch4.views(ds), "guesses": guesses.round(4)}
    return {"tables": tables, "views": views}, ch4.histograms(ds, folder)
