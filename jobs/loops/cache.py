"""A persistent cache of solver evaluations, one ``.npz`` file per content hash.

The client is the only writer (it writes what its futures return), so a cache needs no
locking; every file is written to a temporary name and renamed into place, so a client
killed mid-write leaves no torn entry. Arrays round-trip exactly (float64), which is
what makes a resumed loop take the very same path as the first run: the loops are
deterministic, so replaying their evaluations through the cache IS resuming them.
"""

from __future__ import annotations

import os
import re
import uuid
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from jobs.errors import JobError

KEY = re.compile(r"[0-9a-f]{64}")


class CacheError(JobError, OSError):
    """The evaluation cache directory cannot be created or written."""


class EvaluationCache:
    """Finished evaluations under ``directory``: ``<key[:2]>/<key>.npz``.

    Parameters
    ----------
    directory : path
        Created on first write. ``None`` keeps nothing on disk (an in-memory cache of
        this process only).
    """

    def __init__(self, directory: str | os.PathLike[str] | None) -> None:
        self.directory = None if directory is None else Path(directory).expanduser()
        self._memory: dict[str, dict[str, np.ndarray]] = {}

    def _path(self, key: str) -> Path:
        if not KEY.fullmatch(key):
            raise ValueError(f"not a content hash: {key!r}")
        assert self.directory is not None
        return self.directory / key[:2] / f"{key}.npz"

    def get(self, key: str) -> dict[str, np.ndarray] | None:
        """The arrays stored under ``key``, or None."""
        if key in self._memory:
            return self._memory[key]
        if self.directory is None:
            return None
        path = self._path(key)
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
        except (OSError, ValueError, KeyError):  # absent, or unreadable: solve again
            return None
        self._memory[key] = arrays
        return arrays

    def put(self, key: str, arrays: Mapping[str, np.ndarray]) -> None:
        """Store ``arrays`` under ``key`` (atomically; the last write wins)."""
        arrays = {k: np.asarray(v) for k, v in arrays.items()}
        self._memory[key] = arrays
        if self.directory is None:
            return
        path = self._path(key)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f"{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp.npz")
            np.savez(tmp, **arrays)
            tmp.replace(path)
        except OSError as e:
            raise CacheError(f"cannot write the evaluation cache at {self.directory}: "
                             f"{e.strerror or e}") from e

    def __contains__(self, key: str) -> bool:
        return self.get(key) is not None

    def __len__(self) -> int:
        if self.directory is None or not self.directory.is_dir():
            return len(self._memory)
        return sum(1 for _ in self.directory.glob("*/*.npz"))
