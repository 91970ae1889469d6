"""Each rolling tree's free-rolling offset, measured from its states (issue 46):
trees simulated with the first-order transient model the fit assumes, then a tree the
model does not hold for in part (a sliding branch), one it cannot measure (no branch),
and a store without trees."""

import numpy as np
import pytest
import xarray as xr

from analysis.errors import MissingVariableError
from analysis.free_rolling import free_rolling, free_slip_ratio, segments

FZ, MU, RADIUS = 4000.0, 0.9, 390.0
TRUNK = np.arange(15.0, 136.0, 15.0)  # 9 states, every 15 mm, as the answer's study
BRANCH = (150.0, 165.0)
SLIPS = (-0.08, -0.03, 0.01, 0.04, 0.09)


def _fx(fx0: float, kappa: float, kappa0: float, ds: float, C: float, sigma: float) -> float:
    """The first-order model over ``ds`` mm at constant slip, exactly."""
    return C * (kappa - kappa0) + (fx0 - C * (kappa - kappa0)) * np.exp(-ds / sigma)


def _tree(kappa0: float, C: float, sigma: float, *, slips=SLIPS, friction=MU,
          pressure=0.2, cap: float = np.inf) -> list[dict]:
    """The states of one tree: a trunk at kappa 0 from rest, branches from its end;
    ``cap`` clips |Fx| (a tyre sliding at its friction limit)."""
    rows, fx, s = [], 0.0, 0.0
    for t in TRUNK:
        fx, s = _fx(fx, 0.0, kappa0, t - s, C, sigma), t
        rows.append(dict(travel=t, roll_from=0.0, slip_ratio=0.0, fx=fx))
    for k in slips:
        f, s = fx, TRUNK[-1]  # each branch from the trunk's end
        for t in BRANCH:
            f, s = float(np.clip(_fx(f, k, kappa0, t - s, C, sigma), -cap, cap)), t
            rows.append(dict(travel=t, roll_from=TRUNK[-1], slip_ratio=k, fx=f))
    return [dict(r, friction=friction, pressure=pressure) for r in rows]


def _dataset(*trees: list[dict]) -> xr.Dataset:
    rows = [r for tree in trees for r in tree]
    col = {k: np.array([r[k] for r in rows], float) for k in rows[0]}
    K = len(rows)
    force = np.column_stack([col.pop("fx"), np.zeros(K), np.full(K, FZ)])
    coords = {k: ("experiment", v) for k, v in col.items()}
    coords |= {"slip_angle": ("experiment", np.zeros(K)),
               "deflection": ("experiment", np.full(K, 20.0)),
               "tilt": ("experiment", np.zeros(K)), "component": ["x", "y", "z"]}
    return xr.Dataset({"total_force": (("experiment", "component"), force),
                       "moment": (("experiment", "component"), np.zeros((K, 3))),
                       "rolling_radius": ("experiment", np.full(K, RADIUS))}, coords=coords)


@pytest.mark.parametrize("kappa0", [-0.0125, 0.005])
@pytest.mark.parametrize(("C", "sigma"), [(60e3, 120.0), (60e3, 400.0), (500e3, 5000.0)])
def test_the_offset_of_a_tree_is_recovered(kappa0, C, sigma):
    """Relaxation lengths from under the trunk's length (Fx settles) to far beyond it
    (Fx still rising linearly at 135 mm, as on lean at 80 kPa): kappa0 to 1e-5, the
    free-rolling radius r / (1 + kappa0)."""
    [row] = free_rolling(_dataset(_tree(kappa0, C, sigma))).to_dict("records")
    assert row["kappa0"] == pytest.approx(kappa0, abs=1e-5)
    assert row["r_free_mm"] == pytest.approx(RADIUS / (1 + kappa0), abs=5e-3)
    assert row["rms_N"] < 1.0 and row["segments"] >= len(TRUNK) + len(SLIPS)


def test_trees_are_measured_apart_and_each_state_gets_its_trees_slip():
    """Two trees, two offsets; a state's slip from free rolling is (1 + kappa) /
    (1 + kappa0) - 1: the trunk's -kappa0 (nearly), a branch commanded at kappa0 zero."""
    ds = _dataset(_tree(-0.01, 60e3, 300.0, slips=(-0.05, -0.01, 0.05)),
                  _tree(0.004, 80e3, 200.0, pressure=0.1, slips=(-0.05, 0.004, 0.05)))
    table = free_rolling(ds)
    assert table["kappa0"].to_numpy() == pytest.approx([-0.01, 0.004], abs=1e-5)
    slip = free_slip_ratio(ds)
    kappa = ds["slip_ratio"].values
    trunk = ds["roll_from"].values == 0
    first = np.arange(ds.sizes["experiment"]) < len(TRUNK) + 6
    assert slip[trunk & first] == pytest.approx(1 / 0.99 - 1, abs=1e-6)
    assert slip[(kappa == -0.01) & first] == pytest.approx(0.0, abs=1e-6)
    assert slip[(kappa == 0.004) & ~first] == pytest.approx(0.0, abs=1e-6)


def test_sliding_segments_are_left_out_of_the_fit(monkeypatch):
    """Branches at the friction limit (|Fx| held at 0.6 mu Fz, a tyre sliding) do not
    follow the linear model: their segments beyond LINEAR_SHARE of mu Fz are left out
    and the offset holds; taken in, they pull it off."""
    import analysis.free_rolling as fr

    ds = _dataset(_tree(-0.008, 60e3, 40.0, cap=0.6 * MU * FZ,
                        slips=(-0.09, -0.06, -0.02, 0.01, 0.03, 0.06, 0.09)))
    assert not segments(ds)["linear"].all()
    assert free_rolling(ds)["kappa0"].item() == pytest.approx(-0.008, abs=1e-5)
    monkeypatch.setattr(fr, "LINEAR_SHARE", 1.0)
    assert abs(free_rolling(ds)["kappa0"].item() + 0.008) > 1e-4


def test_a_tree_without_branches_is_not_measured():
    """A trunk alone (a tree whose branches have not run, or a partial roll) holds one
    slip: C and kappa0 cannot be told apart - NaN, and so is its states' slip."""
    ds = _dataset(_tree(-0.01, 60e3, 300.0, slips=()), _tree(0.0, 60e3, 300.0, friction=0.5))
    table = free_rolling(ds)
    assert np.isnan(table["kappa0"].iloc[0]) and table["kappa0"].iloc[1] == pytest.approx(
        0.0, abs=1e-6)
    slip = free_slip_ratio(ds)
    assert np.isnan(slip[:len(TRUNK)]).all() and np.isfinite(slip[len(TRUNK):]).all()


def test_a_store_without_rolling_trees_says_what_is_missing():
    ds = _dataset(_tree(0.0, 60e3, 300.0)).drop_vars(["roll_from", "rolling_radius"])
    with pytest.raises(MissingVariableError) as missing:
        segments(ds)
    assert "'rolling_radius', 'roll_from'" in str(missing.value)
    assert "a store of rolling trees" in str(missing.value)


def test_the_free_slip_is_a_target_where_every_tree_is_measured():
    """``free_slip_ratio`` among the targets (issue 46): asked for, it is each state's
    slip from its tree's free rolling; ``--targets all`` takes it only when every tree
    is measured, and asking for it then is one error naming the trees that are not."""
    from analysis.camera.features import FREE_SLIP, targets, varying_targets
    from analysis.errors import MissingVariableError

    both = _dataset(_tree(-0.01, 60e3, 300.0), _tree(0.004, 60e3, 300.0, pressure=0.1))
    both["displacement"] = xr.zeros_like(both["slip_ratio"])
    assert FREE_SLIP in varying_targets(both)
    np.testing.assert_allclose(targets(both, (FREE_SLIP,))[:, 0], free_slip_ratio(both))
    one = _dataset(_tree(-0.01, 60e3, 300.0), _tree(0.0, 60e3, 300.0, pressure=0.1, slips=()))
    one["displacement"] = xr.zeros_like(one["slip_ratio"])
    assert FREE_SLIP not in varying_targets(one) and "slip_ratio" in varying_targets(one)
    with pytest.raises(MissingVariableError, match=r"1 of 2 trees is not measured.*100 kPa"):
        targets(one, (FREE_SLIP,))


def test_the_study_writes_its_table_and_summary(tmp_path):
    """``farm analyse free-rolling``'s study: one row per tree, and a summary that says how
    many trees were measured and how far free rolling lies from the radius rolled."""
    from analysis.studies import free_rolling as study

    ds = _dataset(_tree(-0.01, 60e3, 300.0), _tree(0.0, 60e3, 300.0, pressure=0.1, slips=()))
    report = study.run(ds, tmp_path)
    table = report.tables["free_rolling"]
    assert len(table) == 2 and (tmp_path / "free_rolling.csv").exists()
    text = (tmp_path / "summary.md").read_text()
    assert "1 of 2 trees measured" in text
    assert f"{RADIUS / 0.99 - RADIUS:+.2f} to {RADIUS / 0.99 - RADIUS:+.2f} mm" in text



def test_the_summary_says_how_far_the_commanded_labels_are_off(tmp_path):
    """The largest offset in % of the commanded slip ratio's range (SLIPS span 0.17)."""
    from analysis.studies import free_rolling as study

    study.run(_dataset(_tree(-0.0085, 60e3, 300.0)), tmp_path)
    text = (tmp_path / "summary.md").read_text()
    assert f"{100 * 0.0085 / 0.17:.1f} % of the commanded slip ratio's range" in text
