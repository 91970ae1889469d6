"""The statistical "tyre distribution" (thesis §6.2) on a synthetic store: a model in its
own right (held-out maps, totals), the initial guess it gives, and its validation."""

import numpy as np
import pytest

from jobs.errors import StudyError
from jobs.inverse.distribution import (
    TyreDistribution,
    check_mesh,
    fit_distribution,
    guess_from,
    training_set,
)
from tests.synthetic import make_store

SMALL = {"rows": 4, "cols": 6, "tread_rows": 8, "tread_cols": 20}


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """25 deflections 10..40 mm at one pressure: an elliptic patch growing with d
    (tests.synthetic), plus a failed one that must never be read."""
    path = tmp_path_factory.mktemp("dist") / "sweep.zarr"
    group = make_store(path, n_experiments=25, n_failed=1, **SMALL)
    return training_set(str(path), group), str(path), group


def _split(data, every):
    d = data.params["deflection"]
    order = np.argsort(d)
    test = order[1::2]  # held out: never trained on
    train = order[0::2][::every]
    return train, test


def _fit(data, idx, **kw):
    return TyreDistribution(**kw).fit({n: v[idx] for n, v in data.params.items()},
                                      data.forces[idx])


def _rel_error(pred, true):
    return np.linalg.norm(pred - true, axis=1) / np.linalg.norm(true, axis=1)


def test_the_training_set_holds_the_done_experiments_only(data):
    ts, _, _ = data
    assert ts.forces.shape == (25, 8 * 20)
    assert np.isfinite(ts.forces).all()
    assert set(ts.params) >= {"deflection", "pressure"}


def test_held_out_maps_are_predicted_better_than_by_the_uniform_guess(data):
    ts, _, _ = data
    train, test = _split(ts, 1)
    model = _fit(ts, train)
    assert model.parameters_ == ("deflection",)  # pressure is constant: not a feature
    params = {"deflection": ts.params["deflection"][test]}
    true = ts.forces[test]
    err = _rel_error(model.predict(params), true)
    # uniform (§4.5): the true total spread evenly over the truly loaded nodes
    contact = true > 0
    uniform = np.where(contact, true.sum(1, keepdims=True) / contact.sum(1, keepdims=True), 0)
    err_uniform = _rel_error(uniform, true)
    assert np.all(err < err_uniform)
    assert err.mean() < 0.5 * err_uniform.mean()
    totals = model.predict_total(params)
    np.testing.assert_allclose(totals, true.sum(1), rtol=0.02)


def test_held_out_error_falls_with_more_training_data(data):
    ts, _, _ = data
    errors = []
    for every in (4, 2, 1):  # 4, 7, 13 training experiments
        train, test = _split(ts, every)
        model = _fit(ts, train)
        params = {"deflection": ts.params["deflection"][test]}
        errors.append(_rel_error(model.predict(params), ts.forces[test]).mean())
    assert errors[0] > errors[1] > errors[2]


def test_shapes_are_normalised_and_non_negative(data):
    ts, _, _ = data
    model = _fit(ts, np.arange(25))
    s = model.predict_shape({"deflection": np.array([12.0, 27.5, 39.0])})
    assert s.shape == (3, ts.forces.shape[1])
    assert (s >= 0).all()
    np.testing.assert_allclose(s.sum(1), 1.0)


def test_the_guess_carries_the_given_total_on_the_unknowns(data):
    ts, _, _ = data
    model = _fit(ts, np.arange(25))
    true = ts.forces[np.argsort(ts.params["deflection"])[12]]
    unknowns = ts.tread_nodes[true > 0]
    x0 = guess_from(model, ts.tread_nodes, unknowns, {"deflection": 25.0}, 359.0)
    assert x0.shape == (unknowns.size,)
    assert x0.sum() == pytest.approx(359.0)
    assert (x0 >= 0).all() and x0.std() > 0  # a shape, not the uniform guess


def test_the_reference_load_is_left_out_of_training(data):
    ts, _, _ = data
    d = np.sort(ts.params["deflection"])
    every = fit_distribution(ts, n_components=3, degree=2)
    near = fit_distribution(ts, n_components=3, degree=2,
                            exclude={"deflection": d[12]}, within=0.1)
    # the fit without the 25 mm experiment predicts it worse than the fit with it
    k = np.argsort(ts.params["deflection"])[12]
    e_all = _rel_error(every.predict({"deflection": d[12]}), ts.forces[k:k + 1])
    e_out = _rel_error(near.predict({"deflection": d[12]}), ts.forces[k:k + 1])
    assert e_out > e_all


def test_too_few_experiments_are_one_study_error(data):
    ts, _, _ = data
    with pytest.raises(StudyError, match=r"distribution: .*need at least 3"):
        fit_distribution(ts, n_components=3, degree=2, exclude={"deflection": 25.0},
                         within=100.0)


def test_a_missing_store_or_group_is_one_study_error(data, tmp_path):
    _, path, _ = data
    with pytest.raises(StudyError, match="distribution: cannot read group 'nope'"):
        training_set(path, "nope")
    with pytest.raises(StudyError, match="distribution: cannot read group"):
        training_set(str(tmp_path / "absent.zarr"), "g")


def test_a_group_of_another_mesh_is_refused(data):
    ts, _, _ = data
    check_mesh(ts, ts.tread_nodes, ts.tread_xyz)  # its own mesh: fine
    with pytest.raises(StudyError, match=r"distribution\.group: its tread nodes"):
        check_mesh(ts, ts.tread_nodes[:-1], ts.tread_xyz[:-1])
    with pytest.raises(StudyError, match=r"distribution\.group"):
        check_mesh(ts, ts.tread_nodes, ts.tread_xyz + 1.0)


@pytest.mark.parametrize("quick", [True, False])
def test_the_reproduction_trains_the_distribution_on_its_chapter_3_sweep(tmp_path, quick):
    from jobs.inverse.study import parse_inverse_study
    from jobs.reproduce.inverse import study_text
    from jobs.reproduce.options import Options

    opts = Options(out=tmp_path, store=str(tmp_path / "thesis.zarr"), quick=quick)
    study = parse_inverse_study(study_text(opts), "ch4.toml", tmp_path)
    assert study.distribution.group == opts.group("reduced") == "reduced-table-3.1-default"
    assert study.distribution.store == opts.store
    assert [c.initial for c in study.conditions if c.name == "distribution"] == ["distribution"]


@pytest.mark.parametrize(("quick", "repeats"), [(True, 1), (False, 10)])
def test_the_reproduction_regularises_its_noisy_conditions(tmp_path, quick, repeats):
    from jobs.inverse.study import parse_inverse_study
    from jobs.reproduce.inverse import REGULARISED, regularised_text
    from jobs.reproduce.options import Options

    opts = Options(out=tmp_path, store=str(tmp_path / "thesis.zarr"), quick=quick)
    for reg in REGULARISED:
        study = parse_inverse_study(regularised_text(opts, reg), f"{reg}.toml", tmp_path)
        (opt,) = study.optimizers
        assert (opt.name, opt.regularisation, opt.weight_rule) == (
            "least-squares", reg, "discrepancy")
        assert all(c.noise for c in study.conditions)
        assert "distribution" in {c.name for c in study.conditions}
        assert {c.repeats for c in study.conditions} == {repeats}
        assert study.group == f"inverse-ch4-{'quick' if quick else 'full'}-default-{reg}"
