"""scikit-learn conventions: the estimator checks, Pipeline, cross_val_score, parameters."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.model_selection import KFold, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils.estimator_checks import parametrize_with_checks

from analysis.crosscov import CrossCovariancePCA
from analysis.errors import ComponentsError, ParameterError
from analysis.pcr import PCRegression
from analysis.pls import SIMPLSRegression
from analysis.selection import select_n_components


@parametrize_with_checks([SIMPLSRegression(), PCRegression(), CrossCovariancePCA()])
def test_scikit_learn_estimator_checks(estimator, check):
    check(estimator)


@pytest.mark.parametrize("estimator", [SIMPLSRegression(2), PCRegression(2)])
def test_in_a_pipeline_with_cross_val_score(thesis_xy, estimator):
    X, Y = thesis_xy
    pipe = make_pipeline(StandardScaler(), estimator)
    scores = cross_val_score(pipe, X, Y, cv=KFold(3))
    assert scores.shape == (3,) and np.all(np.isfinite(scores))
    fitted = pipe.fit(X, Y)
    assert fitted.predict(X).shape == Y.shape
    assert fitted.score(X, Y) > 0.9


@pytest.mark.parametrize("bad", [0, -1, 1.5, "3", True])
@pytest.mark.parametrize("cls", [SIMPLSRegression, PCRegression, CrossCovariancePCA])
def test_invalid_n_components_fail_at_fit_with_our_error(random_xy, cls, bad):
    X, Y = random_xy(10, 5, 2)
    est = cls(n_components=bad)
    assert est.get_params()["n_components"] is bad  # stored unchanged
    with pytest.raises(ParameterError, match="positive integer"):
        est.fit(X, Y)


def test_clone_and_not_fitted():
    est = SIMPLSRegression(3)
    assert clone(est).get_params() == {"n_components": 3}
    with pytest.raises(NotFittedError):
        est.predict(np.zeros((2, 3)))


def test_cross_validated_component_count(thesis_xy):
    X, Y = thesis_xy
    best, table = select_n_components(SIMPLSRegression(), X, Y, cv=7)
    assert list(table["n_components"]) == [1, 2, 3, 4, 5]  # LOO on 7: folds of 6 -> at most 5
    assert best == int(table.loc[table["mse_mean"].idxmin(), "n_components"])
    assert np.all(table["mse_mean"] > 0)
    with pytest.raises(ComponentsError):
        select_n_components(SIMPLSRegression(), X[:3], Y[:3], cv=2)
    with pytest.raises(ParameterError):
        select_n_components(SIMPLSRegression(), X, Y, cv=8)
