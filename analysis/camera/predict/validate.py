"""A force model file is checked as a whole when it is read (issue 50).

The skops file's checksum proves it is the file ``farm fit`` wrote, but not that the
manifest beside it still describes it (the checksum covers the model, not the
manifest), nor that a file of trusted types has the structure of a force model. A model
whose targets were renamed, repeated or dropped would print a wrong force with exit 0,
so nothing of it is used until every part agrees: the manifest names a sensor, known
and unique inputs and targets; the payload holds a learner that predicts, fitted
conformal intervals with one column per target, and a reference surface of consistent
arrays.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from analysis.camera.predict.intervals import ConformalIntervals
from analysis.errors import ModelFileError, ParameterError

SURFACE_KEYS = ("xyz", "theta", "s", "node_index", "periodic")


def names(manifest: Mapping, key: str, known: Sequence[str], where: str) -> tuple[str, ...]:
    """``manifest[key]``: a non-empty list of unique names out of ``known``."""
    value = manifest.get(key)
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise ModelFileError(f"{where}: the manifest's {key!r} must be a non-empty list of "
                             f"names out of {list(known)}, got {value!r}; save the model "
                             "again with farm fit")
    unknown = [v for v in value if v not in known]
    repeated = sorted({v for v in value if value.count(v) > 1})
    if unknown or repeated:
        what = f"unknown {unknown}" if unknown else f"repeated {repeated}"
        raise ModelFileError(f"{where}: the manifest's {key!r} holds {what} (known: "
                             f"{list(known)}); save the model again with farm fit")
    if value != sorted(value, key=list(known).index):
        raise ModelFileError(f"{where}: the manifest's {key!r} {value} are not in the order "
                             f"farm fit writes them ({list(known)}), so its columns would be "
                             "mislabelled; save the model again with farm fit")
    return tuple(value)


def sensor_dict(manifest: Mapping, where: str) -> dict[str, Any]:
    """``manifest['sensor']``, which must be a dict of the sensor's fields."""
    value = manifest.get("sensor")
    if not isinstance(value, Mapping):
        raise ModelFileError(f"{where}: the manifest's 'sensor' must be the sensor's fields, "
                             f"got {value!r}; save the model again with farm fit")
    return dict(value)


def payload_parts(payload: Any, n_targets: int, where: str) -> tuple[Any, ConformalIntervals,
                                                                     dict[str, Any]]:
    """``(learner, intervals, surface arrays)`` of a force model's payload."""
    if not isinstance(payload, Mapping) or not {"learner", "intervals", "surface"} <= set(
            payload):
        got = sorted(payload) if isinstance(payload, Mapping) else type(payload).__name__
        raise ModelFileError(f"{where}: not a force model (a learner, intervals and a "
                             f"reference surface), got {got}; give a model written by "
                             "farm fit")
    learner, intervals = payload["learner"], payload["intervals"]
    if not callable(getattr(learner, "predict", None)):
        raise ModelFileError(f"{where}: its learner ({type(learner).__name__}) cannot "
                             "predict; give a model written by farm fit")
    fitted = getattr(intervals, "n_targets_", None)
    if not isinstance(intervals, ConformalIntervals) or fitted is None:
        raise ModelFileError(f"{where}: its intervals are not fitted conformal intervals "
                             f"({type(intervals).__name__}); give a model written by farm fit")
    if fitted != n_targets:
        raise ModelFileError(f"{where}: the manifest names {n_targets} target(s) but the "
                             f"model's intervals have {fitted}; the manifest was edited, "
                             "save the model again with farm fit")
    return learner, intervals, _surface(payload["surface"], where)


def _surface(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, Mapping) or not set(SURFACE_KEYS) <= set(value):
        missing = sorted(set(SURFACE_KEYS) - set(value if isinstance(value, Mapping) else ()))
        raise ModelFileError(f"{where}: its reference surface lacks {missing}; give a model "
                             "written by farm fit")
    return dict(value)


def built(build: Any, value: Any, what: str, where: str) -> Any:
    """``build(value)`` (the sensor spec, the reference surface), its refusal turned
    into one model file error."""
    try:
        return build(value)
    except (ParameterError, KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(f"{where}: its {what} is not valid ({exc}); save the model "
                             "again with farm fit") from None
