"""The quick chapter-4 study, full Jacobians vs Jacobian reuse, side by side (issue 16).

Run: .venv/bin/python benchmarks/bench_inverse.py --study [--coarse] [--workers 2]
     [--jacobians full-cold,shared]   (MODE-cold: no warm starts; a mode may carry a
                                        patience: shared:2)

The study is the one ``farm reproduce --quick`` runs (jobs/reproduce/inverse.py
``study_text``: the reduced model at 30 mm, the thesis' four conditions x {displacement,
strain}, least squares; without its tyre-distribution condition, which needs the
chapter-3 sweep), once with ``jacobian = "full"`` and every point solved from
rest (``full-cold``: the path before issue 16) and once with the reproduction's default
(shared Jacobians, warm starts: jobs/inverse/warm.py), one after the other on the same
embedded cluster, each with a fresh evaluation cache (so the reference experiment is
solved in both: its runs are in both totals). Printed per run: ccx runs (with warm
starts one run may solve several evaluations: a Jacobian's columns), evaluations,
sequential rounds, ccx seconds (the solver's own wall time summed over its runs), wall
seconds per solve; per condition and method, the quantities of Tables 4.1-4.4 (Fz,
nodal error std, RMSE of Uz and eyy) from both runs; the ratios of ccx runs (issue 16's
target: >= 4x fewer at the same final errors), ccx seconds and wall time. Wall times
depend on the machine's load: measured figures only.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from jobs.inverse.run import run_inverse
from jobs.inverse.study import parse_inverse_study
from jobs.reproduce.inverse import JACOBIAN, study_text
from jobs.reproduce.options import Options

COLD = "-cold"  # a mode without warm starts: the path before issue 16 is "full-cold"


def run_mode(coarse: bool, workers: int, jacobian: str, tmp: Path) -> dict:
    """``jacobian``: a mode of the study file's ``jacobian`` key, with warm starts
    (``MODE-cold``: without, every point from rest), or ``MODE:P`` for that mode with
    ``jacobian_patience = P`` (e.g. ``shared:2``)."""
    opts = Options(out=tmp, store=str(tmp / "store.zarr"), quick=True, coarse=coarse)
    mode, _, patience = jacobian.partition(":")
    cold = mode.endswith(COLD)
    mode = mode.removesuffix(COLD)
    text = study_text(opts, mode, warm=not cold, distribution=False)  # the thesis' four
    if patience:
        line = f'jacobian = "{mode}"\n'
        text = text.replace(line, f"{line}jacobian_patience = {int(patience)}\n")
    study = parse_inverse_study(text, "ch4.toml", tmp)
    start = time.perf_counter()
    report = run_inverse(study, workers=workers, write=False)
    wall = time.perf_counter() - start
    return {"jacobian": jacobian, "report": report, "wall": wall,
            "rows": table_rows(report)}


def table_rows(report) -> dict[tuple[str, str], dict]:
    """Tables 4.1-4.4 quantities per (condition, method), over the repeats."""
    x_true = report.problem.x_true
    groups: dict[tuple[str, str], list] = {}
    for r in report.results:
        groups.setdefault((r.spec.condition.name, r.spec.method), []).append(r)
    rows = {}
    for key, results in groups.items():
        ok = [r for r in results if r.final is not None]
        errors = np.concatenate([r.x - x_true for r in ok]) if ok else np.array([np.nan])
        rows[key] = {"fz": float(np.mean([r.x.sum() for r in ok])) if ok else np.nan,
                     "nodal_std": float(np.std(errors, ddof=1)) if errors.size > 1 else 0.0,
                     "uz": float(np.mean([r.rmse["Uz"] for r in ok])) if ok else np.nan,
                     "eyy": 1e6 * float(np.mean([r.rmse["eyy"] for r in ok])) if ok else np.nan,
                     "objective": float(np.mean([r.objective for r in results])),
                     "evaluations": int(np.mean([len(r.f_history) for r in results])),
                     "wall": float(np.mean([r.wall_seconds for r in results]))}
    return rows


def compare(coarse: bool, workers: int,
            modes: tuple[str, ...] = ("full" + COLD, JACOBIAN)) -> None:
    """Run the study once per Jacobian mode and print them side by side."""
    runs = []
    for jacobian in modes:
        with tempfile.TemporaryDirectory() as tmp:
            runs.append(run_mode(coarse, workers, jacobian, Path(tmp)))
            _print_run(runs[-1])
    if len(runs) == 2:
        report(runs, coarse, workers)


def _print_run(run: dict) -> None:
    t, n = run["report"].totals, len(run["report"].results)
    print(f"{run['jacobian']}: {t.solved} ccx runs, {t.evaluations} evaluations, {t.rounds} "
          f"rounds, {run['wall']:.1f} s ({run['wall'] / n:.1f} s per solve)", flush=True)
    for key, row in run["rows"].items():
        print(f"  {'/'.join(key):<26} Fz {row['fz']:.2f} N, nodal std {row['nodal_std']:.3f} "
              f"N, RMSE Uz {row['uz']:.2e} mm, eyy {row['eyy']:.2f} ue, objective "
              f"{row['objective']:.4g}, {row['evaluations']} evaluations", flush=True)


def report(runs: list[dict], coarse: bool, workers: int) -> None:
    problem = runs[0]["report"].problem
    print(f"quick chapter-4 study ({'coarse' if coarse else 'default'} reduced mesh, "
          f"{problem.n} unknowns, {len(runs[0]['report'].results)} solves, {workers} workers)")
    print(f"{'jacobian':<12}{'ccx runs':>10}{'evaluations':>13}{'rounds':>8}"
          f"{'ccx s':>9}{'wall s':>9}{'s/solve':>9}")
    for run in runs:
        t, n = run["report"].totals, len(run["report"].results)
        print(f"{run['jacobian']:<12}{t.solved:>10}{t.evaluations:>13}{t.rounds:>8}"
              f"{t.solver_seconds:>9.1f}{run['wall']:>9.1f}{run['wall'] / n:>9.1f}")
    print(f"final errors (Tables 4.1-4.4 quantities), {runs[0]['jacobian']} | "
          f"{runs[1]['jacobian']}:")
    print(f"{'condition/method':<26}{'Fz N':>20}{'nodal std N':>18}{'RMSE Uz mm':>22}"
          f"{'RMSE eyy ue':>18}{'evals/solve':>14}{'objective':>22}")
    a, b = runs[0]["rows"], runs[1]["rows"]
    for key in a:
        x, y = a[key], b[key]
        print(f"{'/'.join(key):<26}{x['fz']:>10.2f}{y['fz']:>10.2f}"
              f"{x['nodal_std']:>9.3f}{y['nodal_std']:>9.3f}{x['uz']:>11.2e}{y['uz']:>11.2e}"
              f"{x['eyy']:>9.2f}{y['eyy']:>9.2f}{x['evaluations']:>7}{y['evaluations']:>7}"
              f"{x['objective']:>11.4g}{y['objective']:>11.4g}")
    full, reused = (r["report"].totals for r in runs)
    names = f"{runs[0]['jacobian']} / {runs[1]['jacobian']}"
    print(f"ccx runs, {names}: {full.solved / max(reused.solved, 1):.1f}x "
          "(target >= 4x at the same final errors)")
    print(f"ccx seconds (the solver's own time, summed over runs), {names}: "
          f"{full.solver_seconds / max(reused.solver_seconds, 1e-9):.1f}x; wall: "
          f"{runs[0]['wall'] / max(runs[1]['wall'], 1e-9):.1f}x")
