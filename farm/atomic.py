"""Atomic file writes: a reader sees the old file or the new one, never a torn one.

The one helper of the on-disk caches (meshes, the inflation pre-run, the loops'
evaluations, issue 25). Each once rolled its own temporary name; the inflation cache's
held only the pid, so two threads of one worker writing the same entry shared a
temporary file: one truncated what the other was writing, and the loser's rename found
no file. Here a temporary name is unique per write (pid, thread id and a random uuid),
lies in the target's folder (``os.replace`` is atomic only within one file system), and
is removed when the write fails.

Durability: the temporary file is always fsynced before the rename. Without that, a
machine that loses power may persist the rename before the data (ext4 without
``auto_da_alloc``, XFS), leaving an empty or torn file under the final name, which
numpy's readers raise on with errors the caches do not catch. ``durable=True`` also
fsyncs the folder, so that the rename itself survives a crash: for entries that are
worth a solve to keep (the loops' cache, which is how a killed calibration resumes).
The cost is one or two fsyncs per entry, each entry being the result of a gmsh or ccx
run that took seconds.
"""

from __future__ import annotations

import contextlib
import os
import threading
import uuid
from collections.abc import Iterator
from pathlib import Path


def temp_name(target: Path, suffix: str = "") -> Path:
    """A temporary path beside ``target``, unique to this write (process, thread, uuid).

    ``suffix`` ends the name, for writers that insist on one (``np.savez`` appends
    ``.npz`` to a name without it, and would write elsewhere).
    """
    tag = f"{os.getpid()}.{threading.get_ident()}.{uuid.uuid4().hex}"
    return target.with_name(f"{target.name}.{tag}.tmp{suffix}")


@contextlib.contextmanager
def replacing(target: str | Path, *, suffix: str = "", durable: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write; on success it replaces ``target`` atomically.

    The body writes the whole file at the yielded path (and closes it). If the body
    raises, the temporary file is removed and ``target`` is left as it was. The folder
    of ``target`` must exist.

    Example::

        with replacing(path, suffix=".npz") as tmp:
            np.savez(tmp, **arrays)
    """
    target = Path(target)
    tmp = temp_name(target, suffix)
    try:
        yield tmp
        _fsync(tmp, os.O_RDONLY)
        os.replace(tmp, target)
    except BaseException:  # also KeyboardInterrupt: never leave a stray temporary file
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        raise
    if durable:
        # Some file systems refuse to fsync a folder: the file is in place all the
        # same, only the rename's survival of a power loss is unconfirmed.
        with contextlib.suppress(OSError):
            _fsync(target.parent, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))


def write_bytes(target: str | Path, data: bytes, *, durable: bool = False) -> None:
    """Write ``data`` to ``target`` atomically (see :func:`replacing`)."""
    with replacing(target, durable=durable) as tmp:
        tmp.write_bytes(data)


def write_text(target: str | Path, text: str, *, durable: bool = False) -> None:
    """Write ``text`` (UTF-8) to ``target`` atomically (see :func:`replacing`)."""
    write_bytes(target, text.encode("utf-8"), durable=durable)


def _fsync(path: Path, flags: int) -> None:
    fd = os.open(path, flags)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
