"""The learners of the sensor study (issue 27): CV-chosen PLSR and a GP on its scores."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from analysis.camera.learners import LEARNERS, PLSCV, GPOnScores, learner
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
