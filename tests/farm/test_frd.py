"""The ``.frd`` reader on real CalculiX output.

Fixtures in ``tests/farm/data`` are ccx 2.20 output of the decks beside them (no solver
needed); the tests marked ``ccx`` run the solver on our decks and on CalculiX's own
published examples (Debian's ``calculix-ccx-test``, reference results from ccx 2.11).
"""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from ccx_examples import DATA, EXAMPLES, example, solve

from farm.ccx import frd as frd_module
from farm.ccx import read_dat, read_frd, select_blocks
from farm.errors import ResultsError

ONE = DATA / "one_element.frd"
DIVERGED = DATA / "diverge.frd"
DISP = ("D1", "D2", "D3")


# --------------------------------------------------------------------------- helpers


def rewrite(tmp_path: Path, source: Path, edit) -> Path:
    """Copy of ``source`` with its lines passed through ``edit(list) -> list``."""
    lines = source.read_bytes().split(b"\n")
    out = tmp_path / source.name
    out.write_bytes(b"\n".join(edit(lines)))
    return out


def same_results(a, b) -> None:
    assert [(r.name, r.step, r.increment, r.time, r.components) for r in a.results] == [
        (r.name, r.step, r.increment, r.time, r.components) for r in b.results
    ]
    for x, y in zip(a.results, b.results, strict=True):
        np.testing.assert_array_equal(x.node_ids, y.node_ids)
        np.testing.assert_array_equal(x.values, y.values)
    np.testing.assert_array_equal(a.node_ids, b.node_ids)
    np.testing.assert_array_equal(a.coords, b.coords)
    np.testing.assert_array_equal(a.connectivity, b.connectivity)


# ------------------------------------------------------------- fixture: one element


def test_one_element_mesh_and_blocks():
    f = read_frd(ONE)
    assert f.complete and f.residuals == ()
    np.testing.assert_array_equal(f.node_ids, np.arange(123451, 123459))
    assert f.coords.shape == (8, 3) and f.coords[6].tolist() == [1.0, 1.0, 1.0]
    assert f.element_ids.tolist() == [100001] and f.element_types.tolist() == [1]  # HE8
    np.testing.assert_array_equal(f.connectivity, [np.arange(123451, 123459)])
    assert f.names() == ["DISP", "STRESS", "TOSTRAIN", "FORC", "ERROR"]
    # *TIME POINTS 0.25, 0.6 (total time) plus the end of the step
    np.testing.assert_array_equal(f.times(), [0.25, 0.6, 1.0])
    assert [(r.step, r.increment) for r in f.results_named("DISP")] == [(1, 1), (1, 3), (1, 4)]
    assert f.at("TOSTRAIN", 0.6).components == ("EXX", "EYY", "EZZ", "EXY", "EYZ", "EZX")
    assert f.at("STRESS", 1.0).components == ("SXX", "SYY", "SZZ", "SXY", "SYZ", "SZX")
    assert f.at("FORC", 0.25).components == ("F1", "F2", "F3")  # "ALL" dropped
    assert f.at("ERROR", 0.25).components == ("STR(%)",)


@pytest.mark.parametrize("time", [0.25, 0.6, 1.0])
def test_one_element_top_moves_with_the_boundary(time):
    disp = read_frd(ONE).at("DISP", time)
    assert disp.components == DISP and disp.values.shape == (8, 3)
    top = disp.values_at([123455, 123456, 123457, 123458])
    np.testing.assert_allclose(top[:, 2], -0.3 * time, rtol=1e-5)  # NTOP, 3, 3, -0.3
    np.testing.assert_array_equal(disp.values_at([123451])[0], 0.0)
    np.testing.assert_array_equal(disp.column("D3"), disp.values[:, 2])


def test_values_that_touch_are_cut_by_column():
    raw = ONE.read_bytes()
    assert b"-1.44514E+00-1.44514E+00-1.60954E+00" in raw  # no blank between values
    stress = read_frd(ONE).at("STRESS", 0.25)
    np.testing.assert_array_equal(stress.values[0, :3], [-1.44514, -1.44514, -1.60954])


def test_frd_and_dat_agree_on_the_fixture():
    f, blocks = read_frd(ONE), read_dat(DATA / "one_element.dat")
    for name, quantity in (("DISP", "displacements"), ("FORC", "forces")):
        for time in f.times(name):
            (printed,) = select_blocks(blocks, quantity, time=time)
            # frd prints 6 significant digits, dat 7: agree to half a unit of the 6th
            got = f.at(name, time).values_at(printed.ids)
            np.testing.assert_allclose(got, printed.values, rtol=5e-6, atol=1e-30)


def test_at_tolerates_printed_precision_and_names_what_exists():
    f = read_frd(ONE)
    assert f.at("DISP", 0.6 + 2e-6).time == 0.6  # header holds 6 digits
    with pytest.raises(ResultsError, match=r"no DISP block at time 0\.7.*0\.25, 0\.6, 1\.0"):
        f.at("DISP", 0.7)
    with pytest.raises(ResultsError, match="no component 'D4'"):
        f.at("DISP", 0.6).column("D4")
    with pytest.raises(ResultsError, match=r"no values for ids \[7\]"):
        f.at("DISP", 0.6).values_at([123451, 7])


def test_arrays_are_read_only():
    f = read_frd(ONE)
    with pytest.raises(ValueError):
        f.results[0].values[0, 0] = 1.0
    with pytest.raises(ValueError):
        f.coords[0, 0] = 1.0


# ------------------------------------------------------- layouts the parser must take


def to_short_format(lines: list[bytes]) -> list[bytes]:
    """The same file in the short (I5) layout: ids fit in 5 digits once renumbered."""
    out = []
    for line in lines:
        if line[:6] in (b"    2C", b"    3C") or line[:6] == b"  100C":
            line = line[:-1] + b"0"  # format flag 0
        elif line[:3] == b" -1":
            line = line[:3] + b"%5d" % (int(line[3:13]) % 100000) + line[13:]
        elif line[:3] == b" -2" and line[3:13].strip().isdigit():  # element node lines
            ids = [int(line[3 + 10 * k : 13 + 10 * k]) for k in range((len(line) - 3) // 10)]
            line = b" -2" + b"".join(b"%5d" % (i % 100000) for i in ids)
        out.append(line)
    return out


def test_short_format_reads_like_the_long_one(tmp_path):
    long, short = read_frd(ONE), read_frd(rewrite(tmp_path, ONE, to_short_format))
    np.testing.assert_array_equal(short.node_ids, long.node_ids % 100000)
    np.testing.assert_array_equal(short.connectivity, long.connectivity % 100000)
    for a, b in zip(long.results, short.results, strict=True):
        np.testing.assert_array_equal(a.values, b.values)
        np.testing.assert_array_equal(a.node_ids % 100000, b.node_ids)


@pytest.mark.parametrize(
    "edit",
    [
        pytest.param(lambda ls: [ln + b"\r" for ln in ls], id="crlf"),
        pytest.param(lambda ls: [ln + b"   " if ln.startswith(b" -1") else ln for ln in ls],
                     id="trailing-blanks"),
    ],
)
def test_line_endings_and_padding_do_not_matter(tmp_path, edit):
    same_results(read_frd(rewrite(tmp_path, ONE, edit)), read_frd(ONE))


def test_more_than_six_components_continue_on_minus_two_lines(tmp_path):
    """A 7-component block (as ccx writes for SDV or PSTRESS): 6 values, then a -2 line."""
    text = (
        "    2C                             2                                     1\n"
        " -1         1 0.00000E+00 0.00000E+00 0.00000E+00\n"
        " -1         2 1.00000E+00 0.00000E+00 0.00000E+00\n -3\n"
        "    1PSTEP                         1           1           1\n"
        "  100CL  101 1.000000000           2                     0    1           1\n"
        " -4  SDV         7    1\n"
        + "".join(f" -5  SDV{k}        1    1    0    0\n" for k in range(7))
        + " -1         1 1.00000E+00 2.00000E+00 3.00000E+00 4.00000E+00 5.00000E+00-6.00000E+00\n"
        " -2           7.00000E+00\n"
        " -1         2-1.00000E+00-2.00000E+00-3.00000E+00-4.00000E+00-5.00000E+00 6.00000E+00\n"
        " -2          -7.00000E+00\n -3\n 9999\n"
    )
    path = tmp_path / "sdv.frd"
    path.write_text(text)
    (block,) = read_frd(path).results
    assert block.components == tuple(f"SDV{k}" for k in range(7))
    expected = [[1, 2, 3, 4, 5, -6, 7], [-1, -2, -3, -4, -5, 6, -7]]
    np.testing.assert_array_equal(block.values, expected)


@pytest.mark.parametrize("target", ["_e12_5", "_fixed_int", "_elements_uniform"])
def test_fast_paths_give_the_slow_paths_bits(monkeypatch, target):
    """The vectorised parsers are shortcuts: without them the result is bit-identical."""
    files = [ONE, DIVERGED, *sorted(EXAMPLES.glob("*.frd.ref*"))[:12]]
    fast = [read_frd(p, diverged=False) for p in files]
    monkeypatch.setattr(frd_module, target, lambda *args: None)
    for path, a in zip(files, fast, strict=True):
        same_results(a, read_frd(path, diverged=False))


def test_gzipped_file_reads_like_the_plain_one(tmp_path):
    packed = tmp_path / "one_element.frd.gz"
    packed.write_bytes(gzip.compress(ONE.read_bytes()))
    same_results(read_frd(packed), read_frd(ONE))


# ------------------------------------------------------------ broken files must say where


def cut_after(marker: bytes, extra: int = 0):
    """Truncate the file ``extra`` bytes after the first ``marker``."""

    def edit(lines: list[bytes]) -> list[bytes]:
        raw = b"\n".join(lines)
        at = raw.index(marker) + len(marker) + extra
        return raw[:at].split(b"\n")

    return edit


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        pytest.param(cut_after(b"-7.50000E-02\n", 20),
                     r"line 39: DISP block \(header at line 28\) is truncated", id="mid-record"),
        pytest.param(cut_after(b" -1    123454"),
                     r"line 17: node block \(header at line 13\) is truncated", id="in-node-block"),
        pytest.param(cut_after(b" -5  D2"),
                     r"line 31: result block \(header at line 28\) is truncated", id="in-header"),
        pytest.param(lambda ls: [ln.replace(b"-7.50000E-02", b"-7.5O000E-02") for ln in ls],
                     r"line 38: cannot read '-7.5O000E-02' as a number", id="bad-number"),
        pytest.param(lambda ls: [ln for ln in ls if not ln.startswith(b" -1    123458 0.00")],
                     r"line 13: node block has 7 records, its header announces 8",
                     id="lost-record"),
        pytest.param(lambda ls: [ln[:-12] if ln.startswith(b" -1    123455 0") else ln
                                 for ln in ls], r"line 18: expected a '-1' record of 49 characters",
                     id="short-record"),
        pytest.param(lambda ls: [*ls[:26], b"garbage", *ls[26:]],
                     r"line 27: unexpected record b'garbage'", id="garbage"),
        pytest.param(lambda ls: [ln[:-1] + b"2" if ln.startswith(b"    2C") else ln
                                 for ln in ls], r"line 13: binary frd", id="binary"),
    ],
)
def test_broken_files_raise_with_file_and_line(tmp_path, edit, message):
    path = rewrite(tmp_path, ONE, edit)
    with pytest.raises(ResultsError, match=message) as info:
        read_frd(path)
    assert str(path) in str(info.value)


def test_missing_and_empty_files_raise(tmp_path):
    with pytest.raises(ResultsError, match=r"cannot read frd file .*nothing\.frd"):
        read_frd(tmp_path / "nothing.frd")
    (tmp_path / "empty.frd").write_bytes(b"")
    with pytest.raises(ResultsError, match=r"empty\.frd: frd file is empty"):
        read_frd(tmp_path / "empty.frd")


def test_truncated_last_block_can_be_dropped(tmp_path):
    path = rewrite(tmp_path, ONE, cut_after(b" -4  ERROR", 200))
    f = read_frd(path, allow_truncated=True)
    assert not f.complete and f.truncated and f.residuals == ()
    assert [r.name for r in f.results] == ["DISP", "STRESS", "TOSTRAIN", "FORC"]


def test_header_only_file_has_no_results(tmp_path):
    """What ccx leaves when it stops while reading the deck."""
    path = tmp_path / "stopped.frd"
    path.write_bytes(ONE.read_bytes().split(b"    2C")[0])
    f = read_frd(path)
    assert not f.complete and f.results == () and f.node_ids.shape == (0,)


# ----------------------------------------------------------- a diverged run (fixture)


def test_diverged_run_keeps_converged_results_apart_from_residuals():
    f = read_frd(DIVERGED)
    assert not f.complete  # ccx stopped: no 9999 record
    np.testing.assert_array_equal(f.times(), [0.4, 0.8])  # the *TIME POINTS reached
    assert f.names() == ["DISP", "TOSTRAIN", "FORC"]
    # the attempted increment 0.8 -> 0.9: best displacements and residual forces
    assert [(r.name, r.time, r.increment) for r in f.residuals] == [
        ("DISP", 0.9, 5),
        ("FORC", 0.9, 5),
    ]
    with pytest.raises(ResultsError, match=r"no DISP block at time 0\.9"):
        f.at("DISP", 0.9)
    # the deck's dat file printed exactly the converged outputs
    assert {b.time for b in read_dat(DATA / "diverge.dat")} == {0.4, 0.8}


def test_diverged_flag_overrides_the_guess():
    assert len(read_frd(DIVERGED, diverged=False).residuals) == 0
    assert read_frd(DIVERGED, diverged=False).times().tolist() == [0.4, 0.8, 0.9]
    assert [r.name for r in read_frd(ONE, diverged=True).residuals] == [
        "DISP", "STRESS", "TOSTRAIN", "FORC", "ERROR"]


# ------------------------------------------------------------ eigenmodes (*FREQUENCY)


def modal_frd(modes: list[tuple[int, float, list[float]]], output_offset: int = 0) -> bytes:
    """A ccx-style frd of two nodes and one DISP block per mode, as ccx 2.20 writes a
    ``*FREQUENCY`` step: ``1PSTEP`` (block counter, increment, step), ``1PMODE`` (the
    mode) and a ``100CL`` header with the frequency and the output counter, which is
    the mode only when no step came before (``output_offset``)."""
    out = ["    1C", f"    2C{'':18s}{2:12d}{1:38d}",
           " -1         1 0.00000E+00 0.00000E+00 0.00000E+00",
           " -1         2 1.00000E+00 0.00000E+00 0.00000E+00", " -3"]
    for block, (mode, freq, disp) in enumerate(modes, start=1):
        out += [f"    1PSTEP{block:25d}{1:12d}{1:12d}", f"    1PMODE{mode:25d}",
                f"  100CL{100 + mode:5d}{freq:12.5E}{2:12d}{'':21s}2{mode + output_offset:5d}"
                f"MODAL{1:8d}",
                " -4  DISP        4    1", " -5  D1          1    2    1    0",
                " -5  D2          1    2    2    0", " -5  D3          1    2    3    0",
                " -5  ALL         1    2    0    0    1ALL"]
        out += [f" -1{node:10d}" + "".join(f"{v:12.5E}" for v in disp) for node in (1, 2)]
        out.append(" -3")
    return ("\n".join([*out, " 9999", ""])).encode()


# a square section's two bending modes share their frequency (to all printed digits)
DEGENERATE = [(1, 24645.8153, [1.0, 0.0, 0.0]), (2, 24645.8153, [0.0, 1.0, 0.0]),
              (3, 134175.879, [0.0, 0.0, 1.0])]


@pytest.mark.parametrize("offset", [0, 1])
def test_modes_of_equal_frequency_stay_distinct(tmp_path, offset):
    path = tmp_path / "modes.frd"
    path.write_bytes(modal_frd(DEGENERATE, output_offset=offset))
    f = read_frd(path)
    assert [r.mode for r in f.results] == [1, 2, 3] and f.results[0].time == f.results[1].time
    np.testing.assert_array_equal(f.modes("DISP"), [1, 2, 3])
    for mode, _, disp in DEGENERATE:
        np.testing.assert_array_equal(f.at_mode("DISP", mode).values, [disp, disp])
    with pytest.raises(ResultsError, match=r"modes \[1, 2\] share the frequency 24645\.8"):
        f.at("DISP", 24645.8)  # which one is meant cannot be guessed
    assert f.at("DISP", 134176.0).mode == 3  # a simple frequency still finds its mode
    with pytest.raises(ResultsError, match=r"no DISP block of mode 4 .*modes \[1, 2, 3\]"):
        f.at_mode("DISP", 4)


def test_static_results_have_mode_zero():
    f = read_frd(ONE)
    assert {r.mode for r in f.results} == {0} and f.modes().size == 0


def square_beam_deck(n_modes: int = 4) -> str:
    """A 1 x 1 x 6 cantilever of 2 x 2 x 12 C3D8, clamped at z = 0: by symmetry its
    first two bending modes (about x and about y) have one frequency."""
    def node(i, j, k):
        return 1 + i + 3 * (j + 3 * k)

    lines = ["*NODE, NSET=NALL"]
    lines += [f"{node(i, j, k)}, {i / 2}, {j / 2}, {k / 2}"
              for k in range(13) for j in range(3) for i in range(3)]
    lines.append("*ELEMENT, TYPE=C3D8, ELSET=EALL")
    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1),
               (0, 1, 1)]
    elements = [(i, j, k) for k in range(12) for j in range(2) for i in range(2)]
    lines += [f"{e}, " + ", ".join(str(node(i + a, j + b, k + c)) for a, b, c in corners)
              for e, (i, j, k) in enumerate(elements, start=1)]
    lines += ["*NSET, NSET=FIX", ", ".join(str(node(i, j, 0)) for j in range(3) for i in range(3)),
              "*MATERIAL, NAME=STEEL", "*ELASTIC", "210000., 0.3", "*DENSITY", "7.8E-9",
              "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL", "*BOUNDARY", "FIX, 1, 3",
              "*STEP", "*FREQUENCY", str(n_modes), "*NODE FILE", "U",
              "*NODE PRINT, NSET=NALL", "U", "*END STEP"]
    return "\n".join(lines) + "\n"


@pytest.mark.ccx
def test_square_beam_degenerate_modes_keep_their_numbers(ccx, tmp_path):
    deck = tmp_path / "square.inp"
    deck.write_text(square_beam_deck())
    run = solve(deck, tmp_path)
    assert run.returncode == 0, run.output_tail
    f = read_frd(tmp_path / "square.frd")
    np.testing.assert_array_equal(f.modes("DISP"), [1, 2, 3, 4])
    first, second = f.at_mode("DISP", 1), f.at_mode("DISP", 2)
    assert first.time == second.time  # equal to the 10 printed digits
    # the dat prints the modes in order, all at the step time: the k-th print is mode k
    prints = select_blocks(read_dat(tmp_path / "square.dat"), "displacements")
    assert len(prints) == 4
    for mode, printed in enumerate(prints, start=1):
        got = f.at_mode("DISP", mode).values_at(printed.ids)
        np.testing.assert_allclose(got, printed.values, rtol=5e-6,
                                   atol=5e-6 * np.abs(printed.values).max())
    # two different shapes: the tips of the two bending modes move at right angles
    tip = [n for n in range(1, 118) if n > 108]
    a, b = first.values_at(tip)[:, :2].mean(axis=0), second.values_at(tip)[:, :2].mean(axis=0)
    assert abs(a @ b) < 0.05 * np.linalg.norm(a) * np.linalg.norm(b)


@pytest.mark.parametrize(("name", "frequency"), [("beampsensfreq", 1.17548e5),
                                                 ("boxprofile", 31.6584)])
def test_published_degenerate_modes(name, frequency):
    """ccx 2.11's reference frd files of the test suite hold such pairs (modes 1, 2)."""
    f = read_frd(example(name, ".frd.ref"))
    first, second = f.at_mode("DISP", 1), f.at_mode("DISP", 2)
    assert first.time == second.time == pytest.approx(frequency, rel=1e-6)
    assert first.line != second.line and not np.array_equal(first.values, second.values)


# ------------------------------------------------------------------ real ccx runs


@pytest.mark.ccx
def test_block_deck_time_points_and_steps(ccx, tmp_path):
    run = solve(DATA / "block.inp", tmp_path)
    assert run.returncode == 0, run.output_tail
    f = read_frd(tmp_path / "block.frd")
    assert f.complete and f.names() == ["DISP", "TOSTRAIN", "FORC"]
    np.testing.assert_array_equal(f.times(), [0.25, 0.5, 0.75, 1.0, 1.5, 2.0])
    assert [r.step for r in f.results_named("DISP")] == [1, 1, 1, 1, 2, 2]
    top = [19, 20, 21, 22, 23, 24, 25, 26, 27]
    np.testing.assert_allclose(f.at("DISP", 2.0).values_at(top), [[1.0, 0.0, -2.0]] * 9)
    # reactions of the whole model balance: the sum of FORC over all nodes vanishes
    for r in f.results_named("FORC"):
        assert np.abs(r.values.sum(axis=0)).max() < 1e-4 * np.abs(r.values).max()


@pytest.mark.ccx
def test_contact_deck_writes_contact_block(ccx, tmp_path):
    run = solve(DATA / "contact.inp", tmp_path)
    assert run.returncode == 0, run.output_tail
    f = read_frd(tmp_path / "contact.frd")
    assert f.names() == ["DISP", "TOSTRAIN", "FORC", "CONTACT"]
    contact = f.at("CONTACT", 1.0)
    assert contact.components == ("COPEN", "CSLIP1", "CSLIP2", "CPRESS", "CSHEAR1", "CSHEAR2")
    assert set(contact.node_ids) == set(range(33, 49))  # the slave nodes only
    assert (contact.column("CPRESS") > 0).all() and (contact.column("COPEN") < 0).all()
    # the rigid plate's nodes carry its reaction (the REF node is not in the frd);
    # it balances the block's base, and friction drags the base along in step 2
    assert 2001 not in f.node_ids
    for time, drag in ((1.0, 0.0), (2.0, 4.03)):
        forc = f.at("FORC", time)
        base, plate = forc.values_at(range(1, 17)).sum(0), forc.values_at(range(1001, 1009)).sum(0)
        np.testing.assert_allclose(base, -plate, atol=1e-4 * abs(plate[2]))
        assert base[0] == pytest.approx(-drag, abs=0.05)


@pytest.mark.ccx
def test_diverging_deck_is_read_as_diverged(ccx, tmp_path):
    run = solve(DATA / "diverge.inp", tmp_path)
    assert run.returncode != 0 and "increment size smaller than minimum" in run.output_tail
    f = read_frd(tmp_path / "diverge.frd")
    assert not f.complete and f.times().tolist() == [0.4, 0.8]
    assert {r.name for r in f.residuals} == {"DISP", "FORC"}


# ------------------------------------------------- CalculiX's published examples


FRD_EXAMPLES = {  # name: what it covers (ccx 2.20 run time on one core, seconds)
    "planestrain": "CPE4 expanded to 3D, U/RF/S files (0.01)",
    "shell3": "S8R composite shells expanded to C3D20R (0.01)",
    "b31": "B31 beams expanded to C3D20R (0.06)",
    "cubespring": "NLGEOM, node-to-surface contact, CONTACT file (0.04)",
    "changesurfbeh": "surface-to-surface contact, two steps (0.02)",
    "scheibe2n2f": "NLGEOM node-to-surface contact (0.10)",
    "fricloop": "four NLGEOM steps, friction, 39 output times (0.15)",
}


@pytest.mark.ccx
@pytest.mark.parametrize("name", FRD_EXAMPLES)
def test_example_frd_matches_the_reference(ccx, tmp_path, name):
    """Our ccx 2.20 run against the reference frd that ccx 2.11 wrote for the test suite.

    2.20 adds an ``ERROR`` (stress error estimator) block to every ``S`` output; the
    rest must match block by block: names, steps, times, nodes and values within 0.1 %
    of the block's largest value (the criterion of CalculiX's own ``datcheck.pl``).
    """
    reference = read_frd(example(name, ".frd.ref"))
    run = solve(example(name, ".inp"), tmp_path)
    assert run.returncode == 0, run.output_tail
    ours = read_frd(tmp_path / f"{name}.frd")
    assert ours.complete and reference.complete
    np.testing.assert_array_equal(ours.node_ids, reference.node_ids)
    np.testing.assert_allclose(ours.coords, reference.coords, rtol=1e-5)
    kept = [r for r in ours.results if r.name in reference.names()]
    assert [(r.name, r.step) for r in kept] == [(r.name, r.step) for r in reference.results]
    for a, b in zip(kept, reference.results, strict=True):
        assert a.time == pytest.approx(b.time, rel=1e-5) and a.components == b.components
        np.testing.assert_array_equal(a.node_ids, b.node_ids)
        scale = np.abs(b.values).max()
        assert np.abs(a.values - b.values).max() <= 1e-3 * scale, (a.name, a.time)


@pytest.mark.ccx
@pytest.mark.parametrize("name", ["cubespring", "section", "planestress3"])
def test_example_frd_equals_dat_where_both_hold_displacements(ccx, tmp_path, name):
    run = solve(example(name, ".inp"), tmp_path)
    assert run.returncode == 0, run.output_tail
    f, blocks = read_frd(tmp_path / f"{name}.frd"), read_dat(tmp_path / f"{name}.dat")
    printed = select_blocks(blocks, "displacements")
    assert printed
    for b in printed:
        got = f.at("DISP", b.time).values_at(b.ids)
        np.testing.assert_allclose(got, b.values, rtol=5e-6, atol=1e-30)


# ------------------------------------------- independent readers (optional, on PyPI)


def cross_check_files(tmp_path) -> list[Path]:
    """Fixtures plus a few published reference files, unpacked for readers without gzip."""
    files = [ONE, DIVERGED]
    for name in ("cubespring", "fricloop", "shell3"):
        for packed in EXAMPLES.glob(f"{name}.frd.ref*"):
            plain = tmp_path / f"{name}.frd"
            raw = packed.read_bytes()
            plain.write_bytes(gzip.decompress(raw) if packed.suffix == ".gz" else raw)
            files.append(plain)
    return files


def test_agrees_with_pyvista_frd_reader(tmp_path):
    """pyvista-frd-reader (C++ core, MIT) sees the same numbers; it zero-fills nodes a
    block does not list (contact) and cannot tell residual blocks from results."""
    pyvista_frd = pytest.importorskip("pyvista_frd")
    for path in cross_check_files(tmp_path):
        ours = read_frd(path, diverged=False)
        with pyvista_frd.NativeFile(path) as theirs:
            np.testing.assert_array_equal(theirs.node_ids, ours.node_ids)
            np.testing.assert_allclose(theirs.points, ours.coords, rtol=1e-6)
            np.testing.assert_allclose(theirs.step_times, ours.times(), rtol=1e-9)
            seen = 0
            for step, time in enumerate(theirs.step_times):
                for index, (name, _, derived) in enumerate(theirs.array_infos(step)):
                    if derived:  # Mises and principal values it computes itself
                        continue
                    block = ours.at(name, time)
                    rows = np.searchsorted(theirs.node_ids, block.node_ids)
                    got = theirs.array(step, index).reshape(len(theirs.node_ids), -1)[rows]
                    np.testing.assert_array_equal(got, block.values)
                    seen += 1
            assert seen == len(ours.results), path.name


def test_agrees_with_ccx2paraview(tmp_path):
    """ccx2paraview (pure Python on top of vtk, GPL-3) parses the same values."""
    common = pytest.importorskip("ccx2paraview.common")
    renamed = {"U": "DISP", "S": "STRESS", "E": "TOSTRAIN", "RF": "FORC"}
    for path in cross_check_files(tmp_path):
        ours = read_frd(path, diverged=False)
        with path.open() as handle:
            theirs = common.FRD(handle)
            theirs.parse_mesh()
            theirs.count_increments()
            blocks = [(time, block) for step, time in theirs.steps_increments
                      for block in theirs.parse_results(step, time)]
        plain = [(t, b) for t, b in blocks if "_" not in b.name]  # not *_Mises, *_Principal
        assert len(plain) == len(ours.results), path.name
        for (time, theirs_block), block in zip(plain, ours.results, strict=True):
            assert renamed.get(theirs_block.name, theirs_block.name) == block.name
            assert time == pytest.approx(block.time, rel=1e-9)
            values = np.array([theirs_block.results[n] for n in block.node_ids.tolist()])
            np.testing.assert_array_equal(values, block.values)
