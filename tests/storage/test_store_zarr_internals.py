"""zarr-python internals are used in one module only (storage/_zarr.py), so that a zarr
upgrade is checked in one place."""

from __future__ import annotations

import re
from pathlib import Path

import storage

# the internal modules, the async view of an array and its coroutines, zarr's loop runner
INTERNALS = re.compile(r"zarr\.core|\.async_array\b|\.(get|set)item\(|\bsync\(|from zarr import")


def test_only_the_wrapper_touches_zarr_internals():
    folder = Path(storage.__file__).parent
    offenders = [f"{path.name}:{n}" for path in sorted(folder.glob("*.py"))
                 if path.name != "_zarr.py"
                 for n, line in enumerate(path.read_text().splitlines(), start=1)
                 if INTERNALS.search(line.split("#")[0])
                 and "from storage._zarr import" not in line]
    assert offenders == []
