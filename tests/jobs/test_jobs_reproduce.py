"""The reproduction's simulations as plain functions: the chapter-3 and chapter-4 study
texts, what a stage run reports (without ccx: the sweep is faked), and the imports of
``jobs/reproduce`` (farm, storage and jobs only: never analysis or the CLI)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import jobs.sweep
from jobs.inverse.study import parse_inverse_study
from jobs.reproduce import Options, validation
from jobs.reproduce.inverse import study_text
from jobs.study import parse_study
from jobs.sweep import SweepReport

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("coarse", [True, False])
def test_the_chapter_3_sweeps_are_the_thesis_force_deflection_cases(tmp_path, coarse):
    opts = Options(out=tmp_path, store=str(tmp_path / "s.zarr"), coarse=coarse)
    studies = {n: parse_study(t, n) for n, t in validation.studies(opts).items()}
    full, reduced = studies["ch3-full"], studies["ch3-reduced"]
    steps = tuple(float(d) for d in range(5, 45, 5))
    assert full.deflections == reduced.deflections == steps
    assert full.pressures == (0.08, 0.2) and reduced.pressures == (0.0,)
    # chapter 5 reads the 200 kPa experiments from this very group
    assert full.group_name == opts.group("full") == f"full-table-3.1-{opts.mesh_tag()}"
    assert reduced.group_name == opts.group("reduced")
    assert full.store == reduced.store == opts.store
    assert (full.model.mesh.circumferential, reduced.model.mesh.circumferential) == (
        (16, 8) if coarse else (40, 20))
    assert reduced.model.materials.tread.youngs_modulus == 10.0  # Table 3.1


@pytest.mark.parametrize(("quick", "coarse", "optimizers", "repeats"), [
    (True, True, {"least-squares"}, 1), (True, False, {"least-squares"}, 2),
    (False, False, {"least-squares", "nelder-mead"}, 10)])
def test_the_chapter_4_study_has_the_thesis_conditions(tmp_path, quick, coarse, optimizers,
                                                       repeats):
    opts = Options(out=tmp_path, store=str(tmp_path / "s.zarr"), quick=quick, coarse=coarse)
    study = parse_inverse_study(study_text(opts), "ch4.toml", tmp_path)
    thesis = ["ideal", "noise", "guess-90", "guess-uniform"]
    # the tyre-distribution start (issue 16) after the thesis' four
    assert [c.name for c in study.conditions] == [*thesis, "distribution"]
    assert {o.name for o in study.optimizers} == optimizers
    assert [c.repeats for c in study.conditions] == [1, *[repeats] * 4]
    lsq = study.optimizer("least-squares")
    assert (lsq.jacobian, lsq.warm_starts) == ("shared", True)
    # the benchmark's study (benchmarks/bench_inverse_study.py): the thesis' four, and
    # issue 16's "before": full Jacobians, every point from rest
    before = parse_inverse_study(study_text(opts, "full", warm=False, distribution=False),
                                 "ch4.toml", tmp_path)
    assert [c.name for c in before.conditions] == thesis and before.distribution is None
    lsq = before.optimizer("least-squares")
    assert (lsq.jacobian, lsq.warm_starts) == ("full", False)
    assert study.model.materials.tread.youngs_modulus < 10  # the 359 N reference (§4.1)
    assert study.deflection == 30 and study.noise.displacement == 1.0


def test_a_stage_run_sums_the_sweeps_and_notes_failures_without_printing(
        tmp_path, monkeypatch, capsys):
    def fake_sweep(study, *, cluster=None, progress=None):
        report = SweepReport(study, total=16, skipped=2, ccx_runs=3, solve_seconds=1.5,
                             done=[f"e{k}" for k in range(14)])
        if study.name == "ch3-reduced":
            report.done = report.done[2:]
            report.failed = {"e0": "too many cutbacks", "e1": "too many cutbacks"}
        return report

    monkeypatch.setattr(jobs.sweep, "run_sweep", fake_sweep)
    lines = []
    run = validation.run(Options(out=tmp_path, store=str(tmp_path / "s.zarr")), log=lines.append)
    assert list(run.studies) == list(run.texts) == list(run.reports) == ["ch3-full",
                                                                         "ch3-reduced"]
    assert run.ccx_runs == 6 and run.solver_seconds == 3.0 and run.wall_seconds >= 0
    assert run.notes == ["ch3-reduced: 2 experiments failed: too many cutbacks"]
    assert len(lines) == 2 and lines[0].startswith("ch3-full: 16 experiments (2 already done)")
    assert capsys.readouterr().out == ""


def _imports(path: Path) -> set[str]:
    """Top-level packages ``path`` imports, at module level or inside functions."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_jobs_reproduce_imports_neither_analysis_nor_the_cli():
    files = sorted((ROOT / "jobs" / "reproduce").glob("*.py"))
    assert {p.stem for p in files} >= {"__init__", "options", "validation", "inverse"}
    for path in files:
        imported = _imports(path)
        assert not imported & {"analysis", "tyre_farm_cli", "typer", "rich"}, path.name
