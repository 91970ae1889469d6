"""``farm sweep`` on an adaptive study (issue 28): bad input is one line and nothing is
made; the table of its rounds."""

from __future__ import annotations

from cli_helpers import run_cli

from jobs.adaptive.log import Fit, Log, Round
from jobs.study import parse_study
from tyre_farm_cli.adaptive import rounds_table

STUDY = """[study]
name = "adaptive"
store = "{store}"
[study.adaptive]
rounds = 2
batch = 2
{extra}
[model]
kind = "reduced"
road = "contact"
[model.mesh]
circumferential = 8
[loads.sample]
method = "lhs"
n = 4
deflection_mm = [10, 25]
friction = [0.3, 1.0]
"""


def _study(tmp_path, extra: str = ""):
    path = tmp_path / "study.toml"
    path.write_text(STUDY.format(store=tmp_path / "s.zarr", extra=extra))
    return path


def test_a_bad_adaptive_key_is_one_line_and_makes_nothing(tmp_path, capsys):
    code, out, err = run_cli(["sweep", "submit", str(_study(tmp_path, "candidates = 3"))],
                             capsys)
    assert code == 1 and out == ""
    assert err.startswith("farm: error: ") and err.count("\n") == 1
    assert "study.adaptive.candidates: must be a power of 2" in err
    assert not (tmp_path / "s.zarr").exists()


def test_the_rounds_table_shows_each_fit_and_why_it_stopped(tmp_path):
    from rich.console import Console

    study = parse_study(STUDY.format(store=tmp_path / "s.zarr", extra="target_pct = 2.0"))
    fit = Fit(4, {"field": 0.5, "Fx": None, "Fy": 3.25, "Fz": 1.0, "Mz": None})
    log = Log({}, (Round(1, ((12.0, 0.5), (20.0, 0.7)), fit),),
              Fit(6, {"field": 0.25, "Fy": 1.5, "Fz": 0.75}), "target")
    console = Console(width=200, record=True)
    console.print(rounds_table(log, study))
    text = console.export_text()
    assert "every output within 2 %" in text
    assert "Fx" not in text and "Mz" not in text  # no round's fit has them: not shown
    lines = [line for line in text.splitlines() if "│" in line]
    assert [c.strip() for c in lines[0].split("│")[1:-1]] == ["1", "4", "0.50", "3.25", "1.00",
                                                              "2"]
    assert [c.strip() for c in lines[1].split("│")[1:-1]] == ["final", "6", "0.25", "1.50",
                                                              "0.75", "-"]
