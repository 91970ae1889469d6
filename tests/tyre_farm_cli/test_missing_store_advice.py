"""A missing store or group names the farm command that creates it, not the Python call
the storage library suggests to its own callers (issue 25)."""

from __future__ import annotations

import pytest
from cli_helpers import run_cli

from tests.synthetic import make_store
from tyre_farm_cli.errors import CLI_ADVICE, for_the_cli


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("stores") / "s.zarr"
    make_store(path, n_experiments=3, rows=8, cols=16, tread_rows=6, tread_cols=12)
    return path


@pytest.mark.parametrize("command", [["sweep", "status"], ["sweep", "list"],
                                     ["analyse", "pca"]], ids=" ".join)
def test_a_missing_store_suggests_farm_sweep_submit(command, tmp_path, capsys):
    code, out, err = run_cli([*command, str(tmp_path / "nope.zarr")], capsys)
    assert code == 1 and out == ""
    assert err.startswith(f"farm: error: no store at {tmp_path / 'nope.zarr'}")
    assert "`farm sweep submit STUDY.toml`" in err and "storage." not in err


def test_a_missing_group_suggests_farm_sweep_submit(store, capsys):
    code, _, err = run_cli(["sweep", "status", str(store), "--group", "nope"], capsys)
    assert code == 1 and "no group 'nope'" in err
    assert "farm sweep submit" in err and "storage." not in err


def test_the_advice_replaced_is_what_storage_says(tmp_path):
    """The replacement follows the library's wording: if storage rewords its advice,
    this fails instead of the CLI leaking Python calls again."""
    import storage

    with pytest.raises(storage.NotAStoreError) as info:
        storage.list_groups(tmp_path / "nope.zarr")
    assert CLI_ADVICE[0][0] in str(info.value)
    assert "storage." not in for_the_cli(str(info.value))
