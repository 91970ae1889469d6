"""Rolling studies (issue 30) through study files, identities, the store and a sweep.

The physics of a roll is tested in tests/farm/test_rolling.py; here: that the rolling
keys reach the right experiments, ids and parameters, that bad ones are one error before
anything runs, and that examples/rolling_quick.toml runs end to end with every array in
the store."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from conftest import ccx_runs

from farm.specs import RoadMotion
from jobs.errors import StudyError
from jobs.expand import cases, experiments, parameters, plan
from jobs.study import load_study, parse_study

SOLVER = "CalculiX 2.20"
ROOT = Path(__file__).resolve().parents[2]
FULL = """
[model]
kind = "full"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 16
"""


def _rolling(tmp_path, loads: str, model: str = FULL) -> str:
    return (f'[study]\nname = "r"\nstore = "{tmp_path / "s.zarr"}"\n' + model
            + f"\n[loads]\npressure_kpa = [200]\ndeflection_mm = [15]\n{loads}\n")


def test_slip_keys_make_every_case_a_roll(tmp_path):
    study = parse_study(_rolling(tmp_path, "friction = [0.6]\nslip_angle_deg = [-2, 2]\n"
                                            "slip_ratio = [0, 0.01]\n"))
    assert study.combined and study.rolling is not None
    assert (study.rolling.distance, study.rolling.rolling_radius) == (150.0, None)  # defaults
    motions = [m for _, _, m in cases(study)]
    assert len(motions) == 4 and all(m is not None and m.rolls for m in motions)
    assert {(m.slip_ratio, m.slip_angle) for m in motions if m} == {
        (0.0, -2.0), (0.0, 2.0), (0.01, -2.0), (0.01, 2.0)}
    paths = plan(study, SOLVER)
    assert len(paths) == 4 and all(len(p.experiments) == 1 for p in paths)  # a roll a path
    params = parameters(experiments(paths), study.combined, True)
    assert set(params) == {"deflection", "pressure", "friction", "shift_x", "shift_y", "tilt",
                           "slip_ratio", "slip_angle", "travel"}
    assert params["travel"].tolist() == [150.0] * 4  # the end of each roll, by default
    assert sorted(params["slip_angle"].tolist()) == [-2.0, -2.0, 2.0, 2.0]
    assert not params["shift_x"].any()


def test_the_roll_table_sets_distance_and_radius_and_enters_the_ids(tmp_path):
    free = parse_study(_rolling(tmp_path, "friction = [0.6]\n[loads.roll]\n"))
    fixed = parse_study(_rolling(tmp_path, "friction = [0.6]\n[loads.roll]\ndistance_mm = 90\n"
                                           "rolling_radius_mm = 401.5\n"))
    [(_, _, m_free)] = cases(free)
    [(_, _, m_fixed)] = cases(fixed)
    assert m_free == RoadMotion(friction=0.6, roll=150.0)  # free rolling, kappa = alpha = 0
    assert m_fixed == RoadMotion(friction=0.6, roll=90.0, rolling_radius=401.5)
    ids = {experiments(plan(s, SOLVER))[0].id for s in (free, fixed)}
    assert len(ids) == 2
    # a sampled design over slip, the rest listed
    sampled = parse_study(_rolling(tmp_path, "friction = [0.6]\n[loads.sample]\nmethod = 'lhs'"
                                             "\nn = 5\nslip_angle_deg = [-3, 3]\n"))
    angles = [m.slip_angle for _, _, m in cases(sampled) if m is not None]
    assert len(angles) == 5 and all(-3 <= a <= 3 for a in angles)


@pytest.mark.parametrize(("loads", "model", "match"), [
    ("slip_ratio = [2.0]", FULL, "loads.slip_ratio"),
    ("slip_angle_deg = [0]\nshift_x_mm = [1]", FULL, "loads.shift_x_mm"),
    ("[loads.roll]\ndistance_mm = 0", FULL, "loads.roll.distance_mm"),
    ("[loads.roll]\nrolling_radius_mm = 'auto'", FULL, "loads.roll.rolling_radius_mm"),
    ("[loads.roll]\nspeed = 3", FULL, "loads.roll"),
    ("slip_angle_deg = [1]", FULL.replace('kind = "full"', 'kind = "reduced"\nroad = "contact"'),
     "loads.roll"),
])
def test_bad_rolling_loads_are_one_study_error(tmp_path, loads, model, match):
    with pytest.raises(StudyError, match=match.replace(".", r"\.")) as info:
        parse_study(_rolling(tmp_path, loads, model).replace(
            "pressure_kpa = [200]\n", "pressure_kpa = [200]\n" if "full" in model else ""))
    assert "\n" not in str(info.value)


def _quick_study(tmp_path, slip_angles: str = "[-2, 0, 2]", slip_ratios: str = "[-0.01, 0.0, 0.01]",
                 ) -> Path:
    """examples/rolling_quick.toml, writing into ``tmp_path``."""
    text = (ROOT / "examples" / "rolling_quick.toml").read_text()
    text = text.replace('store = "results/rolling_quick.zarr"',
                        f'store = "{tmp_path / "rolling.zarr"}"')
    text = text.replace("slip_angle_deg = [-2, 0, 2]", f"slip_angle_deg = {slip_angles}")
    text = text.replace("slip_ratio = [-0.01, 0.0, 0.01]", f"slip_ratio = {slip_ratios}")
    assert str(tmp_path) in text and slip_angles in text and slip_ratios in text
    path = tmp_path / "rolling.toml"
    path.write_text(text)
    return path


def _check_store(path: Path) -> None:
    import storage

    study = load_study(path)
    ds = storage.open_dataset(study.store, study.group_name)
    assert ds["slip_angle"].attrs["units"] == "deg" and ds["slip_ratio"].attrs["units"] == "1"
    want = {e.id: e.motion for e in experiments(plan(study, ds.attrs["solver"]))}
    for k, e in enumerate(ds["experiment"].values.tolist()):
        assert (float(ds["slip_ratio"].values[k]), float(ds["slip_angle"].values[k])) == (
            want[e].slip_ratio, want[e].slip_angle)
    done = storage.done(ds)  # verified against the checksums
    assert done.sizes["experiment"] == ds.sizes["experiment"]  # none failed
    total, road = done["total_force"].values, done["road_reaction"].values
    angle = done["slip_angle"].values
    # the radii (issue 30): every roll turned with the study's r_e, on a road 15 mm up
    np.testing.assert_array_equal(done["rolling_radius"].values, 402.9)
    loaded = done["loaded_radius"].values
    assert np.ptp(loaded) < 1e-9 and 380.0 < loaded[0] < 400.0
    for k in range(done.sizes["experiment"]):
        fz = road[k][2]
        assert fz > 1000.0
        # the camera's re-read tread forces sum to the road's reaction (uniform grid)
        assert np.all(np.abs(total[k] - road[k]) <= 0.02 * fz), (total[k], road[k])
        assert np.sign(road[k][1]) == -np.sign(angle[k]) or angle[k] == 0  # Fy opposes
    # mirrored slip angles at the same slip ratio mirror Fy
    ratio = done["slip_ratio"].values
    for kappa in np.unique(ratio):
        fy = {a: road[k][1] for k, a in enumerate(angle) if ratio[k] == kappa}
        if 2.0 in fy and -2.0 in fy:
            assert fy[2.0] == pytest.approx(-fy[-2.0], rel=0.05, abs=0.01 * fz)


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_quick_rolling_study_end_to_end(tmp_path, counting_ccx, capsys):
    """3 rolls of examples/rolling_quick.toml (kappa 0.01; slip angles -2, 0, 2) through
    `farm sweep submit`: the store complete, balanced and mirrored; resume solves nothing."""
    from tyre_farm_cli import main

    path = _quick_study(tmp_path, slip_ratios="[0.01]")
    main(["sweep", "submit", str(path), "--workers", "2"])  # returns: every roll done
    assert "3 │      0 │" in capsys.readouterr().out  # done now, failed
    runs = ccx_runs(counting_ccx)
    assert 3 <= runs <= 5  # one roll each (and the inflation once per worker, cached)
    _check_store(path)
    main(["sweep", "resume", str(path), "--workers", "1"])
    assert ccx_runs(counting_ccx) == runs


def test_a_roll_s_states_are_experiments_labelled_by_their_travel(tmp_path):
    """Issue 45: ``[loads.roll] states`` makes every state along a roll an experiment of
    its own, in one path, with the id a roll of its travel from rest has; the default
    keeps the end alone (the ids of before); the count is checked with the states."""
    loads = "friction = [0.6]\nslip_angle_deg = [-2, 2]\n[loads.roll]\ndistance_mm = 90\n"
    study = parse_study(_rolling(tmp_path, loads + "states = 3\n"))
    paths = plan(study, SOLVER)
    assert len(paths) == 2 and all(len(p.experiments) == 3 for p in paths)
    travels = [e.motion.roll for e in paths[0].experiments]
    assert travels == [30.0, 60.0, 90.0]
    assert parameters(list(paths[0].experiments), True, True)["travel"].tolist() == travels
    from_rest = parse_study(_rolling(tmp_path, loads.replace("90", "60")))
    assert ({e.id for e in experiments(plan(from_rest, SOLVER))}
            <= {e.id for e in experiments(paths)})
    alone = parse_study(_rolling(tmp_path, loads))  # states = 1: the end, as before
    assert [len(p.experiments) for p in plan(alone, SOLVER)] == [1, 1]
    for bad, match in (("states = 0", "loads.roll.states"), ("states = 91", "closer than 1 mm"),
                       ("states = 2.5", "loads.roll.states")):
        with pytest.raises(StudyError, match=match):
            parse_study(_rolling(tmp_path, loads + bad + "\n"))


def _stored(study, ids: list[str]) -> dict[str, object]:
    import storage

    ds = storage.open_dataset(study.store, study.group_name)
    index = {e: k for k, e in enumerate(ds["experiment"].values.tolist())}
    return {e: ds.isel(experiment=index[e]) for e in ids}


@pytest.mark.ccx
@pytest.mark.e2e  # two sweeps of a partial roll, ~50 s: run by .ci/run (--e2e)
def test_a_roll_that_stops_keeps_the_states_it_reached_and_resume_rolls_for_the_rest(
        tmp_path):
    """A roll of two states that runs out of increments between them (no retry): the
    state it reached is stored done, equal to a whole run's, the other failed with a
    reason naming where the roll stopped; run again with enough increments, the task
    rolls to the end and stores the missing state alone, as the whole run has it."""
    import storage
    from jobs.storeio import ensure_group
    from jobs.tasks import PathTask, run_path

    def task_of(where: Path, solver: str = "") -> tuple:
        loads = ("friction = [0.6]\nslip_angle_deg = [2]\n[loads.roll]\ndistance_mm = 160\n"
                 "rolling_radius_mm = 403.8\nstates = 2\n")
        study = parse_study(_rolling(where, loads) + solver)
        [path] = plan(study, SOLVER)
        ensure_group(study, SOLVER)
        exps = list(path.experiments)
        storage.reserve(study.store, study.group_name, [e.id for e in exps],
                        parameters(exps, True, True))
        return study, PathTask(path, study.model, study.settings, study.store,
                               study.group_name, retry_smaller_increments=False)

    whole, task = task_of(tmp_path / "whole")
    assert len(run_path(task).done) == 2
    ids = [e.id for e in task.path.experiments]
    # 118 increments for the whole path with ccx 2.20 (the roll's last 40 mm take 12)
    stopped, short = task_of(tmp_path / "stopped", "[solver]\nmax_increments = 104\n")
    out = run_path(short)
    assert out.done == (ids[0],) and [e for e, _ in out.failed] == [ids[1]]
    reason = out.failed[0][1]
    assert reason.startswith("partial roll: stopped after the state at 80 mm") and (
        "max_increments" in reason and "in the roll at 15 mm, after" in reason)
    ds = storage.open_dataset(stopped.store, stopped.group_name)
    assert ds["travel"].values.tolist() == [80.0, 160.0]
    assert ds["status"].values.tolist() == [storage.DONE, storage.FAILED]
    again = run_path(dataclasses.replace(short, settings=whole.settings))
    assert again.skipped == (ids[0],) and again.done == (ids[1],)
    a, b = _stored(whole, ids), _stored(stopped, ids)
    for e in ids:  # the kept state as the whole run's; the resumed one too (same deck)
        for name in ("displacement", "strain", "road_reaction", "reaction_force"):
            np.testing.assert_allclose(b[e][name].values, a[e][name].values, rtol=1e-9,
                                       atol=1e-9, err_msg=f"{e} {name}")
