"""`farm analyse surrogate` on a synthetic combined store (issue 28): the table as JSON,
the saved model, and bad options refused in one line before anything is read."""

from __future__ import annotations

import json

import pytest
from cli_helpers import run_cli

from tests.synthetic import make_combined_store

TINY = {"rows": 6, "cols": 12, "tread_rows": 5, "tread_cols": 10}


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("surrogate") / "c.zarr"
    make_combined_store(path, n_experiments=20, seed=3, **TINY)
    return path


def _cli(argv, capsys):
    return run_cli([str(a) for a in argv], capsys)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_the_json_carries_the_held_out_table_and_the_model_is_written(store, tmp_path,
                                                                       capsys):
    code, out, err = _cli(["analyse", "surrogate", store, "--out", tmp_path, "--folds", 4,
                           "--restarts", 0, "--json"], capsys)
    assert code == 0, err
    doc = json.loads(out)
    rows = {r["target"]: r for r in doc["tables"]["cv_errors"]}
    assert rows["Fz"]["rmse_pct_of_range"] < 1.0
    assert (tmp_path / "surrogate" / "manifest.json").exists()


@pytest.mark.parametrize(("option", "value", "message"), [
    ("--folds", 1, "--folds must be at least 2"),
    ("--restarts", -1, "--restarts must be at least 0"),
    ("--field", "stress", "--field must be displacement or strain"),
])
def test_a_bad_option_is_one_line_and_nothing_is_written(store, tmp_path, capsys, option,
                                                         value, message):
    code, _out, err = _cli(["analyse", "surrogate", store, "--out", tmp_path / "o",
                            option, value], capsys)
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "o").exists()
