"""Save and load a trained predictor safely: skops, a manifest, a checksum.

A model is one directory (or one ``.zip`` archive) holding

- ``model.skops``: the estimator (or a dict of estimators and arrays), written by
  :func:`skops.io.dump`. skops stores objects as a schema of known types, not as pickle
  byte code: loading builds only the types it is allowed to, so a model file from
  elsewhere cannot run code on load. Never replace it by pickle/joblib.
- ``manifest.json``: what the model is (:data:`FORMAT_VERSION`, creation time in UTC,
  training store, group and experiment ids, sensor spec, input and target names, the
  package versions that wrote it, any ``extra`` the caller passes: interval quantiles,
  held-out errors...) and the SHA-256 of ``model.skops``.

:func:`load_model` refuses, with one :class:`~analysis.errors.ModelFileError` line: a
missing or corrupt manifest, an unknown format version, a model file whose checksum
differs from the manifest's (corrupted or edited), a file that is not skops (a pickle
renamed ``model.skops``), and a file holding any type outside :data:`TRUSTED_TYPES`
(plus skops' own defaults: builtins, numpy arrays and dtypes, scikit-learn's
estimators). The checksum catches corruption and careless edits, not an attacker who
also edits the manifest; the type check is what keeps such a file harmless.

A file saved before one of the farm's trusted types moved names it by its old module;
after the checksum is checked on the file as written, :func:`load_model` renames such
types to where they live now (:data:`LEGACY_TYPES`) and checks the types of the result.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import platform
import tempfile
import zipfile
from collections.abc import Iterable, Mapping
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from analysis.errors import ModelFileError, ParameterError

__all__ = ["FORMAT_VERSION", "LEGACY_TYPES", "MANIFEST", "MODEL", "TRUSTED_TYPES",
           "load_model", "renamed_types", "save_model", "untrusted_types"]

#: version of the layout below; :func:`load_model` reads only this one
FORMAT_VERSION = 1
FORMAT_NAME = "tyre-farm-model"
MODEL = "model.skops"
#: the member of a skops archive that names its types (skops.io's layout)
SCHEMA = "schema.json"
MANIFEST = "manifest.json"
#: the biggest manifest / model file read (a guard against zip bombs and wrong files)
MAX_MANIFEST_BYTES = 16 * 2**20
MAX_MODEL_BYTES = 4 * 2**30

#: Types, by skops' name (module.qualname), that the farm saves and loads beyond skops'
#: defaults (which trust builtins, numpy arrays/dtypes and scikit-learn's estimators,
#: Pipeline, StandardScaler, PLSRegression, KernelRidge, GaussianProcessRegressor, but not
#: the GP kernels). Each is a plain estimator whose state is arrays and numbers. Adding a
#: class here is a security decision: it must rebuild from its attributes without running
#: anything else (no custom __setstate__ that evaluates, imports or opens files).
#: KRROnScores and AutoLearner (issue 46) hold arrays, numbers, strings and the estimators
#: above (PLSCV, BlockRegression, KernelRidge); no __setstate__. skops' refusal of
#: ``sklearn.tree._tree.Tree`` stands: scikit-learn indexes a tree's node arrays without
#: bounds checks, so a crafted file could read memory out of bounds on predict - no
#: learner of the farm holds trees.
TRUSTED_TYPES: tuple[str, ...] = (
    "analysis.camera.learners.AutoLearner",
    "analysis.camera.learners.GPOnScores",
    "analysis.camera.learners.KRROnScores",
    "analysis.camera.learners.PLSCV",
    "analysis.camera.predict.intervals.ConformalIntervals",
    "analysis.combined.BlockRegression",
    "analysis.combined.BlockScaler",
    "analysis.pcr.PCRegression",
    "analysis.pls.SIMPLSRegression",
    "analysis.surrogate.FieldSurrogate",
    *(f"sklearn.gaussian_process.kernels.{k}" for k in (
        "CompoundKernel", "ConstantKernel", "DotProduct", "ExpSineSquared", "Exponentiation",
        "Matern", "PairwiseKernel", "Product", "RBF", "RationalQuadratic", "Sum",
        "WhiteKernel")),
)

#: Trusted types that moved: the name a model file saved before the move holds -> the name
#: now (issue 49: the camera's room, analysis/camera/). skops names a type by its module,
#: so such a file's schema still says ``analysis.learners.PLSCV``; :func:`load_model` reads
#: it as the type's new name (:func:`renamed_types`). A moved trusted type is added here,
#: never removed while model files of the old name may exist.
LEGACY_TYPES: dict[str, str] = {
    "analysis.learners.GPOnScores": "analysis.camera.learners.GPOnScores",
    "analysis.learners.PLSCV": "analysis.camera.learners.PLSCV",
    "analysis.predict.intervals.ConformalIntervals":
        "analysis.camera.predict.intervals.ConformalIntervals",
}

#: manifest keys the caller may give to :func:`save_model` (all optional)
CALLER_KEYS = ("store", "group", "experiment_ids", "sensor", "inputs", "targets", "extra")
_WRITTEN_KEYS = ("format", "format_version", "created", "versions", "model_file",
                 "model_sha256")


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def _versions() -> dict[str, str | None]:
    return {"tyre-farm": _version("tyre-farm"), "numpy": _version("numpy"),
            "scikit-learn": _version("scikit-learn"), "skops": _version("skops"),
            "python": platform.python_version()}


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, (set, frozenset, tuple)):
        return list(obj)
    raise TypeError(type(obj).__name__)


def _strings(key: str, value: Any) -> list[str]:
    if value is None:
        return []
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise ParameterError(f"manifest[{key!r}] must be a list of names, got "
                             f"{type(value).__name__}")
    return [str(v) for v in value]


def _mapping(key: str, value: Any) -> dict:
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ParameterError(f"manifest[{key!r}] must be a dict, got {type(value).__name__}")
    return dict(value)


def _build_manifest(given: Mapping, checksum: str) -> dict:
    if not isinstance(given, Mapping):
        raise ParameterError(f"manifest must be a dict, got {type(given).__name__}")
    unknown = sorted(set(given) - set(CALLER_KEYS))
    if unknown:
        raise ParameterError(f"unknown manifest keys {unknown}; give only {list(CALLER_KEYS)} "
                             "(put anything else under 'extra')")
    store, group = given.get("store"), given.get("group")
    return {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "store": None if store is None else os.fspath(store),
        "group": None if group is None else str(group),
        "experiment_ids": _strings("experiment_ids", given.get("experiment_ids")),
        "sensor": _mapping("sensor", given.get("sensor")),
        "inputs": _strings("inputs", given.get("inputs")),
        "targets": _strings("targets", given.get("targets")),
        "versions": _versions(),
        "model_file": MODEL,
        "model_sha256": checksum,
        "extra": _mapping("extra", given.get("extra")),
    }


def untrusted_types(data: bytes, trusted: Iterable[str] = ()) -> list[str]:
    """Types in a skops file (given as bytes) outside skops' defaults, :data:`TRUSTED_TYPES`
    and ``trusted``; empty when the file is safe to load. Raises ModelFileError when the
    bytes are not a skops file."""
    import skops.io as sio

    if not data:
        raise ModelFileError(f"{MODEL} is empty; save the model again")
    try:
        found = sio.get_untrusted_types(data=data)
    except Exception as exc:  # BadZipFile, KeyError (no schema), JSON errors, ...
        raise ModelFileError(f"{MODEL} is not a skops file ({_why(exc)}); a model must be "
                             "written by save_model (pickle/joblib files are refused)") from None
    allowed = set(TRUSTED_TYPES) | set(trusted)
    return sorted(t for t in found if t not in allowed)


def renamed_types(data: bytes) -> bytes:
    """A skops file (given as bytes) with each type of :data:`LEGACY_TYPES` named as it is
    now; ``data`` itself when it holds none (or is not a skops file: :func:`untrusted_types`
    says so).

    Only the schema's ``__module__``/``__class__`` pairs that name a legacy type change;
    every other member of the archive is copied as it was. Call it after the checksum
    was checked on the file's own bytes, and check the types of what it returns.
    """
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            schema = json.loads(zf.read(SCHEMA))
            if not _rename(schema):
                return data
            out = io.BytesIO()
            with zipfile.ZipFile(out, "w") as new:
                for info in zf.infolist():
                    body = (json.dumps(schema, indent=2).encode() if info.filename == SCHEMA
                            else zf.read(info))
                    new.writestr(info, body)  # the member's own name, date, compression
    except Exception:  # not a skops file: refused by the type check, in one line
        return data
    return out.getvalue()


def _rename(schema: Any) -> int:
    """Rename every node of ``schema`` (skops' JSON tree) whose type is a key of
    :data:`LEGACY_TYPES`, in place; the count renamed."""
    count, stack = 0, [schema]
    while stack:
        node = stack.pop()
        if isinstance(node, list):
            stack.extend(node)
            continue
        if not isinstance(node, dict):
            continue
        module, name = node.get("__module__"), node.get("__class__")
        new = LEGACY_TYPES.get(f"{module}.{name}")
        if isinstance(module, str) and isinstance(name, str) and new is not None:
            node["__module__"], node["__class__"] = new.rsplit(".", 1)
            count += 1
        stack.extend(node.values())
    return count


def _why(exc: BaseException) -> str:
    msg = (str(exc).splitlines() or [""])[0][:120]
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def _dump(estimator: Any) -> bytes:
    import skops.io as sio

    try:
        return sio.dumps(estimator)
    except Exception as exc:
        where = _unsaveable(estimator, "model")
        raise ModelFileError(f"skops cannot save {where} ({_why(exc)}); store such attributes "
                             "as numpy arrays, or in the manifest's 'extra'") from None


def _unsaveable(obj: Any, where: str, depth: int = 0) -> str:
    """Where in ``obj`` (an attribute path) the object skops cannot save sits."""
    import skops.io as sio

    children: Iterable[tuple[str, Any]]
    if isinstance(obj, Mapping):
        children = ((f"{where}[{k!r}]", v) for k, v in obj.items())
    elif isinstance(obj, (list, tuple)):
        children = ((f"{where}[{i}]", v) for i, v in enumerate(obj))
    elif hasattr(obj, "get_params") and hasattr(obj, "__dict__"):  # an estimator
        children = ((f"{where}.{k}", v) for k, v in vars(obj).items())
    else:
        children = ()
    if depth < 20:
        for name, child in children:
            try:
                sio.dumps(child)
            except Exception:
                return _unsaveable(child, name, depth + 1)
    return f"{where} (a {type(obj).__module__}.{type(obj).__qualname__})"


def _write_atomic(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def save_model(path: str | os.PathLike, estimator: Any, manifest: Mapping) -> Path:
    """Write ``estimator`` and its manifest to a model directory, or a ``.zip`` archive.

    Parameters
    ----------
    path : str or path-like
        A directory (created if needed; ``model.skops`` and ``manifest.json`` in it are
        replaced) or a file name ending in ``.zip``.
    estimator : object
        A fitted estimator, or a dict/list of estimators, arrays and plain values. Every
        type in it must be one :func:`load_model` trusts (:data:`TRUSTED_TYPES` or skops'
        defaults); anything else is refused here already.
    manifest : dict
        The caller's part of the manifest, keys of :data:`CALLER_KEYS`, all optional:
        ``store`` (training store path), ``group``, ``experiment_ids`` (list, stored as
        str), ``sensor`` (dict: the sensor spec), ``inputs`` and ``targets`` (names),
        ``extra`` (dict of JSON-ready metadata: conformal quantiles, held-out errors;
        numpy arrays and scalars are converted). Format version, creation time, package
        versions and the checksum are added here.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    data = _dump(estimator)
    bad = untrusted_types(data)
    if bad:
        raise ModelFileError(f"the model holds types load_model would refuse: {bad}; add them "
                             "to analysis.camera.predict.persist.TRUSTED_TYPES only if they are "
                             "plain estimators (arrays and numbers)")
    text = _manifest_text(manifest, data)
    if path.suffix.lower() == ".zip":
        return _write_zip(path, data, text)
    return _write_dir(path, data, text)


def _manifest_text(manifest: Mapping, data: bytes) -> str:
    """The full manifest as JSON text (one line of error if the caller's part cannot be)."""
    full = _build_manifest(manifest, _sha256(data))
    try:
        return json.dumps(full, indent=2, default=_json_default)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"the manifest holds a value JSON cannot store ({exc}); give "
                             "numbers, strings, lists and dicts") from None


def _write_zip(path: Path, data: bytes, text: str) -> Path:
    """The model and its manifest as one ``.zip`` archive, written atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as zf:
        zf.writestr(MODEL, data, compress_type=zipfile.ZIP_STORED)
        zf.writestr(MANIFEST, text, compress_type=zipfile.ZIP_DEFLATED)
    _write_atomic(path, buffer.getvalue())
    return path


def _write_dir(path: Path, data: bytes, text: str) -> Path:
    """The model and its manifest in a directory, the manifest last."""
    if path.exists() and not path.is_dir():
        raise ModelFileError(f"model path {path} is a file; give a directory or a .zip name")
    path.mkdir(parents=True, exist_ok=True)
    _write_atomic(path / MODEL, data)
    _write_atomic(path / MANIFEST, text.encode())  # last: no manifest, no model
    return path


def _read_parts(path: Path) -> tuple[bytes | None, bytes | None]:
    """(manifest bytes, model bytes) of a model directory or zip; None for a missing part."""

    def read(p: Path) -> bytes | None:
        if not p.is_file():
            return None
        limit = MAX_MANIFEST_BYTES if p.name == MANIFEST else MAX_MODEL_BYTES
        if p.stat().st_size > limit:
            raise ModelFileError(f"model {path}: {p.name} is larger than {limit} bytes; not a "
                                 "model written by save_model")
        return p.read_bytes()

    if path.is_dir():
        return read(path / MANIFEST), read(path / MODEL)
    if not path.is_file():
        raise ModelFileError(f"model {path}: no such directory or .zip; give the path "
                             "save_model wrote")
    try:
        with zipfile.ZipFile(path) as zf:
            parts: list[bytes | None] = []
            for name, limit in ((MANIFEST, MAX_MANIFEST_BYTES), (MODEL, MAX_MODEL_BYTES)):
                try:
                    info = zf.getinfo(name)
                except KeyError:
                    parts.append(None)
                    continue
                if info.file_size > limit:
                    raise ModelFileError(f"model {path}: {name} is larger than {limit} bytes; "
                                         "not a model written by save_model")
                parts.append(zf.read(info))
    except ModelFileError:
        raise
    except Exception as exc:  # BadZipFile, CRC errors, truncated archives
        raise ModelFileError(f"model {path}: not a model directory or a readable .zip "
                             f"({_why(exc)})") from None
    return parts[0], parts[1]


def _parse_manifest(path: Path, raw: bytes | None) -> dict:
    if raw is None:
        raise ModelFileError(f"model {path}: no {MANIFEST}; a model must be written by "
                             "save_model (the manifest is written last: was saving cut short?)")
    try:
        manifest = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise ModelFileError(f"model {path}: {MANIFEST} is not valid JSON ({_why(exc)}); save "
                             "the model again") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT_NAME:
        raise ModelFileError(f"model {path}: {MANIFEST} is not a {FORMAT_NAME} manifest; save "
                             "the model again")
    version = manifest.get("format_version")
    if version != FORMAT_VERSION:
        raise ModelFileError(f"model {path}: format version {version!r}, this farm reads "
                             f"version {FORMAT_VERSION}; save the model again with this farm")
    checksum = manifest.get("model_sha256")
    if not isinstance(checksum, str) or len(checksum) != 64:
        raise ModelFileError(f"model {path}: {MANIFEST} lacks the model's sha256; save the "
                             "model again")
    return manifest


def load_model(path: str | os.PathLike, *, trusted: Iterable[str] = ()) -> tuple[Any, dict]:
    """Read a model written by :func:`save_model`, verifying it on the way.

    Parameters
    ----------
    path : str or path-like
        The model directory or ``.zip``.
    trusted : iterable of str, optional
        Type names (skops' ``module.QualName``) to trust beyond :data:`TRUSTED_TYPES`,
        for a caller that has reviewed them.

    Returns
    -------
    estimator : object
        What was saved.
    manifest : dict
        The manifest as written (see :func:`save_model`).

    Raises
    ------
    ModelFileError
        One line: missing/corrupt manifest, wrong format version, checksum mismatch, not
        a skops file, or types outside the trusted list.
    """
    import skops.io as sio

    path = Path(path)
    raw_manifest, data = _read_parts(path)
    manifest = _parse_manifest(path, raw_manifest)
    if data is None:
        raise ModelFileError(f"model {path}: no {MODEL}; save the model again")
    if _sha256(data) != manifest["model_sha256"]:
        raise ModelFileError(f"model {path}: {MODEL} does not match the checksum in {MANIFEST} "
                             "(corrupted or modified); do not use it, save the model again")
    data = renamed_types(data)  # a file saved before a trusted type moved (LEGACY_TYPES)
    try:
        bad = untrusted_types(data, trusted)
    except ModelFileError as exc:
        raise ModelFileError(f"model {path}: {exc}") from None
    if bad:
        raise ModelFileError(f"model {path}: {MODEL} holds untrusted types {bad}; refused (pass "
                             "trusted=[...] only for types you have reviewed)")
    allowed = sorted(set(TRUSTED_TYPES) | set(trusted))
    try:
        estimator = sio.loads(data, trusted=allowed)
    except Exception as exc:
        raise ModelFileError(f"model {path}: {MODEL} cannot be loaded ({_why(exc)}); save the "
                             "model again with this farm's versions") from None
    return estimator, manifest
