"""The field surrogate (issue 28): accuracy on a smooth known map, honest uncertainty,
batches that go where the data are not, safe persistence, bad input refused."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from analysis.camera.predict.persist import load_model, save_model
from analysis.errors import ParameterError
from analysis.surrogate import FieldSurrogate

NODES = np.linspace(0.0, 1.0, 60)
N_FIELD = 60  # the field's columns; then 3 'forces'


def _truth(P: np.ndarray) -> np.ndarray:
    """A smooth 'field' over 60 nodes and 3 'forces' of two load parameters in [0, 1]."""
    d, p = P[:, :1], P[:, 1:2]
    field = (1 + 2 * d) * np.cos(3 * NODES + 1.5 * p) + 0.5 * d**2 * NODES
    forces = np.hstack([1000 * d * (1 + 0.3 * p), 50 * np.sin(2 * d + p), 200 * p**2])
    return np.hstack([field, forces])


def _lhs(n: int, seed: int, low=(0.0, 0.0), high=(1.0, 1.0)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    cells = np.column_stack([rng.permutation(n) for _ in range(2)])
    unit = (cells + rng.random((n, 2))) / n
    return np.asarray(low) + unit * (np.asarray(high) - np.asarray(low))


@pytest.fixture(scope="module")
def fitted():
    P = _lhs(30, seed=1)
    return FieldSurrogate(n_field=N_FIELD).fit(P, _truth(P)), P


def test_held_out_predictions_are_within_one_percent_of_range(fitted):
    model, _ = fitted
    Q = _lhs(40, seed=2)
    Y = _truth(Q)
    error = np.abs(model.predict(Q) - Y).max(axis=0) / np.ptp(Y, axis=0)
    assert error.max() < 0.01, error.max()


def test_the_uncertainty_covers_the_error_and_grows_away_from_the_data(fitted):
    model, P = fitted
    Q = _lhs(40, seed=3)
    pred, std = model.predict(Q, return_std=True)
    covered = np.abs(pred - _truth(Q)) <= 3 * std + 1e-9 * np.abs(_truth(Q)).max()
    assert covered.mean() > 0.9, covered.mean()
    # outside the unit square the data end: the uncertainty must be larger there
    far = np.array([[1.6, 0.5], [0.5, -0.6]])
    assert model.uncertainty(far).min() > 10 * model.uncertainty(P).max()


def test_a_batch_goes_where_the_data_are_not_and_spreads_out():
    P = _lhs(12, seed=4, high=(0.5, 1.0))  # only the left half of the square is known
    model = FieldSurrogate(n_field=N_FIELD).fit(P, _truth(P))
    g = np.linspace(0, 1, 11)
    candidates = np.array([(a, b) for a in g for b in g])
    batch = model.next_batch(candidates, 4)
    assert len(set(batch.tolist())) == 4
    assert batch[0] == int(np.argmax(model.uncertainty(candidates)))
    assert (candidates[batch, 0] > 0.5).all(), candidates[batch]
    gaps = [np.linalg.norm(candidates[i] - candidates[j])
            for k, i in enumerate(batch) for j in batch[k + 1:]]
    assert min(gaps) > 0.15, candidates[batch]  # no two picks are neighbours on the grid


def test_adding_the_chosen_batch_lowers_the_held_out_error():
    P = _lhs(10, seed=5, high=(0.5, 1.0))
    model = FieldSurrogate(n_field=N_FIELD).fit(P, _truth(P))
    g = np.linspace(0, 1, 11)
    candidates = np.array([(a, b) for a in g for b in g])
    Q = _lhs(40, seed=6)
    before = np.abs(model.predict(Q) - _truth(Q)).mean()
    P2 = np.vstack([P, candidates[model.next_batch(candidates, 6)]])
    after = np.abs(clone(model).fit(P2, _truth(P2)).predict(Q) - _truth(Q)).mean()
    assert after < 0.5 * before, (before, after)


def test_a_saved_surrogate_loads_and_predicts_the_same(fitted, tmp_path):
    model, _ = fitted
    save_model(tmp_path / "surrogate", model, {"inputs": ["deflection", "pressure"]})
    loaded, manifest = load_model(tmp_path / "surrogate")
    Q = _lhs(5, seed=7)
    np.testing.assert_array_equal(loaded.predict(Q), model.predict(Q))
    assert manifest["inputs"] == ["deflection", "pressure"]


@pytest.mark.parametrize(("P", "Y", "match"), [
    (np.zeros((5, 2)), np.zeros((4, 3)), "same experiments"),
    (np.zeros((2, 2)), np.zeros((2, 3)), "at least 3"),
    (np.full((5, 2), np.nan), np.zeros((5, 3)), "finite 2-D"),
    (np.zeros(5), np.zeros((5, 3)), "finite 2-D"),
    (np.zeros((5, 2)), np.zeros((5, 3)), "n_field=4 must be between 0 and the 3 columns"),
])
def test_bad_input_is_one_clear_error(P, Y, match):
    with pytest.raises(ParameterError, match=match):
        FieldSurrogate(n_field=4 if "n_field" in match else None).fit(P, Y)


@pytest.mark.parametrize("n_field", [0, 63])
def test_only_scalars_or_only_a_field_work_too(n_field):
    P = _lhs(20, seed=8)
    model = FieldSurrogate(n_field=n_field).fit(P, _truth(P))
    Q = _lhs(10, seed=9)
    pred, std = model.predict(Q, return_std=True)
    assert pred.shape == std.shape == (10, 63)
    assert np.abs(pred - _truth(Q)).max(axis=0).max() < 0.1 * np.ptp(_truth(Q), axis=0).max()


def test_an_unfitted_surrogate_says_so():
    with pytest.raises(NotFittedError):
        FieldSurrogate().predict(np.zeros((1, 2)))


def test_a_batch_larger_than_the_candidates_is_refused(fitted):
    with pytest.raises(ParameterError, match="batch size 9"):
        fitted[0].next_batch(np.zeros((3, 2)), 9)


def test_closed_form_leave_one_out_equals_refits_without_each_experiment(fitted):
    """loo_predict is the GP's prediction at an experiment from the others, kernels and
    PCA basis fixed: the same as refitting (optimizer off) without that experiment."""
    from sklearn.gaussian_process import GaussianProcessRegressor

    model, P = fitted
    loo = model.loo_predict()
    Ps = model._p(P)
    for i in (0, 7, 29):
        keep = np.arange(len(P)) != i
        targets = []
        for gp in model.gps_:
            refit = GaussianProcessRegressor(gp.kernel_, optimizer=None)
            refit.fit(Ps[keep], gp.y_train_[keep])
            targets.append(refit.predict(Ps[i:i + 1])[0])
        T = np.asarray(targets) * model.t_scale_ + model.t_mean_
        c = model.n_components_
        expected = np.concatenate([model.pca_.inverse_transform(T[None, :c])[0], T[c:]])
        np.testing.assert_allclose(loo[i], expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())
    # and it is a held-out error: larger than the (interpolating) training fit
    Y = _truth(P)
    assert np.abs(loo - Y).mean() > np.abs(model.predict(P) - Y).mean()


def test_a_batch_avoids_points_counted_as_observed(fitted):
    """``avoid`` points lower the variance around them: the first pick moves away."""
    model, _ = fitted
    C = _lhs(200, seed=9, low=(-0.5, -0.5), high=(1.5, 1.5))  # partly outside the data
    first = model.next_batch(C, 1)[0]
    again = model.next_batch(C, 1, avoid=C[[first]])[0]
    assert again != first
    assert np.linalg.norm(C[again] - C[first]) > 0.2  # not its neighbour either


def test_the_integrated_criterion_spreads_a_batch_inside_the_space(fitted):
    """ALC picks lower the average variance over the candidates more than ALM picks; ALM
    goes to the edge of the candidates (its largest variance), ALC need not."""
    model, _ = fitted
    C = _lhs(150, seed=11, low=(-0.2, -0.2), high=(1.2, 1.2))

    def mean_variance_after(picks):
        from sklearn.gaussian_process import GaussianProcessRegressor

        Ps = model._p(C[picks])
        total = 0.0
        for gp, w in zip(model.gps_, (model.t_scale_ * model.std_scale_) ** 2 * model.weight_,
                         strict=True):
            X = np.vstack([gp.X_train_, Ps])
            b = GaussianProcessRegressor(gp.kernel_, optimizer=None).fit(X, np.zeros(len(X)))
            total += w * np.mean(b.predict(model._p(C), return_std=True)[1] ** 2)
        return total

    alm, alc = model.next_batch(C, 4), model.next_batch(C, 4, criterion="integrated")
    assert len(set(alc)) == 4
    assert mean_variance_after(alc) < mean_variance_after(alm)
    with pytest.raises(ParameterError, match="criterion must be one of variance, integrated"):
        model.next_batch(C, 1, criterion="bogus")
