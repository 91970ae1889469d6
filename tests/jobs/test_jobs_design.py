"""Model-space designs (issue 15): [models] tables, their matrices, models and groups."""

from __future__ import annotations

import contextlib
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import QUICK_MODEL, ccx_runs
from SALib.sample import morris as salib_morris
from SALib.sample import sobol as salib_sobol

from farm.mesh.version import mesh_key
from jobs.design import model_design
from jobs.errors import StudyError
from jobs.study import parse_study

HEAD = """
[study]
name = "space"
store = "space.zarr"
""" + QUICK_MODEL + """
[loads]
deflection_mm = [10, 20]
"""


def study(models: str, head: str = HEAD):
    return parse_study(head + models, "space.toml")


SOBOL = """
[models]
method = "sobol"
n = 8
seed = 3
[models.parameters]
"materials.tread.youngs_modulus" = [2.0, 12.0]
"geometry.sidewall_thickness" = [8.0, 12.0]
"""


def test_sobol_rows_are_salibs_saltelli_design_in_its_order():
    d = model_design(study(SOBOL))
    assert d.method == "sobol" and d.names == ("materials.tread.youngs_modulus",
                                               "geometry.sidewall_thickness")
    assert d.matrix.shape == (8 * (2 + 2), 2)  # N (D + 2), calc_second_order=False
    salib = salib_sobol.sample(d.problem(), 8, calc_second_order=False, seed=3)
    np.testing.assert_allclose(d.matrix, salib, atol=1e-9)
    assert d.problem() == {"num_vars": 2, "names": list(d.names),
                           "bounds": [[2.0, 12.0], [8.0, 12.0]]}


def test_each_row_is_a_model_with_the_rows_values_and_its_own_group():
    s = study(SOBOL)
    d = model_design(s)
    for row, model, group in zip(d.matrix, d.models, d.groups, strict=True):
        assert model.materials.tread.youngs_modulus == row[0]
        assert model.geometry.sidewall_thickness == row[1]
        assert model.materials.sidewall == s.model.materials.sidewall  # the rest is [model]'s
        assert group == dataclasses.replace(s, model=model).group_name
    # Saltelli's A/B/AB rows repeat values; equal models (and only they) share a group
    pairs = set(zip(d.models, d.groups, strict=True))
    assert len({m for m, _ in pairs}) == len({g for _, g in pairs}) == len(pairs)


def test_the_same_file_gives_the_same_design_and_another_seed_another():
    a, b = model_design(study(SOBOL)), model_design(study(SOBOL))
    np.testing.assert_array_equal(a.matrix, b.matrix)
    assert a.groups == b.groups
    other = model_design(study(SOBOL.replace("seed = 3", "seed = 4")))
    assert not np.array_equal(a.matrix, other.matrix)


def test_material_only_variants_share_one_mesh_geometry_variants_do_not():
    materials = model_design(study(SOBOL.replace(
        '"geometry.sidewall_thickness" = [8.0, 12.0]',
        '"materials.sidewall.youngs_modulus" = [5.0, 20.0]')))
    assert len(set(materials.groups)) > 1
    assert len({mesh_key(m) for m in materials.models}) == 1
    geometry = model_design(study(SOBOL))
    assert len({mesh_key(m) for m in geometry.models}) == len(
        {m.geometry for m in geometry.models}) > 1


def test_lhs_and_morris_row_counts_and_morris_steps_move_one_parameter():
    lhs = model_design(study(SOBOL.replace('"sobol"', '"lhs"').replace("n = 8", "n = 5")))
    assert lhs.matrix.shape == (5, 2)
    # a Latin hypercube: one point in each of n strata per parameter
    for j, (low, high) in enumerate(lhs.bounds):
        strata = np.floor((lhs.matrix[:, j] - low) / (high - low) * 5)
        assert sorted(strata) == [0, 1, 2, 3, 4]
    text = SOBOL.replace('"sobol"', '"morris"').replace("n = 8", "n = 3") + \
        '"mesh.circumferential" = { levels = [8, 12, 16, 20] }\n'
    m = model_design(study(text))
    assert m.matrix.shape == (3 * (3 + 1), 3)
    salib = salib_morris.sample({"num_vars": 3, "names": list(m.names),
                                 "bounds": [[2, 12], [8, 12], [0, 1]]}, 3, seed=3)
    np.testing.assert_allclose(m.matrix[:, :2], salib[:, :2], atol=1e-9)
    for t in range(3):  # within a trajectory every step changes exactly one parameter
        steps = np.diff(m.matrix[t * 4:(t + 1) * 4], axis=0)
        assert ((steps != 0).sum(axis=1) == 1).all()
    assert {mod.mesh.circumferential for mod in m.models} <= {8, 12, 16, 20}
    assert [mod.mesh.circumferential for mod in m.models] == list(m.matrix[:, 2])


def test_grid_takes_every_combination_of_lists_ranges_and_text_levels():
    d = model_design(study("""
[models]
method = "grid"
[models.parameters]
"contact.clearance" = { start = 0.25, stop = 0.75, step = 0.25 }
"mesh.circumferential" = [8, 12]
"cut_faces" = ["free", "fixed"]
"""))
    assert d.matrix.shape == (3 * 2 * 2, 3)
    assert {(m.contact.clearance, m.mesh.circumferential, m.cut_faces) for m in d.models} == {
        (c, n, f) for c in (0.25, 0.5, 0.75) for n in (8, 12) for f in ("free", "fixed")}
    assert set(d.matrix[:, 2]) == {0.0, 1.0}  # text levels: their index
    assert len(set(d.groups)) == 12


def test_elements_through_the_wall_can_be_swept_from_a_one_element_model():
    # mesh.through = 1 is left out of ids (old stores keep theirs), not out of what a
    # design may set: the base model here has no `through` key at all
    d = model_design(study("""
[models]
method = "grid"
[models.parameters]
"mesh.through" = [1, 2]
"""))
    assert [m.mesh.through for m in d.models] == [1, 2]
    assert len(set(d.groups)) == 2 and len({mesh_key(m) for m in d.models}) == 2
    one = d.models[0]
    assert "through" not in one.to_dict()["mesh"]  # the one-element model's id as before


def test_integer_levels_are_sampled_by_index_evenly():
    d = model_design(study(SOBOL.replace('"sobol"', '"lhs"').replace("n = 8", "n = 30")
                           + '"mesh.sidewall" = { levels = [1, 2, 3] }\n'))
    counts = np.unique(d.matrix[:, 2], return_counts=True)
    assert counts[0].tolist() == [1, 2, 3] and counts[1].tolist() == [10, 10, 10]


@pytest.mark.parametrize("parameters, where, expected", [
    ('"materials.tread.youngs" = [1.0, 2.0]', '"materials.tread.youngs"', "names no model field"),
    ('"kind" = { levels = ["full"] }', '"kind"', "one model kind"),
    ('"mesh.circumferential" = [8, 16]', '"mesh.circumferential"', "levels"),
    ('"materials.tread" = [1.0, 2.0]', '"materials.tread"', "youngs_modulus"),
    ('"reinforcement.belt.modulus" = [1.0, 2.0]', "reinforcement", "cord-reinforced"),
    ('"materials.tread.youngs_modulus" = [3.0, 2.0]', "youngs_modulus", "low < high"),
])
def test_bad_parameters_are_one_error_naming_them(parameters, where, expected):
    with pytest.raises(StudyError) as e:
        study(f'[models]\nmethod = "lhs"\nn = 4\n[models.parameters]\n{parameters}\n')
    assert where in str(e.value) and expected in str(e.value)


def test_a_row_the_model_rejects_names_parameter_value_and_range():
    with pytest.raises(StudyError) as e:  # walls thicker than a quarter of the section
        study('[models]\nmethod = "lhs"\nn = 8\n[models.parameters]\n'
              '"geometry.tread_thickness" = [10.0, 60.0]\n')
    text = str(e.value)
    assert '"geometry.tread_thickness" = ' in text and "range [10, 60]" in text
    assert "row " in text and "quarter" in text


def test_a_model_that_cannot_take_the_loads_is_refused_before_anything_runs():
    with pytest.raises(StudyError, match=r"cannot take the loads.*reaches through"):
        study('[models]\nmethod = "grid"\n[models.parameters]\n'
              '"geometry.section_height" = [196.0, 160.0]\n',  # 150 mm > 160 - 20 (tread)
              HEAD.replace("[10, 20]", "[10, 150]"))


def test_models_times_load_cases_count_against_the_experiment_limit(monkeypatch):
    monkeypatch.setenv("FARM_MAX_EXPERIMENTS", "60")
    study(SOBOL.replace("n = 8", "n = 4"))  # 16 models x 2 deflections = 32
    with pytest.raises(StudyError,
                       match=r"32 models \(sobol design\) x 1 pressure x 2 deflections is 64"):
        study(SOBOL)


def test_sobol_needs_a_power_of_two_and_grid_no_n_and_no_study_group():
    with pytest.raises(StudyError, match="power of 2"):
        study(SOBOL.replace("n = 8", "n = 6"))
    with pytest.raises(StudyError, match=r"models\.n"):
        study(SOBOL.replace('"sobol"', '"grid"'))
    with pytest.raises(StudyError, match=r"study\.group"):
        study(SOBOL, HEAD.replace('store = "space.zarr"', 'store = "space.zarr"\ngroup = "g"'))


def test_a_study_without_models_has_no_design():
    assert model_design(study("")) is None


def test_material_only_variants_are_meshed_once(tmp_path, monkeypatch):
    """The sweep's groups of a material-only design share one cached mesh: the client
    creating every group (``ensure_group``) meshes once, the rest are cache hits."""
    from farm.mesh import cache
    from jobs.sweep import parts

    built = []
    real = cache.build_mesh
    monkeypatch.setattr(cache, "build_mesh", lambda spec: built.append(spec) or real(spec))
    monkeypatch.setattr(cache, "_MEMO", {})
    s = study(SOBOL.replace('"geometry.sidewall_thickness" = [8.0, 12.0]',
                            '"materials.sidewall.youngs_modulus" = [5.0, 20.0]'))
    groups = parts(s)
    assert len(groups) > 4
    meshes = {cache.mesh_for(p.model, tmp_path).mesh_key for p in groups}
    assert len(meshes) == 1 and len(built) == 1
    assert len(list((tmp_path / "meshes").glob("*.npz"))) == 1


# ------------------------------------------------------------------ the quick study on ccx

EXAMPLE = Path(__file__).parents[2] / "examples" / "model_space_quick.toml"


def _cli(args, capsys) -> tuple[int, dict]:
    from tyre_farm_cli import main

    with pytest.raises(SystemExit) as info:
        main(args)
        raise SystemExit(0)  # a command that succeeds may simply return
    return info.value.code, json.loads(capsys.readouterr().out)


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_the_quick_model_space_study_runs_resumes_and_keeps_its_physics(
        tmp_path, monkeypatch, capsys, counting_ccx):
    import storage
    from jobs.study import load_study

    monkeypatch.setenv("FARM_CACHE_DIR", str(tmp_path / "cache"))  # the workers' meshes too
    path = tmp_path / "quick.toml"
    path.write_text(EXAMPLE.read_text().replace("results/model_space_quick.zarr",
                                                str(tmp_path / "q.zarr")))
    s = load_study(path)
    d = model_design(s)
    distinct = d.distinct()
    assert d.matrix.shape == (8, 2) and len(distinct) == 8

    code, report = _cli(["sweep", "submit", str(path), "--workers", "2", "--json"], capsys)
    assert code == 0 and report["ok"] and report["experiments"] == 16
    assert report["done_now"] == 16 and report["group"] is None
    assert sorted(report["groups"]) == sorted(distinct)
    assert ccx_runs(counting_ccx) == 8  # one load path (two deflections) per model
    # meshes: one per geometry, shared by the models that differ in materials only
    geometries = {mesh_key(m) for m in distinct.values()}
    assert len(geometries) < len(distinct)
    assert len(list((tmp_path / "cache" / "meshes").glob("*.npz"))) == len(geometries)

    code, again = _cli(["sweep", "resume", str(path), "--workers", "2", "--json"], capsys)
    assert code == 0 and again["already_done"] == 16 and again["done_now"] == 0
    assert ccx_runs(counting_ccx) == 8  # resume solved nothing

    code, status = _cli(["sweep", "status", str(path), "--json"], capsys)
    assert {g["group"]: g["counts"]["done"] for g in status["groups"]} == dict.fromkeys(
        distinct, 2)
    code, listing = _cli(["sweep", "list", str(path), "--json"], capsys)
    rows = listing["experiments"]
    assert len(rows) == 16 and {r["status"] for r in rows} == {"done"}
    for r in rows:  # each row carries its model's design values
        k = d.groups.index(r["group"])
        assert r["materials.tread.youngs_modulus"] == d.matrix[k, 0]

    # physics: every model pushes back harder the further it is pressed; of two models
    # with one geometry, the stiffer tread carries more load at the same deflection
    fz = {}
    for g in distinct:
        ds = storage.done(storage.open_dataset(s.store, g))
        order = np.argsort(ds["deflection"].values)
        fz[g] = ds["total_force"].sel(component="z").values[order]
        assert ds["deflection"].values[order].tolist() == [10.0, 20.0]
        assert (fz[g] > 0).all() and fz[g][1] > fz[g][0]
    pairs = [(a, b) for a in distinct for b in distinct
             if a != b and distinct[a].geometry == distinct[b].geometry
             and distinct[a].materials.tread.youngs_modulus
             < distinct[b].materials.tread.youngs_modulus]
    assert pairs
    for a, b in pairs:
        assert (fz[b] > fz[a]).all()


def test_the_model_space_example_is_a_valid_sobol_design():
    from jobs.study import load_study

    s = load_study(EXAMPLE.with_name("model_space.toml"))
    d = model_design(s)
    assert d.method == "sobol" and d.matrix.shape == (8 * (6 + 2), 6)
    assert {m.mesh.circumferential for m in d.models} == {16, 24}
    # its mesh swap moves the level in half the base rows (seed 0 of floor(2 u): none)
    assert _swaps(d, d.names.index("mesh.circumferential")) == 4
    assert all(m.reinforcement is not None for m in d.models)
    # cords and materials leave the mesh alone: far fewer meshes than models
    assert len({mesh_key(m) for m in d.models}) < len(d.distinct()) / 2


def test_morris_needs_an_even_grid():
    with pytest.raises(StudyError, match="num_levels: must be even"):
        study(SOBOL.replace('"sobol"', '"morris"').replace("n = 8", "n = 2\nnum_levels = 3"))


# ------------------------------------------------- level parameters under Saltelli's swap
# Issue 15 review: with level = floor(2 u), the sixth of six parameters reads the first
# binary digit of Sobol' dimensions 6 and 12, which agree (or disagree) in every row for
# every scrambling seed: its A -> AB_j swap never (or always) changed it.

SIX = """
[models]
method = "sobol"
n = 8
seed = SEED
[models.parameters]
"materials.tread.youngs_modulus" = [2.0, 6.0]
"materials.sidewall.youngs_modulus" = [5.0, 15.0]
"geometry.sidewall_thickness" = [8.0, 12.0]
"materials.tread.poisson_ratio" = [0.45, 0.49]
"materials.sidewall.poisson_ratio" = [0.45, 0.49]
"mesh.circumferential" = { levels = [8, 12] }
"""


def _swaps(d, j):
    """Base rows whose A -> AB_j swap changes column j."""
    D = len(d.names)
    blocks = d.matrix.reshape(-1, D + 2, D)
    return int(np.sum(blocks[:, 0, j] != blocks[:, 1 + j, j]))


def test_first_digit_mapping_never_swaps_the_sixth_parameter_so_it_is_refused():
    from jobs.design import check_swaps, parse_models

    base = study("").model
    spec = parse_models(__import__("tomllib").loads(SIX.replace("SEED", "0"))["models"], base)
    unit = salib_sobol.sample({"num_vars": 6, "names": list("abcdef"), "bounds": [[0, 1]] * 6},
                              8, calc_second_order=False, scramble=True, seed=0)
    first_digit = [(*r[:5], (8, 12)[int(r[5] >= 0.5)]) for r in unit]
    blocks = np.array([r[5] for r in first_digit]).reshape(8, 8)
    assert np.array_equal(blocks[:, 0], blocks[:, 6])  # the defect: AB_6 never moves it
    with pytest.raises(StudyError, match=r'"mesh.circumferential".*0 of 8 base rows.*seed'):
        check_swaps(spec, first_digit)


@pytest.mark.parametrize("seed", range(6))
def test_relabelled_strata_swap_levels_in_plausible_shares_and_keep_balance(seed):
    try:
        d = model_design(study(SIX.replace("SEED", str(seed))))
    except StudyError as e:  # an unlucky seed is refused, never silently kept
        assert '"mesh.circumferential"' in str(e) and "another seed" in str(e)
        return
    c = _swaps(d, 5)
    assert 2 <= c <= 6  # binomial(8, 1/2) at 1 %: 0 and 8 are refused
    A = d.matrix.reshape(8, 8, 6)[:, 0, 5]
    B = d.matrix.reshape(8, 8, 6)[:, -1, 5]
    for col in (A, B):  # one Sobol' point per stratum: each level exactly N / k times
        assert np.unique(col, return_counts=True)[1].tolist() == [4, 4]


def test_most_seeds_are_kept_and_their_swaps_average_half_the_rows():
    counts = []
    for seed in range(20):
        with contextlib.suppress(StudyError):
            counts.append(_swaps(model_design(study(SIX.replace("SEED", str(seed)))), 5))
    assert len(counts) >= 17  # P(refused) is a few per cent per seed
    assert 3.0 <= np.mean(counts) <= 5.0  # independent A, B: 8 * (1 - 1/2) = 4


def test_morris_level_steps_always_move_the_level():
    d = model_design(study(SIX.replace("sobol", "morris").replace("n = 8", "n = 4")
                           .replace("SEED", "0")))
    traj = d.matrix.reshape(4, 7, 6)
    assert all(len(set(t[:, 5])) == 2 for t in traj)


def test_a_morris_trajectory_that_keeps_a_level_is_refused():
    # SALib's grids always move a level (the step is over half the level spacing), so the
    # check is a safety net: fed rows whose second trajectory keeps the mesh level.
    from jobs.design import check_swaps

    spec = study(SIX.replace("sobol", "morris").replace("n = 8", "n = 2")
                 .replace("SEED", "0")).models
    moving = [(2.0, 5.0, 8.0, 0.45, 0.45, 8)] * 6 + [(2.0, 5.0, 8.0, 0.45, 0.45, 12)]
    kept = [(2.0, 5.0, 8.0, 0.45, 0.45, 8)] * 7
    check_swaps(spec, moving + moving)
    with pytest.raises(StudyError, match=r'"mesh.circumferential".*1 of 2 trajectories'):
        check_swaps(spec, moving + kept)


# --- a population: each model with load cases of its own (issue 47) -----------------------

POPULATION = """
[models]
method = "lhs"
n = 4
seed = 5
loads = "own"
[models.parameters]
"materials.tread.youngs_modulus" = [8.0, 12.0]
"""

SAMPLED = HEAD.replace("""[loads]
deflection_mm = [10, 20]
""", """[loads]
[loads.sample]
method = "lhs"
n = 3
seed = 1
deflection_mm = [5, 20]
""")


def test_own_loads_give_each_model_cases_of_its_own_and_shared_ones_do_not():
    from jobs.expand import load_cases
    from jobs.sweep import parts

    own = parts(study(POPULATION, SAMPLED))
    shared = parts(study(POPULATION.replace('loads = "own"', ""), SAMPLED))
    assert [p.group_name for p in own] == [p.group_name for p in shared]
    own_cases = [tuple(load_cases(p)) for p in own]
    assert len(set(own_cases)) == 4  # no two tyres share their draws
    assert len({tuple(load_cases(p)) for p in shared}) == 1
    # the same ranges: every own draw lies in the sampled box, and the plan is repeatable
    assert all(5 <= d <= 20 for cases in own_cases for d, _ in cases)
    again = [tuple(load_cases(p)) for p in parts(study(POPULATION, SAMPLED))]
    assert again == own_cases


def test_own_loads_reseed_a_trees_trunks():
    from jobs.nested import trunk_points
    from jobs.sweep import parts

    tree = HEAD.replace('kind = "reduced"', 'kind = "full"').replace("""[loads]
deflection_mm = [10, 20]
""", """[loads.tree]
trunks = 2
levels = 2
slides = 1
pressure_kpa = [100, 200]
friction = [0.3, 0.9]
deflection_mm = [5, 20]
shift_x_mm = [-4, 4]
shift_y_mm = [0, 0]
""")
    trunks = [tuple(t.pressure for t in trunk_points(p.tree))
              for p in parts(study(POPULATION, tree))]
    assert len(set(trunks)) == 4
    # the tyres' slices are one design: a Latin hypercube of 4 x 2 trunks has one
    # pressure in each eighth of [100, 200] kPa
    strata = sorted(int((p * 1000 - 100) // 12.5) for ts in trunks for p in ts)
    assert strata == list(range(8))


@pytest.mark.parametrize(("models", "head", "where"), [
    (POPULATION, HEAD, "models.loads"),  # listed loads: nothing to re-seed
    (POPULATION.replace('"lhs"', '"sobol"').replace("n = 4", "n = 8"), SAMPLED,
     "models.loads"),  # indices compare models under the same loads
    (POPULATION.replace('"own"', '"mine"'), SAMPLED, "models.loads"),
])
def test_own_loads_are_refused_where_they_cannot_mean_anything(models, head, where):
    with pytest.raises(StudyError, match=where.replace(".", r"\.")):
        study(models, head)


@pytest.mark.parametrize(("name", "tyres", "experiments"), [
    ("nominal", 1, 45), ("train", 8, 120), ("stiffer", 1, 15), ("softer", 1, 15),
    ("worn", 1, 15)])
def test_the_population_examples_plan_what_their_headers_say(name, tyres, experiments):
    from jobs.expand import experiments as listed
    from jobs.expand import tree_plan
    from jobs.study import load_study
    from jobs.sweep import parts

    root = Path(__file__).resolve().parents[2] / "examples" / "population"
    groups = parts(load_study(root / f"{name}.toml"))
    assert len(groups) == tyres
    assert sum(len(listed(tree_plan(p, "ccx"))) for p in groups) == experiments
