"""``--json``: one JSON document on stdout instead of the tables, progress still on stderr.

Every command that prints results takes the same option, so a script reads any of them
with one ``json.loads`` of stdout. Values are plain JSON: numpy scalars and arrays become
numbers and lists, paths strings, and a missing number (NaN, what a table shows as '-')
is ``null``: ``NaN`` is not JSON, and a strict parser refuses it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import typer

JSON_HELP = "Print one JSON document on stdout instead of the tables (progress stays on stderr)."
JSON = typer.Option(False, "--json", help=JSON_HELP)


def plain(value: Any) -> Any:
    """``value`` as JSON types (recursively); non-finite floats become None."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        return plain(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def records(frame) -> list[dict[str, Any]]:
    """A pandas DataFrame as one dict per row (column -> value)."""
    return plain(frame.to_dict(orient="records"))


def dump(document: dict) -> None:
    """Print ``document`` on stdout as the command's only output."""
    typer.echo(json.dumps(plain(document), indent=2, allow_nan=False))
