"""Client side: reserve experiment slots; the id -> index table they form.

An experiment id gets one index along ``experiment`` forever. ``reserve`` resizes every
experiment-dim array, so it runs under the store's client lock (:mod:`storage.lock`):
clients take turns, and each reads the ids the one before it reserved. Order makes it
crash-safe: arrays grow first, then the new slots' parameters, then their ids (a slot
exists once its id is written), then the consolidated metadata; a client killed
half-way leaves empty trailing slots that the next call reuses. Last, what was written
is read back: where no lock could exclude a second client (an object store that ignores
conditional writes), a lost race raises :class:`ConcurrentClientError`, never silently.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import zarr

from storage._zarr import array, dimension_names, read, read_coordinates
from storage.checksum import label_digest, split
from storage.errors import (
    ConcurrentClientError,
    ParameterConflictError,
    SchemaError,
)
from storage.group import create_array
from storage.lock import client_lock
from storage.paths import StoreLike, describe, names_the_store, open_group, open_store
from storage.paths import publish as _publish
from storage.schema import (
    COMBINED_PARAMETERS,
    COMBINED_VARIABLES,
    EXPERIMENT_ID,
    FIXED_VARIABLES,
    KNOWN_PARAMETER_UNITS,
    PARAMETER_NAME,
    REQUIRED_PARAMETERS,
    parameter,
)


def _check_ids(experiment_ids: Sequence[str]) -> list[str]:
    if isinstance(experiment_ids, str):
        raise SchemaError(
            f"experiment_ids must be a sequence of ids, got one string {experiment_ids!r}"
        )
    ids = [str(e) if isinstance(e, np.str_) else e for e in experiment_ids]
    for e in ids:
        if not (isinstance(e, str) and EXPERIMENT_ID.fullmatch(e)):
            raise SchemaError(
                f"experiment id must be 1-128 letters, digits, '_', '.', ':' or '-' (a sha256 "
                f"hex digest in the farm), got {e!r}"
            )
    if len(set(ids)) != len(ids):
        dup = next(e for e, n in Counter(ids).items() if n > 1)
        raise SchemaError(f"experiment id {dup!r} is given twice: reserve each id once")
    return ids


def _check_params(
    g: zarr.Group, params: Mapping[str, Any], n: int, units: Mapping[str, str]
) -> dict[str, np.ndarray]:
    missing = sorted(set(REQUIRED_PARAMETERS) - set(params))
    if missing:
        raise SchemaError(
            f"parameter {missing[0]!r} is missing: every experiment needs "
            f"{', '.join(REQUIRED_PARAMETERS)}"
        )
    for name, unit in units.items():
        known = g[name].attrs.get("units") if name in g else KNOWN_PARAMETER_UNITS.get(name)
        if name not in params or (known is not None and known != unit):
            raise SchemaError(
                f"units={{{name!r}: {unit!r}}} does not fit: "
                + (f"{name!r} is in {known!r}" if name in params else "no such parameter given")
            )
    out = {}
    for name, value in params.items():
        if not (isinstance(name, str) and PARAMETER_NAME.fullmatch(name)):
            raise SchemaError(
                f"parameter name must be lower-case letters, digits and '_', got {name!r}"
            )
        if name in FIXED_VARIABLES or (name in g and g[name].attrs.get("role") != "parameter"):
            raise SchemaError(f"{name!r} is a variable of the schema, not a load-case parameter")
        if name not in g and name not in units and name not in KNOWN_PARAMETER_UNITS:
            raise SchemaError(
                f"new parameter {name!r} needs units: pass units={{{name!r}: ...}} to reserve"
            )
        try:
            a = np.broadcast_to(np.asarray(value, dtype=np.float64), (n,))
        except (TypeError, ValueError) as e:
            raise SchemaError(
                f"parameter {name!r} must be a number or {n} numbers (one per id), got "
                f"{np.shape(value)}"
            ) from e
        if not np.isfinite(a).all():
            raise SchemaError(f"parameter {name!r} holds NaN or inf: give finite values")
        out[name] = a
    return out


def read_ids(g: zarr.Group) -> list[str]:
    """Reserved experiment ids in index order (surplus empty slots of a crash dropped)."""
    raw = [str(e) for e in read(array(g, "experiment")).tolist()]
    used = next((i for i, e in enumerate(raw) if not e), len(raw))
    if any(raw[used:]):
        raise SchemaError(
            f"group {g.path!r} has an empty experiment id at index {used} before reserved "
            "ones: the store was modified by hand"
        )
    return raw[:used]


@names_the_store
def reserve(store: StoreLike, group: str, experiment_ids: Sequence[str],
            params: Mapping[str, Any], *, units: Mapping[str, str] | None = None,
            ) -> dict[str, int]:
    """Give each experiment id its slot (index along ``experiment``), forever.

    New ids are appended: every experiment-dim array grows, the new slots read as
    pending (status 0, NaN floats, -1 counts, empty error) and hold their parameters.
    Ids already reserved keep their index; their parameters must be the stored ones.
    Client only (this resizes arrays).

    Parameters
    ----------
    store, group : the store and the group of the experiments' mesh.
    experiment_ids : sequence of str, length K
        Experiment ids, each given once.
    params : mapping of str to (K,) array-like or scalar
        Load-case parameters, at least ``deflection`` (mm) and ``pressure`` (MPa); any
        other name becomes a new float64 parameter variable (NaN for earlier slots).
        A combined-load parameter (friction, shift_x, shift_y, tilt) creates the worker
        variables of a combined-load group (``contact_status``, ``tread_slip``, ...).
    units : mapping of str to str, optional
        Units of new parameters that the schema does not know.

    Returns
    -------
    dict of str to int
        Index of every requested id.

    Raises
    ------
    StoreBusyError
        Another client held the store's lock for too long.
    ConcurrentClientError
        Another client reserved in the group at the same moment without the lock
        (object stores without conditional writes); run again when it is done.
    """
    zs, ids, units = open_store(store), _check_ids(experiment_ids), dict(units or {})
    with client_lock(zs):
        g = open_group(zs, group)  # fresh metadata, read under the lock
        values = _check_params(g, params, len(ids), units)
        _restore_ids(g, ids, values)
        stored = read_ids(g)
        index = {e: i for i, e in enumerate(stored)}
        _check_known(g, group, ids, values, index)
        index.update(_append(zs, g, group, ids, values, units, index, len(stored)))
        _publish(zs)
    return {e: index[e] for e in ids}


def _append(zs, g, group: str, ids: list[str], values: dict[str, np.ndarray],
            units: dict[str, str], index: Mapping[str, int], k_old: int) -> dict[str, int]:
    """Grow the group (``k_old`` slots reserved) by the ids ``index`` lacks, write their
    parameters and then their ids (an id marks its slot used, so it goes last), check
    what was written, and return their new slots. Under the client lock."""
    rows = np.array([j for j, e in enumerate(ids) if e not in index], dtype=np.int64)
    new = [ids[j] for j in rows]
    k_new = k_old + len(new)
    _grow(g, values, units, k_new)
    if not new:
        return {}
    for name, a in values.items():
        array(g, name)[k_old:k_new] = a[rows]
    array(g, "experiment")[k_old:k_new] = np.array(new, dtype=object)
    _check_written(zs, group, slice(k_old, k_new), new,
                   {name: a[rows] for name, a in values.items()})
    return {e: k_old + j for j, e in enumerate(new)}


def _restore_ids(g: zarr.Group, ids: list[str], values: dict[str, np.ndarray]) -> None:
    """Give back the id of a slot whose id was lost (empty before reserved ones) or
    duplicated, where the ids being reserved prove it (issue 50: repair could not tell,
    resume refused, 19 of 20 for good). A candidate is an id given now that the group
    does not hold (or the duplicated id itself); it is proven when the slot's checksum
    label is that id with the slot's stored load case (:mod:`storage.checksum`), or, for
    a slot without a checksum (pending: no result to protect), when the values given for
    it now equal the slot's. Exactly one candidate, or nothing is written."""
    raw = [str(e) for e in read(array(g, "experiment")).tolist()]
    last = max((i for i, e in enumerate(raw) if e), default=-1)
    counts = Counter(e for e in raw if e)
    damaged = [i for i in range(last + 1) if not raw[i] or counts[raw[i]] > 1]
    if not damaged:
        return
    wanted = {e: j for j, e in enumerate(ids)}
    free = [e for e in ids if e not in counts]
    names = [n for n in values if n in g]
    stored = {n: read(array(g, n)) for n in names}
    sums = [str(s) for s in read(array(g, "checksum")).tolist()] if "checksum" in g else None
    fixed: dict[int, str] = {}
    for i in damaged:
        mine = {n: float(stored[n][i]) for n in names if not np.isnan(stored[n][i])}
        label = (split(sums[i]) or ("",))[0] if sums is not None and sums[i] else ""
        pool = free + ([raw[i]] if raw[i] else [])
        if label:
            match = [e for e in pool if label_digest(e, mine) == label]
        else:
            match = [e for e in pool if e in wanted and all(
                float(values[n][wanted[e]]) == v for n, v in mine.items())]
        if len(match) == 1 and match[0] != raw[i]:
            fixed[i] = match[0]
    if fixed and len(set(fixed.values())) == len(fixed):
        a = array(g, "experiment")
        for i, e in sorted(fixed.items()):
            a[i] = e


def _check_written(zs, group: str, slots: slice, ids: list[str],
                   values: dict[str, np.ndarray]) -> None:
    """Read back the new slots: another client racing past the lock shows up here."""
    g = open_group(zs, group)
    found = {n: read(array(g, n), slots) for n in ("experiment", *values)}
    theirs = np.flatnonzero(np.asarray(found["experiment"], dtype=object)
                            != np.array(ids, dtype=object))
    if theirs.size == 0:
        for name, a in values.items():
            theirs = np.flatnonzero(found[name] != a)
            if theirs.size:
                break
    if theirs.size:
        j = int(theirs[0])
        raise ConcurrentClientError(
            f"another client reserved experiments in group {group!r} of {describe(zs)} at "
            f"the same time: slot {slots.start + j} should hold {ids[j]!r} as just written, "
            f"but holds {str(found['experiment'][j])!r} ({theirs.size} of {len(ids)} slots "
            "differ); let one client reserve at a time (object stores: one submitting "
            "client), then run again"
        )


def _check_known(
    g: zarr.Group, group: str, ids: list[str], values: dict[str, np.ndarray],
    index: dict[str, int],
) -> None:
    rows = [j for j, e in enumerate(ids) if e in index]
    if not rows:
        return
    slots = np.array([index[ids[j]] for j in rows])
    restore: list[tuple[str, np.ndarray, np.ndarray]] = []
    for name, a in values.items():
        stored = read(array(g, name))[slots] if name in g else np.full(len(rows), np.nan)
        if name in ID_PARAMETERS:
            # the id fixes it: a slot reserved before the parameter existed keeps NaN
            # (its checksum's label was made without it), and agrees with any value
            stored = np.where(np.isnan(stored), a[rows], stored)
        if name in COMBINED_PARAMETERS:
            # a vertical experiment reserved before its group became a combined one has
            # no friction, shift or tilt stored (NaN): it is the case where all are 0
            stored = np.where(np.isnan(stored), 0.0, stored)
        elif name in g and np.isnan(stored).any():
            # a lost value (its chunk deleted): an id stands for one load case, so the
            # value the id is reserved with again is its value (issue 26: resume refused
            # "pressure=nan" and every result behind it was lost); written only once
            # every other value agrees
            lost = np.flatnonzero(np.isnan(stored))
            restore.append((name, slots[lost], a[np.asarray(rows)[lost]]))
            stored = stored.copy()
            stored[lost] = a[np.asarray(rows)[lost]]
        bad = np.flatnonzero(stored != a[rows])
        signed = _signed(g, [ids[rows[b]] for b in bad], slots[bad],
                         {n: v[np.asarray(rows)[bad]] for n, v in values.items()})
        if signed.size:
            # garbled values the worker's signature proves wrong: the checksum's label
            # is the id with exactly the values given now (issue 26: resume refused an
            # edited deflection); the slot's data failed its checksum, so verify has
            # made it pending, and resume solves it again with its true load case
            restore.append((name, slots[bad[signed]], a[np.asarray(rows)[bad[signed]]]))
            bad = np.delete(bad, signed)
        if bad.size:
            j = rows[bad[0]]
            raise ParameterConflictError(
                f"experiment {ids[j]!r} is reserved in group {group!r} with {name}="
                f"{float(stored[bad[0]])}, not {float(a[j])}: an id stands for one load case "
                "forever, so a changed load case needs a new id"
            )
    for name, where, value in restore:
        array(g, name).set_coordinate_selection(where, value)


#: Parameters that an experiment's id already fixes: a roll's ``travel`` (issue 45) is its
#: ``RoadMotion.roll``, part of every rolling id. A slot reserved before the parameter
#: existed keeps NaN there (its checksum was labelled without it) instead of a conflict.
ID_PARAMETERS = ("travel",)


def _signed(g: zarr.Group, ids: list[str], slots: np.ndarray,
            values: dict[str, np.ndarray]) -> np.ndarray:
    """Positions (into ``ids``) whose slot's checksum label is ``ids[k]`` with exactly
    ``values[...][k]``: the load case the worker signed is the one given now."""
    if not ids or "checksum" not in g:
        return np.array([], dtype=np.int64)
    sums = read_coordinates(array(g, "checksum"), slots).tolist()
    match = [k for k, (e, s) in enumerate(zip(ids, sums, strict=True))
             if (split(s) or ("",))[0] == label_digest(
                 e, {n: float(v[k]) for n, v in values.items()})]
    return np.array(match, dtype=np.int64)


def _grow(g: zarr.Group, values: dict[str, np.ndarray], units: dict[str, str], k: int) -> None:
    for name in values:
        if name not in g:
            var = parameter(name, units.get(name) or KNOWN_PARAMETER_UNITS[name])
            create_array(g, var, (k,))
    if set(values) & set(COMBINED_PARAMETERS):  # the group becomes a combined-load one
        sizes = {"experiment": k, "tread_node": array(g, "tread_node").shape[0], "component": 3}
        for var in COMBINED_VARIABLES:
            if var.name not in g:
                create_array(g, var, tuple(sizes[d] for d in var.dims))
    for _, arr in g.arrays():
        if dimension_names(arr)[:1] == ("experiment",) and arr.shape[0] != k:
            arr.resize((k, *arr.shape[1:]))
