"""``farm reproduce``: the thesis study end to end - validation, dataset, analyses,
inverse problems - with a report that puts every number beside the thesis' own.

The simulations are ``jobs.reproduce``'s, the tables, figures and the report
``analysis.report``'s; this module runs them stage by stage. Every stage is idempotent:
sweeps skip what the store holds as done and inverse loops replay their cached
evaluations, so a second run solves nothing and only redraws tables and figures.
"""

from __future__ import annotations

import time
from pathlib import Path

import typer
from rich.console import Console

from tyre_farm_cli.errors import usage
from tyre_farm_cli.invert import loop_progress
from tyre_farm_cli.options import SCHEDULER, WORKERS, with_cluster
from tyre_farm_cli.params import check_materials
from tyre_farm_cli.progress import LogLines, interactive
from tyre_farm_cli.progress import console as stderr_console
from tyre_farm_cli.sweep import sweep_progress


@with_cluster
def reproduce(
    quick: bool = typer.Option(True, "--quick/--full", help="A reduced set of inverse "
                               "conditions and noise draws (--full: all, 10 repeats)."),
    out: Path = typer.Option(Path("reproduction"), "--out", help="Report folder."),
    store: str = typer.Option(None, "--store", help="Zarr store [default: OUT/thesis.zarr]."),
    scheduler: str = SCHEDULER,
    workers: int = WORKERS,
    coarse: bool = typer.Option(False, "--coarse", help="Test-sized coarse meshes (minutes, "
                                "not for conclusions)."),
    materials: str = typer.Option("table-3.1", "--materials", help="Material preset."),
    cluster=None,
) -> None:
    """Run the thesis study (chapters 3-5) on the farm and write OUT/report.md."""
    from analysis.render.provenance import Run
    from analysis.report import reproduction
    from farm.ccx.runner import ccx_version
    from tyre_farm_cli.invocation import command as invocation

    run = Run(invocation())  # the command, commit and load before the first stage
    opts = _options(quick, out, store, scheduler, workers, coarse, materials, cluster)
    done = []
    for name, stage in (("chapter 3: validation", _validation),
                        ("chapter 5: dataset analyses", _dataset),
                        ("chapter 4: inverse problems", _inverse)):
        _stage_log(f"reproduce: {name}", rule=True)
        done.append(stage(opts))
    provenance = reproduction.provenance(
        run, solver=f"CalculiX {ccx_version()}", store=opts.store, quick=opts.quick,
        meshes=opts.mesh_tag(), materials=opts.materials, scheduler=opts.scheduler,
        workers=opts.workers)
    path = reproduction.write(opts.out, done, provenance, opts.quick)
    Console().print(f"report: {path}")  # the result, on stdout


def _options(quick: bool, out: Path, store: str | None, scheduler: str, workers: int,
             coarse: bool, materials: str, cluster):
    """The study's options, every argument checked (and ccx found) before anything runs."""
    from farm.ccx.runner import find_ccx
    from jobs.cluster import DaskCluster, resolve_scheduler
    from jobs.reproduce import Options
    from jobs.validate import locations
    from tyre_farm_cli.checks import output_folder

    with usage():
        check_materials(materials)
        output_folder(out, "--out")
        if store is not None:
            store = locations.store_location(store, "--store")
    find_ccx()
    out = out.resolve()
    return Options(out=out, store=store or str(out / "thesis.zarr"), quick=quick,
                   coarse=coarse, materials=materials,
                   # the provenance names the scheduler the environment gave, if any
                   scheduler=(resolve_scheduler(scheduler)
                              if isinstance(cluster, DaskCluster) else "slurm"),
                   workers=workers, cluster=cluster)


def _stage_log(text: str, rule: bool = False) -> None:
    """A progress line on stderr: a rule or a plain line on a terminal, else a
    timestamped line flushed at once (``farm reproduce 2>log`` shows it as it happens)."""
    if not interactive():
        LogLines().log(text)
    elif rule:
        stderr_console().rule(text)
    else:
        stderr_console().print(text, markup=False)


def _validation(opts):
    """Chapter 3: the force-deflection sweeps, then their tables and figure from the store."""
    from analysis.report import ch3
    from jobs.reproduce import validation

    start = time.perf_counter()
    run = validation.run(opts, log=_stage_log, progress=sweep_progress)
    stage = ch3.validation(opts.store, run.studies["ch3-full"].group_name,
                           run.studies["ch3-reduced"].group_name, opts.out / "figures")
    stage.notes += run.notes
    stage.ccx_runs, stage.solver_seconds = run.ccx_runs, run.solver_seconds
    stage.studies.update(run.texts)
    stage.wall_seconds = time.perf_counter() - start
    return stage


def _dataset(opts):
    """Chapter 5: the analyses of the validation's 200 kPa experiments (nothing solved)."""
    from analysis.report import ch5

    return ch5.dataset(opts.store, opts.group("full"), opts.out, quick=opts.quick)


def _inverse(opts):
    """Chapter 4: the inverse study, then Tables 4.1-4.4 and Figs. 4.2/4.3 beside the thesis,
    drawn from the study's group as stored (what the report shows is what the store holds)."""
    from analysis.report import ch4, ch4_extra
    from analysis.report.reproduction import StageResult
    from jobs.reproduce import inverse
    from storage.solves import open_solves

    start = time.perf_counter()
    run = inverse.run(opts, log=_stage_log, progress=loop_progress)
    stage = StageResult("inverse", notes=list(run.notes), ccx_runs=run.ccx_runs,
                        solver_seconds=run.solver_seconds, studies=dict(run.texts))
    study = run.studies["ch4"]
    if run.reports["ch4"].results:
        ds = open_solves(study.store, study.group)
        stage.tables.update(_ch4_tables(ch4, ds))
        stage.tables["Initial guesses: evaluations to converge, nodal errors of the guess and "
                     "of the solution, N"] = ch4_extra.guesses(ds).round(4)
        groups = {name.removeprefix("ch4-"): open_solves(s.store, s.group)
                  for name, s in run.studies.items()
                  if name != "ch4" and run.reports[name].results}
        if groups:  # the regularised studies, beside the same noise draws unregularised
            baseline = {"none": ch4_extra.same_solves(ds, groups)}
            stage.tables["Regularisation, weights by the discrepancy principle: nodal errors "
                         "and total force, ours beside the thesis'"] = \
                ch4_extra.regularisation(baseline | groups).round(4)
        for path in ch4.histograms(ds, opts.out / "ch4"):
            stage.figures[f"Nodal force errors, {path.stem.removeprefix('nodal_errors_')} "
                          "(thesis Figs. 4.2/4.3)"] = path
    stage.wall_seconds = time.perf_counter() - start
    return stage


def _ch4_tables(ch4, ds) -> dict:
    import numpy as np

    def text(value) -> str:
        return "-" if value is None or not np.isfinite(value) else f"{value:.3g}"

    views = ch4.views(ds)
    nodal = ch4.nodal_errors(ds)
    for col in ("thesis_std", "thesis_std_over_max_force"):
        nodal[col] = [text(v) for v in nodal[col]]
    return {"Forces and moments, ours and the thesis' (Tables 4.1/4.3)": views["forces"],
            "RMSE of the inner-surface fields: ours (thesis), mm and microstrain "
            "(Tables 4.2/4.4)": views["rmse"],
            "Nodal force errors x - x_true, N (Figs. 4.2/4.3)": nodal,
            "Solver cost per solve (means over repeats)": ch4.cost(ds)}
