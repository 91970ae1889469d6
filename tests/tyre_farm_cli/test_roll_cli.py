"""``farm roll`` (issue 30): one-line errors before any solve, and a real roll as JSON."""

import json

import pytest
from cli_helpers import run_cli

COARSE = ["--set", "mesh.tread=4", "--set", "mesh.sidewall=2", "--set", "mesh.bead=1",
          "--set", "mesh.circumferential=16"]


@pytest.mark.parametrize(("argv", "needle"), [
    (["--slip-angle", "30"], "roll.slip_angle must be a number in [-20, 20]"),
    (["--slip-ratio", "2"], "roll.slip_ratio"),
    (["--distance", "0"], "roll.distance"),
    (["--rolling-radius", "big"], "--rolling-radius: give a radius in mm or 'free'"),
    (["--rolling-radius", "5"], "roll.rolling_radius"),
    (["--samples", "0"], "--samples"),
    (["--pressure", "0"], "--pressure"),
    (["--deflection", "250"], "reaches through the tyre"),
    (["--friction", "-1"], "roll.friction"),
])
def test_bad_arguments_give_one_line_and_nonzero_exit(argv, needle, capsys, monkeypatch):
    monkeypatch.setenv("FARM_CCX", "no-such-ccx")  # nothing may reach the solver
    code, out, err = run_cli(["roll", *COARSE, *argv], capsys)
    assert code not in (0, None) and out == ""
    assert err.count("\n") == 1 and err.startswith("farm: error: ") and needle in err


@pytest.mark.ccx
def test_roll_prints_forces_along_the_roll_as_json(capsys):
    code, out, _ = run_cli(["roll", *COARSE, "--rolling-radius", "402.9", "--distance", "20",
                            "--samples", "2", "--slip-ratio", "-1", "--json"], capsys)
    assert code == 0
    doc = json.loads(out)
    states = doc["states"]
    assert [s["travel_mm"] for s in states] == [0.0, 10.0, 20.0]
    fx, fy, fz = states[-1]["force_n"]
    assert abs(fy) < 1e-3 * fz
    assert fx < 0 and abs(fx) == pytest.approx(0.6 * fz, rel=0.01)  # a locked wheel slides
    assert doc["inflated_radius_mm"] - 15.0 < doc["roll"]["rolling_radius"]
