"""``farm sweep submit|resume|status``: sweeps of virtual experiments on Dask."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

from cli.options import SCHEDULER, WORKERS

app = typer.Typer(help="Sweeps of virtual experiments on Dask: submit, resume, status.",
                    no_args_is_help=True)

STUDY = typer.Argument(..., help="Study file (TOML), e.g. examples/thesis_ch5_dataset.toml.")
RETRY = typer.Option(False, "--retry-failed", help="Run experiments that failed before again.")


class RichProgress:
    """Progress bar (done / failed / running / ETA) and the dashboard address."""

    def __init__(self, console: Console) -> None:
        self.console, self.bar, self.task = console, None, None

    def started(self, session, state) -> None:
        self.console.print(f"dashboard: {session.dashboard}   workers: {session.workers}   "
                           f"experiments: {state.total} ({state.skipped} already done)")
        self.bar = Progress(
            TextColumn("[bold]sweep"), BarColumn(), MofNCompleteColumn(),
            TextColumn("done {task.fields[done]}  failed {task.fields[failed]}  "
                       "running {task.fields[running]}"),
            TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
            console=self.console, transient=False)
        self.bar.start()
        self.task = self.bar.add_task("sweep", total=state.total, completed=state.skipped,
                                      done=0, failed=0, running=0)

    def advanced(self, state) -> None:
        if self.bar is not None:
            self.bar.update(self.task, completed=state.skipped + state.done + state.failed,
                            done=state.done, failed=state.failed, running=state.running)

    def finished(self, report) -> None:
        if self.bar is not None:
            self.bar.stop()


def _summary(report, console: Console) -> None:
    table = Table(title=f"sweep {report.study.name}: {report.study.store} "
                        f"(group {report.study.group_name})")
    for col in ("experiments", "already done", "done now", "failed", "ccx runs",
                "solver s", "wall s"):
        table.add_column(col, justify="right")
    table.add_row(str(report.total), str(report.skipped), str(len(report.done)),
                  str(len(report.failed)), str(report.ccx_runs), f"{report.solve_seconds:.1f}",
                  f"{report.wall_seconds:.1f}")
    console.print(table)
    if report.failed:
        _failure_table([(i, report.experiments[i].deflection, report.experiments[i].pressure, r)
                        for i, r in report.failed.items()], console)


def _failure_table(rows, console: Console) -> None:
    table = Table(title="failed experiments")
    for col in ("experiment", "deflection mm", "pressure kPa", "reason"):
        table.add_column(col)
    for exp, d, p, reason in rows:
        table.add_row(exp[:12], f"{d:g}", f"{1000 * p:g}", reason[:160])
    console.print(table)


def _run(study_file: Path, scheduler, workers, retry_failed) -> None:
    from jobs.study import load_study
    from jobs.sweep import run_sweep

    study = load_study(study_file)  # everything is validated before anything starts
    console = Console()
    report = run_sweep(study, scheduler=scheduler, workers=workers, retry_failed=retry_failed,
                       progress=RichProgress(console))
    _summary(report, console)
    raise typer.Exit(0 if report.ok else 1)


@app.command("submit")
def submit(study: Path = STUDY, scheduler: str = SCHEDULER, workers: int = WORKERS,
           retry_failed: bool = RETRY) -> None:
    """Run every experiment of a study that the store does not hold as done yet."""
    _run(study, scheduler, workers, retry_failed)


@app.command("resume")
def resume(study: Path = STUDY, scheduler: str = SCHEDULER, workers: int = WORKERS,
           retry_failed: bool = RETRY) -> None:
    """Finish an interrupted sweep (the same idempotent operation as submit)."""
    _run(study, scheduler, workers, retry_failed)


@app.command("status")
def status(target: str = typer.Argument(..., help="A study file (.toml) or a store path/URL."),
           group: str = typer.Option(None, "--group", help="One group of the store.")) -> None:
    """Counts of pending, done and failed experiments, and why the failed ones failed."""
    from jobs.status import store_status
    from jobs.study import load_study

    if target.endswith(".toml"):
        study = load_study(target)
        store, group = study.store, group or study.group_name
    else:
        store = target
    console = Console()
    for g in store_status(store, group):
        c = g.counts
        console.print(f"group {g.group}: {c.get('done', 0)} done, {c.get('failed', 0)} failed, "
                      f"{c.get('pending', 0)} pending")
        if g.failures:
            _failure_table([(f.experiment, f.deflection, f.pressure, f.reason)
                            for f in g.failures], console)
