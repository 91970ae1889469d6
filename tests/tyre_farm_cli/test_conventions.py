"""CLI conventions (issue 12): defaults in --help, exit codes, streams, --json, --version,
`farm sweep list`, pressure in kPa, load cases as coordinates, no raw warnings."""

from __future__ import annotations

import io
import json
import re
import warnings

import numpy as np
import pytest
import typer

import storage
from tests.synthetic import make_store
from tyre_farm_cli import app, main
from tyre_farm_cli.progress import LogLines

SMALL = {"rows": 4, "cols": 8, "tread_rows": 3, "tread_cols": 6}
STAMP = r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d"


def _run(argv, capsys):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(SystemExit) as info:
            main([str(a) for a in argv])
            raise SystemExit(0)
    out = capsys.readouterr()
    assert not [str(w.message) for w in caught], "a raw Python warning reached the user"
    return info.value.code, out.out, out.err


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """5 done experiments 10..40 mm at each of 200 and 250 kPa, one failed, one pending."""
    path = tmp_path_factory.mktemp("stores") / "s.zarr"
    make_store(path, n_experiments=5, n_failed=1, n_pending=1, pressures=(0.2, 0.25), **SMALL)
    return path


def _commands(command, path=()):
    yield path, command
    for name, sub in getattr(command, "commands", {}).items():
        yield from _commands(sub, (*path, name))


def test_every_option_shows_its_default_in_help(capsys):
    """Rich markup once ate every `[default: ...]` written in a help text."""
    missing = []
    for path, command in _commands(typer.main.get_command(app)):
        code, out, _ = _run([*path, "--help"], capsys)
        assert code == 0
        text = "".join(out.split())  # no whitespace: wrapping breaks lines at any hyphen
        for param in command.params:
            # typer vendors click (typer._click): match the kind, not click's class
            if param.param_type_name != "option" or param.name == "help":
                continue
            flag_off = param.is_flag and not param.default and not param.secondary_opts
            # off / nothing unless given / required (it shows [required]: farm fit --out
            # passed only because the next option's default was within 60 characters)
            if flag_off or param.default in ([], ()) or param.required:
                continue
            help_text = "".join((param.help or "").split())
            start = text.find(help_text[:40])
            shown = text[start:start + len(help_text) + 60] if start >= 0 else ""
            if "[default:" not in shown:
                missing.append(f"farm {' '.join(path)} {param.opts[0]}")
    assert not missing, missing


def test_scheduler_help_names_the_environment_in_the_order_used(capsys):
    _, out, _ = _run(["sweep", "submit", "--help"], capsys)
    text = " ".join(out.split())
    assert ("[default: $FARM_SCHEDULER, then $DASK_SCHEDULER_ADDRESS, else an embedded "
            "LocalCluster]") in text


def test_version(capsys):
    from importlib.metadata import version

    code, out, err = _run(["--version"], capsys)
    assert code == 0 and err == ""
    assert out.startswith(f"farm {version('tyre-farm')}, CalculiX ")


@pytest.mark.parametrize("argv", [
    ["run", "--model", "bogus"],                 # a value the farm refuses
    ["run", "--pressure", "nan"],
    ["run", "--model", "reduced", "--pressure", "100"],
    ["run", "--threads", "x"],                   # a value click refuses
    ["run", "--pressur", "3"],                   # an unknown option
    ["sweep", "submit", "study.toml", "--workers", "-3"],
    ["sweep", "list", "s.zarr", "--status", "bogus"],
    ["reproduce", "--materials", "nope"],
    ["nosuchcommand"],
])
def test_usage_errors_exit_2(argv, capsys):
    code, out, err = _run(argv, capsys)
    assert code == 2 and out == ""
    assert err.startswith("farm: error: ") and err.count("\n") == 1


def test_a_study_files_content_is_not_usage(tmp_path, capsys):
    study = tmp_path / "bad.toml"
    study.write_text('name = "x"\nstore = "s.zarr"\n[model]\nkind = "bogus"\n')
    code, out, err = _run(["sweep", "submit", study], capsys)
    assert code == 1 and out == "" and err.startswith("farm: error: ")


def test_analyse_pressure_is_kpa(store, tmp_path, capsys):
    """200 kPa selects the store's 0.2 MPa experiments; 0.2 (MPa typed) selects none."""
    code, _, err = _run(["analyse", "pca", store, "--pressure", 200, "--inputs", "Uz",
                           "--out", tmp_path / "a"], capsys)
    assert code == 0, err
    assert "5 done experiments" in (tmp_path / "a" / "summary.md").read_text()  # of 10
    code, _, err = _run(["analyse", "pca", store, "--pressure", 0.2, "--out", tmp_path / "b"],
                        capsys)
    assert code == 1 and err.startswith("farm: error: ")  # nothing at 0.2 kPa


def test_sweep_list_and_status_json(store, capsys):
    code, out, err = _run(["sweep", "list", store, "--json"], capsys)
    assert code == 0 and err == ""
    rows = json.loads(out)["experiments"]
    assert len(rows) == 12
    assert {r["status"] for r in rows} == {"done", "failed", "pending"}
    assert {r["pressure_kpa"] for r in rows} == {200.0, 250.0}  # kPa, not MPa
    ds = storage.open_dataset(store, rows[0]["group"])
    stored = dict(zip(ds["experiment"].values.tolist(), ds["deflection"].values.tolist(),
                      strict=True))
    assert all(r["deflection_mm"] == stored[r["experiment"]] for r in rows)
    failed = [r for r in rows if r["status"] == "failed"]
    assert len(failed) == 1 and failed[0]["error"]
    code, out, _ = _run(["sweep", "list", store, "--status", "done", "--json"], capsys)
    assert [r["status"] for r in json.loads(out)["experiments"]] == ["done"] * 10
    code, out, _ = _run(["sweep", "list", store, "--status", "done"], capsys)
    assert code == 0 and all(r["experiment"][:20] in out for r in rows[:1])
    code, out, err = _run(["sweep", "status", store, "--json"], capsys)
    (group,) = json.loads(out)["groups"]
    assert code == 0 and err == ""
    assert group["counts"] == {"done": 10, "failed": 1, "pending": 1}
    assert group["failed"][0]["experiment"] == failed[0]["experiment"]


@pytest.fixture(scope="module")
def farm_store(tmp_path_factory):
    """A store written the farm's way (storage.reserve/write_experiment), not by xarray."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "store_helpers", Path(__file__).parents[1] / "storage" / "store_helpers.py")
    helpers = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(helpers)
    path = str(tmp_path_factory.mktemp("stores") / "farm.zarr")
    mesh = helpers.make_mesh()
    storage.create_group(path, "g", mesh, helpers.make_attrs())
    ids = [f"exp{k}" for k in range(4)]
    storage.reserve(path, "g", ids, {"deflection": np.array([10.0, 20.0, 30.0, 40.0]),
                                     "pressure": np.array([0.2, 0.2, 0.25, 0.25])})
    for e in ids:
        storage.write_experiment(path, "g", e, helpers.make_result(e, 12, 5),
                                 helpers.make_info(e))
    return path


def test_load_case_parameters_are_coordinates(farm_store):
    ds = storage.open_dataset(farm_store, "g")
    assert {"deflection", "pressure"} <= set(ds.coords)  # one index over both (issue 25)
    assert "deflection" in ds["displacement"].coords  # labels travel with every variable
    d = float(ds["deflection"].values[0])
    picked = ds.where(ds.deflection == d, drop=True)
    assert picked.sizes["experiment"] >= 1 and np.all(picked["deflection"].values == d)
    done = storage.done(ds)
    one = done.sel(deflection=30.0)
    assert one["experiment"].values.tolist() == ["exp2"]
    assert one["pressure"].values.tolist() == [0.25]
    assert done.sel(deflection=30.0, pressure=0.25)["experiment"].values.tolist() == ["exp2"]
    assert storage.parameters(ds) == ["deflection", "pressure"]
    assert storage.select(done, pressure=0.25).sizes["experiment"] == 2


def test_log_lines_are_timestamped_rate_limited_and_keep_the_last():
    now = [0.0]
    stream = io.StringIO()
    lines = LogLines(stream, every=2.0, clock=lambda: now[0])
    for k in range(1, 11):  # ten updates within 1.8 s: one line, then the last at flush
        lines.progress(f"sweep ch5: {k}/10 done, 0 failed")
        now[0] += 0.2
    lines.flush()
    out = stream.getvalue().splitlines()
    assert len(out) == 2
    assert re.fullmatch(rf"{STAMP} sweep ch5: 1/10 done, 0 failed", out[0])
    assert out[1].endswith("sweep ch5: 10/10 done, 0 failed")
    now[0] += 5.0
    lines.progress("later")
    assert stream.getvalue().splitlines()[-1].endswith(" later")


def test_sweep_progress_off_a_terminal_is_lines_on_stderr(capsys):
    from types import SimpleNamespace as NS

    from tyre_farm_cli.sweep import SweepLines, sweep_progress

    progress = sweep_progress("ch5")  # stderr is captured: not a terminal
    assert isinstance(progress, SweepLines)
    progress.started(NS(dashboard="http://127.0.0.1:8787/status", workers=2),
                     NS(total=30, skipped=10))
    progress.advanced(NS(total=30, skipped=10, done=2, failed=0, running=2))
    progress.advanced(NS(total=30, skipped=10, done=19, failed=1, running=0))
    progress.finished(None)
    out, err = capsys.readouterr()
    assert out == ""
    lines = err.splitlines()
    assert re.fullmatch(rf"{STAMP} sweep ch5: dashboard http://127.0.0.1:8787/status, 2 "
                        r"workers, 30 experiments \(10 already done\)", lines[0])
    assert re.fullmatch(rf"{STAMP} sweep ch5: 12/30 done, 0 failed", lines[1])
    assert re.fullmatch(rf"{STAMP} sweep ch5: 30/30 done, 1 failed", lines[-1])


def test_sweep_lines_count_the_states_running_trees_have_stored(capsys):
    """A rolling tree's task returns after its last branch (an hour and more on `lean`),
    but writes each part as it ends: the line says how many states are stored by tasks
    still running, and a new line appears when that count moves (issue 46)."""
    from types import SimpleNamespace as NS

    from tyre_farm_cli.sweep import SweepLines

    progress = SweepLines("t2cam")
    progress.started(NS(dashboard="d", workers=2), NS(total=840, skipped=0))
    progress.advanced(NS(total=840, skipped=0, done=62, failed=0, running=2, stored=0))
    progress.advanced(NS(total=840, skipped=0, done=62, failed=0, running=2, stored=32))
    progress.finished(None)
    lines = capsys.readouterr().err.splitlines()
    assert lines[1].endswith("sweep t2cam: 62/840 done, 0 failed")
    assert lines[2].endswith("sweep t2cam: 62/840 done (+32 stored by running tasks), "
                             "0 failed")
