"""``farm analyse surrogate``'s study on a synthetic combined-load store (4 known load
parameters): held-out errors and honest uncertainty, a model that reloads, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from analysis import data
from analysis.camera.predict.persist import load_model
from analysis.errors import MissingVariableError, TooFewExperimentsError
from analysis.studies import surrogate
from analysis.studies.combined import TOTALS, varying_parameters
from tests.synthetic import make_combined_store

TINY = {"rows": 6, "cols": 12, "tread_rows": 5, "tread_cols": 10}


@pytest.fixture(scope="module")
def ds(tmp_path_factory):
    path = tmp_path_factory.mktemp("stores") / "combined.zarr"
    make_combined_store(path, n_experiments=30, seed=2, **TINY)
    return data.load(path)


@pytest.fixture(scope="module")
def report(ds, tmp_path_factory):
    return surrogate.run(ds, tmp_path_factory.mktemp("surrogate"), folds=4, restarts=1)


def test_held_out_forces_are_predicted_with_honest_uncertainty(report):
    table = report.tables["cv_errors"].set_index("target")
    assert list(table.index) == ["displacement", *TOTALS]
    # smooth maps of 4 parameters, 30 experiments: the forces and the field within 0.5 %
    assert (table.loc[["displacement", "Fx", "Fy", "Fz"]].rmse_pct_of_range < 0.5).all(), table
    assert (table.within_2_std_pct.dropna() >= 60).all(), table
    # Mz of this symmetric synthetic load is 1e-12 N mm: round-off, no error to report
    assert np.isnan(table.loc["Mz"].rmse_pct_of_range)


def test_the_saved_surrogate_reproduces_the_training_experiments(ds, report):
    model, manifest = load_model(report.out / "surrogate")
    params = varying_parameters(ds)
    assert manifest["inputs"] == params
    P = np.column_stack([ds[p].values for p in params]).astype(float)
    fz = model.predict(P)[:, -6 + TOTALS.index("Fz")]
    truth = ds["total_force"].sel(component="z").values
    assert np.abs(fz - truth).max() < 1e-3 * np.ptp(truth)  # a GP interpolates its data
    assert (report.out / "summary.md").read_text().count("| Fz |") == 1


def test_a_missing_field_and_too_few_experiments_are_one_clear_error(ds, tmp_path):
    with pytest.raises(MissingVariableError, match="choose one of"):
        surrogate.run(ds, tmp_path, field="pressure")
    with pytest.raises(TooFewExperimentsError, match="need 32"):
        surrogate.run(ds, tmp_path, folds=30)
