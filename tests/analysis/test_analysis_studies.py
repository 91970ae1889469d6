"""The studies behind `farm analyse`: selections they refuse, Table 5.1's two kinds of
standard deviation, and the noise study's component count (chosen, and reported)."""

from __future__ import annotations

import importlib

import numpy as np
import pandas as pd
import pytest
import zarr
from sklearn.model_selection import LeaveOneOut

from analysis import data
from analysis.errors import AnalysisError
from analysis.pls import SIMPLSRegression
from analysis.studies import noise
from tests.synthetic import make_store

STUDIES = ("crosscov", "pcr", "plsr", "noise")


@pytest.mark.parametrize("study", STUDIES)
def test_one_experiment_is_a_clear_error_naming_the_selection(thesis_store, study, tmp_path):
    """One experiment has no variance to analyse: say so, not a table of 0/0 or NaN."""
    ds = data.load(thesis_store, deflection=30.0)
    assert ds.sizes["experiment"] == 1
    run = importlib.import_module(f"analysis.studies.{study}").run
    with pytest.raises(AnalysisError) as info:
        run(ds, tmp_path)
    msg = str(info.value)
    assert type(info.value).__name__ == "TooFewExperimentsError"
    assert isinstance(info.value, ValueError) and "\n" not in msg
    for part in (str(thesis_store), "'synthetic'", "deflection=30", "1 done experiment"):
        assert part in msg, (part, msg)
    assert "at least 2" in msg or "at least 3" in msg
    assert "--deflection" in msg  # how to fix it: widen the selection
    assert not list(tmp_path.iterdir())  # nothing half-written


def test_noise_with_cross_validation_needs_three_experiments(thesis_store, tmp_path):
    ds = data.load(thesis_store).isel(experiment=[0, 6])
    with pytest.raises(AnalysisError, match="at least 3") as info:
        noise.run(ds, tmp_path)
    assert "--components" in str(info.value)  # or name the count and skip the CV
    report = noise.run(ds, tmp_path, n_components=1, multipliers=(1.0,), draws=10)
    assert report.tables["models"]["n_components"].tolist() == [1, 1]


@pytest.fixture(scope="module")
def flat_fx_store(tmp_path_factory):
    """A store whose longitudinal tread forces Fx are all exactly zero."""
    path = tmp_path_factory.mktemp("stores") / "flat.zarr"
    make_store(path, n_experiments=5, rows=4, cols=6, tread_rows=3, tread_cols=5)
    arr = zarr.open_group(path, mode="r+")["synthetic"]["reaction_force"]
    values = arr[...]
    values[:, :, 0] = 0.0
    arr[...] = values
    return path


@pytest.mark.parametrize("study", STUDIES)
def test_outputs_without_variance_are_refused(flat_fx_store, study, tmp_path):
    """Fx == 0 everywhere: variance explained is 0/0, not 100 % (it was reported as 100 %)."""
    ds = data.load(flat_fx_store)
    run = importlib.import_module(f"analysis.studies.{study}").run
    with pytest.raises(AnalysisError, match="no variance") as info:
        run(ds, tmp_path, component="x")
    assert type(info.value).__name__ == "NoVarianceError"
    assert "force component x" in str(info.value) and "--force-component" in str(info.value)


@pytest.fixture(scope="module")
def noise_report(thesis_store, tmp_path_factory):
    ds = data.load(thesis_store)
    out = tmp_path_factory.mktemp("noise")
    return noise.run(ds, out, multipliers=(0.0, 1.0), draws=400, seed=2)


def _contact(nodes: pd.DataFrame) -> np.ndarray:
    ref = nodes["reference"].abs().to_numpy()
    return ref > 1e-6 * ref.max()


def test_table_5_1_plus_minus_is_the_nodal_average_std(noise_report):
    """Thesis §5.6: Table 5.1's ± is the nodal-averaged standard deviation (133 N beside a
    4.5 kN total), for the moments too; the std of the TOTAL moment of symmetric forces
    is zero. Both are reported, under their own names."""
    totals, nodes = noise_report.tables["totals"], noise_report.tables["nodes"]
    noisy = totals[totals["sigma"] > 0]
    assert len(noisy) == 4 and noisy["training"].value_counts().to_dict() == {"clean": 2,
                                                                              "noisy": 2}
    for _, row in noisy[noisy["training"] == "clean"].iterrows():
        part = nodes[(nodes["inputs"] == row["inputs"]) & (nodes["training"] == "clean")]
        live = _contact(part)
        std = part["std"].to_numpy()[live]
        x, y = part["x"].to_numpy()[live], part["y"].to_numpy()[live]
        assert row["Fz_nodal_avg_std"] == pytest.approx(std.mean(), rel=1e-12)
        assert row["Mx_nodal_avg_std"] == pytest.approx(1e-3 * (np.abs(y) * std).mean())
        assert row["My_nodal_avg_std"] == pytest.approx(1e-3 * (np.abs(x) * std).mean())
        for t in ("Mx", "My"):  # symmetric data: the totals' std vanishes, the thesis' does not
            assert row[f"{t}_total_std"] < 1e-6 * row[f"{t}_nodal_avg_std"]
            assert row[f"{t}_nodal_avg_std"] > 0
        assert row["Fz_total_std"] > 0
        analytic = part["std_analytic"].to_numpy()[live].mean()
        assert row["Fz_nodal_avg_std_analytic"] == pytest.approx(analytic, rel=1e-12)
    summary = (noise_report.out / "summary.md").read_text()
    assert "±" in summary and "nodal-average" in summary and "std of the total" in summary


def test_noise_components_are_chosen_by_leave_one_out_and_reported(noise_report, thesis_ds):
    """Not silently "all the data support" (6 of 7 experiments): leave-one-out CV over
    experiments picks the count with the least held-out error of the tread forces."""
    cv = noise_report.tables["cross_validation"]
    models = noise_report.tables["models"]
    K = thesis_ds.sizes["experiment"]
    for name, part in cv.groupby("inputs"):
        assert list(part["n_components"]) == list(range(1, K - 1))  # folds of 6: <= 5
        best = int(part.loc[part["mse_mean"].idxmin(), "n_components"])
        chosen = models.loc[models["inputs"] == name, "n_components"].item()
        assert chosen == best and part["chosen"].sum() == 1
        assert part.loc[part["chosen"], "n_components"].item() == best
        assert "leave-one-out" in models.loc[models["inputs"] == name, "chosen_by"].item()
    # the held-out error, recomputed with scikit-learn's splitter and our estimator
    X = np.asarray(data.inputs(thesis_ds, "displacement").compute())
    Y = np.asarray(data.outputs(thesis_ds).compute())
    for a in (1, 3):
        errs = [
            np.mean((SIMPLSRegression(a).fit(X[tr], Y[tr]).predict(X[te]) - Y[te]) ** 2)
            for tr, te in LeaveOneOut().split(X)
        ]
        row = cv[(cv["inputs"] == "displacement") & (cv["n_components"] == a)]
        assert row["mse_mean"].item() == pytest.approx(np.mean(errs), rel=1e-8)
    totals = noise_report.tables["totals"]
    # per input set: noise-free, noisy (clean training), noisy (noisy training)
    assert totals["model"].str.contains("components").sum() == 6
    summary = (noise_report.out / "summary.md").read_text()
    assert "leave-one-out" in summary and "cross-validation" in summary.lower()


def test_noise_components_given_are_reported_as_given(thesis_store, tmp_path):
    ds = data.load(thesis_store)
    report = noise.run(ds, tmp_path, n_components=3, multipliers=(1.0,), draws=10)
    models = report.tables["models"]
    assert models["n_components"].tolist() == [3, 3]
    assert models["chosen_by"].str.contains("given").all()
    assert "cross_validation" not in report.tables


def test_noise_reports_clean_and_noisy_training_side_by_side(noise_report, thesis_store,
                                                             tmp_path):
    """Issue 25: every table has a ``training`` column; the clean rows are the thesis'
    setting, unchanged by the noisy-training run; the summary states both and their ratio."""
    ds = data.load(thesis_store)
    clean_only = noise.run(ds, tmp_path, multipliers=(0.0, 1.0), draws=400, seed=2,
                           train_noise=False)
    for name in ("totals", "nodes", "sweep"):
        both, alone = noise_report.tables[name], clean_only.tables[name]
        assert set(alone["training"]) <= {"", "clean"}
        kept = both[both["training"] != "noisy"].reset_index(drop=True)
        pd.testing.assert_frame_equal(kept, alone)
    sweep = noise_report.tables["sweep"]
    noisy = sweep[sweep["training"] == "noisy"]
    assert len(noisy) == len(sweep) / 2 and noisy["Fz_nodal_avg_std_analytic"].isna().all()
    assert (noisy.loc[noisy["multiplier"] == 0, "Fz_nodal_avg_std"] == 0).all()
    clean = sweep[sweep["training"] == "clean"]
    at = noisy["multiplier"] == 1.0
    ratio = noisy.loc[at, "Fz_nodal_avg_std"].to_numpy() / clean.loc[
        clean["multiplier"] == 1.0, "Fz_nodal_avg_std"].to_numpy()
    assert np.all(ratio > 0) and not np.allclose(ratio, 1.0, rtol=0.02)
    summary = (noise_report.out / "summary.md").read_text()
    assert "Noise in training (issue 25)" in summary and "noisy/clean" in summary
    for name, r in zip(noise_report.tables["models"]["inputs"], ratio, strict=True):
        assert f"{name} {r:.2f}" in summary


@pytest.mark.parametrize(("trees", "folds", "ok"), [(3, 2, False), (4, 2, True),
                                                    (4, 5, False), (3, 3, True)])
def test_a_sensor_split_too_small_for_its_intervals_fails_before_any_work(trees, folds, ok):
    """A split of a few rolling trees (the answer's store while it fills): each CV fold's
    model - the intervals' out-of-fold residuals - needs two paths for a CV of its own;
    fewer is one error when the study is set up, not a failure in its first fit."""
    from analysis.errors import ParameterError
    from analysis.studies.sensor import Setup, _trainable

    groups = np.repeat(np.arange(trees), 5)
    setup = Setup(np.arange(groups.size), np.array([], int), ("plsr",), ("displacement",),
                  2, folds, 5, 0, groups)
    if ok:
        assert _trainable(setup) is setup
    else:
        with pytest.raises(ParameterError, match=f"trains on {trees} load paths"):
            _trainable(setup)
