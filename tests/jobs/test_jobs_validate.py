"""jobs.validate: one rule per kind of value, shared by study files and the CLI."""

import ast
import dataclasses
import itertools
import math
import re
import textwrap
from dataclasses import replace
from pathlib import Path

import pytest
from conftest import study_text
from hypothesis import given, settings
from hypothesis import strategies as st

from farm import overrides
from farm.errors import SpecError
from farm.presets import default_model
from farm.reinforcement import Cords, Reinforcement
from farm.specs import ModelSpec, SolverSettings
from jobs.errors import StudyError
from jobs.inverse.study import parse_inverse_study
from jobs.study import parse_study
from jobs.validate import limits, lists, locations, scalars, spec_tables
from tyre_farm_cli import main
from tyre_farm_cli.params import build_model, parse_range

ROOT = Path(__file__).parents[2]
INVERSE = '[study]\nname = "t"\nstore = "out/inverse.zarr"\n[model]\nkind = "reduced"\n'


# ------------------------------------------------------------------------ the range rule


def sweep(deflections: str):
    return parse_study(study_text(Path("/tmp/s.zarr"), deflections=deflections), "s.toml")


@settings(max_examples=60, deadline=None)
@given(start=st.integers(1, 60), count=st.integers(0, 40),
       step=st.sampled_from([1, 2, 5, 0.1, 0.25, 0.3, 2.5]), extra=st.floats(0, 0.99))
def test_both_range_syntaxes_give_the_same_values(start, count, step, extra):
    stop = start + (count + extra) * step  # a stop between grid points is not reached
    text = f"{start}:{stop!r}:{step}"
    table = {"start": start, "stop": stop, "step": step}
    cli = parse_range(text)
    assert cli == parse_range(text, "d") == lists.values(table, "d")
    assert len(cli) == count + 1 and cli[0] == start
    assert cli[-1] <= stop + 1e-9 and stop - cli[-1] < step
    assert all(b - a == pytest.approx(step) for a, b in itertools.pairwise(cli))
    assert all(x == round(x, limits.DECIMALS) for x in cli)
    if stop < 70:  # the tyre takes it: the same values out of a whole study file
        assert sweep(f"{{ start = {start}, stop = {stop!r}, step = {step} }}").deflections == cli


@pytest.mark.parametrize(("text", "toml"), [
    ("10:40:5", "{ start = 10, stop = 40, step = 5 }"),
    ("0.1:0.3:0.1", "{ start = 0.1, stop = 0.3, step = 0.1 }"),  # 0.30000000000000004
    ("30,10,20,20", "[30, 10, 20, 20]"),  # a list is sorted, repeats dropped
    ("25", "25"),
])
def test_the_cli_string_and_the_study_table_agree(text, toml):
    assert parse_range(text) == sweep(toml).deflections
    assert parse_range("0.1:0.3:0.1") == (0.1, 0.2, 0.3)


@pytest.mark.parametrize(("value", "match"), [
    ({"start": 10, "stop": 40, "step": 0}, r"d\.step: must be > 0, got 0"),
    ({"start": 10, "stop": 40, "step": -5}, r"d\.step: must be > 0, got -5"),
    ({"start": 40, "stop": 10, "step": 5}, r"d: stop \(10\) must not be below start \(40\)"),
    ({"start": 0, "stop": 1e12, "step": 1}, r"d: 1000000000001 values is too many"),
    ({"start": 10, "stop": 40}, r"d\.step: is required"),
    ({"start": 10, "stop": 40, "step": 5, "end": 3}, r"d\.end: unknown key; allowed: start"),
    ({"start": "10", "stop": 40, "step": 5}, r"d\.start: must be a number, got '10'"),
    ([10, math.nan], r"d\[1\]: must be a number, got nan"),
    ([], "d: must not be empty"),
])
def test_bad_ranges_name_the_key_the_value_and_the_rule(value, match):
    with pytest.raises(StudyError, match=match):
        lists.values(value, "d")


@pytest.mark.parametrize(("text", "match"), [
    ("0:1e12:1", "values is too many"), ("10:40", "needs three numbers"),
    ("ten", "cannot read deflection 'ten'"), ("40:10:5", "must not be below start"),
])
def test_bad_cli_ranges_are_spec_errors_under_the_same_rule(text, match):
    with pytest.raises(SpecError, match=match):
        parse_range(text)


def test_a_huge_cli_range_is_one_line_not_a_memory_error(capsys):
    with pytest.raises(SystemExit) as info:
        main(["run", "--model", "reduced", "--deflection", "1:1e12:1"])
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1
    assert err.startswith("farm: error: deflection: ") and "at most 100000" in err


def test_bounds_apply_to_every_value_of_every_form():
    assert lists.values([0, 5], "d", low=0) == (0.0, 5.0)
    for value, where in (([5, 0], r"d\[1\]"), ({"start": 0, "stop": 5, "step": 5}, r"d\.start"),
                         (0, "d")):
        with pytest.raises(StudyError, match=f"{where}: must be > 0, got 0"):
            lists.values(value, "d", low=0, strict=True)


# ------------------------------------------------------------------------------ scalars


@pytest.mark.parametrize(("call", "match"), [
    (lambda: scalars.number(True, "k"), "k: must be a number, got True"),
    (lambda: scalars.number(math.inf, "k"), "k: must be a number, got inf"),
    (lambda: scalars.number(2, "k", low=0, high=1, strict=True), r"k: must be in \(0, 1\], got 2"),
    (lambda: scalars.integer(1.0, "k"), "k: must be an integer, got 1.0"),
    (lambda: scalars.integer(0, "k", low=1), "k: must be an integer >= 1, got 0"),
    (lambda: scalars.integer(7, "k", low=1, high=5), r"k: must be an integer in \[1, 5\], got 7"),
    (lambda: scalars.boolean(1, "k"), "k: must be true or false, got 1"),
    (lambda: scalars.choice("c", "k", ("a", "b")), "k: must be one of a, b, got 'c'"),
    (lambda: scalars.choices(["a", "c"], "k", ("a", "b")), "k: must list a, b; got 'c'"),
    (lambda: scalars.choices([], "k", ("a",)), "k: must be a non-empty list"),
    (lambda: scalars.string("  ", "k", "a path", blank=False), "k: must be a path, got '  '"),
    (lambda: scalars.identifier("../x", "k"), "k: must be letters, digits"),
    (lambda: scalars.table([], "k", {"a"}), "k: must be a table, got list"),
    (lambda: scalars.table({"b": 1}, "k", {"a", "c"}), "k.b: unknown key; allowed: a, c"),
    (lambda: scalars.table({}, "k", {"a"}, {"a"}), "k.a: is required"),
])
def test_scalar_errors_name_the_key_the_value_and_what_is_allowed(call, match):
    with pytest.raises(StudyError, match=match):
        call()


def test_scalars_pass_good_values_through():
    assert scalars.number(3, "k", low=0, strict=True) == 3.0
    assert isinstance(scalars.number(3, "k"), float)
    assert scalars.integer(5, "k", low=1, high=5) == 5
    assert scalars.choices(["b", "a", "b"], "k", ("a", "b")) == ("b", "a")


# ------------------------------------------------------------------------ model, solver


def test_the_model_table_is_a_preset_with_overrides():
    spec = spec_tables.model({"kind": "full", "materials": "thesis-calibrated",
                              "mesh": {"tread": 4}})
    preset = default_model("full", "thesis-calibrated")
    assert spec.mesh.tread == 4 and spec.mesh.sidewall == preset.mesh.sidewall
    assert spec.materials == preset.materials
    regions = spec_tables.model({"kind": "full", "materials": {"tread": {"youngs_modulus": 7.5}}})
    assert regions.materials.tread.youngs_modulus == 7.5
    assert regions.materials.sidewall == default_model("full").materials.sidewall


def test_the_cli_builds_the_same_model_as_the_study_table():
    cli = build_model("full", "thesis-calibrated", None,
                      ["mesh.tread=4", "materials.bead.youngs_modulus=9"])
    assert cli == spec_tables.override_model(default_model("full", "thesis-calibrated"),
                                             {"mesh": {"tread": 4},
                                              "materials": {"bead": {"youngs_modulus": 9}}})
    assert cli.materials.bead.youngs_modulus == 9.0


@pytest.mark.parametrize(("table", "match"), [
    ({"kind": "half"}, "model.kind: unknown model 'half'"),
    ({"kind": "full", "materials": "steel"}, "model.materials: unknown preset 'steel'"),
    ({"kind": "full", "mesh": {"treads": 3}}, "model.mesh.treads: unknown key; allowed: bead"),
    ({"kind": "full", "mesh": 3}, "model.mesh: must be a table, got int 3"),
    ({"kind": "full", "mesh": {"tread": "four"}}, "model.mesh.tread must be a int"),
])
def test_bad_model_tables_name_the_key(table, match):
    with pytest.raises(StudyError, match=match):
        spec_tables.model(table)


@pytest.mark.parametrize("kind", ["reduced", "full"])
@pytest.mark.parametrize("materials", ["table-3.1", "cord-reinforced"])
def test_the_model_table_takes_every_field_of_model_spec(kind, materials):
    """Every field of ModelSpec is a key of the study's [model] table, on every preset
    (issue 25: a hand-kept key list once left ``reinforcement`` out, and a cordless
    preset refused it as an unknown key)."""
    spec = replace(default_model(kind, materials), reinforcement=Reinforcement(
        belt=Cords(modulus=100.0, diameter=0.9, spacing=1.8, angle=25.0), tension_only=True))
    editable = spec.editable_dict()
    table = {f.name: editable[f.name] for f in dataclasses.fields(ModelSpec)}
    assert spec_tables.model(table) == spec


def test_a_study_gives_a_cordless_preset_cords_through_its_model_table(tmp_path):
    """``[model.reinforcement]`` on the cordless default: the default cords, changed
    where the table says, as ``--set reinforcement.<key>`` gives them."""
    text = study_text(tmp_path / "s.zarr").replace(
        "\n[loads]", "[model.reinforcement]\ntension_only = true\n"
        "[model.reinforcement.belt]\nplies = 3\n\n[loads]")
    model = parse_study(text, "s.toml").model
    assert model.reinforcement == replace(Reinforcement(), tension_only=True, belt=replace(
        Reinforcement().belt, plies=3))
    assert model.materials == default_model("reduced").materials
    assert model == build_model("reduced", "table-3.1", "contact", [
        "reinforcement.tension_only=true", "reinforcement.belt.plies=3", "mesh.tread=4",
        "mesh.sidewall=2", "mesh.bead=1", "mesh.circumferential=8"])
    with pytest.raises(StudyError, match=r"model\.reinforcement\.tension: unknown key; "
                                         r"allowed: belt, belt_depth, belt_layout, carcass, "
                                         r"tension_only"):
        spec_tables.model({"kind": "full", "reinforcement": {"tension": True}})


@pytest.mark.parametrize("table", [
    {"kind": "half"}, {"kind": "full", "materials": "steel"}, {"kind": "full", "tyre": 1},
    {"kind": "full", "mesh": {"treads": 3}}, {"kind": "full", "mesh": [1] * 100},
    {"kind": "full", "reinforcement": {"belt": {"plies": "x" * 200}}}, {},
])
def test_farm_and_the_study_table_give_the_same_line(table):
    """farm raises its SpecError, a study its StudyError: the user reads one line."""
    with pytest.raises(SpecError) as farm_error:
        overrides.model(table)
    with pytest.raises(StudyError) as study_error:
        spec_tables.model(table)
    assert str(farm_error.value) == str(study_error.value)
    assert str(farm_error.value).startswith("model.")


def test_the_solver_table():
    s = spec_tables.solver({"timeout_s": 60, "threads": 2, "max_path_length": 3,
                            "retry_smaller_increments": False})
    assert (s.settings.timeout, s.settings.threads, s.max_path_length,
            s.retry_smaller_increments) == (60.0, 2, 3, False)
    assert spec_tables.solver({}) == spec_tables.SolverTable(SolverSettings())
    assert spec_tables.solver({"split_rise": True}).settings.split_rise
    with pytest.raises(StudyError, match=r"solver\.split_rise"):
        spec_tables.solver({"split_rise": "yes"})
    with pytest.raises(StudyError, match=r"solver\.threads: must be an integer >= 1, got 0"):
        spec_tables.solver({"threads": 0})


# ------------------------------------------------- every study kind names the bad key


@pytest.mark.parametrize(("edit", "needle"), [
    (lambda t: t.replace("[solver]", "[solver]\nthreads = 0"), "solver.threads"),
    (lambda t: t.replace("tread = 4", "tread = 4\ntreads = 3"), "model.mesh.treads"),
    (lambda t: t.replace("step = 5 }", "step = 0 }"), "loads.deflection_mm.step"),
    (lambda t: t.replace("[loads]", "[loads]\n[loads.sample]\nmethod = 'grid'\nn = 4"),
     "loads.sample.method"),
])
def test_a_bad_value_in_a_sweep_study_names_the_key(edit, needle):
    with pytest.raises(StudyError) as info:
        parse_study(edit(study_text(Path("/tmp/s.zarr"))), "sweep.toml")
    assert str(info.value).startswith(f"sweep.toml: {needle}: ")


@pytest.mark.parametrize(("extra", "needle"), [
    ("[solver]\nthreads = 0\n", "solver.threads"),
    ("[model.mesh]\ntreads = 3\n", "model.mesh.treads"),
    ("[noise]\nstrain = -1\n", "noise.strain"),
    ("[[conditions]]\nname = 'a'\nnoise = 1\n", "conditions[0].noise"),
    ("[optimizers.nelder-mead]\nxatol = 'small'\n", "optimizers.nelder-mead.xatol"),
])
def test_a_bad_value_in_an_inverse_study_names_the_key(extra, needle):
    with pytest.raises(StudyError) as info:
        parse_inverse_study(INVERSE + textwrap.dedent(extra), "inverse.toml")
    assert str(info.value).startswith(f"inverse.toml: {needle}: ")


# ------------------------------------------------------------------- no private imports


@pytest.mark.parametrize("module", ["jobs/study.py", "jobs/inverse/study.py",
                                    *sorted(str(p.relative_to(ROOT))
                                            for p in (ROOT / "jobs/validate").glob("*.py")),
                                    "farm/overrides.py", "tyre_farm_cli/params.py",
                                    "tyre_farm_cli/checks.py"])
def test_study_parsers_import_nothing_private(module):
    tree = ast.parse((ROOT / module).read_text())
    private = [f"{node.module}.{alias.name}" for node in ast.walk(tree)
               if isinstance(node, ast.ImportFrom)
               for alias in node.names if alias.name.startswith("_")]
    assert private == []


# --- issue 26: store paths that were accepted and should not be ---------------------------

@pytest.mark.parametrize(("text", "needle"), [
    ("results/run\u202e.zarr", "U+202E (RIGHT-TO-LEFT OVERRIDE)"),
    ("farm\u200b.zarr", "U+200B (ZERO WIDTH SPACE)"),
    ("C:\\farm\\x.zarr", "looks like a Windows path"),
    ("D:/farm/x.zarr", "looks like a Windows path"),
    ("results\\x.zarr", "looks like a Windows path"),
])
def test_store_paths_that_read_other_than_they_are_are_refused(text, needle, tmp_path):
    with pytest.raises(StudyError, match=re.escape(needle)):
        locations.store_location(text, "study.store", tmp_path)


def test_a_store_through_a_dangling_symlink_is_refused(tmp_path):
    (tmp_path / "link").symlink_to(tmp_path / "nowhere")
    with pytest.raises(StudyError, match=r"is a symbolic link to .*nowhere, which does not exist"):
        locations.store_location(str(tmp_path / "link" / "x.zarr"), "study.store")
    (tmp_path / "nowhere").mkdir()  # the same link, its target made: accepted
    assert locations.store_location(str(tmp_path / "link" / "x.zarr"), "study.store")


def test_zarr_json_is_no_group_name():
    with pytest.raises(StudyError, match="Zarr's own metadata file"):
        scalars.identifier("zarr.json", "study.group")
    assert scalars.identifier("zarr.json2", "study.group") == "zarr.json2"
