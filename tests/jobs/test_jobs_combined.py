"""Combined-load studies (issue 13) through study files, identities, the store and a sweep.

The physics is tested in tests/farm/test_friction.py; here: that the study's keys reach
the right experiments, ids and paths, that vertical studies are untouched, and that a
small combined study runs end to end on ccx with every array in the store."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import QUICK_MODEL, ccx_runs, study_text

from farm.specs import RoadMotion
from jobs import identity
from jobs.errors import StudyError
from jobs.expand import cases, experiments, parameters, plan
from jobs.study import parse_study

SOLVER = "CalculiX 2.20"
ROOT = Path(__file__).resolve().parents[2]


def _combined(tmp_path, loads: str, model: str = QUICK_MODEL) -> str:
    return (f'[study]\nname = "c"\nstore = "{tmp_path / "s.zarr"}"\n' + model
            + f"\n[loads]\n{loads}\n")


# ---------------------------------------------------------------- ids and expansion


def test_vertical_ids_are_those_of_before(tmp_path):
    """Computed on the code before issue 13 phase 2a (commit 8bc2bcb) for this study."""
    study = parse_study(study_text(tmp_path / "s.zarr", deflections="[10, 20]", solver=""))
    assert not study.combined
    ids = [e.id for e in experiments(plan(study, SOLVER))]
    assert ids == ["fdcb90e6b533f9a5ce39fadf592dd896e6e1bd21c9b9cb70189dfbfc21306c59",
                   "0cbc9abaccb77506fab296f437cf99b8bb48a70733c44cc7868445be07d9a2e3"]
    assert set(parameters(experiments(plan(study, SOLVER)))) == {"deflection", "pressure"}


def test_motion_enters_the_id_only_when_there_is_one(tmp_path):
    model = parse_study(study_text(tmp_path / "s.zarr", solver="")).model
    vertical = identity.experiment_id(model, 10.0, 0.0, SOLVER)
    assert identity.experiment_id(model, 10.0, 0.0, SOLVER, None) == vertical
    assert identity.experiment_id(model, 10.0, 0.0, SOLVER, RoadMotion()) == vertical
    rough = identity.experiment_id(model, 10.0, 0.0, SOLVER, RoadMotion(friction=0.5))
    assert rough != vertical
    assert identity.experiment_id(model, 10.0, 0.0, SOLVER, RoadMotion(friction=0.5 + 1e-13)) \
        != identity.experiment_id(model, 10.0, 0.0, SOLVER, RoadMotion(friction=0.6))
    assert identity.experiment_id(model, 10.0, 0.0, SOLVER, RoadMotion(friction=1)) \
        == identity.experiment_id(model, 10.0, 0.0, SOLVER, RoadMotion(friction=1.0))


def test_study_without_motion_keys_expands_as_before(tmp_path):
    loads = "deflection_mm = [10, 20]\n[loads.sample]\nmethod = 'lhs'\nn = 3\nseed = 2\n"
    text = _combined(tmp_path, loads.replace("deflection_mm = [10, 20]\n", "")
                     + "deflection_mm = [5, 25]\n")
    study = parse_study(text)
    got = cases(study)
    assert all(m is None for _, _, m in got) and len(got) == 3
    # the LHS points of a 1-d design over deflection, as scipy draws them
    from scipy.stats import qmc
    want = qmc.scale(qmc.LatinHypercube(d=1, seed=2).random(3), [5], [25])[:, 0]
    assert np.allclose([d for d, _, _ in got], want)


def test_grid_paths_share_friction_and_tilt_but_not_a_shift(tmp_path):
    study = parse_study(_combined(tmp_path, "deflection_mm = [10, 15, 20]\nfriction = [0, 0.5]"
                                  "\ntilt_deg = [2]\nshift_y_mm = [0, 3]"))
    assert study.combined
    paths = plan(study, SOLVER)
    exps = experiments(paths)
    assert len(exps) == 3 * 2 * 2 and len({e.id for e in exps}) == 12
    by_motion = {}
    for p in paths:
        by_motion.setdefault(p.motion, []).append(p)
    # no shift: one path over the three deflections; with a shift: one path per deflection
    for motion, ps in by_motion.items():
        if motion.moves:
            assert [len(p.experiments) for p in ps] == [1, 1, 1]
        else:
            assert [p.deflections for p in ps] == [(10.0, 15.0, 20.0)]
        assert all(e.motion == motion for p in ps for e in p.experiments)
    params = parameters(exps, study.combined)
    assert set(params) == {"deflection", "pressure", "friction", "shift_x", "shift_y", "tilt"}
    assert sorted(set(params["friction"])) == [0.0, 0.5] and set(params["tilt"]) == {2.0}
    assert set(params["shift_x"]) == {0.0} and sorted(set(params["shift_y"])) == [0.0, 3.0]


def test_a_motion_at_zero_is_the_vertical_experiment(tmp_path):
    """friction 0, no shift, no tilt: the vertical case, with the vertical id."""
    study = parse_study(_combined(tmp_path, "deflection_mm = [10]\nfriction = [0, 0.4]"))
    exps = experiments(plan(study, SOLVER))
    vertical = [e for e in exps if e.motion is None]
    assert len(vertical) == 1
    assert vertical[0].id == identity.experiment_id(study.model, 10.0, 0.0, SOLVER)


def test_sampled_motion(tmp_path):
    study = parse_study(_combined(tmp_path, (
        "[loads.sample]\nmethod = 'lhs'\nn = 6\nseed = 1\ndeflection_mm = [10, 20]\n"
        "friction = [0.3, 1.0]\nshift_x_mm = [-3, 3]\nshift_y_mm = [-2, 2]\ntilt_deg = [-4, 4]")))
    got = cases(study)
    assert len(got) == 6
    for d, _, m in got:
        assert 10 <= d <= 20 and 0.3 <= m.friction <= 1.0 and -4 <= m.tilt <= 4
        assert -3 <= m.shift_x <= 3 and -2 <= m.shift_y <= 2
    # LHS: one point per stratum of each dimension
    assert sorted(int((m.friction - 0.3) / 0.7 * 6) for _, _, m in got) == list(range(6))
    assert len(plan(study, SOLVER)) == 6  # every case shifts: one path each


# ---------------------------------------------------------------- bad input: one line


@pytest.mark.parametrize("loads, match", [
    ("deflection_mm = [10]\nfriction = [3]", r"loads.friction\[0\].*3"),
    ("deflection_mm = [10]\nshift_x_mm = [60]", r"loads.shift_x_mm\[0\].*60"),
    ("deflection_mm = [10]\ntilt_deg = -11", r"loads.tilt_deg.*-11"),
    ("[loads.sample]\nmethod = 'lhs'\nn = 3\ndeflection_mm = [5, 10]\nfriction = [0.2, 2.5]",
     r"loads.sample.friction.*2.5"),
    ("[loads.sample]\nmethod = 'lhs'\nn = 3\ndeflection_mm = [5, 10]\ntilt_deg = [2, 1]",
     r"loads.sample.tilt_deg.*low < high"),
    ("deflection_mm = [10]\nfriction = [0.5]\n[loads.sample]\nmethod = 'lhs'\nn = 3\n"
     "friction = [0.2, 0.9]", r"loads.friction.*both sampled and listed"),
    ("deflection_mm = [170]\ntilt_deg = [-9.5, 1]", r"loads: .*tilted road"),
])
def test_bad_combined_loads_are_one_study_error(tmp_path, loads, match):
    with pytest.raises(StudyError, match=match) as e:
        parse_study(_combined(tmp_path, loads))
    assert "\n" not in str(e.value)


def test_iterative_road_refuses_combined_loads(tmp_path):
    model = QUICK_MODEL.replace('road = "contact"\n', "")
    with pytest.raises(StudyError, match=r'loads.friction.*road = "contact".*iterative'):
        parse_study(_combined(tmp_path, "deflection_mm = [10]\nfriction = [0.5]", model))
    with pytest.raises(StudyError, match=r"loads.sample.tilt_deg.*contact"):
        parse_study(_combined(tmp_path, "deflection_mm = [10]\n[loads.sample]\nmethod = 'lhs'"
                              "\nn = 2\ntilt_deg = [1, 2]", model))


def test_motion_values_count_against_the_experiment_limit(tmp_path, monkeypatch):
    monkeypatch.setenv("FARM_MAX_EXPERIMENTS", "20")
    with pytest.raises(StudyError, match=r"3 deflections x 2 frictions x 4 tilts is 24"):
        parse_study(_combined(tmp_path, "deflection_mm = [10, 15, 20]\nfriction = [0.2, 0.5]"
                              "\ntilt_deg = [1, 2, 3, 4]"))


# ---------------------------------------------------------------- farm run


@pytest.mark.parametrize("argv, needle", [
    (["--friction", "3"], "motion.friction"),
    (["--shift-x", "-60"], "motion.shift_x"),
    (["--tilt", "12"], "motion.tilt"),
    (["--model", "reduced", "--friction", "0.5"], "need the contact road"),
])
def test_farm_run_refuses_bad_combined_options_in_one_line(argv, needle, capsys, monkeypatch):
    import farm.experiment
    from tyre_farm_cli import main

    monkeypatch.setattr(farm.experiment, "run_load_path", None)  # nothing may be solved
    with pytest.raises(SystemExit) as info:
        main(["run", "--deflection", "10", *argv])
    err = capsys.readouterr().err.strip()
    assert info.value.code != 0 and needle in err and "\n" not in err


# ---------------------------------------------------------------- a sweep on ccx


def _quick_study(tmp_path, n: int, deflections: str = "[10, 20]") -> Path:
    """examples/combined_quick.toml with ``n`` points, writing into ``tmp_path``."""
    text = (ROOT / "examples" / "combined_quick.toml").read_text()
    text = text.replace('store = "results/combined_quick.zarr"',
                        f'store = "{tmp_path / "combined.zarr"}"').replace("n = 10", f"n = {n}")
    text = text.replace("deflection_mm = [10, 20]", f"deflection_mm = {deflections}")
    assert f"n = {n}" in text and str(tmp_path) in text and deflections in text
    path = tmp_path / "combined.toml"
    path.write_text(text)
    return path


def _check_store(path: Path) -> None:
    import storage
    from jobs.study import load_study

    study = load_study(path)
    ds = storage.open_dataset(study.store, study.group_name)
    status = ds["status"].values
    assert set(status.tolist()) <= {storage.DONE, storage.FAILED}
    failed = np.flatnonzero(status == storage.FAILED)
    assert all(str(ds["error"].values[k]).strip() for k in failed)  # failed with a reason
    units = {n: ds[n].attrs["units"] for n in ("friction", "shift_x", "shift_y", "tilt",
                                                "contact_status", "tread_slip",
                                                "road_reaction", "road_moment")}
    assert units == {"friction": "1", "shift_x": "mm", "shift_y": "mm", "tilt": "deg",
                     "contact_status": "1", "tread_slip": "mm", "road_reaction": "N",
                     "road_moment": "N mm"}
    # the stored load cases are the study's (ids and motion)
    want = {e.id: e for e in experiments(plan(study, ds.attrs["solver"]))}
    assert set(ds["experiment"].values.tolist()) == set(want)
    for k, e in enumerate(ds["experiment"].values.tolist()):
        m = want[e].motion
        assert [float(ds[n].values[k]) for n in ("friction", "shift_x", "shift_y", "tilt")] \
            == [m.friction, m.shift_x, m.shift_y, m.tilt]
    done = storage.done(ds)  # verified against the checksums
    assert done.sizes["experiment"] >= 1
    f = done["reaction_force"].values
    total = done["total_force"].values
    road = done["road_reaction"].values
    assert np.allclose(f.sum(axis=1), total, rtol=1e-9, atol=1e-6)
    for k in range(done.sizes["experiment"]):
        size = np.linalg.norm(total[k])
        # the tread's forces balance the road's reactions in x, y and z (0.5 % of |F|)
        assert np.all(np.abs(total[k] - road[k]) <= 5e-3 * size), (total[k], road[k])
        assert total[k][2] > 100  # pushed up by the road
        assert abs(total[k][0]) > 1 and abs(total[k][1]) > 1  # Fx, Fy filled: slid, rough
        status_k = done["contact_status"].values[k]
        assert set(status_k.tolist()) <= {0, 1, 2} and np.count_nonzero(status_k) >= 1
        assert np.isfinite(done["tread_slip"].values[k]).all()
        assert np.isfinite(done["road_moment"].values[k]).all()


@pytest.mark.ccx
@pytest.mark.e2e  # end to end: run by .ci/run through `scripts/test.sh --e2e`
def test_quick_combined_study_end_to_end(tmp_path, counting_ccx, capsys):
    """2 combined experiments of examples/combined_quick.toml (the smallest that has two
    paths on two workers; shallow deflections, the cheapest) through `farm sweep submit`:
    store complete and balanced; resume and a second submit solve nothing."""
    from tyre_farm_cli import main

    path = _quick_study(tmp_path, 2, "[10, 13]")
    code = _exit_code(main, ["sweep", "submit", str(path), "--workers", "2"])
    assert code in (0, 1), capsys.readouterr()
    runs = ccx_runs(counting_ccx)
    assert 2 <= runs <= 4  # one ccx run each, a retry with smaller increments at most
    _check_store(path)
    for command in ("resume", "submit"):
        assert _exit_code(main, ["sweep", command, str(path), "--workers", "1"]) in (0, 1)
        assert ccx_runs(counting_ccx) == runs


@pytest.mark.ccx
@pytest.mark.slow
def test_examples_combined_quick_in_full(tmp_path, counting_ccx, capsys):
    """The whole quick example (10 experiments), as a user runs it."""
    from tyre_farm_cli import main

    path = _quick_study(tmp_path, 10)
    code = _exit_code(main, ["sweep", "submit", str(path), "--workers", "2"])
    assert code in (0, 1), capsys.readouterr()
    _check_store(path)


def _exit_code(main, argv: list[str]) -> int:
    """``farm``'s exit code: ``main`` raises SystemExit for a non-zero one and returns
    when everything succeeded (0; the test expected SystemExit either way and failed
    whenever all ten experiments of the quick study went through)."""
    try:
        main(argv)
    except SystemExit as e:
        return int(e.code or 0)
    return 0
