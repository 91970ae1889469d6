"""The rows of a long study kept as they are made, so that a stopped run resumes (issue 46).

The answer's sensor study fits three learners on every sensor and every one of ten
grouped splits: hours on one core, longer than a machine may stay up. Each unit of work
(one sensor on one split) writes its error rows to ``<out>/.partial/<key>.json`` when it
ends; the same command run again reads the units it finds and computes the rest. A
unit's key digests everything its rows depend on - the sensor, the split's rows, the
learners and their settings - and the data: the experiment ids and targets of the
selection (a store that gained experiments gives new keys), and the analysis package's
source (rows made by other code are made again).
A unit being written when the run stopped is not there (written whole, then renamed).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr

__all__ = ["PARTIAL", "RowCache", "fingerprint"]

#: the folder of ``out`` the units are kept in
PARTIAL = ".partial"


def _plain(value):
    """JSON for numpy scalars and arrays (digests of arrays, not their values)."""
    if isinstance(value, np.ndarray):
        return hashlib.blake2b(np.ascontiguousarray(value).tobytes(), digest_size=16).hexdigest()
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    raise TypeError(f"{type(value).__name__} is not part of a study's key")


def _code() -> str:
    """A digest of the analysis package's source: rows made by other code are not reused."""
    import analysis

    digest = hashlib.blake2b(digest_size=16)
    for path in sorted(Path(analysis.__file__).parent.rglob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()


def fingerprint(ds: xr.Dataset, Y: np.ndarray) -> str:
    """What identifies the data of a study: its experiment ids, its targets (K, T) and
    the analysis code (:func:`_code`)."""
    ids = [str(i) for i in np.asarray(ds["experiment"].values)]
    return json.dumps({"ids": ids, "Y": np.asarray(Y, float), "code": _code()},
                      default=_plain)


class RowCache:
    """Units of rows under ``out/.partial``, keyed by their inputs and ``data``."""

    def __init__(self, out: Path, data: str):
        self.folder = Path(out) / PARTIAL
        self.data = hashlib.blake2b(data.encode(), digest_size=16).hexdigest()

    def rows(self, key: dict, make: Callable[[], list[dict]]) -> list[dict]:
        """The unit ``key``'s rows: read where a run made them before, else made by
        ``make()`` and kept."""
        digest = hashlib.blake2b(json.dumps({"data": self.data, **key}, sort_keys=True,
                                            default=_plain).encode(), digest_size=16)
        path = self.folder / f"{digest.hexdigest()}.json"
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError):  # not made yet (or unreadable: made again)
            pass
        rows = make()
        self.folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=self.folder, suffix=".tmp")
        try:
            with os.fdopen(fd, "w") as f:
                json.dump(rows, f, default=_plain)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
        return rows
