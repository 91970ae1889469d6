"""Worker side: write one experiment, or its failure, into its own slot.

A write touches only the chunks of its own index (one experiment per chunk along
``experiment``, node dims whole, so every write is whole chunks) and never metadata.
Order is what makes it crash-safe: ``status`` goes to pending first (so that re-writing
a done experiment is never half old, half new), then every data chunk, then ``status``
to done or failed. A writer killed anywhere leaves the slot not done; with atomic
object writes (local directories: temporary file renamed into place; S3: whole-object
PUT) no chunk is ever torn. Readers must take only ``status == 1`` as done.

With the data goes the slot's checksum (:mod:`storage.checksum`: id, load case,
status and data), so that a reader can tell a slot damaged later from one written
whole. Groups made before checksums have no ``checksum`` array; writes there skip it.
Only combined-load groups have the combined variables (:data:`COMBINED_NAMES`); a
result may carry them only there, and a vertical one there stores them as not recorded.
The contact patch and inflation growth (:data:`PATCH_NAMES`, issue 24) come with the
info; groups created before them lack their arrays, and writes there skip them.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from typing import Any

import numpy as np

from storage._zarr import read_item, write_in_order
from storage.checksum import checksum
from storage.errors import (
    AlreadyDoneError,
    MeshMismatchError,
    SchemaError,
    StoreError,
)
from storage.handles import Handle, locate
from storage.paths import StoreLike, names_the_store, open_store
from storage.schema import (
    COMBINED_NAMES,
    DONE,
    EXPERIMENT_ID,
    FAILED,
    FIXED_VARIABLES,
    INFO_NAMES,
    NOT_RECORDED,
    PATCH_NAMES,
    PENDING,
    RESULT_NAMES,
    result_shape,
    truncate_error,
)

_NODE_KEYS = ("inner_node", "tread_node")


def _check_id(experiment_id: str) -> str:
    if not (isinstance(experiment_id, str) and EXPERIMENT_ID.fullmatch(experiment_id)):
        raise SchemaError(f"experiment id must be a reserved id string, got {experiment_id!r}")
    return experiment_id


def check_result(result: Mapping[str, Any], h: Handle) -> dict[str, np.ndarray]:
    """Validate one experiment's result arrays against the group.

    ``result`` holds every name of :data:`RESULT_NAMES` (shapes ``(N, 3)`` for
    displacement, strain and surface_strain, ``(M, 3)`` for reaction_force, ``(3,)``
    for total_force and moment), finite numbers only; it may also hold ``inner_node``
    and ``tread_node`` ids, which must then be the group's. Returns float64 arrays with
    a leading axis of length 1, ready to write into one slot.
    """
    unknown = sorted(set(result) - set(RESULT_NAMES) - set(_NODE_KEYS) - set(COMBINED_NAMES))
    if unknown:
        raise SchemaError(
            f"unknown result variable {unknown[0]!r}; a result holds {', '.join(RESULT_NAMES)}"
        )
    missing = [n for n in RESULT_NAMES if n not in result]
    if missing:
        raise SchemaError(
            f"result variable {missing[0]!r} is missing: a done experiment has all of "
            f"{', '.join(RESULT_NAMES)}"
        )
    for key, stored in zip(_NODE_KEYS, (h.inner_node, h.tread_node), strict=True):
        if key in result and not np.array_equal(np.asarray(result[key]), stored):
            raise MeshMismatchError(
                f"{key} ids of the result differ from the group's ({stored.size} nodes, first "
                f"{stored[:3].tolist()}): write into the group of the mesh that was solved"
            )
    out = {}
    for name in RESULT_NAMES:
        a = np.asarray(result[name])
        want = result_shape(name, h.inner_node.size, h.tread_node.size)
        if a.dtype.kind not in "iuf" or a.shape != want:
            raise SchemaError(
                f"result {name!r} must be a real array of shape {want} for this group, got "
                f"{a.dtype} array of shape {a.shape}"
            )
        bad = int(np.count_nonzero(~np.isfinite(a)))
        if bad:
            raise SchemaError(
                f"result {name!r} holds {bad} NaN/inf values: store the run as a failure "
                "(write_failure) instead"
            )
        out[name] = a.astype(np.float64)[np.newaxis]
    out.update(_combined(result, h))
    return out


def _combined(result: Mapping[str, Any], h: Handle) -> dict[str, np.ndarray]:
    """The combined-load variables of one result: all four or none given; stored only
    in a combined-load group (there, none given: not recorded)."""
    given = [n for n in COMBINED_NAMES if n in result]
    has = [n for n in COMBINED_NAMES if n in h.arrays]
    if given and not has:
        raise SchemaError(
            f"result variable {given[0]!r} is a combined-load one and this group has none: "
            "reserve its experiments with the combined parameters (friction, shift_x, "
            "shift_y, tilt) first"
        )
    if given and len(given) != len(COMBINED_NAMES):
        missing = next(n for n in COMBINED_NAMES if n not in result)
        raise SchemaError(f"combined result variable {missing!r} is missing: give all of "
                          f"{', '.join(COMBINED_NAMES)} or none")
    out = {}
    n_tread = h.tread_node.size
    for name in has:
        want = result_shape(name, 0, n_tread)
        if not given:
            out[name] = _fill(name, want)
            continue
        a = np.asarray(result[name])
        if a.dtype.kind not in "iuf" or a.shape != want:
            raise SchemaError(
                f"result {name!r} must be a real array of shape {want} for this group, got "
                f"{a.dtype} array of shape {a.shape}")
        if name == "contact_status":
            if not np.isin(a, (0, 1, 2)).all():
                raise SchemaError(f"result 'contact_status' must hold 0 (open), 1 (stick) or "
                                  f"2 (slip), got {sorted(set(np.unique(a).tolist()))[:5]}")
            out[name] = a.astype(np.int8)[np.newaxis]
            continue
        bad = int(np.count_nonzero(~np.isfinite(a)))
        if bad:
            raise SchemaError(f"result {name!r} holds {bad} NaN/inf values: store the run as "
                              "a failure (write_failure) instead")
        out[name] = a.astype(np.float64)[np.newaxis]
    return out


def _fill(name: str, shape: tuple[int, ...]) -> np.ndarray:
    var = FIXED_VARIABLES[name]
    return np.full((1, *shape), var.fill, dtype=np.dtype(var.dtype))


def check_info(info: Mapping[str, Any], *, complete: bool) -> dict[str, np.ndarray]:
    """Validate run bookkeeping: ``solve_seconds`` (s, >= 0) and integer counts, and the
    optional contact patch and inflation growth (:data:`PATCH_NAMES`: real numbers, NaN
    for not recorded).

    With ``complete`` every name of :data:`INFO_NAMES` is required; otherwise a missing
    one is stored as not recorded (NaN seconds, -1 counts). A missing patch name is
    never required (NaN).
    """
    unknown = sorted(set(info) - set(INFO_NAMES) - set(PATCH_NAMES))
    if unknown:
        raise SchemaError(f"unknown info key {unknown[0]!r}; info holds "
                          f"{', '.join((*INFO_NAMES, *PATCH_NAMES))}")
    missing = [n for n in INFO_NAMES if n not in info]
    if complete and missing:
        raise SchemaError(f"info {missing[0]!r} is missing: a done experiment records "
                          f"{', '.join(INFO_NAMES)}")
    seconds = info.get("solve_seconds", math.nan)
    if "solve_seconds" in info and not (
        isinstance(seconds, numbers.Real) and not isinstance(seconds, bool)
        and math.isfinite(seconds) and float(seconds) >= 0
    ):
        raise SchemaError(f"info 'solve_seconds' must be a number of seconds >= 0, got {seconds!r}")
    out = {"solve_seconds": np.array([seconds], dtype=np.float64)}
    for name in INFO_NAMES[1:]:
        v = info.get(name, NOT_RECORDED)
        if name in info and not (
            isinstance(v, numbers.Integral) and not isinstance(v, bool) and 0 <= int(v) < 2**31
        ):
            raise SchemaError(f"info {name!r} must be an integer >= 0, got {v!r}")
        out[name] = np.array([v], dtype=np.int32)
    for name in PATCH_NAMES:
        v = info.get(name, math.nan)
        if not (isinstance(v, numbers.Real) and not isinstance(v, bool)
                and not math.isinf(float(v))):
            raise SchemaError(f"info {name!r} must be a finite number (NaN: not recorded), "
                              f"got {v!r}")
        out[name] = np.array([v], dtype=np.float64)
    return out


def _present(h: Handle, values: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``values`` less the patch variables the group has no arrays for (groups created
    before them: issue 24)."""
    return {n: v for n, v in values.items() if n not in PATCH_NAMES or n in h.arrays}


def _signed(h: Handle, i: int, experiment_id: str, values: dict[str, np.ndarray],
            status: int) -> dict[str, np.ndarray]:
    """``values`` with the slot's checksum added (where the group has the array)."""
    if "checksum" not in h.arrays:
        return values
    params = {name: a[i] for name, a in h.params.items() if i < a.size}
    one = {name: v[0] for name, v in values.items()}
    text = checksum(experiment_id, params, status, one)
    return {**values, "checksum": np.array([text], dtype=object)}


def _write(h: Handle, i: int, values: dict[str, np.ndarray], status: int, where: str) -> None:
    region = slice(i, i + 1)
    state = h.arrays["status"]
    steps = [[(state, region, np.array([PENDING], dtype=np.int8))],
             [(h.arrays[name], region, v) for name, v in values.items()],
             [(state, region, np.array([status], dtype=np.int8))]]  # last: publishes
    try:
        write_in_order(steps)
    except Exception as e:  # the store's I/O error, whatever its class
        raise StoreError(
            f"writing {where} failed ({type(e).__name__}: {e}); it is not done: retry the "
            "write (it is idempotent)"
        ) from e


@names_the_store
def write_experiment(
    store: StoreLike,
    group: str,
    experiment_id: str,
    result: Mapping[str, Any],
    info: Mapping[str, Any],
    *,
    mesh_key: str | None = None,
) -> None:
    """Write one solved experiment into its reserved slot and mark it done.

    Idempotent: writing the same experiment again stores the same bytes.

    Parameters
    ----------
    store, group : the store and the group the client reserved the id in.
    experiment_id : str
        A reserved id.
    result : mapping of str to array
        ``displacement`` (N, 3) mm, ``strain`` (N, 3), ``surface_strain`` (N, 3),
        ``reaction_force`` (M, 3) N, ``total_force`` (3,) N, ``moment`` (3,) N mm; all
        finite. Optionally ``inner_node`` (N,) and ``tread_node`` (M,) ids to check.
        In a combined-load group also, optionally, ``contact_status`` (M,) (0 open,
        1 stick, 2 slip), ``tread_slip`` (M, 3) mm, ``road_reaction`` (3,) N and
        ``road_moment`` (3,) N mm (all four or none).
    info : mapping
        ``solve_seconds`` (s), ``increments``, ``ccx_runs``, ``contact_nodes``; and,
        optionally (NaN when not given; skipped in groups created before them), the
        contact patch ``patch_area`` (mm2), ``patch_length``, ``patch_width`` (mm),
        ``peak_pressure``, ``mean_pressure`` (MPa), ``nodal_force_mean``,
        ``nodal_force_std`` (N) and ``inflation_growth`` (mm).
    mesh_key : str, optional
        When given, must be the group's mesh key.
    """
    zs = open_store(store)
    h, i = locate(zs, group, _check_id(experiment_id))
    if set(result) & set(COMBINED_NAMES) and not set(h.arrays) & set(COMBINED_NAMES):
        # a handle opened before a client made the group a combined-load one
        h, i = locate(zs, group, experiment_id, fresh=True)
    _check_mesh_key(h, group, mesh_key)
    values: dict[str, np.ndarray] = {**check_result(result, h),
                                      **_present(h, check_info(info, complete=True))}
    values["error"] = np.array([""], dtype=object)
    values = _signed(h, i, experiment_id, values, DONE)
    _write(h, i, values, DONE, f"experiment {experiment_id!r} into group {group!r}")


@names_the_store
def write_failure(
    store: StoreLike,
    group: str,
    experiment_id: str,
    reason: str,
    info: Mapping[str, Any],
    *,
    mesh_key: str | None = None,
) -> None:
    """Record that an experiment failed: status 2, the reason, what the run spent.

    Result arrays of the slot are reset to NaN. ``reason`` longer than
    :data:`storage.schema.MAX_ERROR_CHARS` is cut in the middle. ``info`` may hold any
    of ``solve_seconds``, ``increments``, ``ccx_runs``, ``contact_nodes`` (and of the
    patch names, which a failure normally leaves NaN).

    Raises
    ------
    AlreadyDoneError
        The experiment is done: a late failure never overwrites a good result.
    """
    if not (isinstance(reason, str) and reason.strip()):
        raise SchemaError(f"a failure needs a reason (non-empty text), got {reason!r}")
    zs = open_store(store)
    h, i = locate(zs, group, _check_id(experiment_id))
    _check_mesh_key(h, group, mesh_key)
    values = _present(h, check_info(info, complete=False))
    if int(read_item(h.arrays["status"], i)) == DONE:
        raise AlreadyDoneError(
            f"experiment {experiment_id!r} in group {group!r} is done; not recording the "
            f"failure {reason[:80]!r} over it (re-run it with write_experiment if needed)"
        )
    n_inner, n_tread = h.inner_node.size, h.tread_node.size
    for name in RESULT_NAMES:
        values[name] = np.full((1, *result_shape(name, n_inner, n_tread)), np.nan)
    for name in COMBINED_NAMES:
        if name in h.arrays:  # combined-load groups only
            values[name] = _fill(name, result_shape(name, n_inner, n_tread))
    values["error"] = np.array([truncate_error(reason)], dtype=object)
    values = _signed(h, i, experiment_id, values, FAILED)
    _write(h, i, values, FAILED, f"the failure of {experiment_id!r} into group {group!r}")


def _check_mesh_key(h: Handle, group: str, mesh_key: str | None) -> None:
    if mesh_key is not None and mesh_key != h.mesh_key:
        raise MeshMismatchError(
            f"group {group!r} holds mesh {h.mesh_key!r}, the experiment was solved on mesh "
            f"{mesh_key!r}: write into the group of its own mesh"
        )
