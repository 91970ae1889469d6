"""``farm sweep submit|resume|status|verify``: sweeps of virtual experiments on Dask."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from rich.table import Table

from jobs.progress import ccx_of
from jobs.wording import plural
from tyre_farm_cli.errors import usage
from tyre_farm_cli.options import (
    APP_SETTINGS,
    SCHEDULER,
    STORAGE_OPTION,
    WORKERS,
    open_target,
    with_cluster,
)
from tyre_farm_cli.progress import LogLines, interactive
from tyre_farm_cli.progress import console as stderr_console

if TYPE_CHECKING:  # storage.paths loads zarr: not at `farm --help`
    from storage.paths import StoreLike

app = typer.Typer(help="Sweeps of virtual experiments on Dask: submit, resume, status, list, "
                  "verify.", no_args_is_help=True, **APP_SETTINGS)

STUDY = typer.Argument(..., help="Study file (TOML), e.g. examples/thesis_ch5_dataset.toml.")
RETRY = typer.Option(False, "--retry-failed", help="Run experiments that failed before again.")
JSON = typer.Option(False, "--json", help="Print one JSON document on stdout, nothing else.")
STATUSES = ("done", "failed", "pending")


def _dump(document) -> None:
    typer.echo(json.dumps(document, indent=2, allow_nan=False))


class RichProgress:
    """Progress bar (done / failed / running / ETA) and the dashboard address, on a
    terminal's stderr."""

    def __init__(self, console: Console) -> None:
        self.console = console
        self.bar: Progress | None = None  # made when the sweep starts
        self.task: TaskID | None = None
        self.session: Any = None

    def started(self, session, state) -> None:
        self.session = session
        self.console.print(f"{session.where}   workers: {session.workers}   "
                           f"experiments: {state.total} ({state.skipped} already done)")
        self.bar = Progress(
            TextColumn("[bold]sweep"), BarColumn(), MofNCompleteColumn(),
            TextColumn("done {task.fields[done]}{task.fields[stored]}  failed "
                       "{task.fields[failed]}  running {task.fields[running]}"),
            TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
            TextColumn("{task.fields[ccx]}"), console=self.console, transient=False)
        self.bar.start()
        self.task = self.bar.add_task("sweep", total=state.total, completed=state.skipped,
                                      done=0, failed=0, running=0, ccx="", stored="")

    def advanced(self, state) -> None:
        if self.bar is not None and self.task is not None:
            self.bar.update(self.task, completed=state.skipped + state.done + state.failed,
                            done=state.done, failed=state.failed, running=state.running,
                            ccx=ccx_of(self.session), stored=_stored(state))

    def finished(self, report) -> None:
        if self.bar is not None:
            self.bar.stop()


class SweepLines:
    """Progress of a sweep off a terminal: timestamped, rate-limited lines on stderr."""

    def __init__(self, name: str, lines: LogLines | None = None) -> None:
        self.name, self.lines = name, lines or LogLines()
        self.seen: tuple[int, int, int] | None = None
        self.session: Any = None
        self.ccx = ""

    def started(self, session, state) -> None:
        self.session = session
        self.lines.log(f"sweep {self.name}: dashboard {session.dashboard}, "
                       f"{plural(session.workers, 'worker')}, "
                       f"{plural(state.total, 'experiment')} ({state.skipped} already done)")

    def advanced(self, state) -> None:
        ended = (state.done, state.failed, getattr(state, "stored", 0))
        ccx = ccx_of(self.session)
        if ended != self.seen or ccx != self.ccx:  # ccx's own progress: issue 48
            self.seen, self.ccx = ended, ccx
            self.lines.progress(self._text(state) + (f"; {ccx}" if ccx else ""))

    def finished(self, report) -> None:
        self.lines.flush()

    def _text(self, state) -> str:
        return (f"sweep {self.name}: {state.skipped + state.done + state.failed}/{state.total} "
                f"done{_stored(state)}, {state.failed} failed")


def _stored(state) -> str:
    """`` (+N stored by running tasks)``: states a running task (a rolling tree) has
    written already; '' when there are none."""
    stored = getattr(state, "stored", 0)
    return f" (+{stored} stored by running tasks)" if stored else ""


def sweep_progress(name: str):
    """A bar on a terminal, else log lines: on stderr either way."""
    return RichProgress(stderr_console()) if interactive() else SweepLines(name)


def _groups(report) -> list[str]:
    """The groups a sweep wrote: its study's, or one per model of a [models] design."""
    return list(dict.fromkeys(report.group_of.values())) or [report.study.group_name]


def _summary_dict(report) -> dict:
    groups = _groups(report)
    return {"study": report.study.name, "store": report.study.location,
            "group": None if report.study.models else report.study.group_name,
            "groups": groups, "ok": report.ok, "experiments": report.total,
            "already_done": report.skipped, "done_now": len(report.done),
            "failed": [{"group": report.group_of.get(i),
                        **_row(i, report.experiments[i], "failed", r)}
                       for i, r in report.failed.items()],
            "ccx_runs": report.ccx_runs, "solver_seconds": round(report.solve_seconds, 3),
            "wall_seconds": round(report.wall_seconds, 3),
            "nothing_to_do": report.nothing_to_do}


def _row(experiment: str, case, status: str, error: str) -> dict:
    """One experiment for JSON: id, load case (pressure in kPa), status, error."""
    return {"experiment": experiment, "deflection_mm": float(case.deflection),
            "pressure_kpa": round(1000 * float(case.pressure), 9), "status": status,
            "error": error}


def _summary(report, console: Console) -> None:
    if report.nothing_to_do:  # no cluster was started: no table of a run that did not run
        _nothing_to_do(report, console)
        return
    groups = _groups(report)
    where = (f"{plural(len(groups), 'group')}, one per model" if report.study.models
             else f"group {groups[0]}")
    table = Table(title=f"sweep {report.study.name}: {report.study.location} ({where})")
    for col in ("experiments", "already done", "done now", "failed", "ccx runs",
                "solver s", "wall s"):
        table.add_column(col, justify="right")
    table.add_row(str(report.total), str(report.skipped), str(len(report.done)),
                  str(len(report.failed)), str(report.ccx_runs), f"{report.solve_seconds:.1f}",
                  f"{report.wall_seconds:.1f}")
    console.print(table)
    _report_failures(report, console)


def _nothing_to_do(report, console: Console) -> None:
    failed = (f", {len(report.failed)} failed before (--retry-failed runs them again)"
              if report.failed else "")
    console.print(f"sweep {report.study.name}: nothing to do in {report.study.location}: "
                  f"{report.skipped} of {plural(report.total, 'experiment')} done{failed}",
                  highlight=False, soft_wrap=True)  # one line, a path unbroken
    _report_failures(report, console)


def _report_failures(report, console: Console) -> None:
    if report.failed:
        _failure_table([(i, report.experiments[i].deflection, report.experiments[i].pressure,
                         _motion_text(report.experiments[i]) + r)
                        for i, r in report.failed.items()], console)


def _motion_text(experiment) -> str:
    """A combined-load case's road motion, ahead of its failure reason ('' if vertical)."""
    m = getattr(experiment, "motion", None)
    if m is None:
        return ""
    return (f"[mu {m.friction:g}, shift ({m.shift_x:g}, {m.shift_y:g}) mm, tilt {m.tilt:g} "
            "deg] ")


def _failure_table(rows, console: Console) -> None:
    table = Table(title="failed experiments")
    for col in ("experiment", "deflection mm", "pressure kPa", "reason"):
        table.add_column(col)
    for exp, d, p, reason in rows:
        table.add_row(exp[:12], f"{d:g}", f"{1000 * p:g}", reason[:160])
    console.print(table)


def _run(study_file: Path, cluster, retry_failed, as_json: bool) -> None:
    from jobs.study import load_study
    from jobs.sweep import run_sweep

    study = load_study(study_file)  # everything is validated before anything starts
    if study.adaptive is not None:
        _run_adaptive(study, cluster, retry_failed, as_json)  # exits with the sweep's code
        return
    report = run_sweep(study, cluster=cluster, retry_failed=retry_failed,
                       progress=sweep_progress(study.name))
    if as_json:
        _dump(_summary_dict(report))
    else:
        _summary(report, Console())
    raise typer.Exit(0 if report.ok else 1)


def _run_adaptive(study, cluster, retry_failed, as_json: bool) -> None:
    """An adaptive study: rounds of sweeps, each chosen by a surrogate (issue 28)."""
    from analysis.adaptive import SurrogateChooser
    from jobs.adaptive.loop import run_adaptive
    from tyre_farm_cli.adaptive import RoundLines, rounds_table

    lines = RoundLines(study)
    chooser = SurrogateChooser(seed=study.adaptive.seed, criterion=study.adaptive.acquisition)
    report = run_adaptive(study, chooser, cluster=cluster,
                          retry_failed=retry_failed, progress=sweep_progress(study.name),
                          on_round=lines.fitted)
    last = report.sweeps[-1]
    if as_json:
        _dump({**_summary_dict(last), "adaptive": report.log.to_json(study.name)})
    else:
        console = Console()
        console.print(rounds_table(report.log, study))
        _summary(last, console)
    raise typer.Exit(0 if report.ok else 1)


@app.command("submit")
@with_cluster
def submit(study: Path = STUDY, scheduler: str = SCHEDULER, workers: int = WORKERS,
           retry_failed: bool = RETRY, as_json: bool = JSON, cluster=None) -> None:
    """Run every experiment of a study that the store does not hold as done yet."""
    _run(study, cluster, retry_failed, as_json)


@app.command("resume")
@with_cluster
def resume(study: Path = STUDY, scheduler: str = SCHEDULER, workers: int = WORKERS,
           retry_failed: bool = RETRY, as_json: bool = JSON, cluster=None) -> None:
    """Finish an interrupted sweep (the same idempotent operation as submit)."""
    _run(study, cluster, retry_failed, as_json)


def _target(target: str, group: str | None, options: list[str] | None = None
            ) -> tuple[StoreLike, list[str] | None, str, dict[str, dict]]:
    """The store, groups and location (text) of a study file, or of the store given, and
    what a study expects of its groups that may not exist yet.

    A study's store is opened with its ``storage_options`` when it has some; the
    location is what the user reads. A model-space study names one group per model of
    its design; for each: its load-case count and the design's parameter values.
    """
    from jobs.study import load_study

    if not target.endswith(".toml"):
        return open_target(target, options), [group] if group else None, target, {}
    study = load_study(target)
    if study.adaptive is not None:  # the points its rounds chose so far count too
        from jobs.adaptive import log

        study = log.with_points(study, log.read(study))
    expected = _expected(study)
    groups = [group] if group else list(expected)
    return study.store, groups, study.location, expected


def _expected(study) -> dict[str, dict]:
    """Group -> {"cases": load cases, "parameters": {path: value}} of a study."""
    from jobs.design import model_design
    from jobs.expand import load_cases
    from jobs.sweep import parts

    design = model_design(study)
    values: dict[str, dict[str, float]] = {}
    if design is not None:
        for row, g in zip(design.matrix, design.groups, strict=True):
            values.setdefault(g, dict(zip(design.names, map(float, row), strict=True)))
    return {p.group_name: {"cases": len(load_cases(p)), "parameters": values.get(
        p.group_name, {})} for p in parts(study)}


def _existing(store) -> set[str]:
    """The store's groups (a missing store is the error it always was)."""
    import storage

    return set(storage.list_groups(store))


TARGET = typer.Argument(..., help="A study file (.toml) or a store path/URL.")
GROUP = typer.Option(None, "--group", help="One group of the store [default: every group; "
                     "a study file's own group].")


@app.command("status")
def status(target: str = TARGET, group: str = GROUP, as_json: bool = JSON,
           storage_option: list[str] = STORAGE_OPTION) -> None:
    """Counts of pending, done and failed experiments, and why the failed ones failed."""
    from jobs.status import GroupStatus, store_status
    from storage import unfinished_groups
    from storage.errors import GroupNotFoundError, NotAStoreError, StoreError, reading

    store, names, where, expected = _target(target, group, storage_option)
    with reading("the store's groups and statuses", where):
        if names is None:
            groups = store_status(store)
        else:  # a study's groups not made yet are all pending
            made = _existing(store)
            groups = [store_status(store, g)[0] if g in made or g not in expected else
                      GroupStatus(g, {"pending": expected[g]["cases"]}, ())
                      for g in names]
        paths = {g.group: _paths(store, g.group) for g in groups if g.counts.get("done")
                 or g.counts.get("failed")}
    if as_json:
        _dump({"store": where, "groups": [
            {"group": g.group, "counts": {k: g.counts.get(k, 0) for k in STATUSES},
             "paths": paths.get(g.group),
             "failed": [_row(f.experiment, f, "failed", f.reason) for f in g.failures]}
            for g in groups]})
        return
    _print_status(groups, paths, Console())
    try:
        with reading("the store's groups", where):
            unfinished = unfinished_groups(store)
    except (NotAStoreError, GroupNotFoundError):  # a study not submitted yet: no store
        unfinished = []
    if unfinished:  # invisible otherwise: "0 groups", exit 0 (issue 26)
        raise StoreError(f"group {unfinished[0]!r} of {where} was never finished (a client "
                         "stopped creating it, e.g. on a full disk): submit the study again "
                         "to rebuild it")


def _print_status(groups, paths: dict, console: Console) -> None:
    """Each group's counts, how far its load paths are, and its failures."""
    for g in groups:
        c = g.counts
        console.print(f"group {g.group}: {c.get('done', 0)} done, {c.get('failed', 0)} failed, "
                      f"{c.get('pending', 0)} pending")
        if (p := paths.get(g.group)) is not None:
            console.print(f"  load paths: {p['whole']} of {p['paths']} whole, {p['growing']} "
                          f"growing, {p['not_started']} not started, {p['with_failures']} "
                          "with failures")
        if g.failures:
            _failure_table([(f.experiment, f.deflection, f.pressure, f.reason)
                            for f in g.failures], console)


def _paths(store, group: str) -> dict[str, int] | None:
    """How far the group's load paths are (rolls and rolling trees), or None."""
    import storage
    from analysis.splits import path_progress

    return path_progress(storage.open_dataset(store, group))


def _status_option(value: str | None) -> str | None:
    if value is not None and value not in STATUSES:
        raise typer.BadParameter(f"{value!r}: choose one of {', '.join(STATUSES)}")
    return value


@app.command("list")
def list_experiments(
    target: str = TARGET, group: str = GROUP,
    status: str = typer.Option(None, "--status", callback=_status_option,
                               help="Only experiments with this status: done, failed or "
                               "pending [default: all]."),
    as_json: bool = JSON,
    storage_option: list[str] = STORAGE_OPTION,
) -> None:
    """Experiment ids with their load case (deflection mm, pressure kPa, ...), status and
    error: the ids `farm export --experiment` takes."""
    from storage.errors import reading
    from tyre_farm_cli.listing import experiments

    store, names, where, expected = _target(target, group, storage_option)
    with reading("the store's experiments", where):
        if names is None:
            rows = experiments(store, None, status)
        else:  # a model-space study: only the groups made so far, with the design's values
            made = _existing(store)
            rows = [{**row, **expected.get(g, {}).get("parameters", {})}
                    for g in names if g in made or g not in expected
                    for row in experiments(store, g, status)]
    if as_json:
        _dump({"store": where, "experiments": rows})
        return
    _list_table(rows, Console(width=None if sys.stdout.isatty() else 240))


def _list_table(rows: list[dict], console: Console) -> None:
    from tyre_farm_cli.listing import header

    columns = list(dict.fromkeys(k for row in rows for k in row)) or ["experiment"]
    table = Table(title=plural(len(rows), "experiment"))
    for col in columns:
        table.add_column(header(col))
    for row in rows:
        table.add_row(*(_cell(row.get(c)) for c in columns))
    console.print(table)


def _cell(value) -> str:
    if value is None:
        return "-"
    return f"{value:g}" if isinstance(value, float) else str(value)[:160]


@app.command("verify")
def verify(store: str = typer.Argument(..., help="The store: a directory or fsspec URL."),
           group: str = typer.Option(None, "--group", help="Only this group of the store "
                                     "[default: every group]."),
           repair: bool = typer.Option(
               False, "--repair", help="Mark damaged experiments pending (`farm sweep resume` "
               "re-solves them), give a lost status back where the slot's checksum verifies "
               "it, and restore damaged metadata from the consolidated copy."),
           as_json: bool = JSON, storage_option: list[str] = STORAGE_OPTION) -> None:
    """Check a store for damage: metadata, ids, statuses, chunks, per-experiment checksums.

    Exit code 0 when nothing is damaged, 1 when something is (even if --repair fixed it).
    """
    from storage.verify import check_group
    from storage.verify import verify as verify_store

    target = open_target(store, storage_option)
    if group is not None:
        with usage():  # a group that is not there is a wrong argument, not damage
            check_group(target, group)
    report = verify_store(target, group, repair=repair)
    if as_json:
        typer.echo(json.dumps(report.to_dict(), indent=2))
    else:
        for line in report.lines():
            typer.echo(line)
    raise typer.Exit(0 if report.ok else 1)
