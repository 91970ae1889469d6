"""`farm analyse ...` on a synthetic store: the files, and facts the tables must obey."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis import data
from analysis.errors import (
    EmptySelectionError,
    ParameterError,
    SchedulerError,
    StoreError,
    TooFewExperimentsError,
)
from tests.synthetic import make_store
from tyre_farm_cli.analyse import app

PNG = b"\x89PNG\r\n\x1a\n"
SMALL = {"rows": 8, "cols": 16, "tread_rows": 6, "tread_cols": 12}
runner = CliRunner()


# The stores of tests/analysis/conftest.py, built here (that conftest is not in scope).
@pytest.fixture(scope="module")
def thesis_store(tmp_path_factory):
    """7 deflections 10..40 mm at 0.2 MPa, plus one failed and one pending experiment."""
    path = tmp_path_factory.mktemp("stores") / "thesis.zarr"
    make_store(path, n_experiments=7, n_failed=1, n_pending=1, **SMALL)
    return path


@pytest.fixture(scope="module")
def thesis_ds(thesis_store):
    return data.load(thesis_store)


@pytest.fixture(scope="module")
def uz_only_store(tmp_path_factory):
    path = tmp_path_factory.mktemp("stores") / "uz_only.zarr"
    make_store(path, n_experiments=9, signal="uz_only", noise=1e-3, seed=3, **SMALL)
    return path


@pytest.fixture(scope="module")
def two_pressure_store(tmp_path_factory):
    """Two groups, so the group must be named."""
    path = tmp_path_factory.mktemp("stores") / "two.zarr"
    make_store(path, n_experiments=5, pressures=(0.2, 0.25), group="mesh_a", **SMALL)
    make_store(path, n_experiments=4, group="mesh_b", include_strain=False, **SMALL)
    return path


def _run(*args):
    result = runner.invoke(app, [str(a) for a in args])
    if result.exception is not None:
        raise result.exception
    assert result.exit_code == 0, result.output
    return result


def _check_outputs(out: Path, csvs, pngs):
    for name in csvs:
        assert not pd.read_csv(out / f"{name}.csv").empty, name
    for name in pngs:
        assert (out / name).read_bytes()[:8] == PNG, name
    summary = (out / "summary.md").read_text()
    assert summary.startswith("# ") and "## Selection" in summary
    for line in summary.splitlines():  # every linked figure exists
        if line.startswith("!["):
            assert (out / line.split("(")[-1].rstrip(")")).exists()


@pytest.fixture(scope="module")
def outputs(thesis_store, tmp_path_factory):
    base = tmp_path_factory.mktemp("out")
    _run("pca", thesis_store, "--out", base / "pca")
    _run("pcr", thesis_store, "--out", base / "pcr", "--reference-deflection", 30)
    _run("plsr", thesis_store, "--out", base / "plsr", "--cv", 7, "--components", 4)
    _run(
        "noise",
        thesis_store,
        "--out",
        base / "noise",
        "--noise-levels",
        "0,0.5,2",
        "--draws",
        200,
        "--components",
        3,
    )
    return base


def test_pca_outputs(outputs):
    out = outputs / "pca"
    _check_outputs(
        out,
        ["singular_values", "importance", "eigen_vectors", "eigen_forces"],
        ["singular_values_displacement.png", "eigen_maps_strain.png"],
    )
    imp = pd.read_csv(out / "importance.csv")
    assert set(imp.loc[imp["rank"] == 1, "direction"]) == {"Uz", "exx", "cst_exx"}
    assert len(imp) == 9


def test_pcr_outputs(outputs, thesis_ds):
    out = outputs / "pcr"
    _check_outputs(
        out,
        ["variance_explained", "predictions", "thesis_comparison"],
        ["variance.png", "predictions_displacement.png", "predictions_strain.png"],
    )
    var = pd.read_csv(out / "variance_explained.csv")
    output = var[var["label"] == "output"]
    assert output["cumulative_pct"].iloc[-1] == pytest.approx(100.0)
    assert output["pct"].is_monotonic_decreasing
    pred = pd.read_csv(out / "predictions.csv")
    assert set(pred["n_modes"]) == {1, 2, 3, 4, 5}
    y30 = thesis_ds["reaction_force"].sel(component="z").values[4]  # --reference-deflection 30
    for _, part in pred.groupby(["inputs", "n_modes"]):
        np.testing.assert_array_equal(part["reference"], y30)
        assert part["error"].abs().max() < 0.25 * y30.max()


def test_plsr_outputs(outputs):
    out = outputs / "plsr"
    _check_outputs(
        out,
        ["pctvar", "predictions", "thesis_comparison", "simpls_vs_nipals", "cross_validation"],
        ["variance.png", "predictions_strain.png"],
    )
    pv = pd.read_csv(out / "pctvar.csv")
    assert pv.groupby(["inputs", "method"])["y_pct"].sum().max() <= 100 + 1e-9
    wide = pv.pivot_table(index=["inputs", "component"], columns="method", values="y_pct")
    np.testing.assert_allclose(wide["simpls"], wide["nipals"], rtol=1e-4)
    comp = pd.read_csv(out / "thesis_comparison.csv")
    assert set(comp["inputs"]) == {"output", "displacement", "strain"}
    assert set(pd.read_csv(out / "cross_validation.csv")["n_components"]) == {1, 2, 3, 4}


def test_noise_outputs(outputs, thesis_ds):
    out = outputs / "noise"
    _check_outputs(
        out,
        ["totals", "nodes", "sweep"],
        ["sweep.png", "nodes_displacement.png", "nodes_strain.png"],
    )
    sweep = pd.read_csv(out / "sweep.csv")
    assert set(sweep["training"]) == {"clean", "noisy"}  # issue 25: both, by default
    sweep = sweep[sweep["training"] == "clean"]  # noisy training has no analytic std
    assert sorted(set(sweep["multiplier"])) == [0.0, 0.5, 1.0, 2.0]  # the thesis level is added
    live = sweep[sweep["sigma"] > 0]
    per_sigma = live["Fz_total_std_analytic"] / live["sigma"]
    np.testing.assert_allclose(
        per_sigma.groupby(live["inputs"]).std(), 0, atol=1e-9 * per_sigma.max()
    )
    ratio = live["Fz_nodal_avg_std"] / live["Fz_nodal_avg_std_analytic"]
    assert ratio.between(0.85, 1.15).all()  # 200 draws: ~5 % sampling error
    totals = pd.read_csv(out / "totals.csv")
    ref = totals[totals["case"] == "reference"]
    assert len(ref) == 1
    y_ref = thesis_ds["reaction_force"].sel(component="z").values[3]  # 25 mm, the median
    assert ref["Fz"].iloc[0] == pytest.approx(y_ref.sum())
    noisy = totals[totals["sigma"] > 0]
    assert set(noisy["sigma"]) == {1.0, 4e-4}  # thesis levels: 1 mm, 0.04 % strain
    models = pd.read_csv(out / "models.csv")  # --components 3: given, not chosen
    assert models["n_components"].tolist() == [3, 3] and set(models["chosen_by"]) == {"given"}
    assert not (out / "cross_validation.csv").exists()


def test_errors_are_raised_not_exited(thesis_store, two_pressure_store, tmp_path):
    with pytest.raises(StoreError, match="pass --group"):
        _run("pca", two_pressure_store, "--out", tmp_path)
    with pytest.raises(EmptySelectionError):
        _run("pcr", thesis_store, "--pressure", 9.0, "--out", tmp_path)
    with pytest.raises(ParameterError):
        _run("noise", thesis_store, "--noise-levels", "1,x", "--out", tmp_path)
    with pytest.raises(TooFewExperimentsError, match=r"deflection=30.*1 done experiment"):
        _run("plsr", thesis_store, "--deflection", 30, "--out", tmp_path)


def test_noise_chooses_components_by_cross_validation(thesis_store, tmp_path):
    _run("noise", thesis_store, "--out", tmp_path, "--noise-levels", "1", "--draws", 10)
    models = pd.read_csv(tmp_path / "models.csv")
    assert models["chosen_by"].str.startswith("leave-one-out").all()
    cv = pd.read_csv(tmp_path / "cross_validation.csv")
    assert cv["chosen"].sum() == 2 and set(cv["folds"]) == {7}
    _run("noise", thesis_store, "--out", tmp_path / "k", "--noise-levels", "1", "--cv", 3)
    assert pd.read_csv(tmp_path / "k" / "models.csv")["chosen_by"].str.startswith("3-fold").all()


def test_analysis_never_imports_farm_or_jobs():
    """Layering rule (docs/architecture.md): analysis (studies and report included) reads the store
    only: no import of farm or jobs, in its source or at run time - except the pure-numpy
    farm.measure.surface and farm.measure.axes (tests/test_layering.py's SHARED), which load
    nothing else of farm."""
    from tests.test_layering import SHARED

    forbidden = ("farm", "jobs", "tyre_farm_cli")
    allowed = sorted(SHARED["analysis"])
    root = Path(__file__).resolve().parents[2] / "analysis"
    files = list(root.rglob("*.py"))
    assert any(p.parent.name == "studies" for p in files)
    assert any(p.parent.name == "report" for p in files)
    for path in files:
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else ([node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            )
            bad = [n for n in names if n.split(".")[0] in forbidden and n not in allowed]
            assert not bad, (path, bad)
    modules = sorted(
        "analysis." + ".".join(p.relative_to(root).with_suffix("").parts)
        for p in files
        if p.name != "__init__.py"
    )
    code = (
        f"import importlib, sys; [importlib.import_module(m) for m in {modules!r}]; "
        f"bad = [m for m in sys.modules if m.split('.')[0] in {forbidden!r} "
        f"and m not in {allowed!r}]; "
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_runs_on_a_dask_cluster(uz_only_store, tmp_path, monkeypatch):
    """--scheduler: the chunk-wise reductions go to the cluster; same tables as locally."""
    from distributed import LocalCluster

    local = _run("pca", uz_only_store, "--inputs", "Uz", "--out", tmp_path / "local")
    assert "wrote" in local.output
    with LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        _run(
            "pca",
            uz_only_store,
            "--inputs",
            "Uz",
            "--out",
            tmp_path / "cluster",
            "--scheduler",
            cluster.scheduler_address,
        )
    a = pd.read_csv(tmp_path / "local" / "singular_values.csv")
    b = pd.read_csv(tmp_path / "cluster" / "singular_values.csv")
    np.testing.assert_allclose(a["singular_value"], b["singular_value"], rtol=1e-12)
    monkeypatch.setattr("analysis.cluster.CONNECT_TIMEOUT", "1s")
    with pytest.raises(SchedulerError, match="Dask scheduler"):
        _run("pca", uz_only_store, "--out", tmp_path / "x", "--scheduler", "tcp://127.0.0.1:1")


@pytest.mark.parametrize("command", ["pcr", "plsr", "noise"])
@pytest.mark.parametrize("value", [999, 27.5, -1, float("nan")])
def test_a_reference_deflection_not_stored_is_an_error_listing_the_stored_ones(
        thesis_store, tmp_path, command, value):
    """Once the nearest experiment was used silently: 999 mm meant 40 mm."""
    with pytest.raises(ParameterError) as info:
        _run(command, thesis_store, "--reference-deflection", value, "--out", tmp_path)
    assert "give one of: 10, 15, 20, 25, 30, 35, 40 mm" in str(info.value)
    assert not any(tmp_path.iterdir())  # nothing written


def test_output_and_scheduler_options_are_checked_before_reading(thesis_store, tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(ParameterError, match=r"--out: .*afile is a file, not a folder"):
        _run("pca", thesis_store, "--out", tmp_path / "afile")
    result = runner.invoke(app, ["pca", str(thesis_store), "--scheduler", "not a url"])
    assert result.exit_code == 2 and "is not a scheduler address" in result.output
    with pytest.raises(ParameterError, match=r"--noise-levels must be .* in \[0, 100\]"):
        _run("noise", thesis_store, "--noise-levels", "1,nan", "--out", tmp_path / "n")


def test_the_scheduler_named_by_the_environment_is_used(thesis_store, tmp_path, monkeypatch):
    """As `farm sweep`: without --scheduler the environment's scheduler, not dask's threads
    (port 9 on loopback: nothing listens, so the analysis must fail to reach it; the order
    of the variables is jobs.cluster.resolve_scheduler's, tested there)."""
    import analysis.cluster

    variable = "DASK_SCHEDULER_ADDRESS"
    monkeypatch.setattr(analysis.cluster, "CONNECT_TIMEOUT", "1s")  # refused: no need to wait
    from analysis.errors import SchedulerError

    for name in ("FARM_SCHEDULER", "DASK_SCHEDULER_ADDRESS"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv(variable, "tcp://127.0.0.1:9")
    result = runner.invoke(app, ["pca", str(thesis_store), "--out", str(tmp_path / "o")])
    assert isinstance(result.exception, SchedulerError)
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in str(result.exception)
    help_text = " ".join(runner.invoke(app, ["pca", "--help"]).output.split())
    assert "$DASK_SCHEDULER_ADDRESS, else dask's local threads]" in help_text
