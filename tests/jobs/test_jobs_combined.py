"""Combined-load studies (issue 13) through study files, identities, the store and a sweep.

The physics is tested in tests/farm/test_friction.py; here: that the study's keys reach
the right experiments, ids and paths, that vertical studies are untouched, and that a
small combined study runs end to end on ccx with every array in the store."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import QUICK_MODEL, study_text

from farm.specs import RoadMotion
from jobs import identity
from jobs.errors import StudyError
from jobs.expand import cases, experiments, parameters, plan
from jobs.study import parse_study

SOLVER = "CalculiX 2.20"


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
