"""The learners of the sensor study (issue 27): CV-chosen PLSR and a GP on its scores;
kernel ridge on the scores and ``auto``, the learner chosen by grouped CV (issue 46)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

import analysis.camera.learners as learners_module
from analysis.camera.learners import (
    AUTO_CANDIDATES,
    LEARNERS,
    PLSCV,
    AutoLearner,
    GPOnScores,
    KRROnScores,
    learner,
)
from analysis.combined import BlockRegression
from analysis.errors import ParameterError


def _latent(k=120, rank=3, features=400, noise=0.02, seed=0):
    rng = np.random.default_rng(seed)
    L = rng.normal(size=(k, rank))
    X = L @ rng.normal(size=(rank, features)) + noise * rng.normal(size=(k, features))
    return L, X


def test_cv_finds_the_latent_count_of_a_linear_problem():
    L, X = _latent()
    Y = L @ np.array([[1.0, 0.5], [-0.3, 1.0], [0.8, -0.6]])
    model = PLSCV(max_components=8, folds=5, y_blocks=[1, 1]).fit(X, Y)
    assert model.n_components_ == 3
    assert list(model.cv_table_["n_components"]) == list(range(1, 9))
    assert np.sqrt(np.mean((model.predict(X) - Y) ** 2)) < 0.05


def test_groups_keep_the_draws_of_one_experiment_in_one_fold():
    """Three noisy copies per experiment: the grouped folds never test on a copy of a
    training experiment, so the CV error is larger than with leaking random folds."""
    L, X = _latent(k=40)
    rng = np.random.default_rng(1)
    Xd = np.concatenate([X + 0.5 * rng.normal(size=X.shape) for _ in range(3)])
    Y = np.tile(L[:, :1] + 0.2 * L[:, 1:2] ** 2, (3, 1))
    groups = np.tile(np.arange(40), 3)
    grouped = PLSCV(max_components=8, folds=5).fit(Xd, Y, groups)
    leaking = PLSCV(max_components=8, folds=5).fit(Xd, Y)
    assert grouped.cv_table_["mse_mean"].min() > leaking.cv_table_["mse_mean"].min()


def test_gp_on_scores_captures_what_a_linear_model_cannot():
    L, X = _latent(k=150)
    Y = np.c_[np.tanh(1.5 * L[:, 0]), L[:, 1] + 0.4 * L[:, 1] ** 2]
    train, test = slice(0, 110), slice(110, None)
    pls = PLSCV(max_components=6, y_blocks=[1, 1]).fit(X[train], Y[train])
    gp = GPOnScores(max_components=6, y_blocks=[1, 1]).fit(X[train], Y[train])
    err = {name: np.sqrt(np.mean((m.predict(X[test]) - Y[test]) ** 2, axis=0))
           for name, m in (("pls", pls), ("gp", gp))}
    assert np.all(err["gp"] < 0.7 * err["pls"])


@pytest.mark.parametrize("name", sorted(LEARNERS))
def test_learners_follow_scikit_learn_conventions(name):
    est = learner(name, max_components=3, folds=3)
    assert clone(est).get_params() == est.get_params()
    L, X = _latent(k=30, features=50)
    fitted = est.fit(X, L[:, :1])
    assert fitted is est and est.n_components_ >= 1
    assert est.predict(X).shape == (30, 1)


def test_unknown_learner_and_bad_folds_are_one_line_errors():
    with pytest.raises(ParameterError, match="unknown learner 'svm'; known: plsr, gp"):
        learner("svm")
    L, X = _latent(k=10, features=20)
    with pytest.raises(ParameterError, match="folds must be between 2 and the 4 training"):
        PLSCV(folds=5).fit(X[:8], L[:8, :1], groups=np.repeat(np.arange(4), 2))


def test_gp_on_a_linear_problem_is_no_worse_than_its_plsr():
    """The grouped CV may choose no correction at all; then the GP is the PLSR."""
    L, X = _latent(k=90, noise=0.3)
    Y = L @ np.array([[1.0], [0.5], [-0.2]])
    gp = GPOnScores(max_components=6, folds=5).fit(X[:60], Y[:60])
    assert gp.cv_mse_.min() <= gp.cv_mse_[0]
    err_gp = np.sqrt(np.mean((gp.predict(X[60:]) - Y[60:]) ** 2))
    err_pls = np.sqrt(np.mean((gp.pls_.predict(X[60:]) - Y[60:]) ** 2))
    assert err_gp <= 1.05 * err_pls


# ------------------------------------------------------------------ issue 46: krr and auto


def _drawn(k, target, draws=3, noise=0.3, features=300, seed=0):
    """``draws`` noisy measurements of k experiments of a rank-3 latent problem: X
    (draws * k, features), Y (draws * k, n_targets), groups (draws * k,) and the latent
    L (k, 3)."""
    rng = np.random.default_rng(seed)
    L = rng.normal(size=(k, 3))
    W = rng.normal(size=(3, features))
    X = np.concatenate([L @ W + noise * rng.normal(size=(k, features))
                        for _ in range(draws)])
    Y = np.tile(target(L), (draws, 1))
    return X, Y, np.tile(np.arange(k), draws), L


def _square(L):
    """y = x0**2: no linear covariance with X, so PLSR cannot follow it."""
    return L[:, :1] ** 2


def _linear(L):
    return L @ np.array([[1.0], [0.5], [-0.2]])


def _held_out(X, Y, groups, test):
    """Rows of groups < test held out."""
    out = groups < test
    return (X[~out], Y[~out], groups[~out]), (X[out], Y[out])


def _rmse(model, X, Y) -> float:
    return float(np.sqrt(np.mean((model.predict(X) - Y) ** 2)))


@pytest.mark.parametrize("cls", [KRROnScores, AutoLearner])
def test_new_learners_follow_scikit_learn_conventions(cls):
    est = cls(max_components=4, folds=3, seed=2)
    params = est.get_params()
    assert vars(est) == params  # __init__ stores its parameters and nothing else
    assert est.set_params(folds=4) is est and est.folds == 4
    twin = clone(est)
    assert twin is not est and twin.get_params() == est.get_params()
    with pytest.raises(NotFittedError):
        est.predict(np.zeros((2, 50)))
    X, Y, groups, _ = _drawn(20, _square, features=50)
    assert est.fit(X, Y, groups) is est
    learned = set(vars(est)) - set(params)
    assert learned and all(name.endswith("_") and not name.startswith("_")
                           for name in learned)
    assert est.predict(X).shape == Y.shape
    assert "max_components" in repr(clone(est).set_params(max_components=5))


@pytest.mark.parametrize("name", ["krr", "auto"])
def test_grouped_cv_never_puts_one_experiment_on_both_sides(name, monkeypatch):
    """Every PLS fitted inside the CV (the linear part, the scores, every candidate of
    auto) trains on all the draws of an experiment or on none."""
    X, Y, groups, _ = _drawn(20, _square, features=40)
    group_of = {row.tobytes(): g for row, g in zip(X, groups, strict=True)}
    size = np.bincount(groups)
    fitted: list[np.ndarray] = []

    class Recording(BlockRegression):
        def fit(self, X, Y):
            fitted.append(np.array([group_of[row.tobytes()] for row in X]))
            return super().fit(X, Y)

    monkeypatch.setattr(learners_module, "BlockRegression", Recording)
    learner(name, max_components=4, folds=4).fit(X, Y, groups)
    assert len(fitted) >= 8  # 4 folds of the PLSCV and 4 of the correction, at least
    for trained in fitted:
        seen = np.bincount(trained, minlength=size.size)
        assert np.all((seen == 0) | (seen == size)), seen


@pytest.fixture(scope="module")
def square():
    """y = x0**2, 40 training experiments x 3 draws, 20 held out: the PLSR and the
    kernel ridge and auto fitted on the training part (shared: auto refits every
    candidate per fold)."""
    (X, Y, g), (Xt, Yt) = _held_out(*_drawn(60, _square, noise=0.1, features=100)[:3],
                                    test=20)
    fitted = {name: learner(name, max_components=6, folds=4).fit(X, Y, g)
              for name in ("plsr", "krr", "auto")}
    return fitted, Xt, Yt


def test_kernel_ridge_on_scores_follows_a_square_plsr_cannot(square):
    fitted, Xt, Yt = square
    krr = fitted["krr"]
    assert krr.krr_ is not None and krr.cv_mse_.min() < krr.cv_mse_[0]
    assert krr.cv_gain_se_[0] > krr.cv_gain_se_[1]
    assert krr.n_scores_ >= 1 and krr.params_ in learners_module.KRR_GRID
    assert _rmse(krr, Xt, Yt) < 0.5 * _rmse(fitted["plsr"], Xt, Yt)


def test_kernel_ridge_on_linear_data_is_the_plsr():
    """No setting beats "no correction" in the grouped CV by more than its standard
    error: the model is the PLSR."""
    (X, Y, g), (Xt, _) = _held_out(*_drawn(45, _linear, features=100)[:3], test=15)
    krr = KRROnScores(max_components=6, folds=4).fit(X, Y, g)
    assert krr.krr_ is None and krr.params_ is None and krr.n_scores_ == 0
    np.testing.assert_array_equal(krr.predict(Xt),
                                  PLSCV(max_components=6, folds=4).fit(X, Y, g).predict(Xt))


def test_auto_chooses_by_grouped_cv_on_the_training_data(square):
    fitted, Xt, Yt = square
    auto = fitted["auto"]
    assert auto.candidates_ == AUTO_CANDIDATES and auto.cv_errors_.shape == (3,)
    best = auto.candidates_[int(np.argmin(auto.cv_errors_))]
    assert auto.chosen_ == best != "plsr"
    assert auto.cv_errors_.min() < 0.5 * auto.cv_errors_[0]
    assert type(auto.model_) is LEARNERS[auto.chosen_]
    assert _rmse(auto, Xt, Yt) < 0.5 * _rmse(fitted["plsr"], Xt, Yt)


def test_auto_on_linear_data_keeps_the_plsr():
    (X, Y, g), _ = _held_out(*_drawn(30, _linear, features=60)[:3], test=10)
    linear = AutoLearner(max_components=4, folds=3).fit(X, Y, g)
    assert linear.chosen_ == "plsr", linear.cv_errors_  # a tie goes to the earlier


def test_auto_refuses_unknown_candidates_in_one_line():
    X, Y, g, _ = _drawn(10, _linear, features=20)
    with pytest.raises(ParameterError, match="auto chooses among plsr, gp, krr"):
        AutoLearner(candidates=("plsr", "svm")).fit(X, Y, g)
    with pytest.raises(ParameterError, match="got \\['auto'\\]"):
        AutoLearner(candidates=("auto",)).fit(X, Y, g)


@pytest.mark.parametrize("name", ["krr", "auto"])
def test_new_learners_save_and_load_with_skops_and_predict_the_same(name, square, tmp_path):
    from analysis.camera.predict.persist import load_model, save_model

    fitted, Xt, _ = square
    model = fitted[name]
    # a nonlinear correction is saved, not only a PLSR
    assert model.krr_ is not None if name == "krr" else model.chosen_ != "plsr"
    loaded, _ = load_model(save_model(tmp_path / name, {"learner": model}, {}))
    assert type(loaded["learner"]) is type(model)
    np.testing.assert_array_equal(loaded["learner"].predict(Xt), model.predict(Xt))


@pytest.mark.parametrize("name", ["krr", "auto"])
def test_a_force_model_of_a_new_learner_saves_and_loads(name, tmp_path):
    """Through analysis.camera.predictor.fit/save/load, as farm fit and farm predict."""
    from analysis import data
    from analysis.camera import predictor
    from analysis.camera.sensor import sensor_spec
    from tests.synthetic import make_combined_store

    make_combined_store(tmp_path / "s.zarr", n_experiments=24, seed=1, coupling=0.5,
                        rows=9, cols=24, tread_rows=4, tread_cols=8)
    ds = data.load(str(tmp_path / "s.zarr"))
    spec = sensor_spec("t2cam-2017,spacing_mm=20,noise_mm=0.2")
    model, check = predictor.fit(ds, spec, learner=name, draws=2, folds=3,
                                 max_components=6)
    assert model.info["learner"] == name and len(check) == 4
    path = predictor.save(model, tmp_path / "m", store="s.zarr", group="combined",
                          ids=["x"], check=check)
    loaded, _ = predictor.load(path)
    assert type(loaded.learner) is type(model.learner)
    X = np.random.default_rng(3).normal(size=(5, loaded.domain.mean_.size))
    pd_ = loaded.predict_features(X)
    np.testing.assert_array_equal(pd_.to_numpy(), model.predict_features(X).to_numpy())
