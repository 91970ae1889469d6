"""``farm run`` says on stderr what it is doing while it meshes and solves (issue 25: it
printed nothing for 40-110 s); stdout keeps the results only."""

from __future__ import annotations

import io
import json

import pytest
from cli_helpers import run_cli

import tyre_farm_cli.run
from tyre_farm_cli.progress import LogLines
from tyre_farm_cli.run import RunLines

TINY = ["--model", "reduced", "--set", "mesh.tread=4", "--set", "mesh.sidewall=2",
        "--set", "mesh.bead=1", "--set", "mesh.circumferential=8"]


def _stages(err: str) -> list[str]:
    return [line.split(" run: ", 1)[1] for line in err.splitlines() if " run: " in line]


@pytest.mark.ccx
@pytest.mark.parametrize("as_json", [True, False], ids=["json", "table"])
def test_stages_go_to_stderr_and_stdout_stays_clean(as_json, monkeypatch, capsys):
    monkeypatch.setattr(tyre_farm_cli.run, "HEARTBEAT_SECONDS", 0.0)  # every poll a line
    code, out, err = run_cli(["run", *TINY, "--deflection", "10:20:10",
                              *(["--json"] if as_json else [])], capsys)
    assert code == 0, err
    stages = _stages(err)
    # first: which tyre and mesh, and how far to trust them (issue 48); --set made the
    # mesh one of its own, and the line says so rather than naming the preset it replaced
    assert stages[0].startswith("reduced model, materials table-3.1: the thesis' Table 3.1")
    assert "a mesh of its own (tread 4, sidewall 2, bead 1, 8 round" in stages[0]
    stages = stages[1:]
    assert stages[0].startswith("meshing the reduced model")
    assert stages[1].startswith("mesh ready: ")
    assert stages[2] == "solving 2 deflections at 0 kPa on the iterative road with ccx"
    assert any(s.startswith("solving, ") for s in stages[3:-1])  # the heartbeat
    assert stages[-1].startswith("done in ") and "ccx run" in stages[-1]
    if as_json:
        assert json.loads(out)["pressure_kpa"] == 0  # the whole of stdout is the document
    else:
        assert "Fz N" in out
    assert " run: " not in out


def test_the_heartbeat_is_rate_limited_and_never_stops_the_solve():
    stream, now = io.StringIO(), [0.0]
    lines = RunLines(LogLines(stream, every=10.0, clock=lambda: now[0]))
    poll = lines.solving()
    for t in (0.1, 5.0, 9.9, 10.0, 12.0, 20.5):
        now[0] = t
        assert poll() is False
    beats = [s for s in _stages(stream.getvalue()) if s.startswith("solving, ")]
    assert len(beats) == 2  # at 10 s and 20.5 s: not at the start, not every poll


def test_the_heartbeat_says_how_far_ccx_has_got():
    from farm.ccx.progress import SolverProgress

    stream, now = io.StringIO(), [0.0]
    lines = RunLines(LogLines(stream, every=10.0, clock=lambda: now[0]), bar=False)
    poll = lines.solving()
    now[0] = 10.0
    poll()
    lines.report(SolverProgress(0.43, 1, 2, 12, 1))
    now[0] = 20.0
    poll()
    beats = [s for s in _stages(stream.getvalue()) if s.startswith("solving, ")]
    assert beats[0].startswith("solving, starting, ")
    assert beats[1].startswith("solving, 43 % of the path (step 1 of 2, 12 increments, "
                               "1 cutback), ")


def test_on_a_terminal_the_progress_is_a_bar_that_goes_away():
    from farm.ccx.progress import SolverProgress

    stream = io.StringIO()
    lines = RunLines(LogLines(stream), bar=True)
    poll = lines.solving()
    lines.report(SolverProgress(0.5, 1, 1, 3, 0))
    assert poll() is False
    assert lines._bar is not None and lines._bar.tasks[0].completed == 0.5
    lines.close()
    assert lines._bar is None
    assert "solving, " not in stream.getvalue()  # the bar, not heartbeat lines
