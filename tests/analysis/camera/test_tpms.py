"""A force model that also reads the tyre's inflation pressure, as a TPMS does (issue 47):
the pressure a real system knows, one feature beside the camera's thousands."""

from __future__ import annotations

import numpy as np
import pytest

from analysis import data
from analysis.camera import predictor
from analysis.camera.features import TPMS, pressures, with_tpms
from analysis.camera.mismatch import clouds, table
from analysis.camera.sensor import sensor_spec
from analysis.errors import ParameterError
from tests.synthetic import make_combined_store

SMALL = {"rows": 9, "cols": 24, "tread_rows": 4, "tread_cols": 8}
SENSOR = sensor_spec("t2cam-2017,spacing_mm=20,noise_mm=0.2")
TPMS_INPUTS = (*predictor.INPUTS, TPMS)


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    """Forces that grow with the pressure as (p / 0.2 MPa)^3, which the synthetic fields
    do not show: only a model that reads the pressure can know it."""
    path = tmp_path_factory.mktemp("tpms") / "s.zarr"
    make_combined_store(path, n_experiments=60, seed=3, group="tyre",
                        vary=("deflection", "pressure", "shift_x", "shift_y", "tilt"), **SMALL)
    ds = data.load(str(path)).load()
    factor = (ds["pressure"] / 0.2) ** 3
    for var in ("total_force", "moment"):
        ds[var] = ds[var] * factor
    return ds


@pytest.fixture(scope="module")
def models(store):
    return {tpms: predictor.fit(store, SENSOR, draws=2, folds=4, seed=1,
                                inputs=TPMS_INPUTS if tpms else predictor.INPUTS)
            for tpms in (False, True)}


def test_the_pressure_is_one_column_after_the_camera_s(store):
    kpa = pressures(store)
    assert kpa.min() >= 180 and kpa.max() <= 220  # the store holds MPa
    X = np.zeros((len(kpa), 5))
    np.testing.assert_array_equal(with_tpms(X, kpa, TPMS_INPUTS)[:, -1], kpa)
    assert with_tpms(X, kpa, predictor.INPUTS) is X


def test_a_model_reading_the_pressure_knows_what_the_camera_cannot_see(models):
    fz = {tpms: check.set_index("target").loc["Fz", "rmse"]
          for tpms, (_, check) in models.items()}
    assert models[True][0].tpms and not models[False][0].tpms
    assert fz[True] < 0.5 * fz[False], fz


def test_a_tpms_reading_10_percent_high_biases_fz_up(models, store):
    model = models[True][0]
    X, T = clouds(model, store, draws=1, seed=4)
    Xh, _ = clouds(model, store, draws=1, seed=4, tpms_error=0.1)
    np.testing.assert_allclose(Xh[:, -1], 1.1 * X[:, -1])
    np.testing.assert_array_equal(Xh[:, :-1], X[:, :-1])
    true, high = table(model, X, T).set_index("target"), table(model, Xh, T).set_index("target")
    assert high.loc["Fz", "bias"] > true.loc["Fz", "bias"] + 2 * true.loc["Fz", "rmse"]


def test_predict_needs_the_reading_and_a_camera_only_model_refuses_one(models, store):
    tpms, plain = models[True][0], models[False][0]
    with pytest.raises(ParameterError, match="--pressure-kpa"):
        tpms.check_pressure(None)
    with pytest.raises(ParameterError, match="without --tpms"):
        plain.check_pressure(200.0)
    for bad in (0.0, -5.0, float("nan"), float("inf")):
        with pytest.raises(ParameterError, match="positive"):
            tpms.check_pressure(bad)
    tpms.check_pressure(200.0)
    plain.check_pressure(None)


def test_a_model_reading_the_pressure_saves_and_loads_as_it_predicts(models, store, tmp_path):
    model, check = models[True]
    predictor.save(model, tmp_path / "m", store="s", group="tyre", ids=["a"], check=check)
    loaded, manifest = predictor.load(tmp_path / "m")
    assert manifest["inputs"] == list(TPMS_INPUTS) and loaded.tpms
    X, _ = clouds(model, store, draws=1, seed=5)
    np.testing.assert_allclose(loaded.predict_features(X).to_numpy(),
                               model.predict_features(X).to_numpy())


def test_fit_refuses_inputs_without_a_camera_field(store):
    with pytest.raises(ParameterError, match="camera fields"):
        predictor.fit(store, SENSOR, draws=1, folds=3, inputs=(TPMS,))
