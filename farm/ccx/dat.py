"""Reader for CalculiX ``.dat`` print files (``*NODE PRINT``, ``*EL PRINT``, ``*CONTACT PRINT``).

Each printed block is a title line, a blank line and fixed-format rows::

     displacements (vx,vy,vz) for set NTOP and time  0.2500000E+00

            19  0.000000E+00  0.000000E+00 -5.000000E-01

The title gives the quantity, the column names in parentheses (after the id labels
``elem``, ``integ.pnt.``, ``slave node``, ``slave element+face``), the set and the total
time (7 significant digits). Rows hold 0 (``total ...`` blocks, ``TOTALS=ONLY``),
1 (node, element) or 2 (element + integration point, element + face) integer ids, then
the values. Text that is not such a block (eigenvalue tables, participation factors)
is skipped. ccx writes nothing to the ``.dat`` file for a diverged increment, so every
block is converged output.

What ccx always does, and the reader therefore checks (docs/readers.md, "Damaged
files"): it ends every line; it separates blocks by blank lines and never puts a blank
or text line among a block's rows; a block has rows unless it is a contact print with
nothing in contact or a ``statistics for ...`` section (sub-headed tables, kept as a
block without rows); a node print lists every node of its set, in the same order, each
time the set is printed; an element print lists every integration point of each of its
elements. A file that breaks one of these is damaged or cut short: ``ResultsError``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from farm.ccx.frd import read_bytes, rows_of
from farm.errors import ResultsError

_TITLE = re.compile(
    r"^\s*(?P<head>[A-Za-z].*?)\s*(?:and|for)\s+time\s+(?P<time>[-+]?[0-9.]+(?:[EeDd][-+]?\d+)?)\s*$"
)
# "for set X", also the run-together "forset X", "...,eneset X" (2.11) and "for setX" (2.20)
_SET = re.compile(r"\s*(?:for\s*)?set\s*(?P<set>\S+)$")
_CONTACT_SET = re.compile(r"\s*for\s+all\s+contact\s+elements$")
_ID_LABELS = {"node": 1, "slave node": 1, "elem": 1, "element": 1, "integ.pnt.": 1,
              "slave element+face": 2}


@dataclass(frozen=True, eq=False)
class DatBlock:
    """One printed block of a ``.dat`` file.

    Attributes
    ----------
    quantity : str
        Title words before the parentheses, e.g. ``"displacements"``, ``"forces"``,
        ``"stresses"``, ``"contact stress"``, ``"total force"``.
    components : tuple of str
        Column names from the title, e.g. ``("vx", "vy", "vz")``; ``(quantity,)`` for a
        single unnamed column, ``("v1", ...)`` when the title does not name them.
    set_name : str
        The set after ``for set`` (upper case, as ccx prints it); ``""`` for contact
        blocks (printed "for all contact elements") and set-less totals.
    time : float
        Total time of the block.
    ids : ndarray, shape (n,) or (n, 2)
        int64 node or element ids; (n, 2) for element + integration point or
        element + face; shape (0,) for totals.
    values : ndarray, shape (n, k)
        float64 values; one row for totals.
    total : bool
        True for ``total ...`` blocks (``TOTALS=ONLY``/``YES``, energies, volumes).
    line : int
        Line of the title, for messages.
    tags : ndarray of str, shape (n,), or None
        Text ccx 2.20 appends to some rows: ``"L"`` when the values are in local axes
        (``*TRANSFORM``), the expanded element's label (``"_shell_0000000001"``) for
        shells and beams; ``""`` for untagged rows. None when no row has a tag.
    """

    quantity: str
    components: tuple[str, ...]
    set_name: str
    time: float
    ids: np.ndarray
    values: np.ndarray
    total: bool
    line: int = 0
    tags: np.ndarray | None = None

    def column(self, component: str) -> np.ndarray:
        """Values of one component, shape (n,); ``ResultsError`` for an unknown name."""
        try:
            return self.values[:, self.components.index(component)]
        except ValueError:
            raise ResultsError(
                f"{self.quantity} block (line {self.line}) has no component {component!r}; "
                f"it has {', '.join(self.components)}"
            ) from None

    def values_at(self, ids) -> np.ndarray:
        """Rows for node or element ``ids`` (shape (m,) -> (m, k)) of a one-id block."""
        what = f"{self.quantity} block (line {self.line})"
        if self.ids.ndim != 1 or self.total:
            raise ResultsError(f"{what} is not keyed by one id per row (ids {self.ids.shape})")
        return self.values[rows_of(self.ids, ids, what)]


def read_dat(path: str | Path) -> list[DatBlock]:
    """Read every printed block of a ccx ``.dat`` file (or ``.dat.gz``), in file order.

    Parameters
    ----------
    path : str or Path
        The ``.dat`` file.

    Returns
    -------
    list of DatBlock
        One per printed block; a ``TOTALS=YES`` print gives a per-node block and a
        ``total ...`` block.

    Raises
    ------
    ResultsError
        Missing, empty or binary file, a file cut short (inside a line, after a title,
        inside a node or element print), a blank or text line among a block's rows, or
        rows that do not match their title (wrong number of columns, a row cut short,
        an unreadable number); names the file, the line and what was expected there.
    """
    path = Path(path)
    lines = _lines(read_bytes(path, "dat"), path)
    blocks, kinds, firsts, i = [], [], [], 0
    while i < len(lines):
        match = _TITLE.match(lines[i])
        if match is None:
            i += 1
            continue
        rows, end = _rows(lines, i + 1)
        block = _block(match, rows, str(path), i + 1)
        _check_block_end(lines, end, block, str(path))
        blocks.append(block)
        kinds.append(_kind(block, match.group("head")))
        firsts.append(rows[0][0] if rows else end + 1)
        i = end
    _check_sets(blocks, kinds, firsts, str(path))
    return blocks


def select_blocks(
    blocks: list[DatBlock],
    quantity: str | None = None,
    *,
    set_name: str | None = None,
    time: float | None = None,
    total: bool | None = None,
    rtol: float = 1e-6,
) -> list[DatBlock]:
    """Blocks matching every criterion given (set names compare case-insensitively).

    ``time`` matches within ``rtol`` relative (the ``.dat`` prints 7 digits).
    """
    out = []
    for b in blocks:
        if quantity is not None and b.quantity != quantity:
            continue
        if set_name is not None and b.set_name.upper() != set_name.upper():
            continue
        if time is not None and abs(b.time - time) > 1e-12 + rtol * abs(time):
            continue
        if total is not None and b.total != total:
            continue
        out.append(b)
    return out


def block_times(blocks: list[DatBlock], quantity: str | None = None) -> np.ndarray:
    """Sorted distinct times of the blocks (of ``quantity`` if given)."""
    return np.unique(np.array([b.time for b in select_blocks(blocks, quantity)], dtype=float))


_NOT_TEXT = re.compile(rb"[\x00-\x08\x0b\x0e-\x1f\x7f]")
_TEXT_BYTES = bytes(sorted(set(range(256)) - set(range(0x20)) - {0x7F} | set(b"\t\n\r\x0c")))
# titles whose body is sub-headings and tables (*SECTION PRINT, *CONTACT PRINT CF; the
# per-point face flux of ccx 2.11's *FACE PRINT): listed as blocks without rows
_SECTIONS = ("statistics for", "heat flux at the integration points")


def _lines(raw: bytes, path: Path) -> list[str]:
    """The file's lines; ``ResultsError`` for an empty, binary or cut-short file."""
    if not raw.strip():
        raise ResultsError(f"{path}: dat file is empty: ccx printed nothing (the deck has no "
                           "*NODE PRINT, *EL PRINT or *CONTACT PRINT, or the run stopped "
                           "before its first print)")
    if raw.translate(None, _TEXT_BYTES) and (bad := _NOT_TEXT.search(raw)):  # translate: fast
        line = raw.count(b"\n", 0, bad.start()) + 1
        raise ResultsError(f"{path}, line {line}: byte 0x{raw[bad.start()]:02x} is not text: "
                           "expected a ccx .dat print file (binary or corrupted file)")
    lines = raw.decode("latin-1").replace("\r\n", "\n").split("\n")
    if lines[-1]:  # ccx ends every line: the writer was stopped inside this one
        raise ResultsError(f"{path}, line {len(lines)}: the file ends inside a line (no end "
                           f"of line after {lines[-1][-40:]!r}): cut short")
    return lines[:-1]


def _check_block_end(lines: list[str], end: int, block: DatBlock, path: str) -> None:
    """What follows a block's rows must be a blank line and then no row, or the file end."""
    what = f"{block.quantity} block (title at line {block.line})"
    if len(block.values) == 0:
        _check_no_rows(lines, end, block, path)
    elif end < len(lines) and lines[end].strip():
        raise ResultsError(f"{path}, line {end + 1}: expected another row of the {what} or a "
                           f"blank line, got {lines[end].strip()[:40]!r}")
    else:
        after = end
        while after < len(lines) and not lines[after].strip():
            after += 1
        if after < len(lines) and _is_row(lines[after]):
            raise ResultsError(
                f"{path}, line {after + 1}: a row after the blank line {end + 1} that ends the "
                f"{what}; ccx puts no blank line inside a block and starts each block with a "
                "title (a line inserted or lost)")


def _check_no_rows(lines: list[str], end: int, block: DatBlock, path: str) -> None:
    """A title without rows: a contact print with nothing in contact, or a section."""
    what = f"{block.quantity} block (title at line {block.line})"
    if "contact" in block.quantity:
        return
    if end == len(lines):
        raise ResultsError(f"{path}, line {block.line}: the file ends after the title of the "
                           f"{what}: expected its rows (cut short)")
    if _TITLE.match(lines[end]):
        raise ResultsError(f"{path}, line {end + 1}: the {what} has no rows: expected rows "
                           "before the next title")
    if not block.quantity.startswith(_SECTIONS):
        raise ResultsError(f"{path}, line {end + 1}: expected a row of the {what}, got "
                           f"{lines[end].strip()[:40]!r}")


def _check_sets(blocks: list[DatBlock], kinds: list[str], first_rows: list[int],
                path: str) -> None:
    """Prints of one set must list its nodes alike and each element's points alike.

    ccx prints every node of a node set each time; an element print may lose whole
    elements (``*MODEL CHANGE, TYPE=ELEMENT, REMOVE``) but never part of one. So a print
    cut at a row boundary shows as a missing node or integration point whenever the
    set was printed before (any quantity). Contact prints, totals and per-element
    prints are not checked.
    """
    last: dict[tuple[str, str], DatBlock] = {}
    for block, kind, first in zip(blocks, kinds, first_rows, strict=True):
        if kind not in ("node", "point"):
            continue
        ref = last.get((block.set_name, kind))
        if ref is not None and kind == "node":
            _same_nodes(block, ref, first, path)
        elif ref is not None:
            _same_points(block, ref, first, path)
        last[block.set_name, kind] = block


def _kind(block: DatBlock, head: str) -> str:
    """``node``, ``point`` (element + integration point), ``element`` or ``other``."""
    if block.total or not block.set_name or "contact" in block.quantity or not len(block.ids):
        return "other"  # no rows: a statistics section
    if block.ids.ndim == 2:
        return "point" if "integ.pnt." in _parse_head(head)[1] else "other"
    return "element" if {"elem", "element"} & set(_parse_head(head)[1]) else "node"


def _same_nodes(block: DatBlock, ref: DatBlock, first: int, path: str) -> None:
    n, m = len(block.ids), len(ref.ids)
    differ = np.flatnonzero(block.ids[: min(n, m)] != ref.ids[: min(n, m)])
    if differ.size == 0 and n == m:
        return
    what = f"the {ref.quantity} block of set {ref.set_name} (line {ref.line})"
    if differ.size:
        k = int(differ[0])
        raise ResultsError(
            f"{path}, line {first + k}: node {block.ids[k]} where {what} has node "
            f"{ref.ids[k]}; ccx prints every node of a set in the same order each time "
            "(a row lost or the file damaged)")
    if n < m:
        raise ResultsError(
            f"{path}, line {first + n}: expected the row of node {ref.ids[n]} (row {n + 1} "
            f"of {m}) of the {block.quantity} block (title at line {block.line}): {what} "
            "lists every node of the set (file cut short or a row lost)")
    raise ResultsError(f"{path}, line {first + m}: node {block.ids[m]} is not in {what}, "
                       f"which lists the set's {m} nodes (a row too many)")


def _same_points(block: DatBlock, ref: DatBlock, first: int, path: str) -> None:
    elems, start, count = np.unique(block.ids[:, 0], return_index=True, return_counts=True)
    ref_elems, ref_count = np.unique(ref.ids[:, 0], return_counts=True)
    _, mine, theirs = np.intersect1d(elems, ref_elems, return_indices=True)
    bad = np.flatnonzero(count[mine] != ref_count[theirs])
    if bad.size:
        k = mine[bad[0]]
        line = first + int(start[k] + count[k])  # where its next point was due
        raise ResultsError(
            f"{path}, line {line}: element {elems[k]} has {count[k]} integration points in "
            f"the {block.quantity} block (title at line {block.line}), "
            f"{ref_count[theirs[bad[0]]]} in the {ref.quantity} block of set "
            f"{ref.set_name} (line {ref.line}); ccx prints every point of an element "
            "(file cut short or a row lost)")


def _rows(lines: list[str], start: int) -> tuple[list[tuple[int, str]], int]:
    """Data rows after a title: skip blank lines, stop at the next blank or text line."""
    i = start
    while i < len(lines) and not lines[i].strip():
        i += 1
    rows = []
    while i < len(lines) and lines[i].strip() and _is_row(lines[i]):
        rows.append((i + 1, lines[i]))
        i += 1
    return rows, i


def _is_row(line: str) -> bool:
    first = line.lstrip()[:3].lower()
    return not first[:1].isalpha() or first in ("nan", "inf")


def _block(match: re.Match, rows: list[tuple[int, str]], path: str, line: int) -> DatBlock:
    """Turn a title match and its rows into a block, checking the columns."""
    quantity, labels, set_name = _parse_head(match.group("head"))
    total = quantity.startswith("total ")
    n_ids = 0 if total else max(1, sum(_ID_LABELS.get(lab, 0) for lab in labels))
    names = tuple(lab for lab in labels if lab not in _ID_LABELS)
    table, tags = _table(rows, path)
    n_vals = table.shape[1] - n_ids if rows else max(len(names), 1)
    if n_vals < 1:
        raise ResultsError(f"{path}, line {rows[0][0]}: row has {table.shape[1]} fields, "
                           f"expected {n_ids} ids and at least one value")
    components = _components(quantity, names, n_vals, path, line)
    values = _numbers(table[:, n_ids:], np.float64, rows, path).reshape(len(rows), n_vals)
    ids = _numbers(table[:, :n_ids], np.int64, rows, path).reshape(len(rows), n_ids)
    if n_ids < 2:  # node/element ids as a flat vector; totals have none
        ids = ids[:, 0] if n_ids == 1 else np.zeros(0, dtype=np.int64)
    time = float(match.group("time").replace("D", "E").replace("d", "e"))
    tags = None if tags is None else _frozen(tags)
    return DatBlock(quantity, components, set_name, time, _frozen(ids), _frozen(values),
                    total, line, tags)


def _parse_head(head: str) -> tuple[str, list[str], str]:
    """Split a title head into quantity, parenthesised labels and set name."""
    set_name = ""
    if m := _SET.search(head):
        set_name, head = m.group("set"), head[: m.start()]
    elif m := _CONTACT_SET.search(head):
        head = head[: m.start()]
    quantity, _, inner = head.partition("(")
    inner = inner.rsplit(")", 1)[0] if ")" in inner else inner
    labels = [lab.strip().lower() for lab in inner.split(",") if lab.strip()]
    return " ".join(quantity.split()).lower(), labels, set_name


def _components(quantity: str, names: tuple[str, ...], n_vals: int, path: str, line: int):
    if len(names) == n_vals:
        return tuple("".join(n.split()) for n in names)  # ccx once printed "sz    z"
    if not names and n_vals == 1:
        return (quantity,)
    if len(names) <= 1 or any(" " in n for n in names):  # "values", or prose, not names
        return tuple(f"v{k + 1}" for k in range(n_vals))
    raise ResultsError(f"{path}, line {line}: title names {len(names)} columns "
                       f"({', '.join(names)}) but the rows hold {n_vals} values")


def _table(rows: list[tuple[int, str]], path: str) -> tuple[np.ndarray, np.ndarray | None]:
    """Numeric tokens of all rows as an (n, columns) string array, and the row tags.

    ccx 2.20 may end a row with a tag: ``L`` (values in local axes, ``*TRANSFORM``) or
    the expanded element's label (``_shell_0000000001``). The numeric part of every row
    must have the same number of fields and the same width (the rows are fixed format).
    """
    if not rows:
        return np.zeros((0, 0), dtype="U1"), None
    fixed = _fixed_table([text for _, text in rows])
    if fixed is not None:
        return fixed, None
    tokens, tags, widths = [], [], []
    for _, text in rows:
        fields = text.split()
        k = len(fields)
        while k and _is_tag(fields[k - 1]):
            k -= 1
        tokens.append(fields[:k])
        tags.append(" ".join(fields[k:]))
        widths.append(len(text[: text.find(" " + fields[k]) if k < len(fields) else None].rstrip()))
    for (lineno, _), row, width in zip(rows, tokens, widths, strict=True):
        if len(row) != len(tokens[0]) or width != widths[0]:
            raise ResultsError(
                f"{path}, line {lineno}: row has {len(row)} numbers in {width} characters, "
                f"the block's first row (line {rows[0][0]}) has {len(tokens[0])} in "
                f"{widths[0]} (row cut short or malformed)"
            )
    table = np.array(tokens, dtype=str).reshape(len(rows), len(tokens[0]))
    return table, (np.array(tags, dtype=str) if any(tags) else None)


def _fixed_table(texts: list[str]) -> np.ndarray | None:
    """Vectorised path: rows of one length whose fields line up with the first row's.

    Returns an (n, columns) bytes array, or None (tags, ragged rows) for the slow path.
    """
    width = len(texts[0])
    ends = [m.end() for m in re.finditer(r"\S+", texts[0])]
    if not ends or _is_tag(texts[0][: ends[-1]].split()[-1]) or any(len(t) != width for t in texts):
        return None
    try:
        chars = np.frombuffer("".join(texts).encode("ascii"), np.uint8).reshape(len(texts), -1)
    except UnicodeEncodeError:
        return None
    table = np.empty((len(texts), len(ends)), dtype=f"S{max(np.diff([0, *ends]))}")
    for j, (start, end) in enumerate(zip([0, *ends[:-1]], ends, strict=True)):
        field = chars[:, start:end]
        blank = field == ord(" ")
        # one right-aligned token per field in every row: blanks, then none
        if blank[:, -1].any() or not np.all(blank[:, :-1] >= blank[:, 1:]):
            return None
        table[:, j] = np.ascontiguousarray(field).view(f"S{end - start}").ravel()
    return table


def _is_tag(token: str) -> bool:
    return (token[:1].isalpha() or token[:1] == "_") and token[:3].lower() not in ("nan", "inf")


def _numbers(table: np.ndarray, dtype, rows: list[tuple[int, str]], path: str) -> np.ndarray:
    """Convert a token table, falling back to Fortran spellings (``1.0-100``, ``1.0D+00``)."""
    try:
        return table.astype(dtype)
    except ValueError:
        out = np.empty(table.shape, dtype=dtype)
        for (r, c), raw in np.ndenumerate(table):
            token = raw.decode("ascii").strip() if isinstance(raw, bytes) else str(raw)
            text = re.sub(r"(?<=\d)([-+]\d{3})$", r"E\1", token.replace("D", "E"))
            try:
                out[r, c] = int(text) if dtype is np.int64 else float(text)
            except ValueError:
                raise ResultsError(
                    f"{path}, line {rows[r][0]}: cannot read {token!r} as "
                    f"{'an integer' if dtype is np.int64 else 'a number'}"
                ) from None
        return out


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


__all__ = ["DatBlock", "block_times", "read_dat", "select_blocks"]
