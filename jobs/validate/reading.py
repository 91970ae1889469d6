"""Reading input files: regular files only, at most 1 MiB of UTF-8, TOML nested 8 deep.

Files are read only when they are regular files of at most :data:`MAX_FILE_BYTES`, as
UTF-8, nested at most :data:`MAX_DEPTH` deep (:func:`read_text`, :func:`parse_toml`): a
FIFO, a device or a directory is refused before it is opened for reading, so nothing
waits for ever.
"""

from __future__ import annotations

import os
import stat
import tomllib
from pathlib import Path
from typing import Any

from jobs.errors import StudyError
from jobs.validate.limits import MAX_DEPTH, MAX_FILE_BYTES
from jobs.validate.messages import fail, located, shown


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """The TOML document ``text`` as a dict, nested at most :data:`MAX_DEPTH` deep
    (raises :class:`StudyError` naming ``source``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise StudyError(f"{source} is not valid TOML: {e}") from e
    except RecursionError as e:  # tomllib recurses once per level of [ or {
        raise StudyError(f"{source} is nested too deeply to read (lists or tables inside "
                         f"each other hundreds of levels deep; a study needs {MAX_DEPTH} "
                         "at most)") from e
    with located(source):
        _check_depth(data)
    return data


def _check_depth(data: dict) -> None:
    """Walk the document without recursion: too deep a value is refused before any
    check (or error message) recurses into it."""
    stack: list[tuple[Any, str, int]] = [(data, "", 0)]
    while stack:
        value, where, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise fail(where[:80] + ("..." if len(where) > 80 else ""),
                       f"nested more than {MAX_DEPTH} tables or lists deep")
        if isinstance(value, dict):
            stack += [(v, f"{where}.{k}" if where else str(k), depth + 1)
                      for k, v in value.items()]
        elif isinstance(value, list):
            stack += [(v, f"{where}[{k}]", depth + 1) for k, v in enumerate(value)]


_FILE_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
               (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
               (stat.S_ISSOCK, "a socket"))


def _file_kind(mode: int) -> str:
    return next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")


def read_text(path: Path, what: str = "study file") -> str:
    """The UTF-8 text of the regular file ``path``, at most :data:`MAX_FILE_BYTES`.

    A FIFO, a device or a directory is refused from its ``stat`` before it is opened
    for reading (opening a FIFO waits for a writer; ``/dev/urandom`` never ends), and
    the file is opened non-blocking and checked again, in case it was swapped in
    between. Raises :class:`StudyError` saying what is wrong and what to give instead.
    """
    try:
        data = _read_regular(path)
    except OSError as e:
        raise StudyError(f"cannot read {what} {path}: {e.strerror or e}") from e
    except ValueError as e:  # a NUL byte in the path
        raise StudyError(f"cannot read {what} {shown(str(path))}: {e}") from e
    if isinstance(data, str):
        raise StudyError(f"cannot read {what} {path}: it is {data}, not a regular file")
    if len(data) > MAX_FILE_BYTES:
        raise StudyError(f"cannot read {what} {path}: it is larger than "
                         f"{MAX_FILE_BYTES >> 20} MiB")
    try:
        return data.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as e:
        line = data[:e.start].count(b"\n") + 1
        raise StudyError(f"cannot read {what} {path}: it is not UTF-8 text (byte "
                         f"0x{data[e.start]:02x} on line {line}): save it as UTF-8") from e


def regular_file(path: Path, what: str) -> Path:
    """``path`` if it is a regular file, judged from its ``stat`` alone (a table that
    another module reads later, and may be large): a FIFO or a device is refused."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError) as e:
        raise StudyError(f"cannot read {what} {shown(str(path))}: "
                         f"{getattr(e, 'strerror', None) or e}") from e
    if not stat.S_ISREG(mode):
        raise StudyError(f"cannot read {what} {path}: it is {_file_kind(mode)}, not a "
                         "regular file")
    return path


def _read_regular(path: Path) -> bytes | str:
    """The first ``MAX_FILE_BYTES + 1`` bytes of ``path``, or what kind of file it is
    when it is not a regular one."""
    mode = os.stat(path).st_mode
    if not stat.S_ISREG(mode):
        return _file_kind(mode)
    with os.fdopen(os.open(path, os.O_RDONLY | os.O_NONBLOCK), "rb") as f:
        mode = os.fstat(f.fileno()).st_mode
        if not stat.S_ISREG(mode):
            return _file_kind(mode)
        return f.read(MAX_FILE_BYTES + 1)
