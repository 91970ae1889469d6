"""``--json`` on ``farm analyse``, ``farm invert`` and ``farm calibrate`` (issue 25): one
JSON document on stdout, nothing else there, with the numbers the tables show (which the
commands also write as CSV: the document must agree with those files)."""

from __future__ import annotations

import json
import types

import numpy as np
import pandas as pd
import pytest
from cli_helpers import run_cli

from jobs.loops.evaluator import LoopStats
from storage.solves import DIRECTIONS, SolveRecord, SolvesAttrs, Unknowns, write_solves
from tests.synthetic import make_store

SMALL = {"rows": 8, "cols": 16, "tread_rows": 6, "tread_cols": 12}


def _same(rows: list[dict], csv) -> None:
    """The document's table equals the CSV the command wrote (an empty CSV cell is a
    missing number, null here, or an empty text)."""
    frame = pd.read_csv(csv)
    assert len(rows) == len(frame) > 0
    assert list(rows[0]) == list(frame.columns)
    for row, (_, expected) in zip(rows, frame.iterrows(), strict=True):
        for col, value in expected.items():
            got = row[col]
            if isinstance(value, float) and np.isnan(value):
                assert got is None or got == "", col
            elif isinstance(value, (float, np.floating)):
                assert got == pytest.approx(value, rel=1e-9, abs=1e-12), col
            else:
                assert str(got) == str(value), col


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("stores") / "s.zarr"
    make_store(path, n_experiments=7, n_failed=1, **SMALL)
    return path


@pytest.mark.parametrize("command", ["pca", "pcr"])
def test_analyse_json_is_the_tables_it_wrote(store, tmp_path, capsys, command):
    code, out, err = run_cli(["analyse", command, str(store), "--out", str(tmp_path / "j"),
                              "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)  # the whole of stdout is one document
    assert doc["out"] == str(tmp_path / "j") and doc["summary"].endswith("summary.md")
    assert doc["tables"] and all((tmp_path / "j" / f"{n}.csv").exists() for n in doc["tables"])
    for name, rows in doc["tables"].items():
        _same(rows, tmp_path / "j" / f"{name}.csv")
    code, text, _ = run_cli(["analyse", command, str(store), "--out", str(tmp_path / "t")],
                            capsys)
    assert code == 0 and text.startswith(f"wrote {len(doc['files'])} files to ")


def test_an_analysis_names_its_command_commit_and_load(store, tmp_path, capsys):
    """What `farm analyse` wrote ends with where it came from (analysis/render/provenance)."""
    from analysis.render.provenance import ROOT, code_commit

    out = tmp_path / "p"
    code, _, err = run_cli(["analyse", "pca", str(store), "--out", str(out)], capsys)
    assert code == 0, err
    rows = dict(pd.read_csv(out / "provenance.csv").itertuples(index=False))
    assert rows["command"] == f"farm analyse pca {store} --out {out}"
    assert rows["commit"] == code_commit()
    if (ROOT / ".git").exists():  # a checkout (CI's clean clone): the commit itself
        assert len(rows["commit"]) == 40 and int(rows["commit"], 16) >= 0
    summary = (out / "summary.md").read_text()
    assert summary.index("## Provenance") > 0 and f"`farm analyse pca {store}" in summary


# ---------------------------------------------------------------- farm invert

X_TRUE = np.array([10.0, 20.0, 40.0])


def _solve(i: int, repeat: int, fz: float) -> SolveRecord:
    return SolveRecord(
        id=f"s{i}", condition="ideal", method="displacement", optimizer="least-squares",
        repeat=repeat, status="converged", message="", objective_units="mm",
        x0=0.9 * X_TRUE, x_final=X_TRUE + i, x_history=np.tile(X_TRUE, (3, 1)),
        objective_history=np.linspace(1.0, 0.1, 3), objective=0.1 * (i + 1),
        total_force=np.array([0.0, 0.0, fz]), moment=np.array([-1000.0, 20.0, 0.0]),
        rmse=dict(zip(DIRECTIONS, (0.01, 0.02, 0.03, 1e-4, 2e-4, 3e-4), strict=True)),
        solved=3, rounds=2, wall_seconds=10.0, solver_seconds=5.0)


@pytest.fixture
def inverse_study(tmp_path, monkeypatch):
    """An inverse study whose group holds two solves; run_inverse answers at once (the
    loops are jobs' business: this tests what the CLI prints of the stored group)."""
    import jobs.inverse.run
    from jobs.inverse.study import load_inverse_study

    path = tmp_path / "inverse.toml"
    path.write_text(f'[study]\nname = "j"\nstore = "{tmp_path / "inv.zarr"}"\n'
                    '[model]\nkind = "reduced"\n[model.mesh]\ntread = 4\nsidewall = 2\n'
                    'bead = 1\ncircumferential = 8\n[[conditions]]\nname = "ideal"\n'
                    'noise = false\nrepeats = 2\n')
    study = load_inverse_study(path)
    write_solves(study.store, study.group,
                 Unknowns(np.array([7, 8, 9]), X_TRUE, np.zeros((3, 3)),
                          np.array([0.0, 0.0, 70.5]), np.array([-840.0, 20.0, 0.0])),
                 [_solve(0, 0, 69.0), _solve(1, 1, 71.0)],
                 SolvesAttrs("j", '{"kind": "reduced"}', "CalculiX 2.20", 30.0, -369.2,
                             '{"displacement_mm": 1.0, "strain": 0.0004}', "abc"))
    results = [types.SimpleNamespace(objective=0.1), types.SimpleNamespace(objective=0.3)]
    report = types.SimpleNamespace(
        results=results, errors={}, ok=True, wall_seconds=12.5,
        totals=LoopStats(evaluations=6, rounds=4, solved=5, cached=1, shared=0),
        summary=lambda: "2 solves, 6 evaluations")
    monkeypatch.setattr(jobs.inverse.run, "run_inverse", lambda *a, **k: report)
    return path


def test_invert_json_has_the_summary_and_the_csv_tables(inverse_study, tmp_path, capsys):
    code, out, err = run_cli(["invert", str(inverse_study), "--out", str(tmp_path / "r"),
                              "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    assert (doc["solves"], doc["evaluations"], doc["solved"], doc["cached"], doc["rounds"]) == (
        2, 6, 5, 1, 4)
    assert doc["median_objective"] == pytest.approx(0.2) and doc["ok"] is True
    assert set(doc["tables"]) >= {"forces", "rmse", "nodal_errors", "cost", "guesses"}
    for name, rows in doc["tables"].items():
        if rows:
            _same(rows, tmp_path / "r" / f"{name}.csv")
    forces = {r["condition"]: r for r in doc["tables"]["forces"]}
    assert forces["ideal"]["Fz_mean"] == pytest.approx(70.0)  # (69 + 71) / 2
    code, text, _ = run_cli(["invert", str(inverse_study), "--out", str(tmp_path / "t")],
                            capsys)
    assert code == 0 and "2 solves, 6 evaluations" in text and "Fz" in text


# ---------------------------------------------------------------- farm calibrate

MESH = ["--set", "mesh.tread=4", "--set", "mesh.sidewall=2", "--set", "mesh.bead=1",
        "--set", "mesh.circumferential=8"]


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_calibrate_json_agrees_with_its_csv_files(tmp_path, capsys):
    refs = tmp_path / "refs.csv"
    refs.write_text("model,deflection_mm,pressure_kpa,force_n\nreduced,20,0,250\n")
    args = ["calibrate", "--references", str(refs), *MESH, "--workers", "1",
            "--max-evaluations", "4", "--out", str(tmp_path / "cal")]
    code, out, err = run_cli([*args, "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    _same(doc["parameters"], tmp_path / "cal" / "parameters.csv")
    _same(doc["points"], tmp_path / "cal" / "points.csv")
    assert doc["points"][0]["reference_n"] == 250 and doc["evaluations"] >= 1
    code, text, _ = run_cli(args, capsys)  # replayed from the cache: the same numbers
    assert code == 0 and "fitted parameters" in text
    assert f"{doc['evaluations']} evaluations in {doc['rounds']} rounds" in text
