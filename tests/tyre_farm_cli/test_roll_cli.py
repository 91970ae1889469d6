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
    (["--lead", "80"], "roll.lead must be a number in [-50, 50]"),
    (["--lead", "3", "--distance", "60"], "roll.lead = 3.0 on a roll of 60.0 mm: the lead "
                                          "is eased in over the first 96 mm"),
    (["--lead-x", "-51"], "roll.lead_x must be a number in [-50, 50]"),
    (["--lead-x", "3", "--distance", "90"], "roll.lead_x = 3.0 on a roll of 90.0 mm"),
    (["--restart-every", "5"], "--restart-every: solver.restart_every_mm must be 0"),
    (["--restart-every", "nan"], "--restart-every"),
])
def test_bad_arguments_give_one_line_and_nonzero_exit(argv, needle, capsys, monkeypatch):
    monkeypatch.setenv("FARM_CCX", "no-such-ccx")  # nothing may reach the solver
    code, out, err = run_cli(["roll", *COARSE, *argv], capsys)
    assert code not in (0, None) and out == ""
    assert err.count("\n") == 1 and err.startswith("farm: error: ") and needle in err


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
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


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_searched_radius_is_the_one_rolled_and_reported(capsys, monkeypatch):
    """``--rolling-radius free``: the roll runs at the radius the search returns, and the
    document lists the search's rolls (the search itself: tests/farm/test_rolling.py)."""
    import farm.experiment
    from farm.solve.rolling import RadiusTry

    tried = [RadiusTry(401.0, 12.0, 3000.0, 9.0, 20), RadiusTry(402.5, 0.5, 3001.0, 9.0, 20)]
    monkeypatch.setattr(farm.experiment, "free_rolling_radius",
                        lambda *a, **k: (402.5, tried))
    code, out, _ = run_cli(["roll", *COARSE, "--distance", "10", "--samples", "1", "--json"],
                           capsys)
    assert code == 0
    doc = json.loads(out)
    assert doc["roll"]["rolling_radius"] == 402.5
    assert doc["free_rolling"] == {"radius_mm": 402.5, "tried": [
        {"radius_mm": 401.0, "fx_n": 12.0, "fz_n": 3000.0},
        {"radius_mm": 402.5, "fx_n": 0.5, "fz_n": 3001.0}]}
    assert [s["travel_mm"] for s in doc["states"]] == [0.0, 10.0]


class _Searched(Exception):
    pass


@pytest.mark.parametrize(("argv", "searched_mm"), [
    (["--distance", "20"], 400.0),  # the coarse mesh's search length, not the roll's 20 mm
    (["--distance", "20", "--mesh", "patch", "--materials", "reinforced-calibrated"], 150.0),
])
def test_the_radius_search_rolls_its_own_length_not_the_rolls(argv, searched_mm, capsys,
                                                                 monkeypatch):
    """``--rolling-radius free`` searches with rolls of ``free_roll_mm`` at kappa = 0,
    whatever ``--distance`` asks of the roll itself: a 20 mm search roll reads Fx in the
    roll-in (it found 394.7 mm for ``patch`` at 200 kPa and 15 mm, where 135 mm rolls put
    free rolling at about 392.6 mm; docs/rolling.md)."""
    import farm.experiment

    rolls = []

    def spy(model, mesh, deflection, pressure, roll, settings, **kw):
        rolls.append(roll)
        raise _Searched

    monkeypatch.setattr(farm.experiment, "free_rolling_radius", spy)
    monkeypatch.setattr(farm.experiment, "mesh_for", lambda model: None)
    with pytest.raises(_Searched):
        run_cli(["roll", *([] if "patch" in argv else COARSE), *argv, "--slip-ratio", "0.05"],
                capsys)
    [roll] = rolls
    assert roll.distance == searched_mm and roll.slip_ratio == 0.05  # zeroed by the search


def test_restart_points_reach_the_roll_s_settings(capsys, monkeypatch):
    """``--restart-every 40``: the roll is solved with restart points every 40 mm (what
    they do: tests/farm/test_roll_restart.py)."""
    import farm.experiment

    seen = []

    def spy(model, mesh, deflection, pressure, motion, settings, fractions):
        seen.append(settings)
        raise _Searched

    monkeypatch.setattr(farm.experiment, "solve_roll", spy)
    monkeypatch.setattr(farm.experiment, "mesh_for", lambda model: None)
    with pytest.raises(_Searched):
        run_cli(["roll", *COARSE, "--rolling-radius", "395", "--restart-every", "40"], capsys)
    assert [s.restart_every_mm for s in seen] == [40.0]
