"""The mesh-convergence study: Richardson arithmetic, the verdict, and a real run."""

import itertools
import math

import pytest

from farm.errors import SpecError
from farm.presets import MESH_PRESETS
from farm.spacing import MAX_GROWTH, half_steps
from jobs.cluster import connect
from jobs.convergence.levels import (
    CASES,
    DIRECTIONS,
    LEVELS,
    POINT_CASES,
    QUICK_CASES,
    QUICK_LEVELS,
    ROLL_CASES,
    Case,
    chosen_cases,
    chosen_directions,
    direction_levels,
    direction_study,
    refined,
)
from jobs.convergence.run import model_of, run_study, solve_case
from jobs.convergence.table import direction_markdown, markdown, richardson, rows, verdict


@pytest.mark.parametrize("p", [1.0, 2.0, 1.5])
def test_richardson_recovers_the_order_and_the_error_of_a_power_law(p):
    exact, c = 100.0, 7.0
    f = [exact + c * h ** p for h in (4.0, 2.0, 1.0)]
    order, error = richardson(*f, 2.0)
    assert order == pytest.approx(p)
    assert f[2] + error == pytest.approx(exact)


@pytest.mark.parametrize("f", [(1.0, 2.0, 1.5), (1.0, 1.0, 1.0), (1.0, 1.1, 1.3)])
def test_richardson_gives_no_order_for_oscillating_flat_or_diverging_sequences(f):
    assert all(math.isnan(x) for x in richardson(*f, 2.0))


def _record(level, fz, fy=0.0, u=1.0):
    state = {"state": "20 mm", "Fx": 0.0, "Fy": fy, "Fz": fz, "Mz": 0.0,
             "patch": {k: 1.0 for k in ("nodes", "columns", "area", "length", "width",
                                         "peak_pressure", "mean_pressure", "nodal_mean",
                                         "nodal_std")},
             "U_rms": u, "strain_rms": u, "solver_strain_rms": u}
    return {"level": level, "case": "c", "status": "done", "states": [state], "nodes": 1,
            "elements": 1, "growth": 1.0, "ccx_runs": 1, "solve_s": 1.0, "wall_s": 1.0}


def test_verdict_judges_totals_at_2_and_fields_at_5_percent_and_skips_zero_forces():
    records = [_record("a", 1000.0, u=1.0), _record("b", 1100.0, u=1.2),
               _record("c", 1115.0, u=1.26)]
    table = rows(records, ["a", "b", "c"])
    fz = next(r for r in table if r["quantity"] == "Fz N")
    assert fz["last_change_pct"] == pytest.approx(100 * 15 / 1115)
    assert fz["converged"] is True and fz["order"] > 0
    u = next(r for r in table if r["quantity"] == "window RMS of U mm")
    assert u["converged"] is True  # 4.8 %
    fy = next(r for r in table if r["quantity"] == "Fy N")
    assert fy["limit_pct"] is None  # 0 N: round-off, not judged
    assert verdict(table)["converged"]
    worse = rows([*records[:2], _record("c", 1140.0, u=1.4)], ["a", "b", "c"])
    assert {r["quantity"] for r in verdict(worse)["failing"]} == {
        "Fz N", "window RMS of U mm", "window RMS of CST strain",
        "window RMS of solver strain"}


def test_failed_solves_are_rows_of_the_cost_table_not_crashes():
    records = [_record("a", 1000.0), {"level": "b", "case": "c", "status": "failed",
                                      "reason": "SolverError: too many cutbacks",
                                      "wall_s": 1.0}]
    text = markdown(rows(records, ["a", "b"]), records, ["a", "b"])
    assert "failed: SolverError: too many cutbacks" in text


def test_levels_are_valid_models_refined_by_two_in_the_window_and_tread():
    seq = [lv for lv in LEVELS if lv.ratio]
    for coarse, fine in itertools.pairwise(seq):
        model_of(coarse), model_of(fine)
        assert fine.mesh.window_elements == 2 * coarse.mesh.window_elements
        assert fine.mesh.tread == 2 * coarse.mesh.tread
        assert fine.mesh.window == coarse.mesh.window
    assert {c.pressure_kpa for c in CASES} == {80.0, 200.0}
    assert any(c.motion and c.motion.friction and c.motion.shift_y for c in CASES)
    assert any(c.motion and c.motion.tilt for c in CASES)


def test_cases_are_chosen_by_name_from_the_study_s_and_the_rolling_ones():
    assert chosen_cases([]) == CASES and chosen_cases([], quick=True) == QUICK_CASES
    [roll] = chosen_cases(["roll-150mm"])
    assert roll in ROLL_CASES and roll.motion.rolls and roll.motion.rolling_radius
    # a name the quick study shares means the quick case there
    assert chosen_cases(["slide-y-3mm"], quick=True) == (QUICK_CASES[1],)
    assert chosen_cases(["slide-y-3mm", "roll-150mm", "slide-y-3mm"]) == (CASES[2], roll)


@pytest.mark.ccx
def test_a_solver_failure_is_a_record_with_its_reason():
    from farm.specs import SolverSettings

    record = solve_case(model_of(QUICK_LEVELS[0]), Case("c", 200.0, (20.0,)),
                        SolverSettings(timeout=1.0))
    assert record["status"] == "failed"
    assert record["reason"].startswith("ccx failed (timeout")


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_two_levels_solve_on_a_dask_cluster_and_balance():
    case = Case("vertical", 200.0, (15.0,))
    with connect(workers=2) as client:
        records = run_study(QUICK_LEVELS[:2], [case], client)
    assert [r["level"] for r in records] == [lv.name for lv in QUICK_LEVELS[:2]]
    for r in records:
        assert r["status"] == "done", r.get("reason")
        (state,) = r["states"]
        assert state["Fz"] > 1000.0 and abs(state["Fy"]) < 1e-6 * state["Fz"]
        assert state["patch"]["nodes"] >= 1 and state["patch"]["area"] > 0
        assert state["patch"]["mean_pressure"] == pytest.approx(
            state["Fz"] / state["patch"]["area"], rel=1e-3)
        assert 0 < r["growth"] < 30.0  # table-3.1 grows ~16 mm at 200 kPa
    # refining the window adds contact nodes
    assert records[1]["states"][0]["patch"]["nodes"] > records[0]["states"][0]["patch"]["nodes"]
    assert QUICK_CASES  # the CLI's quick study is a superset (tests/tyre_farm_cli)


# --- one direction at a time (issue 44) ------------------------------------------------

PATCH = MESH_PRESETS["patch"]["full"]


@pytest.mark.parametrize(("direction", "field"), [
    ("tread", "tread"), ("sidewall", "sidewall"), ("bead", "bead"), ("through", "through")])
def test_a_direction_doubles_its_own_count_and_leaves_the_others(direction, field):
    for factor in (2, 4):
        mesh = refined(PATCH, direction, factor)
        assert getattr(mesh, field) == factor * getattr(PATCH, field)
        others = {f: getattr(PATCH, f) for f in ("tread", "sidewall", "bead", "through",
                                                  "circumferential", "window_elements")
                  if f != field}
        assert {f: getattr(mesh, f) for f in others} == others


@pytest.mark.parametrize("factor", [2, 4])
def test_the_circumferential_direction_halves_the_window_s_elements_within_the_grading(factor):
    mesh = refined(PATCH, "circumferential", factor)
    assert mesh.window == PATCH.window
    assert mesh.window_elements == factor * PATCH.window_elements
    steps = half_steps(180.0, mesh.circumferential // 2, mesh.window, mesh.window_elements)
    assert steps[:mesh.window_elements] == pytest.approx(PATCH.window / mesh.window_elements)
    assert steps.sum() == pytest.approx(180.0)
    assert max(steps[1:] / steps[:-1]) <= MAX_GROWTH * (1 + 1e-9)
    # the outside keeps its elements, plus only what the grading limit needs
    outside = mesh.circumferential - 2 * mesh.window_elements
    base_outside = PATCH.circumferential - 2 * PATCH.window_elements
    assert outside >= base_outside
    if outside > base_outside:
        with pytest.raises(SpecError, match="grow"):
            half_steps(180.0, mesh.circumferential // 2 - 1, mesh.window, mesh.window_elements)


def test_together_refines_every_direction_and_sequences_double():
    both = refined(PATCH, "together", 2)
    assert both == refined(refined(refined(refined(refined(
        PATCH, "circumferential", 2), "tread", 2), "sidewall", 2), "bead", 2), "through", 2)
    levels = direction_levels("sidewall", PATCH)
    assert [lv.name for lv in levels] == ["patch", "sidewall-x2", "sidewall-x4"]
    assert [lv.mesh.sidewall for lv in levels] == [5, 10, 20]
    assert [lv.ratio for lv in levels[1:]] == [2.0, 2.0]


def test_the_direction_study_solves_the_base_once_and_names_each_sequence():
    levels, sequences = direction_study(chosen_directions(["all"]))
    names = [lv.name for lv in levels]
    assert names.count("patch") == 1 and len(names) == len(set(names))
    assert list(sequences) == list(DIRECTIONS)
    assert all(seq[0] == "patch" for seq in sequences.values())
    assert sequences["together"] == ["patch", "together-x2"]  # 4 x: ~87,000 nodes
    assert chosen_directions(["bead", "all", "bead"])[0] == "bead"


@pytest.mark.parametrize(("call", "needle"), [
    (lambda: chosen_directions(["radial"]), "'radial' is not a direction"),
    (lambda: refined(PATCH, "through", 8), "at most 4"),
    (lambda: refined(MESH_PRESETS["thesis"]["full"], "circumferential", 2), "has none"),
    (lambda: direction_study(["bead"], mesh="fine"), "unknown mesh preset 'fine'"),
])
def test_directions_that_cannot_be_built_are_refused_with_the_fix(call, needle):
    with pytest.raises(SpecError, match=needle):
        call()


def test_point_cases_are_the_calibration_s_points():
    assert [(c.pressure_kpa, c.deflections) for c in POINT_CASES] == [
        (80.0, (25.0,)), (200.0, (30.0,))]
    assert chosen_cases([], default=POINT_CASES) == POINT_CASES
    assert chosen_cases(["point-80kPa"]) == POINT_CASES[:1]


def test_each_direction_is_judged_on_its_own_levels():
    def rec(level, fz):
        r = _record(level, fz)
        r["case"] = "point"
        return r

    records = [rec("patch", 1000.0), rec("sidewall-x2", 950.0), rec("sidewall-x4", 930.0),
               rec("bead-x2", 999.0), rec("bead-x4", 998.5)]
    text, summary, tables = direction_markdown(
        records, {"sidewall": ["patch", "sidewall-x2", "sidewall-x4"],
                  "bead": ["patch", "bead-x2", "bead-x4"]})
    fz = {name: next(r for r in t if r["quantity"] == "Fz N") for name, t in tables.items()}
    assert fz["sidewall"]["last_change_pct"] == pytest.approx(100 * 20 / 930)
    assert not fz["sidewall"]["converged"] and fz["bead"]["converged"]
    assert fz["sidewall"]["order"] == pytest.approx(math.log2(50 / 20))
    assert set(fz["bead"]["values"]) == {"patch", "bead-x2", "bead-x4"}  # no sidewall
    assert "## sidewall: patch -> sidewall-x2 -> sidewall-x4" in text
    assert "not met: point Fz N 2.15 %" in text
    assert summary.startswith("finest step: 7 of 8 judged rows")


def test_the_peak_nodal_pressure_is_labelled_mesh_dependent_and_never_judged():
    """Issue 44: it moved 51 % between levels while Fz moved 0.5 %."""
    table = rows([_record("a", 1000.0), _record("b", 1001.0), _record("c", 1001.5)],
                 ["a", "b", "c"])
    (peak,) = [r for r in table if "peak" in r["quantity"]]
    assert "mesh-dependent" in peak["quantity"] and peak["limit_pct"] is None
    from storage.schema import PATCH_VARIABLES

    (stored,) = [v for v in PATCH_VARIABLES if v.name == "peak_pressure"]
    assert "mesh-dependent" in stored.long_name


def test_factors_follow_a_direction_further_and_skip_what_the_mesher_cannot_build():
    _, seq = direction_study(["sidewall", "through"], factors=(2, 4, 8))
    assert seq["sidewall"] == ["patch", "sidewall-x2", "sidewall-x4", "sidewall-x8"]
    assert seq["through"] == ["patch", "through-x2", "through-x4"]  # 8 layers: over 4
    with pytest.raises(SpecError, match="powers of 2"):
        direction_study(["bead"], factors=(3,))


def test_the_converged_preset_refines_the_sidewall_and_puts_the_belts_at_depth():
    from farm.presets import default_model

    conv, patch = MESH_PRESETS["converged"]["full"], PATCH
    assert conv == refined(refined(patch, "sidewall", 4), "through", 2)
    model = default_model("full", "reinforced-calibrated", mesh="converged")
    assert model.mesh.through == 2 and model.reinforcement.belt_layout == "cords"
    # patch and its ids stay as they were
    assert patch == MESH_PRESETS["patch"]["full"] and patch.through == 1


def test_a_direction_with_no_buildable_level_is_refused_not_skipped():
    with pytest.raises(SpecError, match="has none"):
        direction_study(["circumferential"], mesh="thesis")
    with pytest.raises(SpecError, match="at most 4"):
        direction_study(["through"], mesh="converged", factors=(4,))
