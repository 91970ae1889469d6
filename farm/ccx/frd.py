"""Reader for CalculiX ``.frd`` result files (the ASCII variant ccx writes by default).

The layout is the cgx manual's "Result Format" (fixed-width Fortran records):

- ``    1C`` / ``    1U`` / ``    1P`` model and parameter headers (``1PSTEP`` carries the
  block counter, the increment and the step number of the next result block; in a
  ``*FREQUENCY`` step ``1PMODE`` carries the block's mode number);
- ``    2C`` node block: `` -1`` + id + 3 x E12.5 per node, closed by `` -3``;
- ``    3C`` element block: `` -1`` + id, type, group, material, then `` -2`` node lines;
- ``  100C`` result block: the header carries the time (or frequency), then a `` -4``
  record (name, number of components), one `` -5`` record per component and one
  `` -1`` data record per node (more than 6 values continue on `` -2`` lines);
- `` 9999`` ends a file that ccx finished writing.

Ids are I10 in the long format (flag 1, what ccx 2.x always writes) and I5 in the short
one (flag 0, older writers). Values are E12.5 and may touch (``-1.2E-01-2.3E+00``), so
records are cut by column, never split on blanks, and a whole block is converted at
once with numpy. The binary variants (flags 2 and 3) are refused with a clear error.

When a nonlinear step diverges, ccx appends one last output with the best unconverged
displacements (``DISP``) and the *residual* forces (``FORC``), then stops without the
`` 9999`` end record. Those blocks land in :attr:`FrdFile.residuals`, not in
:attr:`FrdFile.results`, so they are never mistaken for converged results.
"""

from __future__ import annotations

import gzip
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from farm.errors import ResultsError

ELEMENT_TYPES = {
    1: "HE8", 2: "PE6", 3: "TE4", 4: "HE20", 5: "PE15", 6: "TE10",
    7: "TR3", 8: "TR6", 9: "QU4", 10: "QU8", 11: "BE2", 12: "BE3",
}
"""frd element type codes (cgx manual, "Element Types"); C3D8/C3D8I/C3D8R are ``HE8``."""

RESIDUAL_NAMES = frozenset({"DISP", "FORC", "NDTEMP", "RFL", "TOTEMP", "MAFLOW", "TOPRES"})
"""Blocks ccx writes for a diverged increment (ccx ``storeresidual``: U, RF, NT, RFL
and the network fields); ``FORC`` then holds residual forces, not reactions."""

_VALUE_WIDTH = 12  # E12.5
_PER_LINE = 6  # values per data line; more continue on " -2" lines
_ID_WIDTH = {0: 5, 1: 10}  # format flag -> id field width


@dataclass(frozen=True, eq=False)
class FrdResult:
    """One nodal result block of an ``.frd`` file.

    Attributes
    ----------
    name : str
        Block name as written (``DISP``, ``FORC``, ``TOSTRAIN``, ``STRESS``,
        ``CONTACT``, ``ERROR``, ...).
    step, increment : int
        From the block's ``1PSTEP`` record (0 when the file has none).
    time : float
        Total time of the block (the eigenfrequency for modal steps), as printed in
        the header: 6 significant digits below 1, 10 above.
    components : tuple of str
        Component names, e.g. ``("D1", "D2", "D3")``; the derived ``ALL`` is dropped.
    node_ids : ndarray, shape (n,)
        int64 node ids in file order: ascending for nodal fields, ccx's contact-element
        order for ``CONTACT``; only the ``NSET`` nodes when the output card names one.
        Blocks of one output share this (read-only) array.
    values : ndarray, shape (n, k)
        float64 values, one column per component.
    line : int
        Line of the block's ``100C`` header, for messages.
    mode : int
        Mode number of an eigenmode block (``*FREQUENCY`` step, from the ``1PMODE``
        record ccx writes before it), 0 for every other block. Modes of equal frequency
        (symmetric structures) differ only in this number: look them up with
        :meth:`FrdFile.at_mode`, not by frequency.
    """

    name: str
    step: int
    increment: int
    time: float
    components: tuple[str, ...]
    node_ids: np.ndarray
    values: np.ndarray
    line: int = 0
    mode: int = 0

    def column(self, component: str) -> np.ndarray:
        """Values of one component, shape (n,); ``ResultsError`` for an unknown name."""
        try:
            return self.values[:, self.components.index(component)]
        except ValueError:
            raise ResultsError(
                f"{self.name} block (line {self.line}) has no component {component!r}; "
                f"it has {', '.join(self.components)}"
            ) from None

    def values_at(self, node_ids) -> np.ndarray:
        """Rows for ``node_ids`` (shape (m,) -> (m, k)); ``ResultsError`` if one is absent."""
        what = f"{self.name} block (line {self.line})"
        return self.values[rows_of(self.node_ids, node_ids, what)]


def rows_of(ids: np.ndarray, wanted, what: str) -> np.ndarray:
    """Row index of each of ``wanted`` in ``ids`` (any order), shape (m,)."""
    wanted = np.asarray(wanted, dtype=np.int64).ravel()
    order = np.argsort(ids, kind="stable")
    ranked = ids[order]
    pos = np.searchsorted(ranked, wanted)
    hit = pos < len(ranked)
    hit[hit] = ranked[pos[hit]] == wanted[hit]
    if not hit.all():
        raise ResultsError(f"{what} has no values for ids {wanted[~hit][:5].tolist()}")
    return order[pos]


@dataclass(frozen=True, eq=False)
class FrdFile:
    """Mesh and results of one ``.frd`` file.

    Attributes
    ----------
    path : str
        The file read.
    node_ids : ndarray, shape (N,)
        int64 ids of the node block.
    coords : ndarray, shape (N, 3)
        Reference coordinates (5 significant digits, as printed).
    element_ids, element_types : ndarray, shape (E,)
        int64 ids and frd type codes (see :data:`ELEMENT_TYPES`).
    connectivity : ndarray, shape (E, M)
        int64 node ids in frd order, padded with -1 (M = most nodes of any element).
    results : tuple of FrdResult
        Converged result blocks, in file order.
    residuals : tuple of FrdResult
        Blocks written for a diverged increment (best solution, residual forces).
    complete : bool
        True when the `` 9999`` end record was read, i.e. ccx finished the file.
    truncated : bool
        True when a last block cut short was dropped (``allow_truncated=True``).
    """

    path: str
    node_ids: np.ndarray
    coords: np.ndarray
    element_ids: np.ndarray
    element_types: np.ndarray
    connectivity: np.ndarray
    results: tuple[FrdResult, ...]
    residuals: tuple[FrdResult, ...] = ()
    complete: bool = True
    truncated: bool = False

    def names(self) -> list[str]:
        """Distinct result names, in order of first appearance."""
        return list(dict.fromkeys(r.name for r in self.results))

    def results_named(self, name: str) -> list[FrdResult]:
        """All converged blocks called ``name``, in file order."""
        return [r for r in self.results if r.name == name]

    def times(self, name: str | None = None) -> np.ndarray:
        """Sorted distinct times of the converged blocks (of ``name`` if given)."""
        chosen = self.results if name is None else self.results_named(name)
        return np.unique(np.array([r.time for r in chosen], dtype=np.float64))

    def modes(self, name: str | None = None) -> np.ndarray:
        """Sorted distinct mode numbers of the eigenmode blocks (of ``name`` if given)."""
        chosen = self.results if name is None else self.results_named(name)
        return np.unique(np.array([r.mode for r in chosen if r.mode], dtype=np.int64))

    def at(self, name: str, time: float, *, rtol: float = 1e-5, atol: float = 1e-12) -> FrdResult:
        """The last ``name`` block whose time is within ``atol + rtol * |time|``.

        The default ``rtol`` covers the header's 6 printed digits, so the time asked
        for in the deck (``*TIME POINTS``) finds its block. For eigenmodes the time is
        the frequency; when modes share it, ``ResultsError``: use :meth:`at_mode`.
        """
        hits = [
            r for r in self.results_named(name) if abs(r.time - time) <= atol + rtol * abs(time)
        ]
        if not hits:
            have = self.times(name)
            raise ResultsError(
                f"{self.path}: no {name} block at time {time:g} "
                f"(it has {name} at times {have.tolist()[:12]}; names: {self.names()})"
            )
        modes = sorted({r.mode for r in hits if r.mode})
        if len(modes) > 1:
            raise ResultsError(
                f"{self.path}: {name} blocks of modes {modes} share the frequency {time:g} "
                f"(lines {[r.line for r in hits][:6]}); pick one with at_mode({name!r}, mode)"
            )
        return hits[-1]

    def at_mode(self, name: str, mode: int, *, step: int | None = None) -> FrdResult:
        """The ``name`` block of eigenmode ``mode`` (of ``step`` when several steps are
        ``*FREQUENCY`` steps); ``ResultsError`` when there is none or more than one."""
        hits = [r for r in self.results_named(name)
                if r.mode == mode and (step is None or r.step == step)]
        if len(hits) == 1:
            return hits[0]
        where = "" if step is None else f" in step {step}"
        if not hits:
            raise ResultsError(f"{self.path}: no {name} block of mode {mode}{where} (it has "
                               f"{name} of modes {self.modes(name).tolist()[:12]}; names: "
                               f"{self.names()})")
        raise ResultsError(
            f"{self.path}: {len(hits)} {name} blocks of mode {mode}{where} (steps "
            f"{[r.step for r in hits]}, lines {[r.line for r in hits][:6]}); give the step, "
            "or for cyclic symmetry read the blocks with results_named")


def read_frd(
    path: str | Path, *, diverged: bool | None = None, allow_truncated: bool = False
) -> FrdFile:
    """Read an ASCII ``.frd`` file written by ccx (or cgx, short or long format).

    Parameters
    ----------
    path : str or Path
        The ``.frd`` file (``.frd.gz`` is read through gzip).
    diverged : bool or None
        Whether the run stopped on divergence. ``None`` (default) decides from the file:
        it lacks the end record and its last output holds only residual-type blocks
        (:data:`RESIDUAL_NAMES`), residual forces (``FORC`` or ``RFL``) among them.
        ``True``/``False`` overrides that guess with the outcome classified from the
        ccx log (a run killed on timeout right after an output of only ``U, RF``
        would otherwise pass for a diverged one).
    allow_truncated : bool
        Drop a last block cut short (a killed writer) instead of raising.

    Returns
    -------
    FrdFile

    Raises
    ------
    ResultsError
        Missing or empty file, binary frd, a record that breaks the layout, or a block
        cut short (unless ``allow_truncated``); the message names the file and line.
    """
    path = Path(path)
    data = read_bytes(path, "frd")
    if not data or data.isspace():
        raise ResultsError(f"{path}: frd file is empty (ccx wrote nothing)")
    parts = _Scanner(data, str(path), allow_truncated).scan()
    return _assemble(str(path), parts, diverged)


def read_bytes(path: Path, kind: str) -> bytes:
    """The file's bytes, gunzipped when the name ends in ``.gz`` (archived results)."""
    try:
        raw = path.read_bytes()
        return gzip.decompress(raw) if path.suffix == ".gz" else raw
    except (OSError, EOFError) as exc:  # gzip.BadGzipFile is an OSError
        raise ResultsError(f"cannot read {kind} file {path}: {exc}") from None


@dataclass
class _Parts:
    """What the scanner collected, before the results are split."""

    nodes: tuple[np.ndarray, np.ndarray] | None = None
    elements: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    blocks: list[tuple[int, FrdResult]] = field(default_factory=list)  # (output no., block)
    complete: bool = False
    truncated: bool = False


def _assemble(path: str, parts: _Parts, diverged: bool | None) -> FrdFile:
    blocks = parts.blocks
    n_last = 0  # size of the trailing run of blocks from one output (same output number)
    while n_last < len(blocks) and blocks[-1 - n_last][0] == blocks[-1][0]:
        n_last += 1
    if diverged is None:  # ccx writes the residual output whole, then stops; a cut
        names = {b.name for _, b in blocks[len(blocks) - n_last :]}  # file was killed
        diverged = (not parts.complete and not parts.truncated and names <= RESIDUAL_NAMES
                    and bool(names & {"FORC", "RFL"}))
    n_res = n_last if diverged else 0
    results = tuple(b for _, b in blocks[: len(blocks) - n_res])
    residuals = tuple(b for _, b in blocks[len(blocks) - n_res :])
    ids, coords = parts.nodes or (np.zeros(0, np.int64), np.zeros((0, 3)))
    empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 0), np.int64))
    eids, etypes, conn = parts.elements or empty
    return FrdFile(path, ids, coords, eids, etypes, conn, results, residuals, parts.complete,
                   parts.truncated)


class _Scanner:
    """Walks the file record by record; bodies of blocks are parsed in bulk."""

    def __init__(self, data: bytes, path: str, allow_truncated: bool) -> None:
        self.data = data
        self.path = path
        self.allow_truncated = allow_truncated
        self.pos = 0
        self.lineno = 0  # line number of the line last returned
        self.known_ids: dict[bytes, np.ndarray] = {}
        self.truncated = False

    def fail(self, line: int, message: str) -> ResultsError:
        return ResultsError(f"{self.path}, line {line}: {message}")

    def next_line(self) -> bytes | None:
        """The next line without its end of line, or None at the end of the file."""
        if self.pos >= len(self.data):
            return None
        end = self.data.find(b"\n", self.pos)
        end = len(self.data) if end < 0 else end
        line = self.data[self.pos : end].rstrip(b"\r")
        self.pos = end + 1
        self.lineno += 1
        return line

    def scan(self) -> _Parts:
        parts = _Parts()
        step = (0, 0)  # (step, increment) of the last 1PSTEP record
        mode = 0  # of the 1PMODE record after that 1PSTEP (eigenmode blocks only)
        while (line := self.next_line()) is not None:
            key = line[:6].strip()
            if key == b"2C":
                parts.nodes = self.node_block(line)
            elif key == b"3C":
                parts.elements = self.element_block(line)
            elif line.lstrip().startswith(b"1PSTEP"):
                step, mode = (_int(line[48:60]), _int(line[36:48])), 0
            elif line.lstrip().startswith(b"1PMODE"):
                mode = _int(line[10:36])  # "%5sPMODE%25i"
            elif key == b"100C":
                block = self.result_block(line, step, mode)
                if block is None:  # truncated and allowed: nothing after it
                    break
                parts.blocks.append(block)
            elif key == b"9999":
                parts.complete = True
                break
            elif key[:2] in (b"1C", b"1U", b"1P") or not key:
                continue  # model/user/analysis headers carry nothing we need
            else:
                raise self.fail(self.lineno, f"unexpected record {line[:20]!r}; expected a "
                                "block header (1C, 1U, 1P, 2C, 3C, 100C) or 9999")
        parts.truncated = self.truncated
        return parts

    def body(self, header_line: int, what: str, count: int | None,
             reclen: int = 0) -> tuple[bytes, int] | None:
        """The data records up to the `` -3`` that closes the block, and their first line."""
        start, first_line = self.pos, self.lineno + 1
        close = start + (count or 0) * reclen - 1  # where ccx's layout puts it: no search
        if not (reclen and count is not None and self.data[close : close + 4] == b"\n -3"):
            close = self.data.find(b"\n -3", start - 1)
        if close < 0:
            if self.allow_truncated:
                self.pos, self.truncated = len(self.data), True
                return None
            expected = f"{count} records and " if count is not None else ""
            end = self.data.count(b"\n", start) + self.lineno + (not self.data.endswith(b"\n"))
            raise self.fail(end, f"{what} block (header at line {header_line}) is truncated: "
                            f"the file ends before its {expected}' -3' end record")
        body = self.data[start : close + 1] if close >= start else b""
        self.pos = close + 1
        self.lineno += body.count(b"\n")
        self.next_line()  # the " -3" itself
        return body, first_line

    def check_count(self, header_line: int, what: str, found: int, count: int | None) -> None:
        if count is not None and found != count:
            raise self.fail(header_line, f"{what} block has {found} records, its header "
                            f"announces {count}")

    def node_block(self, header: bytes) -> tuple[np.ndarray, np.ndarray] | None:
        line, idw, count = self.lineno, self.id_width(header), _count(header)
        got = self.body(line, "node", count, _layout(3, idw)[0])
        if got is None:
            return None
        ids, coords = _records(*got, 3, idw, self.path)
        self.check_count(line, "node", len(ids), count)
        return _frozen(ids), _frozen(coords)

    def element_block(self, header: bytes):
        line, idw, count = self.lineno, self.id_width(header), _count(header)
        got = self.body(line, "element", count)
        if got is None:
            return None
        return tuple(_frozen(a) for a in _elements(*got, idw, self.path))

    def result_block(self, header: bytes, step: tuple[int, int],
                     mode: int = 0) -> tuple[int, FrdResult] | None:
        line, idw, count = self.lineno, self.id_width(header), _count(header)
        time = _float(header[12:24], self, line, "time")
        name, components = self.component_records(line)
        if name is None:
            return None
        got = self.body(line, name, count, _layout(len(components), idw)[0])
        if got is None:
            return None
        ids, values = _records(*got, len(components), idw, self.path, self.known_ids)
        self.check_count(line, name, len(ids), count)
        result = FrdResult(name, *step, time, components, ids, _frozen(values), line, mode)
        return _int(header[58:63]), result

    def component_records(self, header_line: int) -> tuple[str | None, tuple[str, ...]]:
        """Read the ``-4`` record and its ``-5`` records; drop derived components."""
        line = self.next_line()
        if line is None:
            return self.truncated_header(header_line)
        if line[:3] != b" -4":
            raise self.fail(self.lineno, f"expected the ' -4' record after a 100C header, "
                            f"got {line[:20]!r}")
        name = line[5:13].decode("ascii", "replace").strip()
        ncomp = _int(line[13:18])
        components: list[str] = []
        for _ in range(ncomp):
            line = self.next_line()
            while line is not None and line[:3] == b" -6":  # cgx-only; ccx never writes it
                line = self.next_line()
            if line is None:
                return self.truncated_header(header_line)
            if line[:3] != b" -5":
                raise self.fail(self.lineno, f"expected ' -5' record {len(components) + 1} "
                                f"of {ncomp} of block {name}, got {line[:20]!r}")
            if _int(line[33:38]) != 1:  # IEXIST=1: computed by the viewer (ALL), not stored
                components.append(line[5:13].decode("ascii", "replace").strip())
        if not components:
            raise self.fail(header_line, f"block {name} declares no stored components")
        return name, tuple(components)

    def truncated_header(self, header_line: int) -> tuple[None, tuple[str, ...]]:
        if self.allow_truncated:
            self.truncated = True
            return None, ()
        raise self.fail(self.lineno, f"result block (header at line {header_line}) is "
                        "truncated: the file ends inside its ' -4'/' -5' records")

    def id_width(self, header: bytes) -> int:
        flag = header.split()[-1] if header.split() else b""
        if flag in (b"2", b"3"):
            raise self.fail(self.lineno, "binary frd (format flag 2/3) is not supported; "
                            "let ccx write the default ASCII frd")
        try:
            return _ID_WIDTH[int(flag)]
        except (ValueError, KeyError):
            raise self.fail(self.lineno, f"unknown format flag {flag!r} (expected 0 or 1) "
                            f"in header {header[:20]!r}") from None


def _layout(ncols: int, idw: int) -> tuple[int, list[int], np.ndarray]:
    """Byte layout of one record: its length, line start offsets, value char columns."""
    starts: list[int] = []
    cols: list[int] = []
    pos = 0
    for first in range(0, max(ncols, 1), _PER_LINE):
        n = min(_PER_LINE, ncols - first)
        starts.append(pos)
        cols.extend(range(pos + 3 + idw, pos + 3 + idw + _VALUE_WIDTH * n))
        pos += 3 + idw + _VALUE_WIDTH * n + 1  # key, id field, values, "\n"
    return pos, starts, np.array(cols, dtype=np.intp)


def _records(body: bytes, first_line: int, ncols: int, idw: int, path: str,
             known: dict[bytes, np.ndarray] | None = None):
    """Parse fixed-width ``-1``/``-2`` records into ids (n,) and values (n, ncols).

    ``known`` maps the raw id columns of earlier blocks to their parsed ids: blocks of
    one output share the node list, so the ids are parsed once and the array shared.
    """
    reclen, starts, cols = _layout(ncols, idw)
    rec = _as_matrix(body, reclen, starts)
    if rec is None:  # CR/LF, trailing blanks or a broken record: normalise line by line
        rec = _as_matrix(_normalise(body, ncols, idw, starts, path, first_line), reclen, starts)
        assert rec is not None  # _normalise raised at any record that would not fit
    n = rec.shape[0]
    raw = np.ascontiguousarray(rec[:, 3 : 3 + idw])
    key = raw.tobytes()
    ids = known.get(key) if known is not None else None
    if ids is None:
        ids = _frozen(_parse(raw, np.int64, path, first_line, len(starts)).reshape(n))
        if known is not None:
            known.clear()  # only the latest node list is worth keeping
            known[key] = ids
    chars = np.ascontiguousarray(rec[:, cols])
    values = _parse(chars, np.float64, path, first_line, len(starts), _VALUE_WIDTH)
    return ids, values.reshape(n, ncols)


def _as_matrix(body: bytes, reclen: int, starts: list[int]) -> np.ndarray | None:
    """View ``body`` as (n, reclen) bytes if every record has the expected keys."""
    if len(body) % reclen:
        return None
    rec = np.frombuffer(body, dtype=np.uint8).reshape(-1, reclen)
    for i, start in enumerate(starts):
        key = b" -1" if i == 0 else b" -2"
        end = starts[i + 1] - 1 if i + 1 < len(starts) else reclen - 1
        if not (np.all(rec[:, start : start + 3] == np.frombuffer(key, np.uint8))
                and np.all(rec[:, end] == ord("\n"))):
            return None
    return rec


def _normalise(body, ncols, idw, starts, path, first_line) -> bytes:
    """Rebuild ``body`` with exact record lengths, or raise at the first bad line."""
    lines = body.split(b"\n")
    if lines and lines[-1] == b"":
        lines.pop()
    per_rec = len(starts)
    out = []
    for i, raw in enumerate(lines):
        k = i % per_rec
        n = min(_PER_LINE, ncols - _PER_LINE * k)
        want = 3 + idw + _VALUE_WIDTH * n
        line = raw.rstrip(b"\r\t ")
        key = b" -1" if k == 0 else b" -2"
        if line[:3] != key or len(line) != want:
            raise ResultsError(
                f"{path}, line {first_line + i}: expected a {key.decode().strip()!r} record "
                f"of {want} characters ('{key.decode()}' + I{idw} + {n} x E12.5), "
                f"got {len(line)}: {line[:40]!r}"
            )
        out.append(line)
    if len(out) % per_rec:
        raise ResultsError(f"{path}, line {first_line + len(out)}: record of {ncols} values "
                           f"ends early (expected {per_rec} lines per record)")
    return b"\n".join(out) + b"\n" if out else b""


def _parse(chars: np.ndarray, dtype, path: str, first_line: int, lines_per_rec: int,
           width: int | None = None) -> np.ndarray:
    """Convert a (n, w) uint8 matrix of fixed-width fields to numbers, vectorised."""
    width = width or chars.shape[1]
    if chars.size and dtype is np.float64 and width == _VALUE_WIDTH:
        fast = _e12_5(chars.reshape(-1, _VALUE_WIDTH))
        if fast is not None:
            return fast.reshape(chars.shape[0], -1)
    if chars.size and dtype is np.int64:
        fast = _fixed_int(chars.reshape(-1, width))
        if fast is not None:
            return fast.reshape(chars.shape[0], -1)
    fields = np.ascontiguousarray(chars).view(f"S{width}")
    try:
        return fields.astype(dtype)
    except ValueError:
        return _parse_slowly(fields, dtype, path, first_line, lines_per_rec)


_POW10 = np.array([float(10**k) for k in range(23)])  # exact doubles
_DIGITS = [1, 3, 4, 5, 6, 7, 10, 11]  # " d.dddddE+dd": mantissa and exponent digits
_PLACE = np.array([1e5, 1e4, 1e3, 1e2, 1e1, 1e0, 0.0, 0.0])


def _e12_5(c: np.ndarray) -> np.ndarray | None:
    """Arithmetic parse of C's ``%12.5E`` fields, shape (m, 12) -> (m,), ~3x numpy's.

    The integer mantissa times or divided by an exact power of ten is one correctly
    rounded operation, so the result equals ``float(text)`` bit for bit. None when a
    field is not in exactly that form (or its exponent is extreme): use the slow path.
    """
    digits = c[:, _DIGITS] - np.uint8(ord("0"))  # wraps non-digits to > 9
    if not (np.all(digits <= 9) and np.all(c[:, 2] == ord(".")) and np.all(c[:, 8] == ord("E"))
            and np.all((c[:, 0] == ord(" ")) | (c[:, 0] == ord("-")))
            and np.all((c[:, 9] == ord("+")) | (c[:, 9] == ord("-")))):
        return None
    mantissa = digits.astype(np.float64) @ _PLACE
    exponent = digits[:, 6].astype(np.int16) * 10 + digits[:, 7]
    shift = np.where(c[:, 9] == ord("-"), -exponent, exponent) - 5
    if np.abs(shift).max() >= len(_POW10):
        return None
    value = np.where(shift >= 0, mantissa * _POW10[np.maximum(shift, 0)],
                     mantissa / _POW10[np.maximum(-shift, 0)])
    return np.where(c[:, 0] == ord("-"), -value, value)


def _fixed_int(c: np.ndarray) -> np.ndarray | None:
    """Arithmetic parse of right-aligned unsigned integer fields, shape (m, w) -> (m,)."""
    digits = c - np.uint8(ord("0"))
    blank = c == ord(" ")
    # digits only, blanks only before the first digit, at least one digit per field
    if not (np.all((digits <= 9) | blank) and np.all(blank[:, :-1] >= blank[:, 1:])
            and not np.any(blank[:, -1])):
        return None
    place = 10.0 ** np.arange(c.shape[1] - 1, -1, -1)  # exact below 2**53
    return (np.where(blank, 0, digits).astype(np.float64) @ place).astype(np.int64)


def _parse_slowly(fields, dtype, path, first_line, lines_per_rec) -> np.ndarray:
    """Field by field, accepting Fortran's ``1.0-100`` and ``1.0D+00``; names the bad line."""
    out = np.empty(fields.shape, dtype=dtype)
    for (r, c), raw in np.ndenumerate(fields):
        text = raw.decode("ascii", "replace").strip().replace("D", "E").replace("d", "e")
        if dtype is np.float64 and len(text) > 1 and text[-4] in "+-" and "E" not in text:
            text = text[:-4] + "E" + text[-4:]
        try:
            out[r, c] = dtype(text) if dtype is np.float64 else int(text)
        except ValueError:
            line = first_line + r * lines_per_rec + c // _PER_LINE
            shown = bytes(raw).decode("ascii", "replace")
            raise ResultsError(f"{path}, line {line}: cannot read {shown!r} as a number") from None
    return out


def _elements(body: bytes, first_line: int, idw: int, path: str):
    """Element ids (E,), types (E,) and connectivity (E, M) padded with -1.

    The header's element count is not checked: ccx 2.x writes the count before it
    expands shells, beams and rebars (e.g. 10 announced, 110 written).
    """
    uniform = _elements_uniform(body, idw, path, first_line)
    if uniform is not None:
        return uniform
    lines = [ln.rstrip(b"\r\t ") for ln in body.split(b"\n")]
    if lines and lines[-1] == b"":
        lines.pop()
    heads = [i for i, ln in enumerate(lines) if ln[:3] == b" -1"]
    bad = [i for i, ln in enumerate(lines) if ln[:3] not in (b" -1", b" -2")]
    if bad or (lines and heads[:1] != [0]):
        i = bad[0] if bad else 0
        raise ResultsError(f"{path}, line {first_line + i}: expected a ' -1' or ' -2' "
                           f"element record, got {lines[i][:40]!r}")
    ids, types, conn = [], [], []
    for h, nxt in zip(heads, [*heads[1:], len(lines)], strict=True):
        head = lines[h]
        try:
            ids.append(int(head[3 : 3 + idw]))
            types.append(int(head[3 + idw : 8 + idw]))
            text = b"".join(ln[3:] for ln in lines[h + 1 : nxt])
            conn.append([int(text[j : j + idw]) for j in range(0, len(text), idw)])
        except ValueError:
            raise ResultsError(f"{path}, line {first_line + h}: unreadable element record "
                               f"{head[:40]!r}") from None
        expected = _nodes_per_type(types[-1])
        if expected is not None and len(conn[-1]) != expected:
            raise ResultsError(f"{path}, line {first_line + h}: element {ids[-1]} of type "
                               f"{ELEMENT_TYPES[types[-1]]} has {len(conn[-1])} nodes, "
                               f"expected {expected}")
    width = max((len(c) for c in conn), default=0)
    table = np.full((len(conn), width), -1, dtype=np.int64)
    for row, nodes in enumerate(conn):
        table[row, : len(nodes)] = nodes
    return np.array(ids, dtype=np.int64), np.array(types, dtype=np.int64), table


def _elements_uniform(body: bytes, idw: int, path: str, first_line: int):
    """Vectorised path when every element record has the first one's layout and type."""
    second = body.find(b"\n -1")
    reclen = second + 1 if second >= 0 else len(body)
    if not body or len(body) % reclen:
        return None
    rec = np.frombuffer(body, dtype=np.uint8).reshape(-1, reclen)
    ends = np.flatnonzero(rec[0] == ord("\n"))
    starts = np.concatenate(([0], ends[:-1] + 1))
    same_lines = np.all(rec[:, ends] == ord("\n")) and np.all(
        np.count_nonzero(rec == ord("\n"), axis=1) == len(ends))
    keys_ok = all(np.all(rec[:, s : s + 3] == np.frombuffer(b" -2" if i else b" -1", np.uint8))
                  for i, s in enumerate(starts))
    cols = np.concatenate([np.arange(s + 3, e) for s, e in zip(starts[1:], ends[1:], strict=True)]
                          or [np.zeros(0, np.intp)])
    one_type = np.all(rec[:, 3 + idw : 8 + idw] == rec[0, 3 + idw : 8 + idw])
    if not (same_lines and keys_ok and one_type) or len(cols) % idw:
        return None
    try:
        ids = _parse(rec[:, 3 : 3 + idw], np.int64, path, first_line, len(starts)).reshape(-1)
        code = _parse(rec[:1, 3 + idw : 8 + idw], np.int64, path, first_line, 1).item()
        conn = _parse(rec[:, cols], np.int64, path, first_line, len(starts), idw)
    except ResultsError:
        return None  # let the line-by-line path name the offending line
    if conn.shape[1] != (_nodes_per_type(code) or conn.shape[1]):
        return None
    return ids, np.full(len(ids), code, dtype=np.int64), conn


def _nodes_per_type(code: int) -> int | None:
    name = ELEMENT_TYPES.get(code)
    return None if name is None else int("".join(ch for ch in name if ch.isdigit()))


def _count(header: bytes) -> int | None:
    """The record count of a 2C/3C/100C header (columns 25-36), None when blank."""
    field = header[24:36].strip()
    return int(field) if field.isdigit() else None


def _int(field: bytes) -> int:
    field = field.strip()
    try:
        return int(field) if field else 0
    except ValueError:
        return 0


def _float(field: bytes, scanner: _Scanner, line: int, what: str) -> float:
    try:
        return float(field)
    except ValueError:
        raise scanner.fail(line, f"cannot read the {what} {field!r} in a 100C header "
                           "(columns 13-24)") from None


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


__all__ = ["ELEMENT_TYPES", "RESIDUAL_NAMES", "FrdFile", "FrdResult", "read_frd"]
