"""Chapter 3 of the reproduction: the force-deflection sweeps of the full model at 80 and
200 kPa and of the reduced model, 5-40 mm (thesis Fig. 3.3, §3.3, §3.4).

Sweeps skip what the store holds as done, so a second run solves nothing.
"""

from __future__ import annotations

import time

from jobs.reproduce.options import COARSE_MESH, Options
from jobs.reproduce.stage import Log, ProgressFor, StageRun, logger
from jobs.wording import plural

STEPS = "deflection_mm = { start = 5, stop = 40, step = 5 }"


def study_text(opts: Options, name: str, kind: str, loads: str) -> str:
    """The TOML of one study of the reproduction (also written next to the report)."""
    mesh = f"[model.mesh]\n{COARSE_MESH[kind]}\n" if opts.coarse else ""
    return (f'[study]\nname = "{name}"\nstore = "{opts.store}"\n'
            f'group = "{opts.group(kind)}"\n\n'
            f'[model]\nkind = "{kind}"\nmaterials = "{opts.materials}"\n{mesh}\n'
            f"[loads]\n{loads}\n")


def studies(opts: Options) -> dict[str, str]:
    """The chapter-3 sweeps, name -> TOML: the full model at 80/200 kPa, the reduced one."""
    return {"ch3-full": study_text(opts, "ch3-full", "full",
                                   f"pressure_kpa = [80, 200]\n{STEPS}"),
            "ch3-reduced": study_text(opts, "ch3-reduced", "reduced", STEPS)}


def run(opts: Options, log: Log | None = None, progress: ProgressFor | None = None) -> StageRun:
    """Run the chapter-3 sweeps on the farm; the 200 kPa ones are chapter 5's dataset too.

    ``progress(name)`` gives each sweep its progress display (none by default).
    """
    from jobs.study import parse_study
    from jobs.sweep import run_sweep

    log = logger(log)
    start, stage = time.perf_counter(), StageRun("validation")
    for name, text in studies(opts).items():
        study = parse_study(text, f"{name}.toml")
        stage.texts[name], stage.studies[name] = text, study
        report = run_sweep(study, cluster=opts.cluster_spec(),
                           progress=progress(name) if progress else None)
        stage.reports[name] = report
        log(f"{name}: {plural(report.total, 'experiment')} ({report.skipped} already "
            f"done), {plural(report.ccx_runs, 'ccx run')}, {report.wall_seconds:.1f} s")
        stage.ccx_runs += report.ccx_runs
        stage.solver_seconds += report.solve_seconds
        if not report.ok:
            stage.notes.append(f"{name}: {plural(len(report.failed), 'experiment')} failed: "
                               + "; ".join(sorted(set(report.failed.values())))[:400])
    stage.wall_seconds = time.perf_counter() - start
    return stage
