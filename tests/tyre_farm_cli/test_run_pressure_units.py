"""``farm run`` speaks kPa in every message about the pressure (issue 25: ``--pressure 200``
on the reduced model answered "got 0.2 MPa", the library's unit)."""

from __future__ import annotations

import pytest
from cli_helpers import run_cli


@pytest.mark.parametrize(("argv", "needles"), [
    (["--model", "reduced", "--pressure", "200"], ("not inflated", "got 200 kPa")),
    (["--model", "reduced", "--pressure", "0.5"], ("not inflated", "got 0.5 kPa")),
    (["--model", "full", "--pressure", "0"], ("is inflated", "> 0 kPa", "--pressure 200")),
    (["--model", "reduced", "--pressure", "5000"], ("--pressure", "[0, 1000]", "5000")),
])
def test_pressure_errors_are_in_kpa(argv, needles, capsys):
    code, out, err = run_cli(["run", *argv, "--deflection", "30"], capsys)
    assert code == 2 and out == ""
    assert err.count("\n") == 1
    for needle in needles:
        assert needle in err, (needle, err)
    assert "MPa" not in err and "0.2 " not in err
