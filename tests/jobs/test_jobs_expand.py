"""Expansion of a study into load paths, and content-hash identities."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from conftest import study_text

from farm.specs import MeshDensity
from jobs.expand import experiments, load_cases, plan
from jobs.identity import experiment_id
from jobs.study import parse_study

SOLVER = "CalculiX 2.20"


def _study(**kwargs):
    return parse_study(study_text(Path("/tmp/s.zarr"), **kwargs))


def test_grid_makes_one_path_per_pressure():
    full = study_text(Path("/tmp/s.zarr"), solver="").replace('kind = "reduced"\nroad = "contact"',
                                                               'kind = "full"')
    full = full.replace("circumferential = 8", "circumferential = 16").replace(
        "[loads]", "[loads]\npressure_kpa = [80, 200]")
    paths = plan(parse_study(full), SOLVER)
    assert [p.pressure for p in paths] == [0.08, 0.2]
    assert all(p.deflections == (5.0, 10.0, 15.0, 20.0, 25.0, 30.0) for p in paths)
    assert len(experiments(paths)) == 12


@pytest.mark.parametrize("size, pieces", [(1, 6), (2, 3), (4, 2), (0, 1)])
def test_long_paths_are_split(size, pieces):
    paths = plan(_study(solver=f"max_path_length = {size}"), SOLVER)
    assert len(paths) == pieces
    assert sum(len(p.experiments) for p in paths) == 6
    assert len({p.key for p in paths}) == pieces


def test_ids_are_stable_and_unique():
    a, b = plan(_study(), SOLVER), plan(_study(), SOLVER)
    ids = [e.id for e in experiments(a)]
    assert ids == [e.id for e in experiments(b)] and len(set(ids)) == len(ids)
    assert [p.key for p in a] == [p.key for p in b]


def test_every_input_changes_the_id():
    study = _study()
    base = experiment_id(study.model, 10.0, 0.0, SOLVER)
    other_model = dataclasses.replace(study.model, mesh=MeshDensity(4, 2, 1, 10))
    assert experiment_id(other_model, 10.0, 0.0, SOLVER) != base
    assert experiment_id(study.model, 10.5, 0.0, SOLVER) != base
    assert experiment_id(study.model, 10.0, 0.0, "CalculiX 2.21") != base
    assert experiment_id(study.model, 10.0 + 1e-12, 0.0, SOLVER) == base  # canonical rounding


def test_adding_cases_keeps_existing_ids():
    small = {e.id for e in experiments(plan(_study(solver=""), SOLVER))}
    big = {e.id for e in experiments(plan(_study(
        deflections="{ start = 5, stop = 40, step = 5 }", solver=""), SOLVER))}
    assert small < big


@pytest.mark.parametrize("method", ["lhs", "sobol"])
def test_sampling_covers_the_ranges_reproducibly(method):
    text = study_text(Path("/tmp/s.zarr"), solver="").replace(
        "deflection_mm = { start = 5, stop = 30, step = 5 }",
        f'[loads.sample]\nmethod = "{method}"\nn = 16\nseed = 3\ndeflection_mm = [10, 30]')
    study = parse_study(text)
    cases = np.array(load_cases(study))
    assert cases.shape == (16, 2)
    assert cases[:, 0].min() >= 10 and cases[:, 0].max() <= 30
    if method == "lhs":  # one sample per stratum of width 20 / 16
        assert sorted(np.floor((cases[:, 0] - 10) / (20 / 16)).astype(int)) == list(range(16))
    assert np.array_equal(cases, np.array(load_cases(parse_study(text))))
    assert not np.array_equal(cases, np.array(load_cases(parse_study(text.replace(
        "seed = 3", "seed = 4")))))
    # pressure 0 for every case of the uninflated model: a single path
    assert len(plan(study, SOLVER)) == 1
