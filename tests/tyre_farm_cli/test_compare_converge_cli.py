"""``farm compare`` and ``farm converge`` (issue 24): refusals, and real runs."""

import json

import pytest
from cli_helpers import COARSE_FULL, run_cli

COARSE = COARSE_FULL


def _run(argv, capsys):
    return run_cli(argv, capsys)


@pytest.mark.parametrize(("argv", "needle"), [
    (["compare", "--mesh", "fine"], "unknown mesh preset 'fine' for the full model"),
    (["compare", "--materials", "steel"], "unknown material preset 'steel'"),
    (["compare", "--set", "mesh.window=30"], "go together"),
    (["run", "--model", "reduced", "--mesh", "patch"], "choose one of thesis"),
    (["converge", "--materials", "steel"], "unknown material preset 'steel'"),
    (["converge", "--case", "roll-1m"], "--case 'roll-1m' is not a load case"),
    (["converge", "--direction", "radial"], "--direction 'radial' is not a direction"),
    (["converge", "--direction", "bead", "--mesh", "fine"], "unknown mesh preset 'fine'"),
    (["converge", "--direction", "circumferential", "--mesh", "thesis"], "has none"),
    (["converge", "--direction", "bead", "--factors", "2,x"], "--factors"),
    (["converge", "--direction", "bead", "--factors", "3"], "powers of 2"),
])
def test_bad_input_is_one_line_and_nothing_is_solved(argv, needle, capsys, monkeypatch):
    import jobs.calibrate.compare
    import jobs.convergence.run

    monkeypatch.setattr(jobs.calibrate.compare, "solve_curves", lambda *a: pytest.fail("solved"))
    monkeypatch.setattr(jobs.convergence.run, "run_study", lambda *a, **k: pytest.fail("solved"))
    code, out, err = _run(argv, capsys)
    assert code == 2 and out == "" and err.count("\n") == 1 and needle in err, err


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_compare_puts_both_readings_beside_the_model(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("FARM_CACHE_DIR", str(tmp_path / "cache"))
    code, out, err = _run(["compare", *COARSE, "--workers", "2", "--out",
                           str(tmp_path / "cmp")], capsys)
    assert code == 0, err
    assert "80kPa reading:" in out and "200kPa reading:" in out
    assert "| model-30mm-80kPa | thesis model | 80kPa | 4476 |" in out
    assert "| growth-200kPa | measured tyre | both | ≤ 4 |" in out
    doc = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    fz = {p: c["Fz"] for p, c in doc["curves"].items()}
    # stiffer with pressure and with deflection (a physical curve)
    assert all(b > a for a, b in zip(fz["0.08"], fz["0.08"][1:], strict=False))
    assert all(h > lo for lo, h in zip(fz["0.08"], fz["0.2"], strict=True))
    growth = {p: c["growth"] for p, c in doc["curves"].items()}
    assert 0 < growth["0.08"] < growth["0.2"]
    ratio = next(r for r in doc["statements"] if r["statement"] == "stiffness-ratio")
    assert ratio["ours"] > 1.0


@pytest.mark.slow
@pytest.mark.ccx
def test_converge_quick_writes_the_table(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("FARM_CACHE_DIR", str(tmp_path / "cache"))
    code, out, err = _run(["converge", "--quick", "--workers", "2", "--out",
                           str(tmp_path / "conv")], capsys)
    assert code == 0, err
    text = (tmp_path / "conv" / "convergence.md").read_text()
    assert "| vertical-200kPa | 10 mm | Fz N |" in text and "judged rows" in out
    doc = json.loads((tmp_path / "conv" / "convergence.json").read_text())
    assert {r["status"] for r in doc["records"]} == {"done"}


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_converge_refines_one_direction_and_judges_it_on_its_own(tmp_path, capsys,
                                                                 monkeypatch):
    """Issue 44: ``--direction`` solves the base and its refinement at the calibration's
    points and writes one section per direction; --replay redraws it unchanged."""
    monkeypatch.setenv("FARM_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "conv"
    code, _, err = _run(["converge", "--quick", "--direction", "sidewall", "--workers", "2",
                         "--out", str(out)], capsys)
    assert code == 0, err
    text = (out / "convergence.md").read_text()
    assert "## sidewall: window-8deg -> sidewall-x2" in text
    doc = json.loads((out / "convergence.json").read_text())
    assert doc["sequences"] == {"sidewall": ["window-8deg", "sidewall-x2"]}
    assert {(r["level"], r["case"]) for r in doc["records"]} == {
        (lv, c) for lv in ("window-8deg", "sidewall-x2") for c in ("point-80kPa", "point-200kPa")}
    assert {r["status"] for r in doc["records"]} == {"done"}
    fz = {(r["level"], r["case"]): r["states"][0]["Fz"] for r in doc["records"]}
    for case in ("point-80kPa", "point-200kPa"):
        # a finer sidewall bends more easily: the same deflection carries less load
        assert 0 < fz[("sidewall-x2", case)] < fz[("window-8deg", case)]
    assert fz[("window-8deg", "point-200kPa")] > fz[("window-8deg", "point-80kPa")]
    code, _, err = _run(["converge", "--replay", "--out", str(out)], capsys)
    assert code == 0, err
    assert (out / "convergence.md").read_text() == text


@pytest.mark.parametrize("value", ["0", "-5", "nan", "1e9"])
def test_converge_timeout_is_range_checked_before_anything_runs(value, capsys, monkeypatch,
                                                                 tmp_path):
    import jobs.convergence.run

    monkeypatch.setattr(jobs.convergence.run, "run_study", lambda *a, **k: pytest.fail("solved"))
    code, out, err = _run(["converge", "--quick", "--timeout", value, "--out",
                           str(tmp_path / "c")], capsys)
    assert code == 2 and out == "" and err.count("\n") == 1 and "--timeout" in err, err
    assert not (tmp_path / "c").exists()


def test_converge_passes_its_timeout_to_every_solve(capsys, monkeypatch, tmp_path):
    import jobs.convergence.run

    seen = []

    def fake(levels, cases, client, materials, settings=None, on_record=None):
        seen.append(settings.timeout)
        return []

    monkeypatch.setattr(jobs.convergence.run, "run_study", fake)
    monkeypatch.setattr("tyre_farm_cli.converge._write", lambda *a, **k: None)
    code, _, err = _run(["converge", "--quick", "--timeout", "7200", "--workers", "1",
                         "--out", str(tmp_path / "c")], capsys)
    assert code in (0, None), err
    assert seen == [7200.0]
