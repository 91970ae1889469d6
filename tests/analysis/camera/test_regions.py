"""Where each target lives (analysis.camera.regions, `farm analyse regions`; issue 46).

The grid partitions the nodes it maps; a target planted in one region's field is found
there (held-out R2 near 1) and nowhere else (near 0); noise on the field lowers it; the
folds never split a load path; the study writes its tables, map and summary."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import tyre_farm_cli as cli
from analysis.camera.regions import grouped_folds, held_out_r2, region_grid, region_r2
from analysis.camera.sensor import InnerSurface
from analysis.errors import ParameterError
from tests.analysis.camera.sensor.sensor_helpers import dataset, torus_nodes
from tests.synthetic import make_combined_store


@pytest.fixture(scope="module")
def torus() -> InnerSurface:
    return InnerSurface.from_dataset(dataset(*torus_nodes()))


def test_the_grid_partitions_the_nodes_within_its_span(torus):
    regions = region_grid(torus, bands=3, sectors=4, span_deg=30.0)
    assert len(regions) == 12
    nodes = np.concatenate([r.nodes for r in regions])
    assert np.unique(nodes).size == nodes.size  # no node in two regions
    deg = np.degrees(np.arctan2(torus.node_xyz[:, 0], -torus.node_xyz[:, 2]))
    assert set(nodes) == set(np.flatnonzero(np.abs(deg) <= 30.0 + 1e-9))
    for r in regions:
        assert r.theta_deg[0] - 1e-9 <= deg[r.nodes].min() <= deg[r.nodes].max() <= (
            r.theta_deg[1] + 1e-9)


@pytest.mark.parametrize(("bands", "sectors", "span"), [(0, 4, 30.0), (3, 4, 0.0),
                                                       (3, 4, 200.0), (3, 40, 30.0)])
def test_a_grid_that_cannot_be_made_is_refused(torus, bands, sectors, span):
    with pytest.raises(ParameterError, match="regions"):
        region_grid(torus, bands, sectors, span)


def test_folds_keep_every_group_whole_and_repeats_differ():
    groups = np.repeat(np.arange(10), 4)
    rng = np.random.default_rng(0)
    first, second = grouped_folds(groups, 5, rng), grouped_folds(groups, 5, rng)
    for train, test in first:
        assert not set(groups[train]) & set(groups[test])
    assert sorted(np.concatenate([t for _, t in first])) == list(range(40))
    assert any(not np.array_equal(a[1], b[1]) for a, b in zip(first, second, strict=True))
    with pytest.raises(ParameterError, match="folds"):
        grouped_folds(groups, 11, rng)
    with pytest.raises(ParameterError, match="at least 3 load paths"):
        grouped_folds(np.repeat([0, 1], 5), 2, rng)


def _planted(torus, regions, n_paths=12, states=3, seed=1):
    """Fields of K = n_paths x states experiments: target a lives in region 0's nodes,
    target b in the last region's, every other node noise; b's region adds a small
    shared term so its R2 is below a's."""
    rng = np.random.default_rng(seed)
    K = n_paths * states
    groups = np.repeat(np.arange(n_paths), states)
    Y = rng.normal(size=(K, 2))
    field = 0.05 * rng.standard_normal((K, torus.n_nodes, 3))
    for t, reg in ((0, regions[0]), (1, regions[-1])):
        pattern = rng.standard_normal((reg.nodes.size, 3))
        field[:, reg.nodes, :] += Y[:, t, None, None] * pattern
    return field, Y, groups


def test_a_target_is_found_in_the_region_that_carries_it_and_nowhere_else(torus):
    regions = region_grid(torus, bands=2, sectors=3, span_deg=30.0)
    field, Y, groups = _planted(torus, regions)
    table = region_r2(field, Y, ("a", "b"), groups, regions, folds=4, repeats=2)
    mean = table.groupby(["target", "s_band", "sector"])["r2"].mean()
    assert mean[("a", 0, 0)] > 0.95 and mean[("b", 1, 2)] > 0.95
    others_a = mean["a"].drop((0, 0))
    assert (others_a < 0.3).all()  # a region without the target explains little of it
    assert len(table) == 2 * 6 * 2 and set(table["repeat"]) == {0, 1}


def test_noise_on_the_field_lowers_the_index(torus):
    regions = region_grid(torus, bands=2, sectors=3, span_deg=30.0)[:1]
    field, Y, groups = _planted(torus, region_grid(torus, 2, 3, 30.0))
    r2 = [region_r2(field, Y[:, :1], ("a",), groups, regions, folds=4, repeats=2,
                    noise_mm=n, seed=3)["r2"].mean() for n in (0.0, 2.0, 8.0)]
    assert r2[0] > r2[1] > r2[2]


def test_a_target_with_no_spread_has_no_index():
    X = np.random.default_rng(0).normal(size=(12, 5))
    groups = np.repeat(np.arange(6), 2)
    folds = grouped_folds(groups, 3, np.random.default_rng(0))
    assert np.isnan(held_out_r2(X, np.ones(12), groups, folds, max_components=2))
    y = np.zeros(12)
    y[folds[0][1]] = 1.0  # constant wherever the first fold trains: its mean predicted
    assert held_out_r2(X, y, groups, folds, max_components=2) < 1.0


def test_the_command_writes_its_map_and_names_where_each_target_lives(tmp_path):
    store = tmp_path / "c.zarr"
    make_combined_store(store, n_experiments=24, rows=12, cols=24, rolling=True, seed=2)
    out = tmp_path / "out"
    cli.main(["analyse", "regions", str(store), "--out", str(out), "--bands", "2",
              "--sectors", "3", "--span", "40", "--folds", "3", "--repeats", "2",
              "--targets", "Fx,Fz"])
    table = pd.read_csv(out / "regions.csv")
    assert set(table["target"]) == {"Fx", "Fz"} and len(table) == 2 * 6
    assert ((table["r2_min"] <= table["r2_mean"]) & (table["r2_mean"] <= table["r2_max"])).all()
    text = (out / "summary.md").read_text()
    assert "## Where to look" in text and "| Fz |" in text and "regions.png" in text
    assert (out / "regions.png").stat().st_size > 0 and (out / "provenance.csv").is_file()


@pytest.mark.parametrize(("option", "value"), [("--bands", "0"), ("--span", "0"),
                                               ("--folds", "1"), ("--noise-mm", "nan"),
                                               ("--targets", "Fq")])
def test_bad_options_are_one_line_and_exit_2(tmp_path, capsys, option, value):
    with pytest.raises(SystemExit) as stop:
        cli.main(["analyse", "regions", str(tmp_path / "none.zarr"), option, value])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.count("\n") == 1 and option.lstrip("-").split("-")[0] in err
