"""Where results go: paths and URLs of stores and caches, and a URL store's fsspec options.

Control characters, invisible formatting characters, Windows paths, over-long names, a
``~user`` that does not exist and dangling symbolic links are refused here, where the
key can still be named; a URL must be one the storage layer accepts
(:func:`storage.open_store`), so a store no worker can write is refused before a cluster
starts. Credentials never belong in a study file (:data:`SECRET_OPTIONS`).
"""

from __future__ import annotations

import math
import os
import re
import unicodedata
from pathlib import Path
from typing import Any

from jobs.validate.limits import MAX_PATH_CHARS
from jobs.validate.messages import fail, shown
from jobs.validate.scalars import string
from storage.errors import StoreError

WINDOWS_PATH = re.compile(r"[A-Za-z]:[\\/]")  # C:\farm or C:/farm
#: Keys of fsspec/s3fs/gcsfs/adlfs options that hold secrets: refused in study files,
#: which get copied, committed and shared. Credentials come from the environment
#: (``AWS_ACCESS_KEY_ID``/``AWS_SECRET_ACCESS_KEY``, a profile, an instance role).
SECRET_OPTIONS = frozenset({"key", "secret", "token", "password", "session_token",
                            "aws_access_key_id", "aws_secret_access_key", "aws_session_token",
                            "account_key", "sas_token", "client_secret", "connection_string"})
MAX_OPTIONS_DEPTH = 3  # client_kwargs.config.x: deeper tables are no fsspec option


def location(value: Any, where: str, what: str = "a path or URL", base: Path | None = None
             ) -> str:
    """A store or cache location: a URL (``scheme://...``) as given, or a local path made
    absolute (``~`` expanded, a relative one taken from ``base``, default the current
    folder). Control characters, over-long names and a ``~user`` that does not exist are
    refused here, where the key can still be named."""
    text = string(value, where, what, blank=False)
    if len(text) > MAX_PATH_CHARS or any(ord(c) < 32 or ord(c) == 127 for c in text):
        raise fail(where, f"must be {what} of at most {MAX_PATH_CHARS} printable characters, "
                   f"got {shown(text)}")
    invisible = [c for c in text if unicodedata.category(c) == "Cf"]
    if invisible:  # a U+202E makes a path read differently from what it is (issue 26)
        raise fail(where, f"contains the invisible formatting character "
                   f"U+{ord(invisible[0]):04X} ({unicodedata.name(invisible[0], '?')}): "
                   "type the path again")
    if "://" in text:
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9+.-]*://\S+", text):
            raise fail(where, f"is not a URL (scheme://location), got {shown(text)}")
        return text
    if any(len(part.encode()) > 255 for part in Path(text).parts):
        raise fail(where, f"has a path component longer than 255 bytes: {shown(text)}")
    if os.name == "posix" and (WINDOWS_PATH.match(text) or "\\" in text):
        raise fail(where, f"{shown(text)} looks like a Windows path; on this system paths "
                   "use '/' (e.g. /data/farm.zarr)")
    try:
        path = Path(text).expanduser()
        path = path if base is None else base / path
        _check_links(path, where)
        return str(path.resolve())
    except (RuntimeError, KeyError, OSError) as e:  # ~nobody: no such user
        raise fail(where, f"cannot resolve the path {shown(text)}: {e}") from e


def _check_links(path: Path, where: str) -> None:
    """Refuse a path through a symbolic link whose target does not exist: the store would
    be created at the link's target, somewhere the user did not name (issue 26)."""
    for part in (path, *path.parents):
        if part.is_symlink() and not part.exists():
            raise fail(where, f"{part} is a symbolic link to {os.readlink(part)}, which does "
                       "not exist: create the target or give another path")


def store_location(value: Any, where: str, base: Path | None = None) -> str:
    """A store: :func:`location`, then what the storage layer accepts as a store
    (:func:`storage.open_store`, no I/O: schemes, buckets, control characters), so that
    a store no worker can write is refused before a cluster starts."""
    # Imported here: storage.paths loads zarr (0.2 s), and the CLI imports this module to
    # declare its options, so ``farm --help`` would pay for it (issue 25).
    from storage.paths import open_store

    text = location(value, where, "a directory path or URL", base)
    try:
        open_store(value)  # as written: "s3:/bucket" is a typo, not a folder "s3:"
    except StoreError as e:
        raise fail(where, str(e)) from e
    return text


def storage_options(data: Any, where: str, store: str) -> dict[str, Any]:
    """fsspec options of a URL store (``[study.storage_options]``): endpoint, region,
    ``anon``, ``client_kwargs``... as strings, numbers, booleans and nested tables.
    Refused: options for a local directory (they would be ignored), and secrets
    (:data:`SECRET_OPTIONS`: credentials stay in environment variables)."""
    if "://" not in store:
        raise fail(where, f"are for object-store URLs (s3://...), but the store is the "
                   f"local path {shown(store)}: drop the table")
    return _options(data, where, 1)


def _options(data: Any, where: str, depth: int) -> dict[str, Any]:
    if not isinstance(data, dict):
        raise fail(where, f"must be a table, got {type(data).__name__} {shown(data)}")
    if depth > MAX_OPTIONS_DEPTH:
        raise fail(where, f"nests deeper than {MAX_OPTIONS_DEPTH} tables")
    out: dict[str, Any] = {}
    for name, value in data.items():
        at = f"{where}.{name}"
        if name.lower() in SECRET_OPTIONS:
            raise fail(at, "credentials do not belong in a study file: set them in the "
                       "environment (AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY for S3, "
                       "or a profile) on the client and on every worker")
        if isinstance(value, dict):
            out[name] = _options(value, at, depth + 1)
        elif isinstance(value, str | bool | int | float):
            if isinstance(value, float) and not math.isfinite(value):
                raise fail(at, f"must be finite, got {shown(value)}")
            out[name] = value
        else:
            raise fail(at, f"must be a string, number, boolean or table, got {shown(value)}")
    return out
