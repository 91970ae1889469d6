"""``farm run`` end to end, and one-line errors with non-zero exit codes."""

import numpy as np
import pytest

from cli import main

COARSE = ["--set", "mesh.tread=4", "--set", "mesh.sidewall=2", "--set", "mesh.bead=1",
          "--set", "mesh.circumferential=8"]


def _run(argv, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
        raise SystemExit(0)
    out = capsys.readouterr()
    return info.value.code, out.out, out.err


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["run", "--model", "bogus"], "unknown model 'bogus'"),
        (["run", "--deflection", "-5"], "deflection must be a positive number"),
        (["run", "--deflection", "10:250:10"], "reaches through the tyre"),
        (["run", "--deflection", "ten"], "cannot read deflection"),
        (["run", "--model", "reduced", "--pressure", "100"], "not inflated"),
        (["run", "--road", "sideways"], "road must be one of"),
        (["run", "--set", "mesh.circ=3"], "model.mesh.circ: unknown key; allowed: bead, circ"),
        (["run", "--pressur", "3"], "No such option"),
    ],
)
def test_bad_arguments_give_one_line_and_nonzero_exit(argv, needle, capsys):
    code, out, err = _run(argv, capsys)
    assert code not in (0, None)
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("farm: error: ") and needle in err


def test_missing_solver_is_one_line(monkeypatch, capsys):
    monkeypatch.setenv("FARM_CCX", "no-such-ccx")
    code, _, err = _run(["run", "--model", "reduced", *COARSE], capsys)
    assert code == 1 and "not found on PATH" in err and err.count("\n") == 1


def test_debug_shows_the_traceback():
    from farm.errors import SpecError

    with pytest.raises(SpecError):
        main(["--debug", "run", "--model", "bogus"])


@pytest.mark.ccx
def test_run_prints_the_force_table_and_saves_arrays(tmp_path, capsys):
    out_file = tmp_path / "path.npz"
    code, out, _ = _run(["run", "--model", "reduced", "--deflection", "10:20:10", *COARSE,
                         "--out", str(out_file)], capsys)
    assert code == 0
    for column in ("deflection", "Fz N", "Mx N m", "My N m", "contact", "solve s"):
        assert column in out
    with np.load(out_file) as z:
        assert list(z["deflection"]) == [10.0, 20.0]
        assert z["displacement"].shape == (2, len(z["inner_node"]), 3)
        assert np.all(z["total_force"][:, 2] > 0)
