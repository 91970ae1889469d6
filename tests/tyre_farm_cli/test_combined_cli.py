"""`farm analyse combined` on synthetic stores: files, option checks, one-line errors."""

from __future__ import annotations

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.errors import NoVarianceError, ParameterError
from tests.synthetic import make_combined_store, make_store
from tyre_farm_cli import main
from tyre_farm_cli.analyse import app

TINY = {"rows": 5, "cols": 10, "tread_rows": 4, "tread_cols": 8}
runner = CliRunner()


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """A combined group and a vertical-only group in one store."""
    path = tmp_path_factory.mktemp("stores") / "c.zarr"
    make_combined_store(path, n_experiments=24, group="combined", seed=2, **TINY)
    make_store(path, n_experiments=7, group="vertical", **TINY)
    return path


def _run(*args):
    result = runner.invoke(app, [str(a) for a in args])
    if result.exception is not None:
        raise result.exception
    assert result.exit_code == 0, result.output
    return result


def test_combined_writes_its_tables(stores, tmp_path):
    result = _run("combined", stores, "--group", "combined", "--out", tmp_path,
                  "--inputs", "both", "--folds", 3, "--draws", 2, "--max-components", 6,
                  "--test-fraction", 0.25, "--seed", 1)
    assert "summary.md" in result.output
    totals = pd.read_csv(tmp_path / "totals.csv")
    assert set(totals["total"]) == {"Fx", "Fy", "Fz", "Mx", "My", "Mz"}
    assert set(totals["scenario"]) == {"noise-free", "1 mm, 0.04 %", "1 mm, 0.5 %"}
    models = pd.read_csv(tmp_path / "models.csv")
    assert models["n_components"].between(1, 6).all()
    assert "18 training, 6 held out" in (tmp_path / "summary.md").read_text()
    assert (tmp_path / "error_map_both.png").stat().st_size > 0


def test_option_errors_are_raised_before_reading(stores, tmp_path):
    with pytest.raises(ParameterError, match="--test-fraction must be in"):
        _run("combined", stores, "--group", "combined", "--test-fraction", 1.5, "--out", tmp_path)
    with pytest.raises(ParameterError, match="--folds must be at least 2"):
        _run("combined", stores, "--group", "combined", "--folds", 1, "--out", tmp_path)
    with pytest.raises(ParameterError, match="--axes must be wheel or road"):
        _run("combined", stores, "--group", "combined", "--axes", "tyre", "--out", tmp_path)
    with pytest.raises(NoVarianceError, match="not a combined-load selection"):
        _run("combined", stores, "--group", "vertical", "--out", tmp_path)


def test_console_prints_one_line_and_exits_non_zero(stores, tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        main(["analyse", "combined", str(stores), "--group", "vertical", "--out", str(tmp_path)])
    assert info.value.code == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "none of friction, shift_x" in err
    with pytest.raises(SystemExit) as info:
        main(["analyse", "combined", str(stores), "--folds", "0", "--out", str(tmp_path)])
    assert info.value.code == 2


def test_road_axes_turn_the_learned_forces_of_tilted_experiments(stores, tmp_path):
    """--axes road (issue 45): the same analysis on the forces in the road's axes; the
    summary says so."""
    _run("combined", stores, "--group", "combined", "--out", tmp_path / "road", "--folds", 3,
         "--draws", 2, "--max-components", 6, "--axes", "road")
    assert "road's axes" in (tmp_path / "road" / "summary.md").read_text()


def test_free_rolling_of_a_store_without_trees_is_one_line(stores, tmp_path, capsys):
    """``farm analyse free-rolling`` (issue 46) on a group that never rolled: one line
    naming what is missing, exit 1, no output folder."""
    with pytest.raises(SystemExit) as info:
        main(["analyse", "free-rolling", str(stores), "--group", "combined", "--out",
              str(tmp_path / "fr")])
    assert info.value.code == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "a store of rolling trees" in err
    assert "'slip_ratio'" in err and not (tmp_path / "fr" / "summary.md").exists()
