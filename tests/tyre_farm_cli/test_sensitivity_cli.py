"""`farm analyse sensitivity STUDY.toml` (issue 15): the design regenerated from the study
file, its outputs read from the store, the tables, figure and ranking written.

The default tests give each model of the study's design a synthetic group (the schema,
with a known Fz); the ccx test runs the quick model-space study on the real solver.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import zarr
from typer.testing import CliRunner

from analysis.errors import IncompleteDesignError, ParameterError
from jobs.design import model_design
from jobs.study import load_study
from tests.synthetic import make_store
from tyre_farm_cli.analyse import app

PNG = b"\x89PNG\r\n\x1a\n"
E, T = "materials.tread.youngs_modulus", "geometry.sidewall_thickness"
TINY = {"rows": 4, "cols": 6, "tread_rows": 4, "tread_cols": 6, "n_experiments": 2,
        "deflection_range": (20.0, 30.0)}
runner = CliRunner()

STUDY = """
[study]
name = "space"
store = "{store}"

[model]
kind = "reduced"
road = "contact"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 8

[loads]
deflection_mm = [20, 30]

[models]
method = "{method}"
n = 4
seed = 1
[models.parameters]
"{E}" = [5.0, 15.0]
"{T}" = [8.0, 12.0]
"""


def _fz(row, d):
    """The known output: Fz grows with the tread modulus only (N)."""
    return 300.0 * row[0] * d / 30.0


def _study(tmp_path, method: str):
    """A study file and, for each model of its design, a synthetic group whose Fz is
    :func:`_fz` of the model's parameters (pressure 0.2 MPa: the synthetic physics)."""
    store = tmp_path / f"{method}.zarr"
    path = tmp_path / f"{method}.toml"
    path.write_text(STUDY.format(store=store, method=method, E=E, T=T))
    design = model_design(load_study(path))
    for k, group in enumerate(design.distinct()):
        make_store(store, group=group, seed=k, **TINY)
        x = design.matrix[design.groups.index(group)]
        g = zarr.open_group(str(store), path=group, mode="r+")
        tf = g["total_force"][:]
        tf[:, 2] = _fz(x, g["deflection"][:])
        g["total_force"][:] = tf
        disp = g["displacement"][:]
        g["displacement"][:] = disp * (x[1] / 10.0)  # the field scales with the thickness
    return path, design


def _run(*args):
    result = runner.invoke(app, ["sensitivity", *[str(a) for a in args]])
    if result.exception is not None:
        raise result.exception
    assert result.exit_code == 0, result.output
    return result


@pytest.fixture(scope="module")
def sobol_study(tmp_path_factory):
    return _study(tmp_path_factory.mktemp("sobol"), "sobol")


def test_sobol_report_ranks_the_parameter_fz_depends_on(sobol_study, tmp_path):
    path, design = sobol_study
    assert design.matrix.shape == (16, 2)
    out = tmp_path / "out"
    result = _run(path, "--out", out, "--pressure-kpa", 200, "--field", "displacement",
                  "--components", 1, "--num-resamples", 200)
    assert "wrote 5 files" in result.output
    table = pd.read_csv(out / "sensitivity.csv")
    assert list(table.columns) == ["output", "parameter", "S1", "S1_conf", "ST", "ST_conf",
                                   "swapped_rows", "note"]
    outputs = list(dict.fromkeys(table["output"]))
    assert outputs == [f"{q} d={d}mm p=200kPa" for d in (20, 30) for q in
                       ("Fz", "contact_nodes", "contact_area", "displacement PC1")]
    fz = table[table["output"] == "Fz d=30mm p=200kPa"].set_index("parameter")
    assert fz.loc[E, "ST"] > 0.5
    assert fz.loc[T, "ST"] == pytest.approx(0.0, abs=1e-9)  # f(A) = f(AB_T) row by row
    pc = table[table["output"] == "displacement PC1 d=20mm p=200kPa"].set_index("parameter")
    assert pc.loc[T, "ST"] > 0.5 and pc.loc[E, "ST"] == pytest.approx(0.0, abs=1e-9)
    # contact is the same in every synthetic group: undefined, not a number
    assert table[table["output"].str.startswith("contact")][["S1", "ST"]].isna().all().all()
    rows = pd.read_csv(out / "design.csv")
    assert len(rows) == 16 and rows["group"].tolist() == list(design.groups)
    np.testing.assert_allclose(rows["Fz d=20mm p=200kPa"], _fz(design.matrix.T, 20.0))
    assert (out / "sensitivity.png").read_bytes()[:8] == PNG
    summary = (out / "summary.md").read_text()
    assert "N = 4 base samples x (D + 2) = 16 rows" in summary
    ranking = [line for line in summary.splitlines() if line.startswith("| Fz d=30mm")]
    assert ranking[-1].split("|")[2].strip().startswith(E)  # the ranking table, after the outputs
    assert "undefined: the output does not vary" in summary
    assert "![Indices with confidence intervals](sensitivity.png)" in summary


def test_morris_screen_ranks_the_inert_parameter_last(tmp_path):
    path, _ = _study(tmp_path, "morris")
    out = tmp_path / "out"
    _run(path, "--out", out, "--pressure-kpa", 200, "--deflection", 30)
    table = pd.read_csv(out / "sensitivity.csv")
    assert list(table.columns) == ["output", "parameter", "mu", "mu_star", "mu_star_conf",
                                   "sigma"]
    fz = table[table["output"] == "Fz d=30mm p=200kPa"].set_index("parameter")
    assert fz.loc[T, "mu_star"] == 0 and fz.loc[E, "mu_star"] > 0
    # SALib's elementary effect is Δy over the unit-cube step Δ: a linear Fz = 300 E
    # gives slope x range = 300 N/MPa x (15 - 5) MPa in every trajectory
    assert fz.loc[E, "mu_star"] == pytest.approx(300.0 * (15.0 - 5.0), rel=1e-6)
    assert fz.loc[E, "sigma"] == pytest.approx(0.0, abs=1e-6)
    assert "Morris design: r = 4 trajectories x (D + 1) = 12 rows" in (
        out / "summary.md").read_text()


def test_bad_input_is_one_error_before_anything_is_written(sobol_study, tmp_path):
    path, _ = sobol_study
    out = tmp_path / "out"
    with pytest.raises(ParameterError, match="--deflection must be numbers"):
        _run(path, "--out", out, "--deflection", "20,x")
    with pytest.raises(ParameterError, match="--method morris needs a morris design"):
        _run(path, "--out", out, "--method", "morris")
    with pytest.raises(ParameterError, match="--field must be one of"):
        _run(path, "--out", out, "--field", "stress")
    with pytest.raises(IncompleteDesignError, match=r"16 of 16 design rows .* 16 missing"):
        _run(path, "--out", out, "--pressure-kpa", 200, "--deflection", 25)
    plain = tmp_path / "plain.toml"
    plain.write_text(path.read_text().split("[models]")[0])
    with pytest.raises(ParameterError, match="has no \\[models\\] table"):
        _run(plain, "--out", out)
    assert not out.exists() or not any(out.iterdir())


def test_exit_codes_through_the_farm_command(sobol_study, tmp_path, capsys):
    from tyre_farm_cli import main

    path, _ = sobol_study
    for args, code, text in (
        (["--method", "lhs"], 2, "--method must be sobol or morris"),
        (["--deflection", "25", "--pressure-kpa", "200"], 1, "lack a done experiment"),
    ):
        with pytest.raises(SystemExit) as info:
            main(["analyse", "sensitivity", str(path), "--out", str(tmp_path / "o"), *args])
        err = capsys.readouterr().err
        assert info.value.code == code and text in err
        assert len(err.strip().splitlines()) == 1


@pytest.mark.ccx
@pytest.mark.slow
def test_sensitivity_of_the_quick_model_space_study_on_ccx(tmp_path, monkeypatch):
    """The quick study (8 models, 2 deflections, 8 ccx runs; ~45 s on 2 cores) and its
    Sobol' analysis over the real store: every output read, Fz indices finite."""
    from pathlib import Path

    from tyre_farm_cli import main

    monkeypatch.setenv("FARM_CACHE_DIR", str(tmp_path / "cache"))
    example = Path(__file__).parents[2] / "examples" / "model_space_quick.toml"
    path = tmp_path / "quick.toml"
    path.write_text(example.read_text().replace("results/model_space_quick.zarr",
                                                str(tmp_path / "q.zarr")))
    try:
        main(["sweep", "submit", str(path), "--workers", "2"])
        code = 0
    except SystemExit as exit_:
        code = exit_.code
    assert code == 0
    out = tmp_path / "out"
    _run(path, "--out", out, "--field", "displacement", "--components", 2)
    table = pd.read_csv(out / "sensitivity.csv")
    assert set(table["output"]) >= {"Fz d=10mm p=0kPa", "Fz d=20mm p=0kPa",
                                    "displacement PC1 d=20mm p=0kPa"}
    fz = table[table["output"].str.startswith("Fz")]
    assert np.isfinite(fz[["S1", "ST", "S1_conf", "ST_conf"]].to_numpy()).all()
    rows = pd.read_csv(out / "design.csv")
    assert (rows["Fz d=20mm p=0kPa"] > rows["Fz d=10mm p=0kPa"]).all()  # pressed further
