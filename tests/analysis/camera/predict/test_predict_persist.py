"""analysis.camera.predict.persist: skops model files with a manifest; tampered, untrusted,
pickled and malformed files are refused with one line; files saved before issue 49 moved
the camera's types still load."""

from __future__ import annotations

import hashlib
import importlib
import io
import json
import pickle
import warnings
import zipfile
from datetime import datetime

import numpy as np
import pytest
import skops.io as sio
from sklearn.base import BaseEstimator
from sklearn.cross_decomposition import PLSRegression
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.kernel_ridge import KernelRidge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from analysis.camera.learners import PLSCV, GPOnScores
from analysis.camera.predict import persist
from analysis.camera.predict.intervals import ConformalIntervals
from analysis.camera.predict.persist import (
    FORMAT_VERSION,
    LEGACY_TYPES,
    MANIFEST,
    MODEL,
    TRUSTED_TYPES,
    load_model,
    renamed_types,
    save_model,
)
from analysis.combined import BlockRegression
from analysis.errors import AnalysisError, ModelFileError, ParameterError
from tests.analysis.camera.predict.legacy_files import OLD_NAMES, saved_before_the_move

MANIFEST_IN = {"store": "/data/farm.zarr", "group": "combined", "experiment_ids": ["e1", "e2"],
               "sensor": {"camera": "T2Cam", "noise_mm": 0.02},
               "inputs": ["displacement", "surface_strain"], "targets": ["Fx", "Fy", "Fz"]}


class Custom(BaseEstimator):
    """A class no trusted list names."""

    def __init__(self, a=1):
        self.a = a


class Boom:
    """Pickling this object would run ``open(marker, "w")`` on unpickling."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (open, (str(self.marker), "w"))


@pytest.fixture(scope="module")
def xy():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 6))
    Y = X @ rng.normal(size=(6, 3)) + 0.01 * rng.normal(size=(40, 3))
    return X, Y


@pytest.fixture
def saved(tmp_path, xy):
    X, Y = xy
    model = BlockRegression("plsr", 2, x_blocks=[3, 3], y_blocks=[2, 1]).fit(X, Y)
    return save_model(tmp_path / "model", model, MANIFEST_IN), model


def _refused(path, **kw) -> str:
    with pytest.raises(ModelFileError) as info:
        load_model(path, **kw)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


def _rewrite_manifest(path, **changes):
    manifest = json.loads((path / MANIFEST).read_text())
    manifest.update(changes)
    (path / MANIFEST).write_text(json.dumps(manifest))


def test_model_file_error_is_an_analysis_error():
    assert issubclass(ModelFileError, AnalysisError) and issubclass(ModelFileError, ValueError)


def test_block_regression_round_trip(saved, xy):
    path, model = saved
    assert sorted(p.name for p in path.iterdir()) == [MANIFEST, MODEL]
    loaded, _ = load_model(path)
    assert type(loaded) is BlockRegression
    np.testing.assert_array_equal(loaded.predict(xy[0]), model.predict(xy[0]))
    assert loaded.get_params() == model.get_params()


def test_the_manifest(saved):
    path, _ = saved
    _, manifest = load_model(path)
    assert manifest["format_version"] == FORMAT_VERSION
    assert datetime.fromisoformat(manifest["created"]).utcoffset().total_seconds() == 0
    for key, value in MANIFEST_IN.items():
        assert manifest[key] == value
    assert manifest["model_sha256"] == hashlib.sha256((path / MODEL).read_bytes()).hexdigest()
    versions = manifest["versions"]
    assert set(versions) == {"tyre-farm", "numpy", "scikit-learn", "skops", "python"}
    assert versions["numpy"] == np.__version__ and versions["skops"]
    assert manifest["extra"] == {}


@pytest.mark.parametrize("pipeline", [
    make_pipeline(StandardScaler(), PLSRegression(n_components=2)),
    make_pipeline(StandardScaler(), KernelRidge(alpha=0.1, kernel="rbf")),
])
def test_sklearn_pipeline_round_trip_as_zip(tmp_path, xy, pipeline):
    X, Y = xy
    pipeline.fit(X, Y)
    path = save_model(tmp_path / "pipe.zip", pipeline, {"targets": ["Fx", "Fy", "Fz"]})
    assert zipfile.is_zipfile(path)
    loaded, manifest = load_model(path)
    np.testing.assert_array_equal(loaded.predict(X), pipeline.predict(X))
    assert manifest["targets"] == ["Fx", "Fy", "Fz"]


def test_gaussian_process_with_kernels_round_trip(tmp_path, xy):
    X, Y = xy
    gp = GaussianProcessRegressor(ConstantKernel() * RBF(np.ones(6)) + WhiteKernel(),
                                  normalize_y=True, optimizer=None).fit(X[:20], Y[:20])
    loaded, _ = load_model(save_model(tmp_path / "gp", gp, {}))
    np.testing.assert_array_equal(loaded.predict(X), gp.predict(X))


def test_a_payload_dict_with_intervals_and_arrays(tmp_path, xy):
    """What the force model saves: a learner, its intervals, arrays; extra metadata."""
    X, Y = xy
    model = BlockRegression("pcr", 2).fit(X, Y)
    ci = ConformalIntervals(alpha=0.1).fit(Y - model.predict(X))
    payload = {"learner": model, "intervals": ci,
               "surface": {"xyz": X[:, :3], "periodic": True, "node_index": np.arange(40)}}
    extra = {"quantiles": ci.quantile_, "rmse": np.float64(0.5), "check": [{"pct": np.nan}]}
    path = save_model(tmp_path / "m", payload, {**MANIFEST_IN, "extra": extra})
    loaded, manifest = load_model(path)
    np.testing.assert_array_equal(loaded["learner"].predict(X), model.predict(X))
    np.testing.assert_array_equal(loaded["intervals"].quantile_, ci.quantile_)
    np.testing.assert_array_equal(loaded["surface"]["xyz"], X[:, :3])
    assert loaded["surface"]["periodic"] is True
    assert manifest["extra"]["quantiles"] == ci.quantile_.tolist()
    assert manifest["extra"]["rmse"] == 0.5 and np.isnan(manifest["extra"]["check"][0]["pct"])


def test_saved_farm_types_are_exactly_trusted(saved):
    path, _ = saved
    found = sio.get_untrusted_types(file=path / MODEL)
    assert found == ["analysis.combined.BlockRegression", "analysis.combined.BlockScaler",
                     "analysis.pls.SIMPLSRegression"]
    assert set(found) <= set(TRUSTED_TYPES)


@pytest.mark.parametrize("name", TRUSTED_TYPES)
def test_every_trusted_name_is_a_class(name):
    module, _, qualname = name.rpartition(".")
    assert isinstance(getattr(importlib.import_module(module), qualname), type)


def test_a_tampered_model_file_is_refused(saved):
    path, _ = saved
    data = bytearray((path / MODEL).read_bytes())
    data[len(data) // 2] ^= 0x01
    (path / MODEL).write_bytes(bytes(data))
    assert "checksum" in _refused(path)


def test_an_untrusted_type_is_refused_on_save_and_on_load(tmp_path):
    with pytest.raises(ModelFileError, match="Custom") as info:
        save_model(tmp_path / "c", {"x": Custom()}, {})
    assert "\n" not in str(info.value)
    # a file written around save_model, with a matching checksum: the type check holds
    saved = save_model(tmp_path / "c", ConformalIntervals().fit(np.ones((20, 1))), {})
    data = sio.dumps({"x": Custom()})
    (saved / MODEL).write_bytes(data)
    _rewrite_manifest(saved, model_sha256=hashlib.sha256(data).hexdigest())
    msg = _refused(saved)
    assert "untrusted" in msg and f"{__name__}.Custom" in msg
    loaded, _ = load_model(saved, trusted=[f"{__name__}.Custom"])  # reviewed by the caller
    assert isinstance(loaded["x"], Custom)


def test_a_pickle_renamed_model_skops_is_refused_unexecuted(saved, tmp_path):
    path, _ = saved
    marker = tmp_path / "executed"
    data = pickle.dumps(Boom(marker))
    (path / MODEL).write_bytes(data)
    assert "checksum" in _refused(path)
    _rewrite_manifest(path, model_sha256=hashlib.sha256(data).hexdigest())
    assert "not a skops file" in _refused(path)
    assert not marker.exists()


def test_missing_and_corrupt_parts(saved, tmp_path):
    path, _ = saved
    manifest = (path / MANIFEST).read_text()
    (path / MANIFEST).write_text(manifest[: len(manifest) // 2])
    assert "not valid JSON" in _refused(path)
    (path / MANIFEST).write_text('{"format": "something-else"}')
    assert "not a tyre-farm-model manifest" in _refused(path)
    (path / MANIFEST).unlink()
    assert "no manifest.json" in _refused(path)
    (path / MANIFEST).write_text(manifest)
    (path / MODEL).unlink()
    assert "no model.skops" in _refused(path)
    assert "no such directory" in _refused(tmp_path / "absent")
    (tmp_path / "junk.zip").write_bytes(b"PK\x03\x04 not really a zip")
    assert "readable .zip" in _refused(tmp_path / "junk.zip")
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as zf:
        zf.writestr("other.txt", "x")
    (tmp_path / "other.zip").write_bytes(buffer.getvalue())
    assert "no manifest.json" in _refused(tmp_path / "other.zip")


def test_wrong_format_version_is_refused(saved):
    path, _ = saved
    _rewrite_manifest(path, format_version=FORMAT_VERSION + 1)
    assert f"format version {FORMAT_VERSION + 1}" in _refused(path)


def test_an_empty_model_file_is_refused(saved):
    path, _ = saved
    (path / MODEL).write_bytes(b"")
    _rewrite_manifest(path, model_sha256=hashlib.sha256(b"").hexdigest())
    assert "empty" in _refused(path)


def test_save_model_checks_its_input(tmp_path, xy):
    model = ConformalIntervals().fit(np.ones((20, 1)))
    with pytest.raises(ParameterError, match="unknown manifest keys"):
        save_model(tmp_path / "a", model, {"stroe": "typo"})
    with pytest.raises(ParameterError, match="JSON"):
        save_model(tmp_path / "b", model, {"extra": {"when": object()}})
    with pytest.raises(ParameterError, match="list of names"):
        save_model(tmp_path / "c", model, {"targets": "Fx"})
    (tmp_path / "file").write_text("x")
    with pytest.raises(ModelFileError, match="is a file"):
        save_model(tmp_path / "file", model, {})


def test_an_attribute_skops_cannot_save_is_named(tmp_path, xy):
    pd = pytest.importorskip("pandas")
    model = BlockRegression("plsr", 2).fit(*xy)
    model.table_ = pd.DataFrame({"a": [1.0, 2.0]})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ModelFileError, match=r"model\.table_ \(a pandas") as info:
            save_model(tmp_path / "m", model, {})
    assert "\n" not in str(info.value)


# ------------------------------------------------------- files saved before the move (issue 49)
@pytest.fixture(scope="module")
def force_model_parts():
    """What a force model saves: a GP on PLS scores (a PLSCV inside) and its intervals."""
    rng = np.random.default_rng(49)
    X = rng.normal(size=(32, 3))
    Y = np.column_stack([X[:, 0] + 0.5 * X[:, 1], np.sin(2 * X[:, 0]) + 0.5 * X[:, 2]])
    gp = GPOnScores(max_components=3, folds=4).fit(X, Y, np.repeat(np.arange(16), 2))
    assert gp.gp_ is not None  # the kernels are in the file too
    intervals = ConformalIntervals(alpha=0.2).fit(Y - gp.predict(X))
    return {"learner": gp, "intervals": intervals}, rng.normal(size=(5, 3))


@pytest.mark.parametrize("name", ["model", "model.zip"])
def test_a_model_file_saved_before_the_camera_moved_loads_and_predicts_the_same(
        tmp_path, force_model_parts, name):
    payload, probe = force_model_parts
    path = saved_before_the_move(save_model(tmp_path / name, payload, MANIFEST_IN))
    data = (zipfile.ZipFile(path).read(MODEL) if path.suffix == ".zip"
            else (path / MODEL).read_bytes())
    assert sio.get_untrusted_types(data=data) == sorted(
        [*OLD_NAMES, "analysis.combined.BlockRegression", "analysis.combined.BlockScaler",
         "analysis.pls.SIMPLSRegression", "sklearn.gaussian_process.kernels.ConstantKernel",
         "sklearn.gaussian_process.kernels.Product", "sklearn.gaussian_process.kernels.RBF",
         "sklearn.gaussian_process.kernels.Sum", "sklearn.gaussian_process.kernels.WhiteKernel"])
    loaded, manifest = load_model(path)
    gp, intervals = loaded["learner"], loaded["intervals"]
    assert type(gp) is GPOnScores and type(gp.pls_) is PLSCV
    assert type(intervals) is ConformalIntervals
    np.testing.assert_array_equal(gp.predict(probe), payload["learner"].predict(probe))
    np.testing.assert_array_equal(intervals.quantile_, payload["intervals"].quantile_)
    assert manifest["model_sha256"] == hashlib.sha256(data).hexdigest()  # checked as written


def test_without_the_legacy_names_such_a_file_would_be_refused(tmp_path, force_model_parts,
                                                               monkeypatch):
    path = saved_before_the_move(save_model(tmp_path / "m", force_model_parts[0], {}))
    monkeypatch.setattr(persist, "LEGACY_TYPES", {})
    assert "untrusted types ['analysis.learners.GPOnScores'" in _refused(path)


def test_a_legacy_file_edited_after_saving_is_refused_by_its_checksum(tmp_path,
                                                                      force_model_parts):
    """The checksum is checked on the file as written, before any renaming."""
    path = saved_before_the_move(save_model(tmp_path / "m", force_model_parts[0], {}))
    data = (path / MODEL).read_bytes()
    (path / MODEL).write_bytes(data.replace(b"analysis.learners", b"analysis.learnerz", 1))
    assert "does not match the checksum" in _refused(path)


def test_every_legacy_name_is_an_old_module_and_a_trusted_type_now():
    assert sorted(LEGACY_TYPES) == sorted(OLD_NAMES)
    for old, new in LEGACY_TYPES.items():
        assert new in TRUSTED_TYPES and old not in TRUSTED_TYPES
        assert old.rpartition(".")[2] == new.rpartition(".")[2]  # moved, not renamed
        with pytest.raises(ModuleNotFoundError):  # no shim left behind: the map is needed
            importlib.import_module(old.rpartition(".")[0])


def test_files_with_current_names_or_no_skops_file_pass_through_unchanged(saved):
    path, _ = saved
    data = (path / MODEL).read_bytes()
    assert renamed_types(data) is data
    assert renamed_types(b"not a zip") == b"not a zip"
