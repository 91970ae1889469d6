"""Combined-load analysis (issue 13) on synthetic stores with 4 known latent load parameters."""

from __future__ import annotations

import numpy as np
import pytest

from analysis import data
from analysis.combined import BlockRegression, BlockScaler, cross_validate, latent_count
from analysis.errors import NoVarianceError, ParameterError, TooFewExperimentsError
from analysis.splits import edge_split, grouped_split, path_groups, path_progress
from analysis.splits import folds as path_folds
from analysis.studies import combined
from tests.synthetic import make_combined_store, make_store

TINY = {"rows": 6, "cols": 12, "tread_rows": 5, "tread_cols": 10}


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """40 experiments, 4 varying load parameters (deflection, shift_x, shift_y, tilt)."""
    path = tmp_path_factory.mktemp("stores") / "combined.zarr"
    make_combined_store(path, n_experiments=40, seed=1, **TINY)
    return path


@pytest.fixture(scope="module")
def ds(store):
    return data.load(store)


@pytest.fixture(scope="module")
def report(ds, tmp_path_factory):
    out = tmp_path_factory.mktemp("combined")
    return combined.run(ds, out, inputs="both,strain", folds=4, draws=3, max_components=8)


def test_pca_finds_the_number_of_varying_load_parameters(report):
    pca = report.tables["pca"].set_index("input")
    for name in ("displacement", "strain", "both (block-scaled)"):
        assert pca.loc[name, "load_parameters_varying"] == 4
        assert pca.loc[name, "n_gap"] == 4, name
        assert pca.loc[name, "n_99_9"] == 4, name


def test_latent_count_follows_the_varied_parameters(tmp_path):
    make_combined_store(tmp_path / "two.zarr", n_experiments=20, vary=("deflection", "tilt"),
                        **TINY)
    two = data.load(tmp_path / "two.zarr")
    assert combined.varying_parameters(two) == ["deflection", "tilt"]
    X = np.asarray(data.inputs(two, "displacement").compute())
    assert latent_count(X).n_gap == 2
    # an exactly rank-1 matrix plus a weak second direction: the gap sits at 1
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((2, 30, 1)), rng.standard_normal((2, 1, 50))
    lc = latent_count(a[0] @ b[0] + 1e-3 * a[1] @ b[1])
    assert (lc.n_gap, lc.n_99) == (1, 1)
    assert lc.n_999 == 1 and lc.gap_ratio > 1e4
    # 8 samples: rank 7 at most; the drop to zero after 7 is the sample count, not a gap
    full = rng.standard_normal((8, 50))
    assert latent_count(full).n_gap < 7
    low = rng.standard_normal((8, 3)) @ rng.standard_normal((3, 50))
    assert latent_count(low).n_gap == 3


def test_noise_free_held_out_errors_are_small_and_meet_the_goal(report):
    tot = report.tables["totals"]
    sel = tot[(tot["inputs"] == "both") & (tot["method"] == "plsr")
              & (tot["scenario"] == "noise-free")].set_index("total")["rmse_pct_range"]
    assert sel["Fz"] < 1.5 and sel["Fy"] < 3.0 and sel["Fx"] < 4.0
    anchors = report.tables["anchors"].set_index("total")
    assert list(anchors.index) == ["Fz", "Fy", "Fx"]
    assert anchors.loc["Fz", "published_pct (strains)"] == 1.8
    assert bool(anchors["goal_met"].all())
    nodal = report.tables["nodal"]
    free = nodal[(nodal["inputs"] == "both") & (nodal["scenario"] == "noise-free")]
    assert (free["rmse_pct_range"] < 8.0).all()


def test_error_grows_with_noise(report):
    tot = report.tables["totals"]
    fz = tot[(tot["inputs"] == "strain") & (tot["method"] == "plsr") & (tot["total"] == "Fz")
             & (tot["training"] == "noise-free")]
    pct = fz.set_index("scenario")["rmse_pct_range"]
    assert pct["noise-free"] < pct["1 mm, 0.04 %"] < pct["1 mm, 0.5 %"]


def test_noise_in_training_is_reported_beside_clean_training(report):
    """Issue 25: a model trained on measurements sees noise in training too. Both are
    reported for every noisy scenario, and the noise-free scenario only once."""
    tot = report.tables["totals"]
    rows = tot.groupby(["inputs", "method", "scenario"])["training"].apply(set)
    for (_, _, scenario), trainings in rows.items():
        assert trainings == ({"noise-free"} if scenario == "noise-free"
                             else {"noise-free", "noisy"})
    m = report.tables["models"]
    noisy = m[m["training"] == "noisy"]
    assert len(noisy) and noisy["chosen_by"].str.contains("noisy training inputs").all()
    # with the heavy noise in training, the CV does not pick more components than clean
    pick = m.set_index(["inputs", "method", "target", "scenario", "training"])["n_components"]
    assert (pick["strain", "plsr", "totals", "1 mm, 0.5 %", "noisy"]
            <= pick["strain", "plsr", "totals", "noise-free", "noise-free"])


def test_cv_picks_the_latent_count_and_fewer_under_heavy_noise(report):
    m = report.tables["models"]
    m = m[m["training"] == "noise-free"]
    pick = m.set_index(["inputs", "method", "target", "scenario"])["n_components"]
    assert pick["both", "plsr", "totals", "noise-free"] in (4, 5)
    assert pick["strain", "plsr", "totals", "1 mm, 0.5 %"] < pick["strain", "plsr", "totals",
                                                                  "noise-free"]
    how = m.set_index(["inputs", "method", "target", "scenario"])["chosen_by"]
    assert how["both", "plsr", "totals", "noise-free"].endswith("experiments, noise-free")
    assert how["strain", "plsr", "totals", "1 mm, 0.5 %"].endswith("noisy held-out inputs")
    cv = report.tables["cross_validation"]
    chosen = cv[cv["chosen"]]
    assert len(chosen) == len(report.tables["models"])  # one chosen count per model
    for _, row in chosen.iterrows():
        same = cv[(cv["inputs"] == row["inputs"]) & (cv["method"] == row["method"])
                  & (cv["target"] == row["target"]) & (cv["scenario"] == row["scenario"])
                  & (cv["training"] == row["training"])]
        assert row["mse_mean"] == same["mse_mean"].min()


def test_files_written(report):
    names = {p.name for p in report.files}
    for name in ("pca.csv", "totals.csv", "nodal.csv", "anchors.csv", "summary.md",
                 "pred_vs_true_both.png", "error_map_both.png", "cross_validation.csv"):
        assert name in names
        assert (report.out / name).stat().st_size > 0
    text = (report.out / "summary.md").read_text()
    assert "published" in text and "error_map_both.png" in text


def test_block_scaler_gives_each_block_unit_total_variance():
    rng = np.random.default_rng(0)
    X = np.hstack([30.0 * rng.standard_normal((20, 5)), 1e-3 * rng.standard_normal((20, 7))])
    s = BlockScaler([5, 7]).fit(X)
    Z = s.transform(X)
    assert Z[:, :5].var(axis=0, ddof=1).sum() == pytest.approx(1.0)
    assert Z[:, 5:].var(axis=0, ddof=1).sum() == pytest.approx(1.0)
    np.testing.assert_allclose(s.inverse_transform(Z), X)
    with pytest.raises(ParameterError, match="add up"):
        BlockScaler([5, 6]).fit(X)


def test_linear_forces_are_recovered_exactly(tmp_path):
    """coupling = 0: the totals are linear in the fields up to Fz's d^1.15 curvature."""
    make_combined_store(tmp_path / "lin.zarr", n_experiments=30, coupling=0.0, seed=4, **TINY)
    lin = data.load(tmp_path / "lin.zarr")
    X = np.asarray(data.inputs(lin, "displacement").compute())
    Y = np.asarray(lin["total_force"].values)
    train, test = combined.split(lin, 0.25, 0)
    model = BlockRegression("plsr", 4, None, [1, 1, 1]).fit(X[train], Y[train])
    err = np.abs(model.predict(X[test]) - Y[test])
    assert err[:, :2].max() < 1e-6 * np.abs(Y[:, :2]).max()  # Fx, Fy: exactly linear
    assert err[:, 2].max() < 0.01 * np.ptp(Y[:, 2])  # Fz: curvature only
    best = cross_validate(X[train], Y[train], folds=4, y_blocks=[1, 1, 1])
    assert best["plsr", "noise-free"][0] >= 4


def test_split_is_seeded_and_disjoint():
    singles = np.arange(20)
    tr, te = grouped_split(singles, 0.25, 3)
    assert len(te) == 5 and len(tr) == 15 and not set(tr) & set(te)
    assert np.array_equal(te, grouped_split(singles, 0.25, 3)[1])
    assert not np.array_equal(te, grouped_split(singles, 0.25, 4)[1])
    # one experiment per path: the experiment split of before, to the index
    perm = np.random.default_rng(3).permutation(20)
    assert np.array_equal(te, np.sort(perm[:5])) and np.array_equal(tr, np.sort(perm[5:]))
    with pytest.raises(ParameterError):
        grouped_split(singles, 1.0, 0)


@pytest.mark.parametrize("seed", range(5))
def test_a_split_or_a_fold_never_splits_a_roll(seed):
    """Issue 45: the states of one roll (one group) are held out, or folded, whole."""
    groups = np.repeat(np.arange(12), 4)  # 12 rolls of 4 states each
    tr, te = grouped_split(groups, 0.25, seed)
    assert len(te) == 12 and not set(groups[tr]) & set(groups[te])
    assert sorted([*tr, *te]) == list(range(48))
    for train, test in path_folds(groups[tr], 3, seed):
        assert not set(groups[tr][train]) & set(groups[tr][test])
    with pytest.raises(ParameterError, match="load paths"):
        path_folds(groups[:8], 3, seed)  # two rolls cannot make three folds


def test_the_states_of_one_roll_are_one_load_path():
    """path_groups: experiments differing in travel alone share a group; without a
    travel parameter every experiment is its own."""
    import xarray as xr

    def ds(**params):
        return xr.Dataset(coords={k: ("experiment", np.asarray(v, dtype=float))
                                  for k, v in params.items()})

    rolls = ds(deflection=[15] * 6, pressure=[0.2] * 6,
               slip_angle=[2, 2, 2, -2, -2, 0], travel=[50, 100, 150, 50, 100, 150])
    assert path_groups(rolls).tolist() == [0, 0, 0, 1, 1, 2]
    # the analyses' split (combined, sensor, fit) holds out whole rolls, whatever the seed
    for seed in range(6):
        train, test = combined.split(rolls, 0.34, seed)
        assert not set(path_groups(rolls)[train]) & set(path_groups(rolls)[test])
    assert path_groups(ds(deflection=[10, 10, 20], pressure=[0.2] * 3)).tolist() == [0, 1, 2]
    # rolling trees (issue 45): a tree's trunk and branches are one group, trees apart
    trees = ds(deflection=[15] * 6, pressure=[0.2] * 6, friction=[0.4] * 3 + [0.8] * 3,
               slip_angle=[0, 2, -2, 0, 2, -2], roll_from=[0, 40, 40, 0, 40, 40],
               travel=[40, 70, 70, 40, 70, 70])
    assert path_groups(trees).tolist() == [0, 0, 0, 1, 1, 1]


@pytest.mark.parametrize(("status", "expected"), [
    ([1, 1, 1, 0, 0, 0, 0, 0, 0], dict(whole=1, growing=0, not_started=2, with_failures=0)),
    ([1, 1, 0, 1, 0, 0, 0, 0, 0], dict(whole=0, growing=2, not_started=1, with_failures=0)),
    ([1, 1, 1, 2, 1, 1, 0, 0, 1], dict(whole=1, growing=1, not_started=0, with_failures=1)),
])
def test_how_far_each_rolling_tree_is(status, expected):
    """path_progress (`farm sweep status`): a tree counts once, whole when every state
    is done, failed when any failed; a group without rolls has no load paths."""
    import xarray as xr

    trees = xr.Dataset({"status": ("experiment", np.asarray(status, dtype=np.int8))},
                       coords={k: ("experiment", np.asarray(v, dtype=float)) for k, v in dict(
                           deflection=[15] * 9, pressure=[0.2] * 9,
                           friction=[0.4] * 3 + [0.6] * 3 + [0.8] * 3,
                           slip_angle=[0, 2, -2] * 3, roll_from=[0, 40, 40] * 3,
                           travel=[40, 70, 70] * 3).items()})
    assert path_progress(trees) == {"paths": 3, **expected}
    assert path_progress(trees.drop_vars("travel")) is None


def test_vertical_only_group_is_refused_in_one_line(tmp_path):
    make_store(tmp_path / "v.zarr", n_experiments=7, **TINY)
    with pytest.raises(NoVarianceError, match="not a combined-load selection") as info:
        combined.run(data.load(tmp_path / "v.zarr"), tmp_path / "out")
    assert "\n" not in str(info.value) and "varying: deflection" in str(info.value)


def test_too_few_experiments(tmp_path):
    make_combined_store(tmp_path / "few.zarr", n_experiments=5, **TINY)
    with pytest.raises(TooFewExperimentsError, match="5 done experiments"):
        combined.run(data.load(tmp_path / "few.zarr"), tmp_path / "out")


def test_summary_warns_when_cv_cannot_reach_the_parameter_count(tmp_path, report):
    """8 experiments: 6 training in 5 folds leave at most 3 components for 4 parameters."""
    make_combined_store(tmp_path / "eight.zarr", n_experiments=8, **TINY)
    small = combined.run(data.load(tmp_path / "eight.zarr"), tmp_path / "out",
                         inputs="strain", draws=1)
    assert small.tables["models"]["n_components"].max() <= 3
    assert "at most 3 components" in (tmp_path / "out" / "summary.md").read_text()
    assert "Warning" not in (report.out / "summary.md").read_text()


def test_a_rolling_group_predicts_its_slip_ratio_and_slip_angle(tmp_path):
    """Issue 30: a rolling group's slip ratio and slip angle are targets beside the
    totals. In this synthetic store they are linear in shift_x and tilt, which shape the
    fields: held out, both come back to a few % of their range (and the summary says)."""
    path = tmp_path / "rolling.zarr"
    make_combined_store(path, n_experiments=40, seed=3, rolling=True, **TINY)
    ds = data.load(path)
    assert {"slip_ratio", "slip_angle"} <= set(combined.varying_parameters(ds))
    out = tmp_path / "out"
    rep = combined.run(ds, out, inputs="both", folds=4, draws=2, max_components=8)
    tot = rep.tables["totals"]
    rows = tot[(tot["scenario"] == "noise-free") & (tot["method"] == "plsr")
               & tot["total"].isin(["slip_ratio", "slip_angle"])]
    assert set(rows["total"]) == {"slip_ratio", "slip_angle"}
    assert set(rows["unit"]) == {"1", "deg"}
    assert (rows["rmse_pct_range"] < 5.0).all(), rows
    assert "slip_angle" in (out / "summary.md").read_text()


def test_the_edge_split_holds_out_whole_paths_at_any_face_of_the_box():
    """analysis.splits.edge_split (issue 46): a path is at an edge when any varying
    parameter is within the outer fraction of its range; a roll goes whole, by any of
    its states' parameters but travel; no interior (or no edge) is one clear error."""
    import xarray as xr

    angle = [0.0, 0.0, 2.0, 2.0, 1.0, 1.0, -2.0, 0.5]
    ratio = [0.0, 0.0, 0.0, 0.0, 0.01, 0.01, 0.0, -0.01]
    travel = [50.0, 100.0] * 4
    ds = xr.Dataset(coords={"slip_angle": ("experiment", angle),
                            "slip_ratio": ("experiment", ratio),
                            "travel": ("experiment", travel)})
    train, test = edge_split(ds, ["slip_angle", "slip_ratio", "travel"], 0.1)
    # edges: angle 2 (paths 1), -2 (path 3, one state), ratio +-0.01 (paths 2, 3's last)
    assert train.tolist() == [0, 1] and test.tolist() == [2, 3, 4, 5, 6, 7]
    with pytest.raises(ParameterError, match="no edge case"):
        edge_split(ds, ["travel"], 0.1)  # travel never counts: nothing at an edge
    two = xr.Dataset(coords={"slip_angle": ("experiment", [0.0, 2.0, 0.0])})
    with pytest.raises(ParameterError, match="no interior"):
        edge_split(two, ["slip_angle"], 0.1)
    with pytest.raises(ParameterError, match=r"\(0, 0.5\)"):
        edge_split(ds, ["slip_angle"], 0.5)


def test_the_edge_split_of_rolling_trees_holds_out_branches_not_trees():
    """In a store of rolling trees (issue 46) every tree of a nested design has branches
    at the slips' edges: the edge split holds out a branch whole (its states) and keeps
    its trunk's states - the straight roll it left - in training where the trunk's own
    parameters are interior; a trunk at an edge goes with all its branches."""
    import xarray as xr

    # two trees (friction 0.6 interior, 1.0 at the edge), each: a trunk at 20 and 40 mm,
    # a branch at alpha 0.5 (interior) and one at +-4 (edge), states at 60 and 80 mm;
    # then a lone trunk at friction 0.3 (the other edge)
    tree = {"travel": [20, 40, 60, 80, 60, 80], "slip_angle": [0, 0, 0.5, 0.5, 4, 4],
            "roll_from": [0, 0, 40, 40, 40, 40]}
    lone = {"travel": [20, 40], "slip_angle": [0, 0], "roll_from": [0, 0]}
    coords = {n: ("experiment", np.array(v * 2 + lone[n], dtype=float))
              for n, v in tree.items()}
    coords["friction"] = ("experiment", np.repeat([0.6, 1.0, 0.3], [6, 6, 2]))
    coords["slip_angle"] = ("experiment", np.concatenate([tree["slip_angle"],
                                                          np.negative(tree["slip_angle"]),
                                                          lone["slip_angle"]]))
    ds = xr.Dataset(coords=coords)
    train, test = edge_split(ds, ["friction", "slip_angle", "travel"], 0.1)
    assert train.tolist() == [0, 1, 2, 3]  # the interior tree's trunk and inner branch
    assert test.tolist() == [4, 5, *range(6, 14)]  # its edge branch; the edge trees whole
