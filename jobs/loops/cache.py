"""A persistent cache of solver evaluations, one ``.npz`` file per content hash.

What is cached is a typed result of :mod:`jobs.guard`: a :class:`~jobs.guard.Solved`
(its measurements, field by field, and the solver state it kept, as bytes) or a
deterministic :class:`~jobs.guard.Failed` (its reason). :func:`encode` and
:func:`decode` are the only places that know the file's layout; an entry in another
layout (an older version of the farm) reads as absent, so it is solved again rather
than misread.

The client is the only writer (it writes what its futures return), so a cache needs no
locking; every file is written to a temporary name and renamed into place, so a client
killed mid-write leaves no torn entry. Arrays round-trip exactly (float64), which is
what makes a resumed loop take the very same path as the first run: the loops are
deterministic, so replaying their evaluations through the cache IS resuming them.
"""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from farm.atomic import replacing
from farm.measure.measurement import Measurement
from jobs.errors import JobError
from jobs.guard import Failed, Result, Solved

KEY = re.compile(r"[0-9a-f]{64}")
LAYOUT = 2  # of the .npz files: 2 = typed results (1 = loose arrays, before 2026-11)
_FIELDS = tuple(f.name for f in dataclasses.fields(Measurement))
# fields that may be None (not written when they are): a missing required one is a bad file
_OPTIONAL = frozenset(f.name for f in dataclasses.fields(Measurement) if f.default is None)


def encode(result: Result) -> dict[str, np.ndarray]:
    """The arrays of a result's cache file."""
    if isinstance(result, Failed):
        return {"layout": np.array(LAYOUT), "failed": np.array(result.reason),
                "outcome": np.array(result.outcome)}
    out = {"layout": np.array(LAYOUT), "solve_seconds": np.array(result.solve_seconds),
           "ccx_runs": np.array(result.ccx_runs), "increments": np.array(result.increments),
           "states": np.array(len(result.measurements))}
    if result.state is not None:
        out["state"] = np.frombuffer(result.state, dtype=np.uint8)
    for k, m in enumerate(result.measurements):
        # fields that are None (the combined-load ones of a vertical path, issue 13) are
        # left out: np.asarray(None) is an object array, which np.load refuses without
        # pickle, so the whole file read as absent and resume-by-replay re-solved it
        out |= {f"m{k}.{name}": np.asarray(getattr(m, name)) for name in _FIELDS
                if getattr(m, name) is not None}
    return out


def decode(arrays: Mapping[str, np.ndarray]) -> Result | None:
    """The result a cache file holds; None for a file of another layout."""
    if "layout" not in arrays or int(arrays["layout"]) != LAYOUT:
        return None
    if "failed" in arrays:
        return Failed(str(arrays["failed"]), str(arrays["outcome"]))
    ms = tuple(_measurement(arrays, k) for k in range(int(arrays["states"])))
    state = arrays["state"].tobytes() if "state" in arrays else None
    return Solved(ms, float(arrays["solve_seconds"]), int(arrays["ccx_runs"]),
                  int(arrays["increments"]), state)


def _measurement(arrays: Mapping[str, np.ndarray], k: int) -> Measurement:
    """State ``k``'s measurement; a missing required field raises KeyError (a bad file)."""
    fields: dict[str, Any] = {}
    for name in _FIELDS:
        key = f"m{k}.{name}"
        fields[name] = _scalar(arrays[key]) if key in arrays or name not in _OPTIONAL else None
    return Measurement(**fields)


def _scalar(a: np.ndarray) -> Any:
    """A 0-d array's Python scalar, any other array as it is."""
    return a.item() if a.ndim == 0 else a


class CacheError(JobError, OSError):
    """The evaluation cache directory cannot be created or written."""


class EvaluationCache:
    """Finished evaluations under ``directory``: ``<key[:2]>/<key>.npz``.

    A kept solver state (``Solved.state``, ~300 kB on the default reduced mesh) stays on
    disk only: :meth:`get` answers without it and :meth:`state` reads it when a solve
    continues from it, so a study of thousands of evaluations holds their measurements
    in memory, not their states.

    Parameters
    ----------
    directory : path
        Created on first write. ``None`` keeps nothing on disk (an in-memory cache of
        this process only, states included).
    """

    def __init__(self, directory: str | os.PathLike[str] | None) -> None:
        self.directory = None if directory is None else Path(directory).expanduser()
        self._memory: dict[str, Result] = {}

    def _path(self, key: str) -> Path:
        if not KEY.fullmatch(key):
            raise ValueError(f"not a content hash: {key!r}")
        assert self.directory is not None
        return self.directory / key[:2] / f"{key}.npz"

    def get(self, key: str) -> Result | None:
        """The result stored under ``key``, or None."""
        if key in self._memory:
            return self._memory[key]
        if self.directory is None:
            return None
        result = self._read(key, lambda files: [k for k in files if k != "state"])
        if result is not None:
            self._memory[key] = result
        return result

    def state(self, key: str) -> bytes | None:
        """The solver state kept with the result under ``key``, or None."""
        if self.directory is None:
            hit = self._memory.get(key)
            return hit.state if isinstance(hit, Solved) else None
        result = self._read(key, list)
        return result.state if isinstance(result, Solved) else None

    def _read(self, key: str, arrays: Callable[[list[str]], list[str]]) -> Result | None:
        path = self._path(key)  # a malformed key raises: it is a bug, not a miss
        try:
            with np.load(path, allow_pickle=False) as z:
                return decode({k: z[k] for k in arrays(z.files)})
        except (OSError, ValueError, KeyError, TypeError):  # absent or unreadable: solve again
            return None

    def put(self, key: str, result: Result) -> None:
        """Store ``result`` under ``key`` (atomically; the last write wins)."""
        if isinstance(result, Solved) and result.state is not None and self.directory is not None:
            self._memory[key] = dataclasses.replace(result, state=None)  # kept on disk only
        else:
            self._memory[key] = result
        if self.directory is None:
            return
        arrays = encode(result)
        path = self._path(key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            # durable: a loop resumes by replaying this cache, so an entry lost to a
            # machine crash costs a solve
            with replacing(path, suffix=".npz", durable=True) as tmp:
                # allow_pickle is numpy's default, named so that the type checker knows
                # that no array of **arrays takes its place
                np.savez(tmp, allow_pickle=True, **arrays)
        except OSError as e:
            raise CacheError(f"cannot write the evaluation cache at {self.directory}: "
                             f"{e.strerror or e}") from e

    def __contains__(self, key: str) -> bool:
        return self.get(key) is not None

    def __len__(self) -> int:
        if self.directory is None or not self.directory.is_dir():
            return len(self._memory)
        return sum(1 for _ in self.directory.glob("*/*.npz"))
