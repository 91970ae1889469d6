"""``farm reproduce --quick`` end to end on test-sized meshes; the second run solves nothing."""

import json
import re

import numpy as np
import pandas as pd
import pytest

from tyre_farm_cli import main

pytestmark = [pytest.mark.ccx, pytest.mark.e2e]  # the main job end to end


def _run(out):
    main(["reproduce", "--coarse", "--out", str(out), "--workers", "2"])
    return json.loads((out / "report.json").read_text())


def test_reproduce_writes_a_complete_report_and_is_idempotent(tmp_path):
    out = tmp_path / "rep"
    first = _run(out)
    text = (out / "report.md").read_text()
    for heading in ("## Provenance", "## Chapter 3", "## Chapter 4", "## Chapter 5",
                    "## Study files"):
        assert heading in text
    for link in re.findall(r"\]\(([^)]+\.png)\)", text):
        assert (out / link).is_file(), link
    tables = {p.stem: pd.read_csv(p) for p in (out / "tables").glob("*.csv")}
    assert tables, "no tables written"
    for name, frame in tables.items():
        assert len(frame), name
        numeric = frame.select_dtypes("number")
        if name.startswith("inverse__regularisation"):  # NaN where nothing applies:
            # no weight without regularisation, no thesis value for the §6.2 guess
            assert frame["weight"].isna().eq(frame["setting"] == "none").all()
            assert frame["thesis_Fz"].isna().eq(frame["condition"] == "distribution").all()
            numeric = numeric.drop(columns=["weight", "thesis_nodal_std", "thesis_Fz"])
        if "training" in frame:  # noise tables: a refitted model has no analytic std, NaN
            # exactly on the rows trained on noisy inputs (analysis.noise, issue 25)
            analytic = [c for c in frame if c.endswith("_analytic")]
            assert not analytic or frame[analytic].isna().all(axis=1).eq(
                frame["training"] == "noisy").all(), name
            numeric = numeric.drop(columns=analytic)
        if "inflation growth mm" in frame:  # the reduced model is not inflated: NaN
            # exactly on its rows (analysis.report.ch3.patch_rows, issue 24)
            growth = frame["inflation growth mm"]
            assert growth.isna().eq(frame["case"].str.startswith("reduced")).all(), name
            assert (growth.dropna() > 0).all(), name
            numeric = numeric.drop(columns=["inflation growth mm"])
        assert np.isfinite(numeric.to_numpy()).all(), name
    curves = tables["validation__force_deflection_thesis_fig_3_3"]
    assert list(curves["deflection mm"]) == [5, 10, 15, 20, 25, 30, 35, 40]
    assert curves.shape[1] == 4 and (curves.iloc[:, 1:].diff().iloc[1:] > 0).all().all()
    points = tables["validation__thesis_reference_points_3_3_3_4"]
    assert list(points["thesis Fz N"]) == [3933.0, 4476.0, 359.0]
    variance = tables["dataset__plsr_thesis_comparison"]
    assert len(variance) == 9 and variance["measured_cum_pct"].between(0, 100).all()
    forces = tables["inverse__forces_and_moments_ours_and_the_thesis_tables_4_1_4_3"]
    assert list(forces["condition"]) == ["reference", "ideal", "ideal", *(
        [c for c in ("noise", "guess-90", "guess-uniform", "distribution") for _ in range(2)])]
    assert (out / "ch4" / "nodal_errors_guess-uniform.png").is_file()
    # issue 16's tables: every initial guess, and the noisy conditions regularised
    guesses = tables[next(k for k in tables if k.startswith("inverse__initial_guesses"))]
    assert "distribution" in set(guesses["condition"])
    regularised = tables[next(k for k in tables if k.startswith("inverse__regularisation"))]
    assert set(regularised["setting"]) == {"none", "tikhonov", "smoothness", "guess"}
    noisy = {"noise", "guess-90", "guess-uniform", "distribution"}
    for setting, frame in regularised.groupby("setting"):
        assert set(frame["condition"]) == noisy, setting
        assert (frame["solves"] == 1).all(), setting  # the same one draw each
    assert first["validation"]["ccx_runs"] > 0 and first["inverse"]["ccx_runs"] > 0

    second = _run(out)
    assert sum(stage["ccx_runs"] for stage in second.values()) == 0

