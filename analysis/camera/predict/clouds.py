"""Read and write measured point clouds (T2Cam's view of the inner surface), in mm.

:func:`read_cloud` reads one cloud of shape (M, 3) from

- a text table: ``.csv``, ``.txt``, ``.xyz``, ``.asc``, comma, semicolon or whitespace
  separated, ``#`` comments, an optional header line. With a header naming columns
  ``x``, ``y`` and ``z`` (case-insensitive, a unit suffix such as ``x_mm`` or
  ``x [mm]`` allowed) those columns are read; otherwise the first three numeric columns
  (a leading label column is skipped);
- a mesh file that meshio reads, whose nodes are taken as the cloud (cells are ignored):
  ``.ply``, ``.vtk``, ``.vtu``, ``.obj``, ``.off``, ``.stl``, ``.msh``. meshio has no
  XYZ reader: ``.xyz`` is read as a whitespace table here.

Files are data, never code: nothing in them is evaluated. A file that cannot be read
(missing, a directory, empty, not UTF-8 text, too few columns, a value that is not a
number, NaN/inf, more than ``max_points`` points, an extension neither reader knows)
raises one :class:`~analysis.errors.CloudError`, a one-line message naming the file and
what to do. :func:`write_cloud` writes the same formats (text tables and PLY/VTK/VTU).
"""

from __future__ import annotations

import codecs
import os
import re
import warnings
from collections.abc import Callable, Generator, Iterator
from pathlib import Path

import numpy as np

from analysis.errors import CloudError

__all__ = ["MAX_COORDINATE_MM", "MAX_POINTS", "MESH_FORMATS", "TEXT_FORMATS", "read_cloud",
           "write_cloud"]

#: most points :func:`read_cloud` accepts by default (a T2Cam frame has ~1e5)
MAX_POINTS = 10_000_000
#: a file larger than this many bytes per allowed point is refused before reading
BYTES_PER_POINT = 200
#: extensions read as text tables
TEXT_FORMATS = (".csv", ".txt", ".xyz", ".asc")
#: extensions read through meshio (nodes only), with the meshio reader's module name
MESH_FORMATS = {".ply": "ply", ".vtk": "vtk", ".vtu": "vtu", ".obj": "obj", ".off": "off",
                ".stl": "stl", ".msh": "gmsh"}
#: extensions :func:`write_cloud` writes through meshio
_MESH_WRITERS = {".ply": "ply", ".vtk": "vtk", ".vtu": "vtu"}
_UNITS = {"mm": 1.0, "m": 1000.0}
_SNIFF_BYTES = 65536
_AXIS_NAME = re.compile(r"^([xyz])(?:$|[\s_\[(])")


def _fail(path: Path, what: str) -> CloudError:
    return CloudError(f"point cloud {path}: {what}")


MAX_COORDINATE_MM = 1e4
"""A coordinate beyond 10 m is no tyre's (the TM700 is 0.8 m across): a file with one
is corrupt or in other units (issue 47: a coordinate of 1e300 printed Fx = 6.6e299 N)."""


def _checked_file(path: Path, max_points: int) -> str:
    """The file's lower-case extension, once it is a regular, non-empty file of a known
    format and a size a cloud of at most ``max_points`` points can have."""
    if not path.exists():
        raise _fail(path, "no such file; check the path")
    if path.is_dir():
        raise _fail(path, "is a directory, not a file; give the cloud file inside it")
    if not path.is_file():
        raise _fail(path, "is not a regular file (a device or pipe?); give a cloud file")
    suffix = path.suffix.lower()
    if suffix not in TEXT_FORMATS and suffix not in MESH_FORMATS:
        raise _fail(path, f"unknown extension {suffix or '(none)'!r}; use one of "
                          f"{', '.join(TEXT_FORMATS + tuple(MESH_FORMATS))}")
    size = path.stat().st_size
    if size == 0:
        raise _fail(path, "the file is empty; it holds no points")
    if size > max_points * BYTES_PER_POINT:
        raise _fail(path, f"the file is {size:,} bytes, more than a cloud of at most "
                          f"{max_points:,} points needs; split it or pass a larger max_points")
    return suffix


def read_cloud(path: str | os.PathLike, *, units: str = "mm",
               max_points: int = MAX_POINTS) -> np.ndarray:
    """Read one point cloud from a text table or a mesh file.

    Parameters
    ----------
    path : str or path-like
        The file; its extension picks the reader (see the module docstring).
    units : {"mm", "m"}, default="mm"
        Length unit of the file's coordinates; the result is always in mm.
    max_points : int, default=MAX_POINTS
        More points than this (or a file larger than ``BYTES_PER_POINT`` bytes per
        allowed point) is refused.

    Returns
    -------
    ndarray of shape (M, 3), float64
        x, y, z of each point in mm, all finite, M >= 1.

    Raises
    ------
    CloudError
        One line naming the file and what is wrong with it.
    """
    path = Path(path)
    if units not in _UNITS:
        raise CloudError(f"units must be one of {sorted(_UNITS)}, got {units!r}")
    suffix = _checked_file(path, max_points)
    xyz = _read_table(path, max_points) if suffix in TEXT_FORMATS else _read_mesh(path, suffix)
    if xyz.shape[0] > max_points:
        raise _fail(path, f"more than {max_points:,} points; split the cloud or pass a "
                          "larger max_points")
    xyz = xyz * _UNITS[units] if units != "mm" else xyz
    far = np.flatnonzero(np.abs(xyz).max(axis=1, initial=0.0) > MAX_COORDINATE_MM)
    if far.size:
        raise _fail(path, f"point {far[0] + 1} has a coordinate of "
                          f"{np.abs(xyz[far[0]]).max():.3g} mm: a tyre's cloud lies within "
                          f"{MAX_COORDINATE_MM / 1000:g} m of the camera; check the file and "
                          "its units")
    return xyz


def write_cloud(path: str | os.PathLike, xyz) -> Path:
    """Write a cloud (M, 3) as a text table (``.csv``/``.txt``/``.xyz``/``.asc``) or a
    PLY/VTK/VTU file (points as vertex cells, through meshio).

    CSV gets an ``x,y,z`` header, the other text formats whitespace-separated columns
    with a ``# x y z`` comment; values are written with 17 significant digits, so
    :func:`read_cloud` gives back the very same float64 numbers.

    Parameters
    ----------
    path : str or path-like
    xyz : array_like of shape (M, 3)
        Finite coordinates, in mm.

    Returns
    -------
    pathlib.Path
        The file written.
    """
    path = Path(path)
    pts = np.asarray(xyz, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] == 0:
        raise CloudError(f"writing {path}: a cloud must have shape (M, 3) with M >= 1, "
                         f"got {pts.shape}")
    if not np.isfinite(pts).all():
        raise CloudError(f"writing {path}: the cloud holds NaN/inf; drop those points first")
    suffix = path.suffix.lower()
    if suffix in TEXT_FORMATS:
        if suffix == ".csv":
            np.savetxt(path, pts, fmt="%.17g", delimiter=",", header="x,y,z", comments="")
        else:
            np.savetxt(path, pts, fmt="%.17g", delimiter=" ", header="x y z")
    elif suffix in _MESH_WRITERS:
        import meshio

        cells = [("vertex", np.arange(pts.shape[0], dtype=np.int32)[:, None])]
        meshio.write_points_cells(path, pts, cells, file_format=_MESH_WRITERS[suffix])
    else:
        raise CloudError(f"writing {path}: unknown extension {suffix or '(none)'!r}; use "
                         f"one of {', '.join(TEXT_FORMATS + tuple(_MESH_WRITERS))}")
    return path


# -- text tables -----------------------------------------------------------------------


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _split(line: str, delimiter: str | None) -> list[str]:
    return [t.strip().strip('"').strip() for t in line.split(delimiter)]


def _content_lines(path: Path) -> Generator[tuple[int, str], None, None]:
    """(1-based line number, stripped line) of the lines that are neither blank nor
    comments; raises CloudError on text that is not UTF-8."""
    try:
        with path.open(encoding="utf-8-sig", newline="") as fh:
            for number, raw in enumerate(fh, start=1):
                line = raw.split("#", 1)[0].strip()
                if line:
                    yield number, line
    except UnicodeDecodeError as exc:
        raise _fail(path, f"not UTF-8 text (binary data at byte {exc.start}?); a text "
                          "table must be plain text, a binary cloud needs .ply/.vtk/.vtu")\
            from None


def _sniff_binary(path: Path) -> None:
    with path.open("rb") as fh:
        head = fh.read(_SNIFF_BYTES)
    if b"\x00" in head:
        raise _fail(path, "binary data (NUL bytes), not a text table; a binary cloud "
                          "needs a .ply/.vtk/.vtu extension")
    try:
        codecs.getincrementaldecoder("utf-8")().decode(head, final=False)
    except UnicodeDecodeError as exc:
        raise _fail(path, f"not UTF-8 text (binary data at byte {exc.start}?); a text "
                          "table must be plain text, a binary cloud needs .ply/.vtk/.vtu")\
            from None


def _read_table(path: Path, max_points: int) -> np.ndarray:
    _sniff_binary(path)
    lines = _content_lines(path)
    first = next(lines, None)
    if first is None:
        raise _fail(path, "no data lines (only blank lines or # comments)")
    header: list[str] | None = None
    header_line = 0
    # A header has no number in it, or names x, y, z; a first line with some numbers
    # and some text is data (a label column, or a bad value reported below).
    words = [t.strip('"').lower() for t in re.split(r"[,;\s]+", first[1]) if t.strip('"')]
    if not any(_is_number(t) for t in words) or _named_columns(words) is not None:
        header_line = first[0]
        data = next(lines, None)
        if data is None:
            raise _fail(path, "a header line but no points below it")
    else:
        data = first
    lines.close()
    number, line = data
    delimiter = ";" if ";" in line else "," if "," in line else None
    if header_line:
        header = [t.lower() for t in _split(first[1], delimiter)]
    cols = _columns(path, number, _split(line, delimiter), header)
    return _load(path, header_line, delimiter, cols, max_points)


def _columns(path: Path, number: int, tokens: list[str], header: list[str] | None
             ) -> list[int]:
    """The x, y, z columns: those the header names, else the first three numeric ones
    of the first data line (line ``number``, split into ``tokens``)."""
    if len(tokens) < 3:
        raise _fail(path, f"line {number} has {len(tokens)} column(s); a cloud needs x, y, z "
                          "(three columns)")
    named = _named_columns(header) if header else None
    if named is not None:
        if max(named) >= len(tokens):
            raise _fail(path, f"line {number} has {len(tokens)} columns but the header puts "
                              f"x, y, z in columns {[c + 1 for c in named]}")
        return list(named)
    numeric = [j for j, t in enumerate(tokens) if _is_number(t)]
    if len(numeric) < 3:
        bad = next(t for t in tokens if not _is_number(t))
        raise _fail(path, f"line {number} has {len(numeric)} numeric column(s) "
                          f"({bad!r} is not a number); a cloud needs x, y, z")
    return numeric[:3]


def _load(path: Path, header_line: int, delimiter: str | None, cols: list[int],
          max_points: int) -> np.ndarray:
    """The table's x, y, z columns below its header, finite, (M, 3)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy's "empty input file" and the like
            xyz = np.loadtxt(path, dtype=np.float64, delimiter=delimiter, comments="#",
                             skiprows=header_line, usecols=cols, ndmin=2,
                             max_rows=max_points + 1, encoding="utf-8-sig", quotechar='"')
    except UnicodeDecodeError as exc:
        raise _fail(path, f"not UTF-8 text (binary data at byte {exc.start}?); a text "
                          "table must be plain text") from None
    except ValueError as exc:
        raise _fail(path, _first_bad_line(path, header_line, delimiter, cols)
                    or str(exc).splitlines()[0]) from None
    if xyz.shape[0] == 0:
        raise _fail(path, "no points")
    finite = np.isfinite(xyz).all(axis=1)
    if not finite.all():
        k = int(np.argmin(finite))
        where = _nth_data_line(path, header_line, k)
        raise _fail(path, f"NaN or inf at line {where}; drop or fix that point")
    return xyz


def _named_columns(header: list[str]) -> list[int] | None:
    found: dict[str, int] = {}
    for j, name in enumerate(header):
        m = _AXIS_NAME.match(name)
        if m and m.group(1) not in found:
            found[m.group(1)] = j
    return [found[a] for a in "xyz"] if len(found) == 3 else None


def _data_lines(path: Path, skip: int) -> Iterator[tuple[int, str]]:
    return ((n, line) for n, line in _content_lines(path) if n > skip)


def _nth_data_line(path: Path, skip: int, k: int) -> int:
    for i, (n, _) in enumerate(_data_lines(path, skip)):
        if i == k:
            return n
    return -1


def _first_bad_line(path: Path, skip: int, delimiter: str | None,
                    cols: list[int]) -> str | None:
    """What is wrong with the first line numpy could not read (None: nothing found)."""
    for n, line in _data_lines(path, skip):
        tokens = _split(line, delimiter)
        if len(tokens) <= max(cols):
            return (f"line {n} has {len(tokens)} column(s), the cloud's x, y, z are in "
                    f"columns {[c + 1 for c in cols]}; fix or drop that line")
        for c in cols:
            if not tokens[c]:
                return f"line {n}, column {c + 1} is empty; fill in or drop that point"
            if not _is_number(tokens[c]):
                return (f"line {n}, column {c + 1}: {tokens[c]!r} is not a number"
                        + ("; use a decimal point, not a comma" if re.fullmatch(
                            r"[-+]?\d+,\d+", tokens[c]) else ""))
    return None


# -- mesh files (meshio) ---------------------------------------------------------------


def _mesh_reader(fmt: str) -> Callable:
    import importlib

    return importlib.import_module(f"meshio.{fmt}").read


def _read_mesh(path: Path, suffix: str) -> np.ndarray:
    fmt = MESH_FORMATS[suffix]
    try:
        read = _mesh_reader(fmt)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy overflow on garbage and the like
            mesh = read(str(path))
        pts = np.asarray(mesh.points, dtype=np.float64)
    # meshio raises anything on a hostile file (and sys.exit on some): one line instead.
    except (Exception, SystemExit) as exc:
        msg = (str(exc).splitlines() or [""])[0][:160]
        raise _fail(path, f"not a readable {fmt.upper()} file ({type(exc).__name__}"
                          f"{': ' + msg if msg else ''}); check the file or export it "
                          "again") from None
    if pts.ndim != 2 or pts.shape[0] == 0:
        raise _fail(path, "the mesh has no points")
    if pts.shape[1] < 3:
        raise _fail(path, f"points have {pts.shape[1]} coordinate(s); a cloud needs x, y, z")
    pts = np.ascontiguousarray(pts[:, :3])
    finite = np.isfinite(pts).all(axis=1)
    if not finite.all():
        raise _fail(path, f"point {int(np.argmin(finite))} (0-based) is NaN or inf; drop "
                          "or fix it")
    return pts
