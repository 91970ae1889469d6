"""``farm sweep verify``: find what is damaged in a store, name it, and mark it.

Per experiment group, :func:`verify` checks that

1. every ``zarr.json`` (the store's, the group's, each array's) decodes, and every
   array of the schema is there (``checksum`` only in groups made since checksums);
2. shapes agree along ``experiment`` and along the node dimensions;
3. the ids decode, are well formed and unique, no empty id comes before reserved ones,
   every status is 0, 1 or 2, and no slot without an id is done or failed;
4. each done or failed experiment's chunks decode and its checksum matches its id,
   load case, status and data (:mod:`storage.checksum`); experiments of groups
   written before checksums are counted "unverifiable (no checksums)"; a *pending*
   slot whose checksum matches it done or failed is damage too (its status was lost or
   reset: readers would silently leave a whole experiment out);
5. the other chunks (mesh arrays, load-case parameters) decode.

``repair=True`` then fixes what the store itself can tell (under the client lock,
:mod:`storage.lock`; run it while no sweep writes to the store):

- a damaged experiment goes back to **pending**, its ``error`` saying why: ``farm sweep
  resume`` re-solves it. Pending rather than a new "damaged" status because every
  reader and the queue already take pending as "not done, solve it" (the queue runs
  pending experiments and, if asked, failed ones: a new value would be skipped by
  every client that does not know it); ``error`` keeps the why;
- a pending slot whose checksum verifies it done (or failed) gets that status back;
- a done slot whose checksum chunk alone is lost or fails its CRC32C is signed again
  when its chunks prove its data intact (:mod:`storage.resign`), not solved again; a
  chunk failing its CRC32C in a slot marked pending is removed;
- ids swapped between slots go back where their checksums were signed (when the failing
  slots' ids are a permutation of each other and every one then verifies, data included);
- a done or failed slot without an id (its ids chunk is lost) goes back to pending:
  resume reserves the study's ids again and re-solves them;
- a ``zarr.json`` that is missing or does not decode is restored from the copy in the
  root's consolidated metadata (refreshed after every client change), its length along
  ``experiment`` taken from the group; a lost ``status`` array then gets its values
  back from the checksums (a slot whose checksum matches as done is done);
- a damaged root ``zarr.json`` is rewritten as a plain group and the consolidated
  metadata rebuilt.

- a done or failed slot whose load case is lost (a parameter chunk deleted or not
  decoding) is kept as it is: ``farm sweep resume STUDY`` writes the load case back
  from the study (an id stands for one load case) and its checksum verifies again; a
  parameter chunk that does not decode is removed first (it read as an error on every
  try, which stopped resume: issue 50's loop).

Load-case values garbled into other numbers mark their experiments pending; resume
writes the true values back where the slot's checksum label proves them
(:func:`storage.reserve`) and solves them again. What the store cannot tell stays
reported: metadata without a consolidated copy.
"""

from __future__ import annotations

import json
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from zarr.abc.store import Store
from zarr.storage import LocalStore

import storage.identity as identity
from storage._zarr import (
    delete_key,
    dimension_names,
    get_bytes,
    key_exists,
    list_dir,
    read,
    set_bytes,
    short_error,
)
from storage.checksum import Slots, check, label_digest, split
from storage.errors import GroupNotFoundError, NotAStoreError, StoreError, verify_hint
from storage.group import unfinished_groups
from storage.paths import LOCK_NAME, StoreLike, describe, names_the_store, open_store, publish
from storage.resign import chunk_key, drop_unreadable, signed_again
from storage.schema import (
    CHECKED_NAMES,
    CLIENT_CHUNK,
    COMBINED_NAMES,
    DONE,
    EXPERIMENT_ID,
    FAILED,
    FIXED_VARIABLES,
    OPTIONAL_NAMES,
    PATCH_NAMES,
    PENDING,
    REQUIRED_PARAMETERS,
    STATUS_NAMES,
    checked_names,
)

#: Arrays every experiment group has (``checksum`` and the patch variables are optional:
#: older groups lack them; the combined-load variables exist in combined-load groups
#: only).
REQUIRED_ARRAYS = tuple(sorted((set(FIXED_VARIABLES) | set(REQUIRED_PARAMETERS))
                               - {*OPTIONAL_NAMES, *COMBINED_NAMES}))
_IDENTITY_ADVICE = {
    "group": ("the group's folder name is not the one it was made under (renamed or copied "
              "by hand): rename the folder back, or delete the copy"),
    "identity": "the group's identity digests do not decode (edited by hand)",
}
_SHOWN = 20  # damage lines shown per group (the JSON report has all)
_ORPHAN = ("is {state} but has no experiment id (the ids chunk of its slot is missing or "
           "damaged)")


@dataclass(frozen=True)
class Damage:
    """One thing found damaged: an experiment (``experiment``/``index``), or a key."""

    group: str
    what: str
    reason: str
    experiment: str | None = None
    index: int | None = None

    def line(self) -> str:
        if self.experiment is not None:
            return f"{self.experiment} (group {self.group}, slot {self.index}): {self.reason}"
        return f"{self.what}: {self.reason}"


@dataclass(frozen=True)
class GroupReport:
    """What :func:`verify` found in one group."""

    group: str
    reserved: int
    checked: int  # done and failed experiments looked at
    unverifiable: int  # of those, how many had nothing to check against
    damage: tuple[Damage, ...]
    repaired: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()  # not damage, but worth knowing (what resume will cost)

    @property
    def damaged_ids(self) -> set[str]:
        return {d.experiment for d in self.damage if d.experiment is not None}

    @property
    def ok(self) -> int:
        """Experiments whose checksum matched."""
        return max(self.checked - self.unverifiable - len(self.damaged_ids), 0)

    def summary(self) -> str:
        return (f"group {self.group}: {self.reserved} reserved, {self.checked} checked: "
                f"{self.ok} ok, {len(self.damaged_ids)} damaged, {self.unverifiable} "
                f"unverifiable (no checksums), {len(self.damage)} problems")


@dataclass(frozen=True)
class VerifyReport:
    """What :func:`verify` found in a store (and what it repaired, if asked)."""

    store: str
    groups: tuple[GroupReport, ...]
    damage: tuple[Damage, ...] = ()  # of the store's own metadata
    repaired: tuple[str, ...] = ()
    after: VerifyReport | None = None  # the store verified again after a repair

    @property
    def ok(self) -> bool:
        return not self.damage and not any(g.damage for g in self.groups)

    @property
    def damaged_ids(self) -> set[str]:
        return set().union(*(g.damaged_ids for g in self.groups))

    def lines(self) -> list[str]:
        out = [f"store {self.store}: {len(self.groups)} group(s), "
               + ("no damage found" if self.ok else "DAMAGED")]
        out += [f"  damaged: {d.line()}" for d in self.damage]
        for g in self.groups:
            out.append(g.summary())
            out += [f"  damaged: {d.line()}" for d in g.damage[:_SHOWN]]
            if len(g.damage) > _SHOWN:
                out.append(f"  ... and {len(g.damage) - _SHOWN} more (--json lists them all)")
            out += [f"  note: {n}" for n in g.notes[:_SHOWN]]
            if len(g.notes) > _SHOWN:
                out.append(f"  ... and {len(g.notes) - _SHOWN} more notes (--json lists them)")
        repaired = [*self.repaired, *(r for g in self.groups for r in g.repaired)]
        out += [f"repaired: {r}" for r in repaired]
        if self.after is not None:
            out.append("after repair: " + ("no damage left" if self.after.ok else
                                           "still damaged: " + "; ".join(
                                               d.line() for d in _all(self.after))))
        elif not self.ok:
            out.append(f"to mark the damaged experiments for re-solving: "
                       f"{verify_hint(self.store)}")
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "store": self.store, "ok": self.ok, "damaged_ids": sorted(self.damaged_ids),
            "damage": [_damage_dict(d) for d in _all(self)],
            "groups": [{"group": g.group, "reserved": g.reserved, "checked": g.checked,
                        "ok": g.ok, "damaged": len(g.damaged_ids),
                        "unverifiable": g.unverifiable, "notes": list(g.notes)}
                       for g in self.groups],
            "repaired": [*self.repaired, *(r for g in self.groups for r in g.repaired)],
            "after_repair": None if self.after is None else self.after.to_dict(),
        }


def _all(report: VerifyReport) -> list[Damage]:
    return [*report.damage, *(d for g in report.groups for d in g.damage)]


def _damage_dict(d: Damage) -> dict[str, Any]:
    return {"group": d.group, "what": d.what, "reason": d.reason,
            "experiment": d.experiment, "index": d.index}


@names_the_store  # a store that cannot be reached is no damage: one line naming it
def verify(store: StoreLike, group: str | None = None, *, repair: bool = False) -> VerifyReport:
    """Check a store (or one group of it) for damage; with ``repair``, mark and restore.

    Parameters
    ----------
    store : path, URL or zarr store
    group : str, optional
        One experiment group; by default every experiment group of the store.
    repair : bool
        Mark damaged experiments pending and restore damaged metadata (module doc).

    Returns
    -------
    VerifyReport
        ``ok`` is True when nothing was found damaged; with ``repair``, ``after`` is
        the store verified again.
    """
    zs = open_store(store, read_only=not repair)
    where = describe(zs)
    if isinstance(zs, LocalStore) and not Path(zs.root).is_dir():
        raise NotAStoreError(f"no store at {where}: check the path")
    root_doc, root_damage = _root(zs)
    if root_damage and get_bytes(zs, "zarr.json") is None and not list_dir(zs, ""):
        raise NotAStoreError(f"no Zarr store at {where}: check the path")
    copies = _copies(root_doc)
    root_damage += _lock_file(zs) + _unfinished(zs, copies)
    lock = [d for d in root_damage if d.what == LOCK_NAME]
    if repair and lock:
        raise StoreError(f"cannot repair {where}: {lock[0].reason}")
    if repair and root_doc is None and get_bytes(zs, "zarr.json") is None \
            and _experiment_groups(zs):
        # a lost root, intact groups (issue 50: repair refused, "not a Zarr v3 store"):
        # the lock, and every client after it, know a store by its root: write it first
        _plain_root(zs)
    if group is not None:
        check_group(zs, group)
    with _lock(zs, repair):  # repairs write metadata: one client at a time
        attributes = _restore_attributes(zs, root_damage, copies) if repair else []
        names = [group] if group is not None else _experiment_groups(zs)
        checks = [_GroupCheck(zs, name, copies, repair) for name in names]
        reports = tuple(c.run() for c in checks)
        restored = any(c.restored for c in checks)
        repaired = [*attributes, *(_repair_root(zs, root_damage, restored or bool(attributes))
                                   if repair else [])]
    report = VerifyReport(where, reports, tuple(root_damage), tuple(repaired))
    if repair and not report.ok:
        report = VerifyReport(where, reports, tuple(root_damage), tuple(repaired),
                              after=verify(store, group))
    return report


def _lock_file(zs: Store) -> list[Damage]:
    """A local store's lock that is not a regular file (a directory, a FIFO): every
    client would fail to take it (issue 26: verify did not flag it)."""
    if not isinstance(zs, LocalStore):
        return []
    path = Path(zs.root) / LOCK_NAME
    if (not path.exists() and not path.is_symlink()) or path.is_file():
        return []
    return [Damage("", LOCK_NAME, f"the lock {path} is not a regular file: remove it "
                   "while no client uses the store (farm recreates it)")]


_LOST_ATTRIBUTES = ("the group's attributes are lost (its zarr.json has no schema_version; "
                    "the consolidated copy has them): repair restores them from it")


def _unfinished(zs: Store, copies: dict[str, dict]) -> list[Damage]:
    """Groups whose creation stopped before it finished (issue 26: after a full disk the
    half-written group was invisible, "0 groups, no damage"), and groups whose
    attributes were lost since (issue 50: they looked unfinished, and resume rebuilt
    the group and solved all of it again): the root's consolidated copy of a finished
    group holds its ``schema_version``."""
    try:
        names = unfinished_groups(zs)
    except Exception:  # a root too damaged to list: _root reports it
        return []
    return [Damage(name, name, _LOST_ATTRIBUTES) if _finished_copy(copies, name) else
            Damage(name, name, "the group's creation never finished (a client stopped "
                   "mid-way, e.g. on a full disk): submit the study again to rebuild it")
            for name in names]


def _finished_copy(copies: dict[str, dict], group: str) -> dict | None:
    copy = copies.get(group)
    attrs = copy.get("attributes") if isinstance(copy, dict) else None
    return copy if isinstance(attrs, dict) and "schema_version" in attrs else None


def _restore_attributes(zs: Store, root_damage: list[Damage], copies: dict[str, dict]
                        ) -> list[str]:
    """Give groups whose attributes were lost their consolidated copy's (before the
    groups are checked and the consolidated metadata rebuilt from them)."""
    done = []
    for d in root_damage:
        copy = _finished_copy(copies, d.group) if d.reason == _LOST_ATTRIBUTES else None
        if copy is None:
            continue
        doc = {k: v for k, v in copy.items() if k != "consolidated_metadata"}
        set_bytes(zs, f"{d.group}/zarr.json", json.dumps(doc, indent=2).encode())
        done.append(f"{d.group}/zarr.json: attributes restored from the consolidated metadata")
    return done


def _lock(zs: Store, repair: bool) -> AbstractContextManager:
    if not repair:
        return nullcontext()
    from storage.lock import client_lock

    return client_lock(zs)


# --- the store's root ---------------------------------------------------------------------


def _root(zs: Store) -> tuple[dict | None, list[Damage]]:
    raw = get_bytes(zs, "zarr.json")
    if raw is None:
        return None, [Damage("", "zarr.json", "the store's root metadata is missing")]
    try:
        doc = json.loads(raw)
        if not isinstance(doc, dict) or doc.get("node_type") != "group":
            raise ValueError("not a group's metadata")
    except ValueError as e:
        return None, [Damage("", "zarr.json", f"the store's root metadata does not decode "
                                              f"({short_error(e)})")]
    return doc, []


def _copies(root_doc: dict | None) -> dict[str, dict]:
    """Key (``group`` or ``group/array``) -> its metadata as last consolidated."""
    try:
        meta = root_doc["consolidated_metadata"]["metadata"]  # type: ignore[index]
    except (TypeError, KeyError):
        return {}
    return meta if isinstance(meta, dict) else {}


def _experiment_groups(zs: Store) -> list[str]:
    """Child groups that are experiment groups, or whose metadata is too damaged to tell."""
    names = []
    for name in list_dir(zs, ""):
        if name.startswith(".") or name == "zarr.json":
            continue
        raw = get_bytes(zs, f"{name}/zarr.json")
        if raw is None and not list_dir(zs, name):
            continue
        try:
            doc = json.loads(raw) if raw is not None else None
        except ValueError:
            doc = None
        if not isinstance(doc, dict):  # e.g. "[1, 2, 3]": too damaged to tell (issue 50)
            doc = None
        attributes = doc.get("attributes") if doc is not None else None
        if doc is None or (doc.get("node_type") == "group" and isinstance(attributes, dict)
                           and "schema_version" in attributes):
            names.append(name)
    return names


def check_group(store: StoreLike, group: str) -> None:
    """Raise :class:`GroupNotFoundError` naming the store's groups when ``group`` is not
    one of them: no folder, no metadata and no consolidated copy (issue 50: verify of a
    misspelt group called an intact store "DAMAGED, 26 problems")."""
    zs = open_store(store, read_only=True)
    if (get_bytes(zs, f"{group}/zarr.json") is not None or list_dir(zs, group)
            or group in _copies(_root(zs)[0])):
        return
    names = ", ".join(_experiment_groups(zs)) or "none"
    raise GroupNotFoundError(f"no group {group!r} in the store at {describe(zs)} (groups: "
                             f"{names}): give one of them, or leave out --group")


def _plain_root(zs: Store) -> None:
    set_bytes(zs, "zarr.json", json.dumps({"zarr_format": 3, "node_type": "group",
                                           "attributes": {}}).encode())


def _repair_root(zs: Store, root_damage: list[Damage], restored: bool) -> list[str]:
    done: list[str] = []
    if any(d.what == "zarr.json" and not d.group for d in root_damage):  # the root's own
        _plain_root(zs)
        done.append("zarr.json: rewritten as a plain root group")
    if done or restored or root_damage:  # the consolidated copy shows what is now there
        try:
            publish(zs)
            done.append("consolidated metadata rebuilt")
        except Exception as e:  # other metadata is still damaged
            done.append(f"consolidated metadata NOT rebuilt ({short_error(e)})")
    return done


# --- one group ---------------------------------------------------------------------------


class _GroupCheck:
    """The checks (and repairs) of one experiment group, in the order of the module doc."""

    def __init__(self, zs: Store, group: str, copies: dict[str, dict], repair: bool) -> None:
        self.zs, self.group, self.copies, self.repair = zs, group, copies, repair
        self.damage: list[Damage] = []
        self.repaired: list[str] = []
        self.arrays: dict[str, zarr.Array] = {}
        self.restored: set[str] = set()
        self.restore: dict[int, int] = {}  # slot -> the status its checksum verifies
        self.keep: set[int] = set()  # slots repair leaves as they are (load case lost)
        self.undecodable: dict[str, list[str]] = {}  # array -> keys of chunks that do not decode
        self.relabel: dict[int, str] = {}  # slot -> the id its checksum was signed with
        self.resign: dict[int, str] = {}  # slot -> its checksum, signed again (intact data)
        self.notes: list[str] = []

    def report(self, reserved: int = 0, checked: int = 0, unverifiable: int = 0) -> GroupReport:
        return GroupReport(self.group, reserved, checked, unverifiable, tuple(self.damage),
                           tuple(self.repaired), tuple(self.notes))

    def key_damage(self, what: str, reason: str) -> None:
        self.damage.append(Damage(self.group, what, reason))

    def run(self) -> GroupReport:
        if not self._open_metadata():
            return self.report()
        k = self._length()
        ids, used = self._ids(k)
        if ids is None:
            return self.report()
        params, bad_params = self._params(k)
        status = self._status(k, ids, used, params)
        if status is None:
            return self.report(reserved=used)
        self._mesh_chunks()
        positions = [i for i in range(used) if status[i] in (DONE, FAILED) and ids[i]]
        self._orphans(ids, status, used)
        lost = self._lost_load_cases(ids, positions, params, bad_params)
        checkable = [i for i in positions if i not in lost and _valid_id(ids[i])]
        unverifiable = self._checksums(ids, status, params, checkable)
        pending = [i for i in range(used) if status[i] == PENDING and ids[i]
                   and i not in bad_params and _valid_id(ids[i])]
        self._lost_status(ids, status, params, pending)
        self._unsigned_data(ids, [i for i in pending if i not in self.restore])
        self._mark()
        return self.report(used, len(positions), unverifiable)

    # 1. metadata --------------------------------------------------------------------------

    def _open_metadata(self) -> bool:
        key = f"{self.group}/zarr.json"
        try:
            zarr.open_group(store=self.zs, path=self.group, mode="r", use_consolidated=False)
        except Exception as e:  # missing or undecodable metadata
            if not self._restore(self.group, key, e):
                return False
        children = [c for c in list_dir(self.zs, self.group)
                    if c != "zarr.json" and not c.startswith(".")]
        # patch arrays are optional (older groups lack them), but one the consolidated
        # metadata lists was there: its loss is damage, as a required array's is
        listed = {n for n in PATCH_NAMES if f"{self.group}/{n}" in self.copies}
        for name in sorted(set(children) | set(REQUIRED_ARRAYS) | {"checksum"} | listed):
            self._open_array(name, present=name in children)
        return True

    def _open_array(self, name: str, present: bool) -> None:
        path = f"{self.group}/{name}"
        if not present and name == "checksum":
            return
        try:
            if not present:
                raise FileNotFoundError("no such array")
            self.arrays[name] = zarr.open_array(store=self.zs, path=path, mode="r")
            return
        except Exception as e:  # missing or undecodable metadata
            if self._restore(path, f"{path}/zarr.json", e):
                self.arrays[name] = zarr.open_array(store=self.zs, path=path, mode="r")

    def _restore(self, path: str, key: str, error: BaseException) -> bool:
        if get_bytes(self.zs, key) is not None:
            self.key_damage(key, f"the metadata does not decode ({short_error(error)})")
        elif path != self.group and not list_dir(self.zs, path):
            self.key_damage(path, "the array is missing (deleted?)")
        else:
            self.key_damage(key, "the metadata is missing")
        copy = self.copies.get(path)
        if not self.repair or not isinstance(copy, dict):
            return False
        doc = {k: v for k, v in copy.items() if k != "consolidated_metadata"}
        set_bytes(self.zs, key, json.dumps(doc, indent=2).encode())
        self.restored.add(path.removeprefix(f"{self.group}/") if path != self.group else "")
        self.repaired.append(f"{key}: restored from the consolidated metadata")
        return True

    # 2. shapes ---------------------------------------------------------------------------

    def _length(self) -> int:
        """Slots along ``experiment``; arrays of another length (or node size) are named,
        and restored ones are brought to it."""
        along = {n: a.shape[0] for n, a in self.arrays.items()
                 if dimension_names(a)[:1] == ("experiment",)}
        k = along.get("experiment", max(along.values(), default=0))
        for name, n in along.items():
            if n != k and name not in self.restored:
                self.key_damage(f"{self.group}/{name}",
                                f"has {n} slots along experiment, the ids have {k}")
                self._restore_length(name, k)
        for name in self.restored & set(along):
            if along[name] != k:
                self._writable(name).resize((k, *self.arrays[name].shape[1:]))
                self.arrays[name] = zarr.open_array(store=self.zs, path=f"{self.group}/{name}",
                                                    mode="r")
        self._node_sizes()
        return k

    def _restore_length(self, name: str, k: int) -> None:
        """Repair: metadata whose length was edited goes back to the consolidated copy,
        when that copy has the ids' length (issue 50: a status shape of 3 for 6 ids made
        repair raise BoundsCheckError)."""
        path = f"{self.group}/{name}"
        copy = self.copies.get(path)
        if not (self.repair and isinstance(copy, dict) and copy.get("shape", [None])[:1] == [k]):
            return
        doc = {key: v for key, v in copy.items() if key != "consolidated_metadata"}
        set_bytes(self.zs, f"{path}/zarr.json", json.dumps(doc, indent=2).encode())
        self.arrays[name] = zarr.open_array(store=self.zs, path=path, mode="r")
        self.restored.add(name)
        self.repaired.append(f"{path}/zarr.json: its length restored from the consolidated "
                             "metadata")

    def _node_sizes(self) -> None:
        for dim in ("inner_node", "tread_node", "component", "strain_component"):
            if dim not in self.arrays:
                continue
            n = self.arrays[dim].shape[0]
            for name, a in self.arrays.items():
                for d, size in zip(dimension_names(a), a.shape, strict=False):
                    if d == dim and size != n:
                        self.key_damage(f"{self.group}/{name}",
                                        f"has {size} {dim} entries, {dim} has {n}")

    # 3. ids and status -------------------------------------------------------------------

    def _ids(self, k: int) -> tuple[list[str | None] | None, int]:
        if "experiment" not in self.arrays:
            return None, 0
        raw, bad = self._read_1d("experiment", k)
        ids: list[str | None] = [None if i in bad else str(v) for i, v in enumerate(raw)]
        used = next((i for i, e in enumerate(ids) if e == ""), k)
        later = [i for i in range(used, k) if ids[i]]
        if later:
            self.key_damage(f"{self.group}/experiment",
                            f"empty id at slot {used} before reserved ones (slots {_few(later)})")
            used = k
        self._check_ids(ids, used)
        return ids, used

    def _check_ids(self, ids: list[str | None], used: int) -> None:
        seen: dict[str, int] = {}
        for i, e in enumerate(ids[:used]):
            if e is None or e == "":
                continue
            if not EXPERIMENT_ID.fullmatch(e):
                self.damage.append(Damage(self.group, "experiment", "its id is garbled",
                                          e[:40], i))
            elif e in seen:
                self.damage.append(Damage(self.group, "experiment",
                                          f"its id is also at slot {seen[e]}", e, i))
            seen.setdefault(e, i)

    def _status(self, k: int, ids: list, used: int, params: dict) -> np.ndarray | None:
        if "status" not in self.arrays:
            return None
        raw, bad = self._read_1d("status", k)
        status = np.array([PENDING if i in bad else int(v) for i, v in enumerate(raw)],
                          dtype=np.int64)
        if "status" in self.restored:
            status = self._recover_status(ids, used, status, params)
        for i in sorted(bad) + [i for i in range(k) if status[i] not in STATUS_NAMES]:
            who = ids[i] if i < used and ids[i] else None
            self.damage.append(Damage(self.group, "status", "its status does not decode"
                                      if i in bad else f"its status {status[i]} is not 0, 1 or 2",
                                      who, i))
            status[i] = PENDING
        return status

    def _orphans(self, ids: list, status: np.ndarray, used: int) -> None:
        for i in np.flatnonzero(np.isin(status, (DONE, FAILED))):
            if i >= used or not ids[i]:
                self.damage.append(Damage(self.group, f"{self.group}/experiment slot {i}",
                                          _ORPHAN.format(state=STATUS_NAMES[status[i]]),
                                          None, int(i)))

    # 4. checksums ------------------------------------------------------------------------

    def _params(self, k: int) -> tuple[dict[str, np.ndarray], dict[int, str]]:
        params: dict[str, np.ndarray] = {}
        bad: dict[int, str] = {}
        for name, a in self.arrays.items():
            if a.attrs.get("role") != "parameter":
                continue
            values, unreadable = self._read_1d(name, k)
            params[name] = np.array([np.nan if i in unreadable else v
                                     for i, v in enumerate(values)], dtype=np.float64)
            for i in unreadable:
                bad.setdefault(i, f"its {name!r} chunk does not decode")
        return params, bad

    def _checksums(self, ids: list, status: np.ndarray, params: dict, positions: list[int]
                   ) -> int:
        missing = [n for n in CHECKED_NAMES if n not in self.arrays]
        if "checksum" not in self.arrays or missing:
            return len(positions)
        sums, bad = self._read_1d("checksum", len(ids))
        texts = ["" if i in bad else str(s) for i, s in enumerate(sums)]
        lost = [i for i in positions if i in bad or not texts[i]]
        for i in lost:
            self._lost_checksum(ids[i], params, i, int(status[i]), i in bad)
        slots = self._slots(ids, status, params, texts)
        failed = check(slots, [i for i in positions if i not in lost])
        moved = self._moved_ids(ids, status, params, texts, list(failed))
        for i, reason in failed.items():
            if i in moved:
                self.relabel[i] = moved[i]
                reason = (f"its id is {ids[i]!r} but its checksum was signed as {moved[i]!r} "
                          "(ids swapped or moved; its data are intact)")
            self._experiment(ids[i], i, reason + self._missing_chunks(i, status[i]))
        return 0

    def _lost_checksum(self, experiment: str, params: dict, i: int, state: int,
                       garbled: bool) -> None:
        """A slot whose checksum chunk is lost or does not decode: signed again when its
        chunks prove its data intact (:mod:`storage.resign`), else damaged."""
        what = "does not decode" if garbled else "is missing"
        text = signed_again(self.zs, self.group, self.arrays, experiment, params, i, state)
        if text is None:
            self._experiment(experiment, i, f"its checksum chunk {what}"
                             + self._missing_chunks(i, state))
            return
        self.resign[i] = text
        self._experiment(experiment, i, f"its checksum chunk {what}, but every chunk of its "
                         "data passes its CRC32C: repair signs it again (no re-solve)")

    def _moved_ids(self, ids: list, status: np.ndarray, params: dict, sums: list[str],
                   failed: list[int]) -> dict[int, str]:
        """Failed slots whose checksum verifies, data included, under another failed
        slot's id, when those ids are a permutation of each other (issue 26: two swapped
        ids cost two experiments, and resume could not restore them)."""
        if len(failed) < 2:
            return {}
        candidates = {ids[i] for i in failed if ids[i]}
        found: dict[int, str] = {}
        for i in failed:
            label = (split(sums[i]) or ("", ""))[0]
            mine = {n: float(a[i]) for n, a in params.items()}
            match = [e for e in candidates - {ids[i]} if label_digest(e, mine) == label]
            if len(match) == 1:
                found[i] = match[0]
        if sorted(found.values()) != sorted(ids[i] for i in found):
            return {}  # not a permutation among these slots: nothing is proven
        trial = list(ids)
        for i, e in found.items():
            trial[i] = e
        wrong = check(self._slots(trial, status, params, sums), list(found))
        return {} if wrong else found

    def _lost_load_cases(self, ids: list, positions: list[int], params: dict,
                         bad_params: dict[int, str]) -> set[int]:
        """Done or failed slots whose load case is lost (a parameter chunk deleted or not
        decoding): nothing in them can be checked, but nothing says their results are
        wrong either. Repair keeps them as they are (issue 26: marking them pending made
        resume refuse them, "pressure=nan", and lost every result); ``farm sweep resume
        STUDY`` writes the load case back from the study, since an id stands for one
        load case (:func:`storage.reserve`), and their checksums then verify again."""
        lost: dict[int, str] = {}
        for i in positions:
            if i in bad_params:
                lost[i] = bad_params[i]
                continue
            gone = [n for n in REQUIRED_PARAMETERS if n in params and np.isnan(params[n][i])]
            if gone:
                lost[i] = f"its {gone[0]!r} value is missing (a chunk deleted)"
        for i, why in lost.items():
            self.keep.add(i)
            self._experiment(ids[i], i, f"its load case is lost: {why}; the results are "
                             "kept, and `farm sweep resume STUDY` restores the load case from "
                             "the study file (their checksums verify again then)")
        return set(lost)

    def _lost_status(self, ids: list, status: np.ndarray, params: dict, pending: list[int]
                     ) -> None:
        """Pending slots whose checksum matches them done or failed: a ``status`` chunk
        lost or reset (issue 26: verify said "no damage" while readers used 19 of 20),
        or a write interrupted between its checksum and its status. Either way the slot
        holds a whole, verified experiment; repair gives it its status back."""
        if "checksum" not in self.arrays or any(n not in self.arrays for n in CHECKED_NAMES):
            return
        for i, state in self._verified_states(ids, params, pending).items():
            self.restore[i] = state
            self.damage.append(Damage(
                self.group, "status", f"its status is pending but its checksum matches it "
                f"{STATUS_NAMES[state]} (the status chunk was lost or reset, or a write "
                "stopped before its status)", ids[i], i))

    def _unsigned_data(self, ids: list, pending: list[int]) -> None:
        """Pending slots that hold data chunks but no checksum: a write that stopped
        between its data and its checksum (a killed worker), or a slot whose status and
        checksum chunks were both lost (issue 50: verify said nothing, and the analyses
        used 19 of 20). The store cannot tell the two apart, so it is a note, not
        damage: resume solves the slot again either way."""
        if "checksum" not in self.arrays or "displacement" not in self.arrays:
            return
        a, sums = self.arrays["displacement"], self.arrays["checksum"]
        for i in pending:
            if (key_exists(self.zs, chunk_key(self.group, "displacement", a, i))
                    and not key_exists(self.zs, chunk_key(self.group, "checksum", sums, i))):
                self.notes.append(
                    f"{ids[i]} (slot {i}): pending, but its data chunks are there and its "
                    "checksum is not: a write that stopped before its checksum, or its "
                    "status and checksum chunks lost; `farm sweep resume STUDY` solves it "
                    "again")

    def _verified_states(self, ids: list, params: dict, slots) -> dict[int, int]:
        """Slot -> done or failed, for those of ``slots`` (with an id and a readable,
        non-empty checksum) whose checksum verifies them with that status."""
        sums, bad = self._read_1d("checksum", len(ids))
        candidates = [i for i in slots if ids[i] and i not in bad and sums[i]]
        found: dict[int, int] = {}
        for state in (DONE, FAILED):
            if not candidates:
                break
            trial = np.full(len(ids), state, dtype=np.int64)
            wrong = check(self._slots(ids, trial, params, [str(s) for s in sums]), candidates)
            found.update({i: state for i in candidates if i not in wrong})
            candidates = list(wrong)
        return found

    def _slots(self, ids, status, params, sums) -> Slots:
        names = checked_names(self.arrays)
        sizes = {n: int(np.prod(self.arrays[n].shape[1:], dtype=np.int64))
                 * self.arrays[n].dtype.itemsize for n in names}
        return Slots([e or "" for e in ids], status, params, sums,
                     lambda n, lo, hi: read(self.arrays[n], slice(lo, hi)), sizes, names)

    def _missing_chunks(self, i: int, state: int) -> str:
        if state != DONE:
            return ""
        keys = [chunk_key(self.group, name, self.arrays[name], i)
                for name in CHECKED_NAMES if name != "error"]
        lost = [key for key in keys if not key_exists(self.zs, key)]
        return f"; missing chunk(s): {', '.join(lost)}" if lost else ""

    def _recover_status(self, ids: list, used: int, status: np.ndarray, params: dict
                        ) -> np.ndarray:
        """A restored status array is all pending: a slot whose checksum matches as done
        (or failed) is done (or failed)."""
        if "checksum" not in self.arrays or any(n not in self.arrays for n in CHECKED_NAMES):
            self.repaired.append(f"{self.group}/status: restored, every experiment pending "
                                 "(no checksums to recover done ones from)")
            return status
        for i, state in self._verified_states(ids, params, range(used)).items():
            status[i] = state
        found = np.flatnonzero(status != PENDING)
        if found.size:
            self._writable("status").set_coordinate_selection(found, status[found].astype(np.int8))
        self.repaired.append(f"{self.group}/status: {np.count_nonzero(status == DONE)} done and "
                             f"{np.count_nonzero(status == FAILED)} failed recovered from their "
                             "checksums, the rest pending")
        return status

    # 5. other chunks ---------------------------------------------------------------------

    def _mesh_chunks(self) -> None:
        values = {}
        for name, a in self.arrays.items():
            if dimension_names(a)[:1] == ("experiment",):
                continue
            try:
                values[name] = a[...]
            except Exception as e:  # a chunk that does not decode
                self.key_damage(f"{self.group}/{name}",
                                f"a chunk does not decode ({short_error(e)})")
        self._identity(values)

    def _identity(self, values: dict[str, Any]) -> None:
        """The group's name, model and mesh (``values``: the arrays read) against the
        digests it was made with (:mod:`storage.identity`): repair cannot tell which
        side is right, so it marks nothing; the message says what to do."""
        if any(name not in values for name in identity.MESH_ARRAYS):
            return  # a lost or undecodable mesh array is damage already
        try:
            attrs = dict(zarr.open_group(store=self.zs, path=self.group, mode="r",
                                         use_consolidated=False).attrs)
        except Exception:  # the metadata does not decode: named already
            return
        arrays = {name: values[name] for name in identity.MESH_ARRAYS}
        for part in identity.changed(self.group, attrs, arrays) or ():
            self.key_damage(f"{self.group}/{part}", _IDENTITY_ADVICE.get(part, (
                f"{identity.PARTS.get(part, part)} differs from what the group was made "
                "with (edited, or a chunk lost): the group's experiments are not of what "
                "it now says; restore it from a copy or submit the study again into a new "
                "store")))

    # repair -------------------------------------------------------------------------------

    def _experiment(self, experiment: str, index: int, reason: str) -> None:
        self.damage.append(Damage(self.group, "experiment", reason, experiment, index))

    def _mark(self) -> None:
        """Damaged experiments and orphan slots back to pending (``error`` says why)."""
        if not self.repair:
            return
        self._write_slots("status", self.restore,
                          "slot(s) given back the status their checksum verifies")
        self._write_slots("experiment", self.relabel,
                          "id(s) put back where their checksums were signed")
        if self.keep:
            self.repaired.append(f"{self.group}: {len(self.keep)} slot(s) kept as they are: "
                                 "their load case is lost; `farm sweep resume STUDY` restores "
                                 "it from the study")
            self._drop_undecodable_parameters()
        self._write_slots("checksum", self.resign,
                          "checksum(s) signed again: their data chunks pass their CRC32C")
        skip = set(self.restore) | self.keep | set(self.relabel) | set(self.resign)
        marked = sorted({d.index for d in self.damage
                         if d.index is not None and d.index not in skip})
        if not marked:
            return
        dropped = drop_unreadable(self.zs, self.group, self.arrays, marked)
        if dropped:
            self.repaired.append(f"{self.group}: {len(dropped)} data chunk(s) that fail their "
                                 f"CRC32C removed ({_few(dropped)}): their slots are pending")
        status = self._writable("status")
        error = self._writable("error") if "error" in self.arrays else None
        for d in self.damage:
            if d.index is None or d.index in skip:
                continue
            status[d.index] = PENDING
            if error is not None and d.experiment is not None:
                error[d.index] = f"damaged, marked pending by farm sweep verify: {d.reason}"[:500]
        ids = sorted({d.experiment for d in self.damage
                      if d.experiment is not None and d.index not in skip})
        self.repaired.append(
            f"{self.group}: {len(marked)} slot(s) marked pending"
            + (f" ({_few(ids)})" if ids else "")
            + ": `farm sweep resume STUDY` re-solves them")

    def _write_slots(self, name: str, values: dict[int, Any], what: str) -> None:
        """Write ``values`` (slot -> value) into array ``name``; say how many, and what."""
        if not values:
            return
        a = self._writable(name)
        for i, value in sorted(values.items()):
            a[i] = value
        self.repaired.append(f"{self.group}: {len(values)} {what}")

    def _writable(self, name: str) -> zarr.Array:
        return zarr.open_array(store=self.zs, path=f"{self.group}/{name}", mode="r+")

    # reading -----------------------------------------------------------------------------

    def _drop_undecodable_parameters(self) -> None:
        """Remove the load-case chunks that do not decode: their values are lost either
        way, and a chunk that raises on every read stopped resume from writing the load
        case back (issue 50: repair said "resume restores it", resume said "run verify",
        a loop). Removed, they read as missing, which resume restores from the study."""
        keys = [k for name, found in sorted(self.undecodable.items())
                if self.arrays[name].attrs.get("role") == "parameter" for k in found]
        for key in keys:
            delete_key(self.zs, key)
        if keys:
            self.repaired.append(f"{self.group}: {len(keys)} load-case chunk(s) that do not "
                                 f"decode removed ({_few(keys)}), so that resume can write "
                                 "them back")

    def _read_1d(self, name: str, k: int) -> tuple[list, set[int]]:
        """Values of a 1-d array over ``k`` slots, and the slots whose chunk does not
        decode (those are named once per chunk)."""
        a = self.arrays[name]
        chunk = a.chunks[0]
        block = max(chunk, CLIENT_CHUNK)
        values: list = [None] * k
        bad: set[int] = set()
        for lo in range(0, min(k, a.shape[0]), block):
            hi = min(lo + block, k, a.shape[0])
            try:
                values[lo:hi] = read(a, slice(lo, hi)).tolist()
                continue
            except Exception:  # find the chunk(s) that do not decode
                pass
            for c in range(lo, hi, chunk):
                try:
                    values[c:c + chunk] = read(a, slice(c, min(c + chunk, hi))).tolist()
                except Exception as e:
                    key = f"{self.group}/{name}/c/{c // chunk}"
                    if key not in self.undecodable.get(name, ()):  # named once, if read twice
                        self.key_damage(key, f"the chunk does not decode ({short_error(e)})")
                        self.undecodable.setdefault(name, []).append(key)
                    bad.update(range(c, min(c + chunk, hi)))
        fill = "" if a.dtype.kind in "OTU" else a.fill_value
        values = [fill if v is None and i not in bad else v for i, v in enumerate(values)]
        return values, bad


def _valid_id(e: str | None) -> bool:
    """Whether ``e`` is a well-formed experiment id (None: its chunk did not decode)."""
    return e is not None and EXPERIMENT_ID.fullmatch(e) is not None


def _few(items: list, n: int = 10) -> str:
    shown = ", ".join(str(x) for x in items[:n])
    return shown + (f" and {len(items) - n} more" if len(items) > n else "")

