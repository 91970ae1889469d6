"""Checks of what only the command line takes: output files and folders, worker counts.

Run before any work, so that a finished solve is never lost to a bad ``--out`` path.
They raise :class:`~jobs.errors.StudyError` lines of :mod:`jobs.validate.messages`, the
form every other input error has (the commands mark them as usage errors, exit 2).
"""

from __future__ import annotations

import os
from pathlib import Path

from jobs.validate.messages import fail
from jobs.validate.scalars import integer

MAX_WORKERS = 1024  # --workers: processes of the embedded cluster, or workers to wait for


def output_file(path: Path, where: str) -> Path:
    """A file to write later: not a directory, in an existing, writable folder.
    Checked before any work, so that a finished solve is never lost to a bad path."""
    path = Path(path).expanduser()
    if path.is_dir():
        raise fail(where, f"{path} is a directory: give a file name")
    folder = path.parent
    if not folder.is_dir():
        raise fail(where, f"the folder {folder} of {path} does not exist (create it first)")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise fail(where, f"the folder {folder} of {path} is not writable")
    return path


def output_folder(path: Path, where: str) -> Path:
    """A folder to write into later (made if missing): not a file, and its nearest
    existing ancestor a writable folder."""
    path = Path(path).expanduser()
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        what = "is" if existing == path else f"would be made under {existing}, which is"
        raise fail(where, f"{path} {what} a file, not a folder: give a folder path")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise fail(where, f"{existing} is not writable: give a folder you can write to")
    return path


NAME_MAX = 255  # bytes in one path component on the file systems the farm writes to


def model_folder(path: Path, where: str) -> Path:
    """A folder of its own for a model (``farm fit --out``): a new folder, an empty one,
    or an earlier model's (whose two files are replaced) - never the current folder, a
    symbolic link, or a folder of other files, which a model would be mixed into."""
    path = Path(path).expanduser()
    if path == Path("."):
        raise fail(where, "the current folder was given (or an empty path): give a folder "
                   "of its own for the model, e.g. --out model")
    long = [part for part in path.parts if len(os.fsencode(part)) > NAME_MAX]
    if long:  # before any look at the path: the system refuses to (ENAMETOOLONG)
        raise fail(where, f"the name {long[0][:40]}... is {len(os.fsencode(long[0]))} bytes, "
                   f"over the {NAME_MAX} a file system allows: give a shorter name")
    if path.is_symlink():
        raise fail(where, f"{path} is a symbolic link: give the folder's own path")
    if path.is_dir() and any(path.iterdir()) and not (path / "manifest.json").is_file():
        raise fail(where, f"{path} holds other files, not a model: give a new folder or an "
                   "earlier model's to replace it")
    return output_folder(path, where)


def worker_count(value: int | None, where: str = "--workers") -> int | None:
    """A worker count in [1, :data:`MAX_WORKERS`]; ``None`` (one per core) passes."""
    return None if value is None else integer(value, where, low=1, high=MAX_WORKERS)
