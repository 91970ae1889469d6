"""The answer's study in small (issue 46), as a user runs it: examples/t2cam_rolling_quick.toml
(rolling trees on the coarse model, radii estimated) through `farm sweep submit`, then
`farm analyse sensor` with repeated grouped splits, the design's edges, every target that
varies and the reference cloud's effect."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.tyre_farm_cli.cli_helpers import run_cli

ROOT = Path(__file__).resolve().parents[2]


def _farm(argv, capsys) -> tuple[int, str, str]:
    code, out, err = run_cli([str(a) for a in argv], capsys)
    return int(code or 0), out, err


@pytest.mark.ccx
@pytest.mark.e2e
def test_the_quick_answer_study_sweeps_and_is_analysed_over_repeated_grouped_splits(
        tmp_path, capsys):
    import storage
    from analysis.splits import path_groups
    from jobs.study import load_study

    text = (ROOT / "examples" / "t2cam_rolling_quick.toml").read_text()
    study = tmp_path / "quick.toml"
    study.write_text(text.replace('"results/t2cam_rolling_quick.zarr"',
                                  f'"{tmp_path / "q.zarr"}"'))
    code, _, err = _farm(["sweep", "submit", study, "--workers", "2"], capsys)
    assert code in (0, 1), err  # 1: some states failed (data, recorded with their reason)
    s = load_study(study)
    ds = storage.open_dataset(s.store, s.group_name)
    status = ds["status"].values
    assert ds.sizes["experiment"] == 104 and set(status.tolist()) <= {1, 2}  # none pending
    done = storage.done(ds)
    groups = path_groups(done)
    assert np.unique(groups).size >= 6  # trees, the splits' groups
    # each trunk rolled at its own estimate, R - 0.59 d of its inflated radius R, which is
    # the unloaded tyre's (one for all) plus the growth under its own pressure
    from farm.solve.rolling import FREE_RADIUS_DROP

    radius, growth = done["rolling_radius"].values, done["inflation_growth"].values
    assert np.unique(np.round(radius, 6)).size == np.unique(groups).size
    unloaded = radius + FREE_RADIUS_DROP * done["deflection"].values - growth
    np.testing.assert_allclose(unloaded, unloaded[0], atol=1e-3)  # touch vs crown node
    # each tree's free rolling measured from its states (the free_slip_ratio target's)
    code, _, err = _farm(["analyse", "free-rolling", s.store, "--out", tmp_path / "free"],
                         capsys)
    assert code == 0, err
    free = pd.read_csv(tmp_path / "free" / "free_rolling.csv")
    assert len(free) == np.unique(groups).size and free["kappa0"].notna().any()
    out = tmp_path / "answer"
    code, _, err = _farm(["analyse", "sensor", s.store, "--out", out, "--repeats", 3,
                          "--edges", 0.1, "--folds", 3, "--targets", "all",
                          "--windows", "40", "--noises", "2", "--spacings", "10",
                          "--learners", "plsr", "--draws", 2], capsys)
    assert code == 0, err
    errors = pd.read_csv(out / "errors.csv")
    base = errors[(errors["axis"] == "base") & (errors["training"] == "noisy")]
    assert {"Fx", "Fy", "Fz", "Mz", "slip_ratio", "slip_angle"} <= set(base["target"])
    assert (base["splits"] == 3).all() and (base["rmse_pct_std"] > 0).any()
    assert ("free_slip_ratio" in set(base["target"])) == free["kappa0"].notna().all()
    edges = pd.read_csv(out / "errors_edges.csv")
    assert set(edges["target"]) == set(errors["target"])
    gap = pd.read_csv(out / "reference.csv").iloc[0]
    # the coarse model grows about 10 mm under inflation: a gap, far below 2 mm of noise
    assert 0.0 < gap["gap"] < 0.2 * gap["noise"]
    summary = (out / "summary.md").read_text()
    assert "3 grouped splits" in summary and "At the design's edges" in summary
    assert "The reference cloud" in summary
