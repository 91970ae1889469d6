"""The feature domain of a force model (issue 47): T² and Q with measured limits."""

import numpy as np
import pytest

from analysis.camera.predict.domain import FeatureDomain
from analysis.errors import ParameterError


def _rows(n, seed=0, f=12):
    rng = np.random.default_rng(seed)
    latent = rng.normal(size=(n, 3))
    mixing = np.random.default_rng(99).normal(size=(3, f))
    return latent @ mixing + 0.01 * rng.normal(size=(n, f))


def test_every_training_and_checked_row_is_inside():
    X, Xc = _rows(40), _rows(10, seed=1)
    dom = FeatureDomain().fit(X, Xc)
    assert not any(dom.outside(np.vstack([X, Xc])))
    t2, q = dom.scores(np.vstack([X, Xc]))
    assert t2.max() * dom.margin == pytest.approx(dom.t2_limit_)
    assert q.max() * dom.margin == pytest.approx(dom.q_limit_)


def test_a_new_direction_raises_q_and_a_far_point_raises_t2():
    X = _rows(40)
    dom = FeatureDomain().fit(X)
    assert dom.components_.shape[0] == 3  # three latent directions hold 99 %
    off = X[:1] + 50.0 * np.eye(1, X.shape[1], 5)  # along no trained direction
    far = 30.0 * X[:1]  # along the trained ones, far out
    assert "Q" in dom.outside(off)[0]
    assert "T2" in dom.outside(far)[0]


def test_non_finite_rows_are_outside():
    dom = FeatureDomain().fit(_rows(20))
    row = _rows(1, seed=3)
    row[0, 2] = np.inf
    t2, q = dom.scores(row)
    assert np.isinf(t2[0]) and np.isinf(q[0]) and dom.outside(row)[0]


def test_round_trip_and_a_dict_of_another_shape_is_refused():
    dom = FeatureDomain().fit(_rows(30))
    back = FeatureDomain.from_dict(dom.to_dict())
    X = _rows(5, seed=7)
    assert np.allclose(back.scores(X), dom.scores(X))
    broken = dict(dom.to_dict(), scale=np.ones(3))
    with pytest.raises(ValueError, match="do not agree"):
        FeatureDomain.from_dict(broken)
    with pytest.raises(KeyError):
        FeatureDomain.from_dict({"variance": 0.99})


@pytest.mark.parametrize("kwargs", [{"variance": 0.0}, {"variance": 1.5}, {"margin": 0.5}])
def test_bad_settings_are_refused(kwargs):
    with pytest.raises(ParameterError):
        FeatureDomain(**kwargs).fit(_rows(10))
