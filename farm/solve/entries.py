"""The physics' small on-disk caches: one JSON entry per content key.

The inflation pre-run's touch height (:func:`farm.solve.contact.touch_height`) and the
free-rolling radius (:func:`farm.solve.rolling.cached_free_radius`) each cost ccx runs
and depend only on what their key hashes, so workers sharing
:func:`farm.mesh.cache.cache_dir` compute them once. A missing, unreadable or damaged
entry is a miss; a cache that cannot be written only costs the computation again.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

from farm.atomic import write_text
from farm.mesh.cache import cache_dir
from farm.specs import content_hash


def _path(kind: str, key: dict[str, Any]) -> Path:
    return cache_dir() / kind / f"{content_hash(key)[:32]}.json"


def read_entry(kind: str, key: dict[str, Any]) -> dict[str, Any] | None:
    """The entry of ``kind`` stored under ``key``, or None."""
    try:
        entry = json.loads(_path(kind, key).read_text())
    except (OSError, ValueError):
        return None
    return entry if isinstance(entry, dict) else None


def write_entry(kind: str, key: dict[str, Any], entry: dict[str, Any]) -> None:
    """Store ``entry`` under ``key`` (atomically, under a unique temporary name: threads
    of one worker may write the same entry)."""
    path = _path(kind, key)
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text(path, json.dumps(entry))
