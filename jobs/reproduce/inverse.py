"""Chapter 4 of the reproduction: the virtual inverse problems (thesis Tables 4.1-4.4).

The reference is the reduced model at 30 mm on the iterative road with the
"thesis-calibrated" materials, whose 359 N is the thesis' own reference force (§4.1),
so that forces and moments compare directly. ``quick`` solves the thesis' four
conditions with the parallel-Jacobian least squares (§5.2/§6.2's recommendation: a few
dozen sequential rounds instead of hundreds of serial evaluations), reusing Jacobians
between rounds and loops (``JACOBIAN``) and continuing every solve from the loop's
solved states (warm starts; docs/inverse.md), two repeats of each random condition (one
on the test-sized ``coarse`` meshes), and a fifth condition whose initial guess is the
statistical "tyre distribution" of §6.2 (``jobs/inverse/distribution.py``), trained on
the chapter-3 reduced sweep of the same run (same mesh; its 30 mm experiment left out).
Then the noisy conditions again, once per regularisation (``REGULARISED``, weights by
the discrepancy principle), one repeat each (issue 16's tables; their unregularised
first stages replay the first repeat from the cache). ``quick=False`` adds the thesis'
own Nelder-Mead and ten repeats of everything.
Evaluations are cached next to the store, so a second run solves nothing.
"""

from __future__ import annotations

import time

from jobs.reproduce.options import COARSE_MESH, Options
from jobs.reproduce.stage import Log, ProgressFor, StageRun, logger
from jobs.wording import plural

MATERIALS = "thesis-calibrated"
# Least squares reuses Jacobians: Broyden updates between full ones, shared between
# the loops (docs/inverse.md, "Jacobian reuse"): the same tables for fewer ccx runs
JACOBIAN = "shared"

# (name, initial guess, scale, guess sigma N, noise) - thesis §4.3-4.5
ConditionRow = tuple[str, str, float, float, bool]
CONDITIONS: tuple[ConditionRow, ...] = (
    ("ideal", "scaled", 0.9, 0.0, False), ("noise", "scaled", 0.9, 0.0, True),
    ("guess-90", "scaled", 0.9, 4.0, True),
    ("guess-uniform", "uniform", 1.0, 4.0, True))
# beyond the thesis (§6.2): the "tyre distribution" guess, with noise, no guess jitter
DISTRIBUTION: ConditionRow = ("distribution", "distribution", 1.0, 0.0, True)
# the noisy conditions again, once per regularisation (weights: discrepancy principle)
REGULARISED = ("tikhonov", "smoothness", "guess")


def study_text(opts: Options, jacobian: str = JACOBIAN, regularisation: str = "none",
               warm: bool = True, distribution: bool = True) -> str:
    """The inverse study of the reproduction (written next to the report).

    ``jacobian``: how least squares gets its Jacobians; ``warm``: whether its solves
    continue from the loop's solved points (``jacobian = "full"`` without warm starts
    is the path before issue 16; benchmarks/bench_inverse.py --study compares them).
    ``regularisation`` other than "none": the study of ``regularised_text``.
    ``distribution``: with the "tyre distribution" condition (trained on the store's
    chapter-3 reduced sweep); without, the thesis' four alone (the benchmark's study).
    """
    regularised = regularisation != "none"
    repeats = 1 if opts.coarse or (opts.quick and regularised) else 2 if opts.quick else 10
    optimizers = (['"least-squares"'] if opts.quick or regularised
                  else ['"nelder-mead"', '"least-squares"'])
    mesh = f"[model.mesh]\n{COARSE_MESH['reduced']}\n" if opts.coarse else ""
    suffix = f"-{regularisation}" if regularised else ""
    lines = [f'[study]\nname = "ch4-{"quick" if opts.quick else "full"}-{opts.mesh_tag()}'
             f'{suffix}"',
             f'store = "{opts.store}"\nseed = 0\n',
             f'[model]\nkind = "reduced"\nmaterials = "{MATERIALS}"\n{mesh}',
             "[reference]\ndeflection_mm = 30\n",
             "[noise]\ndisplacement_mm = 1.0\nstrain = 4e-4\n",
             # ccx's .frd carries six significant digits: relative changes of the cost
             # below ~1e-5 are rounding, and polishing them cost 2-4x the rounds
             "[optimizers.least-squares]\nmax_evaluations = 200\nfd_step_n = 0.1\n"
             f'tolerance = 1e-5\njacobian = "{jacobian}"\n'
             f"warm_starts = {str(warm).lower()}\n"
             + (f'regularisation = "{regularisation}"\nweight = "discrepancy"\n'
                if regularised else "")]
    if not opts.quick and not regularised:
        lines.append('[optimizers.nelder-mead]\nmax_evaluations = 600\n'
                     'noise_draw = "per_evaluation"\n')
    conditions = CONDITIONS
    if distribution:  # the §6.2 guess, trained on the chapter-3 sweep of this run
        lines.append(f'[distribution]\nstore = "{opts.store}"\n'
                     f'group = "{opts.group("reduced")}"\nexclude_within_mm = 0.5\n')
        conditions += (DISTRIBUTION,)
    for name, initial, scale, sigma, noise in conditions:
        if regularised and not noise:  # nothing to regularise against
            continue
        lines.append(f'[[conditions]]\nname = "{name}"\nmethods = ["displacement", "strain"]\n'
                     f'optimizers = [{", ".join(optimizers)}]\ninitial = "{initial}"\n'
                     f"scale = {scale}\nguess_sigma_n = {sigma}\n"
                     f"noise = {str(noise).lower()}\nrepeats = {repeats if noise else 1}\n")
    return "\n".join(lines)


def regularised_text(opts: Options, regularisation: str) -> str:
    """The noisy conditions of the full study (the distribution guess included), least
    squares regularised by ``regularisation`` with the weight the discrepancy principle
    chooses from the noise level (jobs/inverse/regularisation.py)."""
    return study_text(opts, regularisation=regularisation)


def run(opts: Options, log: Log | None = None, progress: ProgressFor | None = None) -> StageRun:
    """Run the chapter-4 study on the farm; its report is ``reports["ch4"]``.

    ``progress("ch4")`` gives the loops their progress display (none by default).
    """
    from jobs.inverse.run import run_inverse
    from jobs.inverse.study import parse_inverse_study

    log = logger(log)
    start, stage = time.perf_counter(), StageRun("inverse")
    text = study_text(opts)
    study = parse_inverse_study(text, "ch4.toml", opts.out)
    stage.texts["ch4"], stage.studies["ch4"] = text, study
    report = run_inverse(study, cluster=opts.cluster_spec(),
                         progress=progress("ch4") if progress else None)
    stage.reports["ch4"] = report
    log(f"ch4: {report.summary()}")
    stage.ccx_runs, stage.solver_seconds = report.totals.solved, report.totals.solver_seconds
    stage.notes += notes(report)
    for reg in REGULARISED:  # same cache: stage 1 replays the above
        name = f"ch4-{reg}"
        text = regularised_text(opts, reg)
        study = parse_inverse_study(text, f"{name}.toml", opts.out)
        stage.texts[name], stage.studies[name] = text, study
        extra = run_inverse(study, cluster=opts.cluster_spec(),
                            progress=progress(name) if progress else None)
        stage.reports[name] = extra
        log(f"{name}: {extra.summary()}")
        stage.ccx_runs += extra.totals.solved
        stage.solver_seconds += extra.totals.solver_seconds
        stage.notes += [f"{name} ({reg} regularisation, weights by the discrepancy principle): "
                        f"{plural(len(extra.results), 'solve')}, {extra.totals.solved} "
                        "solved by ccx"]
        stage.notes += [f"{name} {label}: {error}" for label, error in extra.errors.items()]
    stage.wall_seconds = time.perf_counter() - start
    return stage


def notes(report) -> list[str]:
    """What the inverse run solved (reference, counts) and which loops failed, as text."""
    problem, t = report.problem, report.totals
    lines = [f"reference: reduced model ({MATERIALS} materials) at {report.study.deflection:g}"
             f" mm on the iterative road, Fz = {problem.reference.total_force[2]:.1f} N "
             f"(thesis 359.08 N); {problem.n} unknown nodal forces (thesis 14)",
             f"{plural(len(report.results), 'solve')}, {plural(t.evaluations, 'evaluation')}, "
             f"{t.solved} solved by "
             f"ccx this run, {t.cached} from the evaluation cache, {t.shared} shared between "
             "loops; noise is drawn once per solve for least squares, at every evaluation "
             "for Nelder-Mead (as the thesis, §4.4)"]
    lines += [f"{label}: {error}" for label, error in report.errors.items()]
    return lines
