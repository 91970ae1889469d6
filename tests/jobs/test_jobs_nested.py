"""Nested designs solved as load-path trees (issue 29): ``[loads.tree]`` through the study
file, the expansion, the ids, a sweep on ccx, and the fallback from rest.

The physics of a tree (a branch equals the slide from rest) is tested in
tests/farm/test_tree.py; here: that the design makes the experiments it says, with the
ids those load cases have from rest, and that a tree sweep stores the same results as
the plain sweep of the same cases, in fewer ccx runs."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import storage
from jobs import identity
from jobs.errors import StudyError
from jobs.expand import cases, experiments, parameters, tree_plan
from jobs.nested import trunk_points
from jobs.storeio import ensure_group
from jobs.study import parse_study
from jobs.sweep import run_sweep
from jobs.tasks import PathOutcome
from jobs.trees import TreeTask, TrunkResult, run_branch

SOLVER = "CalculiX 2.20"
ROOT = Path(__file__).resolve().parents[2]
COARSE = """
[model]
kind = "full"
materials = "table-3.1"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 16
"""
TREE = """
[loads.tree]
trunks = 2
levels = 2
slides = 1
pressure_kpa = [200, 200]
friction = [0.3, 0.6]
deflection_mm = [10, 15]
shift_x_mm = [-3, 3]
shift_y_mm = [-3, 3]
fractions = [0.5, 1.0]
"""


def _study(store, tree: str = TREE, model: str = COARSE, head: str = ""):
    return parse_study(f'[study]\nname = "tree"\nstore = "{store}"\n{head}' + model + tree)


def test_design_makes_the_experiments_it_counts_with_ids_from_rest(tmp_path):
    study = _study(tmp_path / "s.zarr")
    design = study.tree
    assert design is not None and study.combined
    assert design.count == 2 * 2 * (1 + 1 * 2) == len(cases(study))
    trees = tree_plan(study, SOLVER)
    exps = experiments(trees)
    # the ids of the same load cases solved from rest (the trees list a trunk's own
    # experiments first, cases() each level's trunk state before its slides)
    assert sorted(e.id for e in exps) == sorted(
        identity.experiment_id(study.model, d, p, SOLVER, m) for d, p, m in cases(study))
    assert len({e.id for e in exps}) == len(exps)
    keys = [t.key for t in trees] + [b.key for t in trees for b in t.branches]
    assert len(set(keys)) == len(keys)
    for t in trees:
        assert list(t.deflections) == sorted(t.deflections)
        assert all(10 <= d <= 15 for d in t.deflections)
        assert len({e.motion.friction for e in t.experiments}) == 1  # a trunk parameter
        for b in t.branches:
            assert all(-3 <= s <= 3 for s in b.shift)
            ends = b.experiments[-1].motion
            half = b.experiments[0].motion
            assert (ends.shift_x, ends.shift_y) == b.shift
            assert half.shift_x == pytest.approx(0.5 * b.shift[0], abs=1e-9)
    assert set(parameters(exps, study.combined)) >= {"friction", "shift_x", "shift_y", "tilt"}
    # deterministic: the same file gives the same design, another seed another one
    assert cases(_study(tmp_path / "s.zarr")) == cases(study)
    other = _study(tmp_path / "s.zarr", TREE.replace("trunks = 2", "trunks = 2\nseed = 1"))
    assert cases(other) != cases(study)


@pytest.mark.parametrize("method", ["lhs", "sobol"])
def test_each_level_of_the_design_spreads_over_its_range(tmp_path, method):
    tree = TREE.replace("trunks = 2", f"trunks = 8\nmethod = '{method}'").replace(
        "levels = 2", "levels = 4")
    design = _study(tmp_path / "s.zarr", tree).tree
    points = trunk_points(design)
    frictions = sorted(t.friction for t in points)
    # a space-filling design: one trunk in each eighth of the friction range (LHS), or
    # no eighth left empty twice over (scrambled Sobol')
    bins = np.histogram(frictions, bins=8, range=(0.3, 0.6))[0]
    assert bins.max() <= (1 if method == "lhs" else 2)
    for t in points:
        assert len(t.deflections) == 4 and len(t.slides) == 4


@pytest.mark.parametrize(("change", "match"), [
    (lambda t: t + "[loads]\npressure_kpa = [200]\n", "loads.pressure_kpa"),
    (lambda t: t.replace("trunks = 2\n", ""), "trunks"),
    (lambda t: t.replace("fractions = [0.5, 1.0]", "fractions = [0.5, 0.8]"), "end at 1"),
    (lambda t: t.replace("fractions = [0.5, 1.0]", "fractions = [1.0, 0.5]"), "fractions"),
    (lambda t: t.replace("deflection_mm = [10, 15]", "deflection_mm = [0, 15]"),
     "deflection_mm"),
    (lambda t: t.replace("pressure_kpa = [200, 200]", "pressure_kpa = [0, 200]"),
     "pressure_kpa"),
    (lambda t: t.replace("shift_x_mm = [-3, 3]", "shift_x_mm = [0, 0]").replace(
        "shift_y_mm = [-3, 3]", "shift_y_mm = [0, 0]"), "shift_x_mm"),
    (lambda t: t.replace("friction = [0.3, 0.6]", "friction = [0.6, 0.3]"), "low <= high"),
    (lambda t: t.replace("slides = 1", "slides = 0"), "slides"),
    (lambda t: t.replace("slides = 1", "slides = 1\nsolve = 'fast'"), "solve"),
    (lambda t: t.replace("slides = 1", "slides = 1\nrise = 'up'"), "loads.tree.rise"),
    (lambda t: t.replace("trunks = 2", "trunks = 20000"), "tree"),
])
def test_bad_tree_tables_are_refused_with_the_key(tmp_path, change, match):
    with pytest.raises(StudyError, match=match):
        _study(tmp_path / "s.zarr", change(TREE))


def test_rise_normal_changes_the_tilted_experiments_only(tmp_path):
    """rise = "normal" (farm.specs.RoadMotion.rise) is a different load history for a
    tilted road, so those experiments get other ids; untilted ones keep theirs."""
    tilted = TREE.replace("slides = 1", "slides = 1\ntilt_deg = [1, 3]")
    flat = TREE.replace("slides = 1", "slides = 1\ntilt_deg = [0, 0]")
    for tree, same in ((tilted, False), (flat, True)):
        normal = tree.replace("slides = 1", "slides = 1\nrise = 'normal'")
        before, after = (experiments(tree_plan(_study(tmp_path / "s.zarr", t), SOLVER))
                         for t in (tree, normal))
        assert ([e.id for e in before] == [e.id for e in after]) == same
        assert all(e.motion is None or e.motion.rise == ("vertical" if same else "normal")
                   for e in after)
    # and a plain study takes the key in [loads]
    plain = parse_study(f'[study]\nstore = "{tmp_path / "p.zarr"}"\n' + COARSE + (
        "[loads]\npressure_kpa = [200]\ndeflection_mm = [10]\ntilt_deg = [2]\n"
        "friction = [0.5]\nrise = 'normal'\n"))
    [(_, _, motion)] = cases(plain)
    assert motion is not None and motion.rise == "normal"


def test_a_tree_needs_the_inflated_contact_model_and_no_adaptive_rounds(tmp_path):
    reduced = '\n[model]\nkind = "reduced"\nroad = "contact"\n'
    with pytest.raises(StudyError, match="inflated full model"):
        _study(tmp_path / "s.zarr", model=reduced)
    with pytest.raises(StudyError, match="adaptive"):
        _study(tmp_path / "s.zarr", head="[study.adaptive]\nrounds = 2\nbatch = 2\n")


def _quick_example(store, solve: str = "tree"):
    """examples/combined_tree_quick.toml into ``store``."""
    text = (ROOT / "examples" / "combined_tree_quick.toml").read_text()
    text = text.replace('store = "results/combined_tree_quick.zarr"', f'store = "{store}"')
    return parse_study(text.replace("slides = 1", f"slides = 1\nsolve = '{solve}'"))


def _forces(store, name: str = "road_reaction") -> dict[str, np.ndarray]:
    (group,) = storage.list_groups(store)
    ds = storage.done(storage.open_dataset(store, group))
    return dict(zip((str(i) for i in ds["experiment"].values), np.asarray(ds[name]),
                    strict=True))


@pytest.mark.ccx
@pytest.mark.e2e  # two sweeps on embedded clusters, ~90 s: run by .ci/run (--e2e)
def test_tree_sweep_stores_the_results_of_the_plain_sweep_in_fewer_runs(tmp_path):
    tree = _quick_example(tmp_path / "tree.zarr")
    assert tree.tree == _study(tmp_path / "s.zarr").tree  # the design of this file's tests
    report = run_sweep(tree, workers=2)
    assert report.ok, report.failed
    assert report.total == 12
    # 2 trunks + 4 slides (+ the cached inflation), against 2 trunk paths + 8 slides
    assert report.ccx_runs <= 8
    again = run_sweep(tree, workers=2)
    assert again.nothing_to_do and again.skipped == 12

    rest = _quick_example(tmp_path / "rest.zarr", solve="rest")
    plain = run_sweep(rest, workers=2)
    assert plain.ok, plain.failed
    assert plain.ccx_runs >= 10
    # the road's reaction to the tolerance of tests/farm/test_tree.py; the sum of the
    # tread forces (contact stress x area, which the coarse mesh's 2-4 contact nodes
    # make sensitive to the increments) to 0.2 % (measured 0.13 %)
    for name, rtol in (("road_reaction", 5e-4), ("total_force", 2e-3)):
        a, b = _forces(tmp_path / "tree.zarr", name), _forces(tmp_path / "rest.zarr", name)
        assert set(a) == set(b) and len(a) == 12
        for i in a:
            assert np.abs(a[i] - b[i]).max() <= rtol * np.linalg.norm(b[i]), (name, a[i], b[i])


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_slide_whose_trunk_failed_is_solved_from_rest(tmp_path):
    study = _study(tmp_path / "s.zarr")
    trees = tree_plan(study, SOLVER)
    tree = trees[0]
    branch = tree.branches[0]
    ensure_group(study, SOLVER)
    exps = experiments(trees)
    storage.reserve(study.store, study.group_name, [e.id for e in exps],
                    parameters(exps, True))
    task = TreeTask(tree, study.model, study.settings, study.store, study.group_name,
                    branch=branch)
    outcome = run_branch(task, TrunkResult(PathOutcome(tree.key), None, "no trunk here"))
    assert outcome.done == tuple(e.id for e in branch.experiments) and not outcome.failed
    assert outcome.ccx_runs <= 2  # one run from rest for both fractions (+ inflation)
    status = storage.statuses(study.store, study.group_name, [e.id for e in exps])
    assert [status[e.id] for e in branch.experiments] == [storage.DONE] * 2
    assert sum(s == storage.DONE for s in status.values()) == 2
    # run again: nothing left to do
    again = run_branch(task, TrunkResult(PathOutcome(tree.key), None, "no trunk here"))
    assert again.skipped == outcome.done and not again.done
    # a slide whose level the trunk's own path from rest did not reach either is not
    # tried from rest again: it fails at once, saying why
    other = replace(task, branch=trees[1].branches[0], tree=trees[1])
    stuck = TrunkResult(PathOutcome(trees[1].key), None, "too many cutbacks",
                        (False,) * len(trees[1].trunk))
    failed = run_branch(other, stuck)
    assert not failed.done and failed.ccx_runs == 0 and len(failed.failed) == 2
    assert all("not tried from rest" in why and "too many cutbacks" in why
               for _, why in failed.failed)


def _reserved(study):
    trees = tree_plan(study, SOLVER)
    ensure_group(study, SOLVER)
    exps = experiments(trees)
    storage.reserve(study.store, study.group_name, [e.id for e in exps],
                    parameters(exps, True))
    return trees


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_trunk_is_solved_once_and_read_back_by_the_next_task(tmp_path):
    """Issue 50: a trunk's states lived in one worker's memory, so a lost worker's
    retry, a resumed study and a second client solved it again. The next task reads it
    from the store: no ccx run, and slides continue from it exactly as from the first."""
    from farm.mesh import mesh_for
    from farm.solve.tree import solve_branch
    from jobs.trees import run_trunk
    from storage.paths import STATES_DIR

    study = _study(tmp_path / "s.zarr")
    tree = _reserved(study)[0]
    task = TreeTask(tree, study.model, study.settings, study.store, study.group_name)
    first = run_trunk(task)
    assert first.trunk is not None and first.outcome.ccx_runs >= 1
    assert len(first.outcome.done) == len(tree.trunk)
    assert (tmp_path / "s.zarr" / STATES_DIR / study.group_name / tree.key).is_file()
    again = run_trunk(task)  # as after a lost worker, a client kill, or a second client
    assert again.outcome.ccx_runs == 0 and again.outcome.solve_seconds == 0
    assert again.outcome.skipped == first.outcome.done and not again.outcome.done
    assert again.trunk is not None and again.trunk.restarts == first.trunk.restarts
    assert again.levels_done == first.levels_done == (True, True)
    mesh, shift = mesh_for(study.model), tree.branches[0].shift
    a = solve_branch(study.model, mesh, first.trunk, 0, shift, study.settings)
    b = solve_branch(study.model, mesh, again.trunk, 0, shift, study.settings)
    for x, y in zip(a.states, b.states, strict=True):
        np.testing.assert_array_equal(x.road_reaction, y.road_reaction)
        np.testing.assert_array_equal(x.displacement, y.displacement)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_resumed_tree_study_solves_no_trunk_again(tmp_path):
    """The trunks ran (a client killed after them): resume solves the four slides only,
    and no saved trunk is left once every tree is finished."""
    from jobs.trees import run_trunk
    from storage.paths import STATES_DIR

    study = _study(tmp_path / "s.zarr")
    for tree in _reserved(study):
        assert run_trunk(TreeTask(tree, study.model, study.settings, study.store,
                                  study.group_name)).outcome.ccx_runs >= 1
    report = run_sweep(study, workers=2)
    assert report.ok and report.total == 12, report.failed
    assert report.ccx_runs == 4  # the slides; before: 6, both trunks solved again
    assert not [p for p in (tmp_path / "s.zarr" / STATES_DIR).rglob("*") if p.is_file()]


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_slide_that_stops_keeps_the_fractions_it_reached(tmp_path):
    """Issue 45: out of increments between its two fractions (11 of the 13 the slide
    takes with ccx 2.20, and too few for the path from rest), a slide stores the fraction
    it reached, equal to the whole slide's, and records the other failed, saying where it
    stopped; resumed with enough increments, it solves the missing one alone."""
    from jobs.trees import run_trunk

    study = _study(tmp_path / "s.zarr")
    tree = _reserved(study)[0]
    task = TreeTask(tree, study.model, study.settings, study.store, study.group_name)
    trunk = run_trunk(task)
    short = replace(task, settings=replace(study.settings, max_increments=11),
                    branch=tree.branches[0], retry_smaller_increments=False)
    first, second = (e.id for e in tree.branches[0].experiments)
    out = run_branch(short, trunk)
    assert out.done == (first,) and [e for e, _ in out.failed] == [second]
    reason = out.failed[0][1]
    assert reason.startswith(f"partial slide: stopped after the state at a shift of "
                             f"(0.208, 0.4947) mm (stored, {first})"), reason
    assert "max_increments" in reason and "from rest" in reason
    kept = _forces(study.store)[first]
    again = run_branch(replace(short, settings=study.settings), trunk)
    assert again.skipped == (first,) and again.done == (second,)
    whole = _branch_states(study, trunk.trunk, tree.branches[0].shift)
    np.testing.assert_allclose(kept, whole[0].road_reaction, rtol=1e-9)


def _branch_states(study, trunk, shift):
    from farm.mesh import mesh_for
    from farm.solve.tree import solve_branch

    return solve_branch(study.model, mesh_for(study.model), trunk, 0, shift,
                        study.settings).states
