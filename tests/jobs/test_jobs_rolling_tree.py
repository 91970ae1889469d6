"""Rolling trees (issue 45) through study files, identities, the store and a sweep.

The solver side (a branch continued from a trunk's restart file) is tested in
tests/farm/test_rolling_tree.py; here: ``[loads.roll] branch_from_mm`` makes one tree per
pressure, deflection, friction and camber, its states get ids and parameters that say
what they are (a straight branch is the straight roll from rest), bad values are one
error before anything runs, and examples/rolling_tree_quick.toml runs end to end and
resumes only what is missing.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import ccx_processes, ccx_runs

from jobs.errors import StudyError
from jobs.expand import RollTreePlan, experiments, parameters, plan
from jobs.study import load_study, parse_study

SOLVER = "CalculiX 2.20"
ROOT = Path(__file__).resolve().parents[2]
MODEL = """
[model]
kind = "full"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 16
"""


def _study(tmp_path, loads: str, roll: str) -> str:
    return (f'[study]\nname = "r"\nstore = "{tmp_path / "s.zarr"}"\n' + MODEL
            + f"\n[loads]\npressure_kpa = [200]\ndeflection_mm = [15]\n{loads}\n"
            + f"[loads.roll]\n{roll}\n")


def test_cases_that_share_a_trunk_are_one_tree_whose_states_say_what_they_are(tmp_path):
    loads = "friction = [0.4, 0.8]\nslip_ratio = [0, 0.05]\nslip_angle_deg = [-2, 2]\n"
    roll = "distance_mm = 90\nstates = 3\nrolling_radius_mm = 403.8\n"
    trees = plan(parse_study(_study(tmp_path, loads, roll + "branch_from_mm = 30\n")), SOLVER)
    assert len(trees) == 2 and all(isinstance(t, RollTreePlan) for t in trees)  # a friction each
    for tree in trees:
        assert tree.motion.roll == 30.0 and not (tree.motion.slip_ratio or tree.motion.slip_angle)
        assert [e.motion.roll for e in tree.trunk] == [30.0]  # the states it passes
        assert len(tree.branches) == 4
        for b in tree.branches:
            assert [e.motion.roll for e in b.experiments] == [60.0, 90.0]
            assert {e.motion.roll_from for e in b.experiments} == {30.0}
    exps = experiments(trees)
    assert len({e.id for e in exps}) == len(exps) == 2 * (1 + 4 * 2)
    params = parameters(exps, True, True, trees=True)
    assert sorted(set(params["roll_from"].tolist())) == [0.0, 30.0]
    # the same cases rolled from rest: other load histories, other ids, but the trunk's
    # states are straight rolls from rest and share theirs
    plain = experiments(plan(parse_study(_study(tmp_path, loads, roll)), SOLVER))
    assert {e.id for e in trees[0].trunk} <= {e.id for e in experiments(plan(parse_study(
        _study(tmp_path, "friction = [0.4]\n", roll)), SOLVER))}
    assert not {e.id for t in trees for b in t.branches for e in b.experiments} & {
        e.id for e in plain}


def test_a_straight_branch_is_the_straight_roll_from_rest(tmp_path):
    roll = "distance_mm = 90\nstates = 3\nrolling_radius_mm = 403.8\n"
    [tree] = plan(parse_study(_study(tmp_path, "friction = [0.6]\nslip_ratio = [0, 0.05]\n",
                                     roll + "branch_from_mm = 30\n")), SOLVER)
    straight = next(b for b in tree.branches if b.slip_ratio == 0)
    rest = experiments(plan(parse_study(_study(tmp_path, "friction = [0.6]\n", roll)), SOLVER))
    assert [e.id for e in (*tree.trunk, *straight.experiments)] == [e.id for e in rest]


@pytest.mark.parametrize(("roll", "match"), [
    ("distance_mm = 90\nbranch_from_mm = 90", "below distance_mm"),
    ("distance_mm = 90\nbranch_from_mm = -1", "loads.roll.branch_from_mm"),
    ("distance_mm = 900\nbranch_from_mm = 100", "at most 320"),
])
def test_bad_branch_points_are_one_study_error(tmp_path, roll, match):
    with pytest.raises(StudyError, match=match) as info:
        parse_study(_study(tmp_path, "friction = [0.6]\n", roll))
    assert "\n" not in str(info.value)


NESTED = """[loads.sample]
method = "lhs"
n = 3
friction = [0.3, 1.0]
[loads.roll]
distance_mm = 70
rolling_radius_mm = 403.8
states = 7
branch_from_mm = 40
[loads.roll.branches]
n = 4
slip_ratio = [-0.1, 0.1]
slip_angle_deg = [-4, 4]
"""


def _nested(tmp_path, text: str = NESTED) -> str:
    return (f'[study]\nname = "r"\nstore = "{tmp_path / "s.zarr"}"\n' + MODEL
            + "\n[loads]\npressure_kpa = [200]\ndeflection_mm = [15]\n" + text)


def test_branches_sample_their_own_slips_for_every_trunk(tmp_path):
    """[loads.roll.branches]: each trunk of the sampled design (3 frictions) gets 4
    branches whose slips a design of its own samples within the ranges (a nested,
    sliced design: every trunk sees the whole slip box, no two trunks the same points);
    the same file gives the same cases."""
    study = parse_study(_nested(tmp_path))
    trees = plan(study, SOLVER)
    assert len(trees) == 3 and all(len(t.branches) == 4 for t in trees)
    assert len({t.motion.friction for t in trees}) == 3
    slips = [[(b.slip_ratio, b.slip_angle) for b in t.branches] for t in trees]
    for points in slips:
        kappa, alpha = np.array(points).T
        assert np.all(np.abs(kappa) <= 0.1) and np.all(np.abs(alpha) <= 4)
        # a Latin hypercube of 4: one point in each quarter of each range
        assert sorted(np.floor((kappa + 0.1) / 0.05).astype(int).tolist()) == [0, 1, 2, 3]
    assert slips[0] != slips[1] != slips[2]
    assert [e.id for e in experiments(trees)] == [
        e.id for e in experiments(plan(parse_study(_nested(tmp_path)), SOLVER))]
    assert len(experiments(trees)) == 3 * (4 + 4 * 3)


@pytest.mark.parametrize(("text", "match"), [
    (NESTED.replace("branch_from_mm = 40\n", ""), "needs \\[loads.roll\\] branch_from_mm"),
    (NESTED.replace("friction = [0.3, 1.0]", "friction = [0.3, 1.0]\nslip_ratio = [0, 0.1]"),
     "loads.sample.slip_ratio"),
    (NESTED.replace("[loads.sample]", "slip_angle_deg = [2]\n[loads.sample]"),
     "loads.slip_angle_deg"),
    (NESTED.replace("slip_ratio = [-0.1, 0.1]\nslip_angle_deg = [-4, 4]\n", ""),
     "no slip_ratio or slip_angle_deg range"),
    (NESTED.replace("n = 4", "n = 0"), "loads.roll.branches.n"),
    (NESTED.replace("slip_angle_deg = [-4, 4]", "slip_angle_deg = [4, -4]"), "low <= high"),
])
def test_bad_branch_designs_are_one_study_error(tmp_path, text, match):
    with pytest.raises(StudyError, match=match) as info:
        parse_study(_nested(tmp_path, text))
    assert "\n" not in str(info.value)


def _quick(tmp_path, slip_angles: str) -> Path:
    text = (ROOT / "examples" / "rolling_tree_quick.toml").read_text()
    text = text.replace('store = "results/rolling_tree_quick.zarr"',
                        f'store = "{tmp_path / "tree.zarr"}"')
    text = text.replace("slip_angle_deg = [-3, 0, 3]", f"slip_angle_deg = {slip_angles}")
    assert str(tmp_path) in text and slip_angles in text
    path = tmp_path / "tree.toml"
    path.write_text(text)
    return path


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_quick_rolling_tree_study_end_to_end_and_grown(tmp_path, counting_ccx, capsys):
    """examples/rolling_tree_quick.toml through `farm sweep submit`, first with the slip
    angle 3 degrees alone (one trunk, 3 branches), then with -3 and 3: the second sweep
    rolls the trunk again and the 3 new branches only, and stores their states alone;
    mirrored slip angles mirror Fy, Fx grows with the slip ratio, the trunk's states are
    straight; resume solves nothing."""
    import storage
    from tyre_farm_cli import main

    main(["sweep", "submit", str(_quick(tmp_path, "[3]")), "--workers", "2"])
    assert "13 │      0 │" in capsys.readouterr().out  # 4 + 3 x 3 done now, 0 failed
    first = ccx_runs(counting_ccx)
    assert 4 <= first <= 6  # trunk and 3 branches (and the inflation, cached per worker)
    path = _quick(tmp_path, "[-3, 3]")
    main(["sweep", "submit", str(path), "--workers", "1"])
    out = capsys.readouterr().out
    assert "22 │          13 │        9 │      0 │" in out, out  # 13 kept, 9 done now
    assert 4 <= ccx_runs(counting_ccx) - first <= 5  # the trunk again, 3 new branches
    study = load_study(path)
    ds = storage.done(storage.open_dataset(study.store, study.group_name))
    assert ds.sizes["experiment"] == 22
    road = ds["road_reaction"].values
    kappa, alpha, travel = (ds[n].values for n in ("slip_ratio", "slip_angle", "travel"))
    assert np.all(np.abs(road[travel <= 40, 1]) < 1e-6 * road[0, 2])
    end = travel == 70
    for k in (-0.05, 0.0, 0.05):
        fy = {a: road[end & (kappa == k) & (alpha == a)][0] for a in (-3.0, 3.0)}
        np.testing.assert_allclose(fy[3.0] * [1, -1, 1], fy[-3.0], atol=1e-3 * fy[3.0][2])
        assert fy[3.0][1] < 0  # against the wheel's lateral travel
    fx = [road[end & (kappa == k) & (alpha == 3.0)][0][0] for k in (-0.05, 0.0, 0.05)]
    assert fx[0] < fx[1] < fx[2]
    runs = ccx_runs(counting_ccx)
    main(["sweep", "resume", str(path), "--workers", "1"])
    assert ccx_runs(counting_ccx) == runs  # all done: nothing solved


def test_a_tree_s_trunk_rolls_with_its_motion_s_stick_slope(tmp_path, monkeypatch):
    """A motion's ``stick_slope`` (set through the API: study files have no such key) is
    in a tree's key; its trunk (and so its branches, which continue the trunk's solver
    state) must roll with it, not with the contact law's."""
    import dataclasses

    from farm.specs import SolverSettings
    from jobs import rolling_trees

    class Caught(Exception):
        pass

    seen = []

    def caught(spec, *args, **kwargs):
        seen.append(spec.contact.stick_slope)
        raise Caught

    monkeypatch.setattr(rolling_trees, "solve_rolling_trunk", caught)
    roll = "distance_mm = 60\nrolling_radius_mm = 403.8\nbranch_from_mm = 30\n"
    study = parse_study(_study(tmp_path, "friction = [0.6]\nslip_angle_deg = [0, 2]\n", roll))
    [tree] = plan(study, SOLVER)
    tree = dataclasses.replace(tree, motion=dataclasses.replace(tree.motion, stick_slope=0.9))
    task = rolling_trees.RollTreeTask(tree, study.model, SolverSettings(), study.store,
                                      "g")
    with pytest.raises(Caught):
        rolling_trees._solve(task, list(tree.trunk), list(tree.branches), set(), None)
    assert seen == [0.9]


def test_an_estimated_radius_rolls_the_trunk_without_a_search(tmp_path, monkeypatch):
    """``rolling_radius_mm = "estimate"`` (issue 46: a study over pressure and deflection
    would search a radius per trunk, about three rolls each): the trunk rolls at
    R - FREE_RADIUS_DROP x deflection of its own pressure's inflated tyre, no search roll;
    the ids of the radius's other modes are unchanged and a bad word is one error."""
    import dataclasses

    from farm.solve import rolling
    from farm.specs import SolverSettings
    from jobs import rolling_trees

    monkeypatch.setattr(rolling, "inflated_radius", lambda spec, mesh, kpa, s: 400.0 + kpa)
    monkeypatch.setattr(rolling, "cached_free_radius", pytest.fail)  # no search roll
    roll = "distance_mm = 60\nbranch_from_mm = 30\n"
    study = parse_study(_study(tmp_path, "friction = [0.6]\nslip_angle_deg = [0, 2]\n",
                               roll + 'rolling_radius_mm = "estimate"\n'))
    [tree] = plan(study, SOLVER)
    assert tree.motion.radius_estimate and tree.motion.rolling_radius is None
    task = rolling_trees.RollTreeTask(tree, study.model, SolverSettings(), study.store, "g")
    radius, seconds, runs = rolling_trees._radius(task, study.model, None, None)
    assert radius == pytest.approx(400.2 - rolling.FREE_RADIUS_DROP * 15.0)
    assert (seconds, runs) == (0.0, 0)
    # other ids than a search's (another motion), the search's ids as they were
    free = plan(parse_study(_study(tmp_path, "friction = [0.6]\nslip_angle_deg = [0, 2]\n",
                                   roll)), SOLVER)[0]
    ids = {e.id for e in experiments([tree])}
    assert not ids & {e.id for e in experiments([free])}
    assert "radius_estimate" not in free.motion.to_dict()
    assert dataclasses.replace(tree.motion, radius_estimate=False) == free.motion
    with pytest.raises(StudyError, match="estimate"):
        parse_study(_study(tmp_path, "friction = [0.6]\n", roll + 'rolling_radius_mm = "guess"'))


@pytest.mark.parametrize("branch_from", ["", "branch_from_mm = 30\n"],
                         ids=["from rest", "trees"])
def test_friction_from_the_roll_is_every_case_s_and_a_load_history_of_its_own(
        tmp_path, branch_from):
    """``[loads.roll] friction_from = "roll"`` (issue 45, a frictionless rise): every roll
    of the study (trunks and branches, or rolls from rest) carries it; its ids are not
    the friction-from-touch study's, whose ids are as before the key existed; a bad word
    is one error naming the key and the words."""
    loads = "friction = [0.6]\nslip_angle_deg = [0, 2]\n"
    roll = "distance_mm = 60\nstates = 2\nrolling_radius_mm = 403.8\n" + branch_from
    rise, touch, default = (experiments(plan(parse_study(_study(tmp_path, loads, roll + extra)),
                                             SOLVER))
                            for extra in ('friction_from = "roll"\n', 'friction_from = "touch"\n',
                                          ""))
    assert {e.motion.friction_from for e in rise} == {"roll"}
    studies = [parse_study(_study(tmp_path, loads, roll + extra))
               for extra in ('friction_from = "roll"\n', "")]
    assert studies[0].group_name == studies[1].group_name + "-rise"  # never mixed
    assert {e.id for e in touch} == {e.id for e in default}
    assert not {e.id for e in rise} & {e.id for e in touch}
    with pytest.raises(StudyError, match=r"loads\.roll\.friction_from.*touch.*roll"):
        parse_study(_study(tmp_path, loads, roll + 'friction_from = "rise"\n'))
    models = ('[models]\nmethod = "lhs"\nn = 2\n[models.parameters]\n'
              '"materials.tread.youngs_modulus" = [5.0, 10.0]\n')
    with pytest.raises(StudyError, match=r"loads\.roll\.friction_from: .*\[models\]"):
        parse_study(_study(tmp_path, loads, roll + 'friction_from = "roll"\n') + models)


LEADS = [  # (key, the slip it leads by, RoadMotion's field, the lead at each slip)
    ("lead_sigma_mm", "slip_angle_deg = [-2, 0, 1]", "slip_angle", "lead",
     lambda alpha: -600 * np.tan(np.radians(alpha))),
    ("lead_sigma_x_mm", "slip_ratio = [-0.01, 0, 0.005]", "slip_ratio", "lead_x",
     lambda kappa: 600 * kappa),
]


@pytest.mark.parametrize(("key", "slips", "slip", "field", "rule"), LEADS)
def test_a_lead_sigma_leads_each_roll_by_its_slip_in_a_group_of_its_own(
        tmp_path, key, slips, slip, field, rule):
    """``[loads.roll] lead_sigma_mm`` and ``lead_sigma_x_mm`` (issue 45, a steady roll):
    each roll from rest is led by -sigma tan(alpha) (RoadMotion.lead) or along x by sigma
    kappa (RoadMotion.lead_x); a straight roll has no lead and keeps its id, the others
    get ids of their own, and the study writes a group of its own; trees, short rolls,
    bad values and [models] are one error each."""
    loads = f"friction = [0.6]\n{slips}\n"
    roll = "distance_mm = 200\nstates = 2\nrolling_radius_mm = 403.8\n"
    led_study, plain_study = (parse_study(_study(tmp_path, loads, roll + extra))
                              for extra in (f"{key} = 600\n", ""))
    led, plain = (experiments(plan(s, SOLVER)) for s in (led_study, plain_study))
    leads = {getattr(e.motion, slip): getattr(e.motion, field) for e in led}
    assert leads == pytest.approx({k: rule(k) for k in leads}) and len(leads) == 3
    assert all(not e.motion.lead for e in led) or all(not e.motion.lead_x for e in led)
    assert led_study.group_name == plain_study.group_name + "-lead"
    straight = {e.id for e in led if not getattr(e.motion, slip)}
    assert len(straight) == 2 and straight <= {e.id for e in plain}
    assert len({e.id for e in led} & {e.id for e in plain}) == 2
    for extra, needle in ((f"{key} = 600\nbranch_from_mm = 30\n", "from rest"),
                          (f"{key} = -1\n", r"in \[0, 5000\], got -1"),
                          (f"{key} = \"long\"\n", "long")):
        with pytest.raises(StudyError, match=rf"loads\.roll\.{key}.*{needle}"):
            parse_study(_study(tmp_path, loads, roll + extra))
    for short in ("distance_mm = 60\n", "distance_mm = 200\nstates = 3\n"):  # a state at 67
        with pytest.raises(StudyError, match=rf"loads\.roll\.{key}: .*first 96 mm.*states"):
            parse_study(_study(tmp_path, loads, f"{short}{key} = 600\n"))
    models = ('[models]\nmethod = "lhs"\nn = 2\n[models.parameters]\n'
              '"materials.tread.youngs_modulus" = [5.0, 10.0]\n')
    with pytest.raises(StudyError, match=rf"loads\.roll\.{key}: .*\[models\]"):
        parse_study(_study(tmp_path, loads, roll + f"{key} = 600\n") + models)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_tree_lost_in_a_branch_rolls_on_from_its_saved_trunk(tmp_path, counting_ccx,
                                                               monkeypatch):
    """A tree's task dies in its first branch (its worker lost, its client killed), after
    the trunk: the trunk was saved in the store, so the resumed study rolls the three
    branches alone (3 ccx runs; the trunk's 40 mm not again), stores every state, and
    leaves no saved trunk once the tree is finished."""
    import jobs.rolling_trees as rolling_trees
    import storage
    from jobs.storeio import ensure_group
    from jobs.sweep import run_sweep
    from storage.paths import STATES_DIR

    study = load_study(_quick(tmp_path, "[3]"))  # one trunk, 3 branches
    [tree] = plan(study, SOLVER)
    assert isinstance(tree, RollTreePlan)
    ensure_group(study, SOLVER)
    exps = experiments([tree])
    storage.reserve(study.store, study.group_name, [e.id for e in exps],
                    parameters(exps, study.combined, rolling=True, trees=True))

    def lost(*args, **kwargs):
        raise RuntimeError("the worker died in a branch")

    branch = rolling_trees._branch
    monkeypatch.setattr(rolling_trees, "_branch", lost)
    task = rolling_trees.RollTreeTask(tree, study.model, study.settings, study.store,
                                      study.group_name)
    with pytest.raises(RuntimeError, match="died in a branch"):
        rolling_trees.run_rolling_tree(task)
    monkeypatch.setattr(rolling_trees, "_branch", branch)
    saved = tmp_path / "tree.zarr" / STATES_DIR
    assert [p for p in saved.rglob("*") if p.is_file()]
    assert storage.status_counts(study.store, study.group_name)["done"] == 4  # the trunk's
    runs = ccx_runs(counting_ccx)
    report = run_sweep(study, workers=1)
    assert report.ok and len(report.done) == 9, report.failed
    assert ccx_runs(counting_ccx) - runs == 3  # the branches; before: 4, the trunk again
    assert storage.status_counts(study.store, study.group_name) == {
        "pending": 0, "done": 13, "failed": 0}
    assert not [p for p in saved.rglob("*") if p.is_file()]


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_a_killed_client_s_rolling_tree_resumes_from_its_saved_trunk(tmp_path, counting_ccx):
    """`farm sweep submit` killed once the trunk is rolled and saved (its workers and
    solvers die with it): `farm sweep resume` rolls on from the saved trunk, one ccx run
    per branch still to do and none for the trunk, and every state ends done once."""
    import os
    import signal
    import subprocess
    import sys
    import time

    import storage
    from jobs.sweep import run_sweep
    from storage.paths import STATES_DIR

    path = _quick(tmp_path, "[3]")  # one trunk (4 states), 3 branches (3 states each)
    study = load_study(path)
    saved = tmp_path / "tree.zarr" / STATES_DIR
    mark = ("FARM_TEST_KILLED_CLIENT", str(os.getpid()))  # this client's solvers alone
    client = subprocess.Popen([sys.executable, "-m", "farm", "sweep", "submit", str(path),
                               "--workers", "1"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL,
                              env={**os.environ, mark[0]: mark[1]})
    try:
        deadline = time.monotonic() + 300
        while not [p for p in saved.rglob("*") if p.is_file()]:
            assert time.monotonic() < deadline and client.poll() is None, "no saved trunk"
            time.sleep(0.2)
    finally:
        client.send_signal(signal.SIGKILL)
        client.wait()
    deadline = time.monotonic() + 30  # the solvers die with their workers: no branch
    while ccx_processes(mark) and time.monotonic() < deadline:  # writes after this
        time.sleep(0.5)
    assert ccx_processes(mark) == []
    [tree] = plan(study, SOLVER)
    status = storage.statuses(study.store, study.group_name, [e.id for e in tree.experiments])
    todo = [b for b in tree.branches if any(status[e.id] != storage.DONE
                                            for e in b.experiments)]
    assert all(status[e.id] == storage.DONE for e in tree.trunk) and todo
    runs = ccx_runs(counting_ccx)
    report = run_sweep(study, workers=1)
    assert report.ok, report.failed
    assert ccx_runs(counting_ccx) - runs == len(todo)  # the branches alone
    assert storage.status_counts(study.store, study.group_name) == {
        "pending": 0, "done": 13, "failed": 0}


def test_a_saved_trunk_rolled_for_other_branches_is_removed_not_used(tmp_path):
    """A trunk saved in the store is rolled on from only where it is the trunk this task
    would roll (the same branches' length and states, deflection, pressure and roll);
    one rolled for another (here: branches 10 mm longer), another mesh or bytes that do
    not read back is removed, and the task rolls its trunk again."""
    import dataclasses

    import storage
    import storage.saved
    from farm.ccx.deck import Road
    from farm.mesh import mesh_for
    from farm.solve import rolling_trunk_file
    from farm.solve.rolling_tree import RollingTrunk
    from farm.solve.states import SolvedState
    from jobs.rolling_trees import RollTreeTask, _saved_trunk, _shape
    from jobs.storeio import ensure_group

    loads = "friction = [0.6]\nslip_ratio = [0.05]\n"
    roll = "distance_mm = 90\nstates = 3\nrolling_radius_mm = 403.8\nbranch_from_mm = 30\n"
    study = parse_study(_study(tmp_path, loads, roll))
    [tree] = plan(study, SOLVER)
    ensure_group(study, SOLVER)
    task = RollTreeTask(tree, study.model, study.settings, study.store, study.group_name)
    mesh, shape = mesh_for(study.model), _shape(tree)
    n = mesh.n_nodes
    reference = SolvedState(0.0, np.nan, np.zeros((n, 3)), np.zeros((2, 6)),
                            np.zeros((2, 3)), np.zeros(3))
    trunk = RollingTrunk(tree.motion.as_roll(403.8), tree.deflection, tree.pressure, (),
                         b"restart", shape.branch_mm, shape.along, mesh, mesh, 0.0, reference,
                         Road(n + 1, 1, -5.0, ("*NODE",), np.zeros((4, 3))), -20.0, 9.0, 3)

    def saved_as(t: RollingTrunk | bytes) -> RollingTrunk | None:
        data = t if isinstance(t, bytes) else rolling_trunk_file.dumps(t)
        storage.saved.save(study.store, study.group_name, tree.key, data)
        return _saved_trunk(task, mesh, shape)

    back = saved_as(trunk)
    assert back is not None and back.restart == b"restart" and back.branch_mm == 60.0
    for other in (dataclasses.replace(trunk, branch_mm=70.0),
                  dataclasses.replace(trunk, roll=dataclasses.replace(trunk.roll,
                                                                  rolling_radius=400.0)),
                  dataclasses.replace(trunk, mesh=dataclasses.replace(
                      mesh, nodes=mesh.nodes[:-1])),
                  b"not a trunk"):
        assert saved_as(other) is None
        assert storage.saved.load(study.store, study.group_name, tree.key) is None
