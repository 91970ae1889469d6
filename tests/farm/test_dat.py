"""The ``.dat`` reader on real CalculiX output.

Fixtures in ``tests/farm/data`` are ccx 2.20 output of the decks beside them; the tests
marked ``ccx`` run the solver on our decks and on CalculiX's own published examples
(Debian's ``calculix-ccx-test``), whose reference ``.dat`` files ccx 2.11 wrote.
"""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest
from ccx_examples import DATA, EXAMPLES, example, solve

from farm.ccx import block_times, read_dat, read_frd, select_blocks
from farm.ccx import dat as dat_module
from farm.errors import ResultsError

ONE = DATA / "one_element.dat"


def dat_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "job.dat"
    path.write_text(text)
    return path


def assert_totals_are_sums(blocks) -> int:
    """Every ``total force`` equals the sum of the per-node forces of its set and time."""
    checked = 0
    for total in select_blocks(blocks, "total force"):
        (nodes,) = select_blocks(blocks, "forces", set_name=total.set_name, time=total.time)
        # both printed with 7 significant digits: allow half a unit per summand
        slack = 5e-7 * (len(nodes.ids) + 1) * np.abs(nodes.values).max()
        np.testing.assert_allclose(nodes.values.sum(axis=0), total.values[0], atol=slack)
        checked += 1
    return checked


# ------------------------------------------------------------- fixture: one element


def test_one_element_blocks():
    blocks = read_dat(ONE)
    assert [(b.quantity, b.set_name, b.time) for b in blocks[:5]] == [
        ("displacements", "NTOP", 0.25),
        ("forces", "NTOP", 0.25),
        ("total force", "NTOP", 0.25),
        ("strains", "EALL", 0.25),
        ("stresses", "EALL", 0.25),
    ]
    np.testing.assert_array_equal(block_times(blocks), [0.25, 0.6, 1.0])  # *TIME POINTS
    disp, forces, total, strains, stresses = blocks[:5]
    assert disp.components == ("vx", "vy", "vz") and forces.components == ("fx", "fy", "fz")
    np.testing.assert_array_equal(disp.ids, [123455, 123456, 123457, 123458])
    np.testing.assert_array_equal(disp.column("vz"), -0.075)
    assert total.total and total.ids.shape == (0,) and total.values.shape == (1, 3)
    assert strains.components == ("exx", "eyy", "ezz", "exy", "exz", "eyz")
    assert stresses.components == ("sxx", "syy", "szz", "sxy", "sxz", "syz")
    assert stresses.ids.shape == (8, 2)  # element, integration point: C3D8I has 8
    np.testing.assert_array_equal(stresses.ids[:, 1], np.arange(1, 9))
    np.testing.assert_array_equal(stresses.ids[:, 0], 100001)
    assert stresses.tags is None and not stresses.total


def test_one_element_totals_are_sums():
    assert assert_totals_are_sums(read_dat(ONE)) == 3


def test_one_element_force_balance():
    """Top and bottom held laterally (uniaxial strain): the 1 mm² section keeps its
    area, so the Cauchy szz at every integration point is the total force on the top."""
    blocks = read_dat(ONE)
    for total in select_blocks(blocks, "total force"):
        (stress,) = select_blocks(blocks, "stresses", time=total.time)
        np.testing.assert_allclose(stress.column("szz"), total.values[0, 2], rtol=1e-6)
        (disp,) = select_blocks(blocks, "displacements", time=total.time)
        np.testing.assert_allclose(disp.column("vz"), -0.3 * total.time, rtol=1e-6)


def test_select_blocks():
    blocks = read_dat(ONE)
    assert len(select_blocks(blocks, "forces")) == 3
    assert len(select_blocks(blocks, set_name="ntop", time=0.6)) == 3  # case-insensitive
    assert len(select_blocks(blocks, time=0.6 * (1 + 1e-7))) == 5  # 7 printed digits
    assert [b.quantity for b in select_blocks(blocks, total=True)] == ["total force"] * 3
    with pytest.raises(ResultsError, match="no component 'fx'"):
        blocks[0].column("fx")
    np.testing.assert_array_equal(blocks[1].values_at([123458, 123455]),
                                  blocks[1].values[[3, 0]])
    with pytest.raises(ResultsError, match=r"no values for ids \[1\]"):
        blocks[1].values_at([1])
    with pytest.raises(ResultsError, match="not keyed by one id per row"):
        blocks[4].values_at([100001])


def test_gzipped_file_reads_like_the_plain_one(tmp_path):
    packed = tmp_path / "one_element.dat.gz"
    packed.write_bytes(gzip.compress(ONE.read_bytes()))
    for a, b in zip(read_dat(packed), read_dat(ONE), strict=True):
        assert (a.quantity, a.time) == (b.quantity, b.time)
        np.testing.assert_array_equal(a.values, b.values)


def test_fast_path_gives_the_slow_paths_result(monkeypatch):
    """Whole blocks are cut by column when the rows line up; the token-by-token path
    (needed for tagged rows) must give the same arrays."""
    files = [ONE, DATA / "diverge.dat", *published_dats()[:40]]
    fast = [read_dat(path) for path in files]
    monkeypatch.setattr(dat_module, "_fixed_table", lambda texts: None)
    for path, blocks in zip(files, fast, strict=True):
        slow = read_dat(path)
        assert [(b.quantity, b.time, b.components) for b in blocks] == [
            (b.quantity, b.time, b.components) for b in slow]
        for a, b in zip(blocks, slow, strict=True):
            np.testing.assert_array_equal(a.ids, b.ids)
            np.testing.assert_array_equal(a.values, b.values)


def published_dats() -> list[Path]:
    """The test suite's reference ``.dat`` files that hold something (35 are empty:
    decks without prints)."""
    def holds_text(path: Path) -> bool:
        raw = path.read_bytes()
        return bool((gzip.decompress(raw) if path.suffix == ".gz" else raw).strip())

    return [path for path in sorted(EXAMPLES.glob("*.dat.ref*")) if holds_text(path)]


def test_every_published_dat_reads():
    """Every non-empty ``.dat`` ccx 2.11 wrote for its test suite passes the damage checks
    (blank and text lines, cuts, node and point lists of a set), and so does ours."""
    files = published_dats()
    if not files:
        example("beamp", ".inp")  # skips (or fails in CI) without the examples
    blocks = [read_dat(path) for path in files]
    assert len(files) >= 300 and sum(map(len, blocks)) >= 2700


def test_diverged_run_printed_only_converged_increments():
    blocks = read_dat(DATA / "diverge.dat")
    np.testing.assert_array_equal(block_times(blocks), [0.4, 0.8])
    assert [b.quantity for b in blocks] == ["total force", "displacements"] * 2


# --------------------------------------------------------- title and row variants


@pytest.mark.parametrize(
    ("title", "quantity", "components", "set_name", "time"),
    [
        (" displacements (vx,vy,vz) for set NTOP and time  0.2500000E+00",
         "displacements", ("vx", "vy", "vz"), "NTOP", 0.25),
        # ccx 2.11: "forset"; "...,pe)for set"; the truncated "...,eneset EALL"
        (" strains (elem, integ.pnt.,exx,eyy,ezz,exy,exz,eyz) forset EALL and time  0.1E+01",
         "strains", ("exx", "eyy", "ezz", "exy", "exz", "eyz"), "EALL", 1.0),
        (" equivalent plastic strain (elem, integ.pnt.,pe)for set E1 and time  0.1000000E+01",
         "equivalent plastic strain", ("pe",), "E1", 1.0),
        (" internal energy density (elem, integ.pnt.,eneset EALL and time  0.1000000E+01",
         "internal energy density", ("ene",), "EALL", 1.0),
        # ccx 2.20: "for setEALL"
        (" heat flux (elem, integ.pnt.,qx,qy,qz) for setEALL and time  0.1000000E+01",
         "heat flux", ("qx", "qy", "qz"), "EALL", 1.0),
        (" contact stress (slave node,press,tang1,tang2) for all contact elements and time"
         " 0.5000000E+00", "contact stress", ("press", "tang1", "tang2"), "", 0.5),
        (" heat generation for set NALL and time -0.5000000E+00",
         "heat generation", ("heat generation",), "NALL", -0.5),
        (" viscous stresses (elem, integ.pnt.,sxx,syy,sz    z,sxy,sxz,syz) for set EALL and "
         "time  0.1E+01", "viscous stresses", ("sxx", "syy", "szz", "sxy", "sxz", "syz"),
         "EALL", 1.0),
    ],
)
def test_title_variants(tmp_path, title, quantity, components, set_name, time):
    n_ids = 2 if "integ.pnt." in title else 1
    row = "".join(f"{k + 1:10d}" if i < n_ids else f"{0.5 * k: 14.6E}"
                  for i, k in enumerate(range(n_ids + len(components))))
    (block,) = read_dat(dat_file(tmp_path, f"\n{title}\n\n{row}\n"))
    assert (block.quantity, block.components, block.set_name, block.time) == (
        quantity, components, set_name, time)
    assert block.values.shape == (1, len(components)) and not block.total


def test_totals_have_no_ids(tmp_path):
    text = (
        "\n total contact spring energy for time  0.1000000E+01\n\n        2.000010E-05\n"
        "\n total force (fx,fy,fz) for set LEFT and time  0.1000000E+01\n\n"
        "        1.0E+00 -2.0E+00  3.0E+00\n"
    )
    energy, force = read_dat(dat_file(tmp_path, text))
    assert energy.total and energy.components == ("total contact spring energy",)
    assert energy.set_name == "" and energy.values.tolist() == [[2.00001e-05]]
    assert force.total and force.ids.shape == (0,) and force.values.tolist() == [[1, -2, 3]]


def test_rows_may_carry_tags(tmp_path):
    """ccx 2.20 marks rows in local axes with L and expanded shells with their label."""
    text = (
        "\n displacements (vx,vy,vz) for set NALL and time  0.1000000E+01\n\n"
        "         1  1.113627E-07 -1.859003E-12 -8.812068E-09 L\n"
        "        21 -3.798064E-04 -3.256995E-04 -8.337951E-03\n"
        "\n stresses (elem, integ.pnt.,sxx,syy,szz,sxy,sxz,syz) for set EALL and time"
        "  0.1000000E+01\n\n"
        "         1   1 -1.1E+02 -2.1E+02 -6.2E+01 -5.9E+01 -6.2E+00  7.2E+00 _shell_0000000001\n"
        "         1   2  1.3E+02  1.2E+01  1.8E+01  4.8E+01 -5.4E-01 -4.1E+00 _shell_0000000001\n"
    )
    disp, stress = read_dat(dat_file(tmp_path, text))
    assert disp.tags.tolist() == ["L", ""] and disp.values.shape == (2, 3)
    assert stress.tags.tolist() == ["_shell_0000000001"] * 2 and stress.values[1, 0] == 130.0


def test_fortran_number_spellings(tmp_path):
    text = (
        "\n forces (fx,fy,fz) for set N and time  0.1000000E+01\n\n"
        "         1  1.000000-100  2.000000D+00           NaN\n"
    )
    (block,) = read_dat(dat_file(tmp_path, text))
    assert block.values[0, :2].tolist() == [1e-100, 2.0] and np.isnan(block.values[0, 2])


def test_other_text_is_skipped(tmp_path):
    text = (
        "\n     E I G E N V A L U E   O U T P U T\n\n MODE NO    EIGENVALUE\n\n"
        "      1   0.1234E+03\n"
        "\n displacements (vx,vy,vz) for set N and time  0.1000000E+01\n\n"
        "         1  1.0E+00  2.0E+00  3.0E+00\n"
    )
    (block,) = read_dat(dat_file(tmp_path, text))
    assert block.quantity == "displacements"


BROKEN_HEAD = "\n displacements (vx,vy,vz) for set N and time  0.1000000E+01\n\n"


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        pytest.param("         1  1.000000E+00  2.000000E+00  3.000000E+00\n"
                     "         2  1.000000E+00  2.000000E+00  3.00\n",
                     r"line 5: row has 4 numbers in 44 characters, .* \(line 4\) has 4 in 52",
                     id="cut-in-number"),
        pytest.param("         1  1.000000E+00  2.000000E+00  3.000000E+00\n"
                     "         2  1.000000E+00  2.000000E+00\n",
                     r"line 5: row has 3 numbers", id="cut-at-field"),
        pytest.param("         1  1.000000E+00  2.0000O0E+00  3.000000E+00\n",
                     r"line 4: cannot read '2.0000O0E\+00' as a number", id="bad-number"),
        pytest.param("         1  1.000000E+00  2.000000E+00  3.000000E+00  4.000000E+00\n",
                     r"line 2: title names 3 columns \(vx, vy, vz\) but the rows hold 4",
                     id="extra-column"),
        pytest.param("       1.5  1.000000E+00  2.000000E+00  3.000000E+00\n",
                     r"line 4: cannot read '1.5' as an integer", id="bad-id"),
    ],
)
def test_broken_files_raise_with_file_and_line(tmp_path, rows, message):
    path = dat_file(tmp_path, BROKEN_HEAD + rows)
    with pytest.raises(ResultsError, match=message) as info:
        read_dat(path)
    assert str(path) in str(info.value)


def test_missing_file_raises(tmp_path):
    with pytest.raises(ResultsError, match=r"cannot read dat file .*nothing\.dat"):
        read_dat(tmp_path / "nothing.dat")


def cut_after(lines: int) -> str:
    """The fixture's first ``lines`` lines, each with its end of line (a cut at a
    line boundary, as a killed writer leaves it)."""
    return "".join(ONE.read_text().splitlines(keepends=True)[:lines])


def test_a_cut_between_blocks_leaves_whole_blocks(tmp_path):
    """A cut between blocks cannot be seen in the file: the blocks before it are whole."""
    assert len(read_dat(dat_file(tmp_path, cut_after(40)))) == 5  # the prints of time 0.25


# ccx writes every line whole and one row per node of a node set at every print, one
# row per integration point of every element at every element print; a block never
# holds a blank or text line (tests/farm/test_dat.py::test_every_published_dat_reads)
@pytest.mark.parametrize(
    ("text", "message"),
    [
        pytest.param(cut_after(85), r"line 86: expected the row of node 123457 \(row 3 of 4\)",
                     id="node-print-cut-at-a-row"),
        pytest.param(cut_after(116), r"line 117: element 100001 has 4 integration points",
                     id="element-print-cut-at-a-row"),
        pytest.param(cut_after(82), r"line 82: .*ends after the title of the displacements",
                     id="cut-after-a-title"),
        pytest.param(cut_after(84) + "    123456  0.000000E+00", r"line 85: .*no end of line",
                     id="cut-inside-a-line"),
        pytest.param(cut_after(81) + " displacements (vx,vy", r"line 82: .*no end of line",
                     id="cut-inside-a-title"),
        pytest.param(cut_after(5) + "garbage\n" + cut_after(120)[len(cut_after(5)):],
                     r"line 6: expected another row of the displacements block \(title at "
                     r"line 2\) or a blank line, got 'garbage'", id="garbage-inside-a-block"),
        pytest.param(cut_after(5) + "\n" + cut_after(120)[len(cut_after(5)):],
                     r"line 7: a row after the blank line 6 .*displacements block \(title at "
                     r"line 2\)", id="blank-line-inside-a-block"),
        pytest.param(cut_after(3) + "garbage\n" + cut_after(120)[len(cut_after(3)):],
                     r"line 4: expected a row of the displacements block \(title at line 2\)",
                     id="garbage-as-first-row"),
        pytest.param(cut_after(2) + cut_after(120)[len(cut_after(7)):],
                     r"line 4: the displacements block \(title at line 2\) has no rows",
                     id="block-without-rows"),
        pytest.param("", r"job\.dat: dat file is empty", id="empty"),
        pytest.param("\n  \n", r"job\.dat: dat file is empty", id="blank"),
    ],
)
def test_damaged_files_raise_with_file_line_and_expectation(tmp_path, text, message):
    path = dat_file(tmp_path, text)
    with pytest.raises(ResultsError, match=message) as info:
        read_dat(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(("head", "line"), [(b"", 1), (BROKEN_HEAD.encode(), 4)])
def test_binary_junk_raises(tmp_path, head, line):
    path = tmp_path / "job.dat"
    path.write_bytes(head + bytes(range(256)) * 4 + b"\n")
    with pytest.raises(ResultsError, match=rf"line {line}: byte 0x00 is not text"):
        read_dat(path)


def test_node_prints_of_a_set_list_the_same_nodes(tmp_path):
    """A row lost in the middle of a file (not only at its end) is caught too."""
    text = cut_after(120).replace("    123457  0.000000E+00  0.000000E+00 -1.800000E-01\n", "")
    with pytest.raises(ResultsError, match=r"line 46: node 123458 where the forces block "
                       r"of set NTOP \(line 9\) has node 123457"):
        read_dat(dat_file(tmp_path, text))


def test_rows_ccx_may_legitimately_vary_or_omit_are_accepted(tmp_path):
    """Contact prints follow the contact state (none in contact: a title without rows);
    an element print after ``*MODEL CHANGE, TYPE=ELEMENT, REMOVE`` lists fewer elements;
    ``*SECTION PRINT`` statistics are sub-headed tables the reader lists without rows."""
    contact = ("\n relative contact displacement (slave node,normal,tang1,tang2) for all "
               "contact elements and time {t}\n")
    ips = "".join(f"{e:10d}{p:4d}  1.000000E+00\n" for e in (1, 2) for p in (1, 2))
    text = (
        contact.format(t=" 0.1000000E+00")
        + contact.format(t=" 0.2000000E+00") + "\n        33  1.0E+00  0.0E+00  0.0E+00\n"
        + "\n pe (elem, integ.pnt.,pe) for set EALL and time  0.1000000E+01\n\n" + ips
        + "\n pe (elem, integ.pnt.,pe) for set EALL and time  0.2000000E+01\n\n" + ips[:58]
        + "\n statistics for surface set SBOT and time  0.1000000E+01\n\n"
        "   total surface force (fx,fy,fz) and moment about the origin(mx,my,mz)\n\n"
        "   -1.329195E+02  8.261111E-12 -3.074208E-12 -4.843667E-11 -5.581704E+02  6.6E+01\n"
        + contact.format(t=" 0.3000000E+00")
    )
    blocks = read_dat(dat_file(tmp_path, text))
    assert [len(b.values) for b in blocks] == [0, 1, 4, 2, 0, 0]
    assert blocks[3].ids.tolist() == [[1, 1], [1, 2]]


# ------------------------------------------------------------------ real ccx runs


@pytest.mark.ccx
def test_block_deck_prints(ccx, tmp_path):
    run = solve(DATA / "block.inp", tmp_path)
    assert run.returncode == 0, run.output_tail
    blocks = read_dat(tmp_path / "block.dat")
    times = [0.25, 0.5, 0.75, 1.0, 1.5, 2.0]  # *TIME POINTS also thin out the prints
    for quantity in ("displacements", "forces", "total force", "strains", "stresses",
                     "total internal energy"):
        np.testing.assert_array_equal(block_times(blocks, quantity), times, err_msg=quantity)
    assert assert_totals_are_sums(blocks) == 6
    (stress,) = select_blocks(blocks, "stresses", time=1.0)
    assert stress.set_name == "ETOP" and stress.ids.shape == (32, 2)  # 4 C3D8I x 8 points
    energy = [b.values[0, 0] for b in select_blocks(blocks, "total internal energy")]
    assert np.all(np.diff(energy) > 0)  # loading only adds energy
    # the printed nodal values are the frd values, to the frd's 6 digits
    f = read_frd(tmp_path / "block.frd")
    for b in select_blocks(blocks, "displacements") + select_blocks(blocks, "forces"):
        name = "DISP" if b.quantity == "displacements" else "FORC"
        np.testing.assert_allclose(f.at(name, b.time).values_at(b.ids), b.values,
                                   rtol=5e-6, atol=1e-6 * np.abs(b.values).max())


@pytest.mark.ccx
def test_contact_deck_prints_match_the_frd(ccx, tmp_path):
    run = solve(DATA / "contact.inp", tmp_path)
    assert run.returncode == 0, run.output_tail
    blocks, f = read_dat(tmp_path / "contact.dat"), read_frd(tmp_path / "contact.frd")
    stresses = select_blocks(blocks, "contact stress")
    slips = select_blocks(blocks, "relative contact displacement")
    assert [b.time for b in stresses] == [b.time for b in slips] == [0.5, 1.0, 1.5, 2.0]
    for press, slip in zip(stresses, slips, strict=True):
        assert press.components == ("press", "tang1", "tang2") and press.set_name == ""
        assert slip.components == ("normal", "tang1", "tang2")
        np.testing.assert_array_equal(press.ids, np.arange(33, 49))  # slave nodes
        frd = f.at("CONTACT", press.time)
        scale = 5e-6 * np.abs(press.values).max()
        np.testing.assert_allclose(frd.values_at(press.ids)[:, 3:], press.values, atol=scale)
        scale = 5e-6 * np.abs(slip.values).max()
        np.testing.assert_allclose(frd.values_at(slip.ids)[:, :3], slip.values, atol=scale)
        # the rigid plate's reference node carries what the block's base reacts
        (ref,) = select_blocks(blocks, "forces", set_name="REF", time=press.time)
        (base,) = select_blocks(blocks, "total force", set_name="BBOT", time=press.time)
        slack = 1e-4 * abs(ref.values[0, 2])
        np.testing.assert_allclose(ref.values[0], -base.values[0], atol=slack)


@pytest.mark.ccx
def test_shear_strain_convention_and_component_order(ccx, tmp_path):
    """Simple shear u_x = 0.001 z: both files hold the tensor component (gamma / 2),
    the frd in the order XY, YZ, ZX and the dat in the order xy, xz, yz."""
    run = solve(DATA / "shear.inp", tmp_path)
    assert run.returncode == 0, run.output_tail
    strains, stresses = read_dat(tmp_path / "shear.dat")
    np.testing.assert_allclose(strains.values, [[0, 0, 0, 0, 0.0005, 0]] * 8, atol=1e-12)
    np.testing.assert_allclose(stresses.column("sxz"), 1000 / 2.6 * 0.001, rtol=1e-6)  # G gamma
    frd = read_frd(tmp_path / "shear.frd").results_named("TOSTRAIN")[0]
    np.testing.assert_allclose(frd.values, [[0, 0, 0, 0, 0, 0.0005]] * 8, atol=1e-7)


@pytest.mark.ccx
def test_diverging_deck_prints_only_converged_increments(ccx, tmp_path):
    run = solve(DATA / "diverge.inp", tmp_path)
    assert run.returncode != 0
    np.testing.assert_array_equal(block_times(read_dat(tmp_path / "diverge.dat")), [0.4, 0.8])


# ------------------------------------------------- CalculiX's published examples


DAT_EXAMPLES = {  # name: what it covers (ccx 2.20 run time on one core, seconds)
    "planestrain": "CPE4 plane strain, U and E/S at integration points (0.01)",
    "shell3": "S8R composite shells expanded to solids, U/RF/S prints (0.01)",
    "b31": "B31 beams expanded to C3D20R, S prints (0.06)",
    "beamnh": "C3D20R Neo-Hookean, NLGEOM (0.07)",
    "beampd": "C3D20R NLGEOM, two steps (0.11)",
    "dloadlinI": "C3D8I NLGEOM, *NODE PRINT TOTALS=YES (0.05)",
    "pret3": "beams + solids + distributing couplings, TOTALS=YES (0.01)",
    "cubespring": "NLGEOM node-to-surface contact (0.04)",
    "friction2": "node-to-surface contact with friction, *CONTACT PRINT, 4 steps (0.06)",
    "contactenergy": "surface-to-surface contact, contact energies and totals (0.03)",
}


@pytest.mark.ccx
@pytest.mark.parametrize("name", DAT_EXAMPLES)
def test_example_dat_matches_the_reference(ccx, tmp_path, name):
    """Our ccx 2.20 run against the ``.dat.ref`` ccx 2.11 wrote for the test suite.

    Same blocks (quantity, set, components, time) in the same order, same ids, and
    values within 0.1 % of the largest value of their block: the criterion of
    CalculiX's own ``datcheck.pl``. (Most agree exactly; the solver changed little.)
    """
    reference = read_dat(example(name, ".dat.ref"))
    run = solve(example(name, ".inp"), tmp_path)
    assert run.returncode == 0, run.output_tail
    ours = read_dat(tmp_path / f"{name}.dat")
    assert reference and len(ours) == len(reference)
    for a, b in zip(ours, reference, strict=True):
        assert (a.quantity, a.set_name, a.components, a.total) == (
            b.quantity, b.set_name, b.components, b.total)
        assert a.time == pytest.approx(b.time, rel=1e-6)
        np.testing.assert_array_equal(a.ids, b.ids)
        scale = np.abs(b.values).max() if b.values.size else 0.0
        assert np.abs(a.values - b.values).max(initial=0.0) <= 1e-3 * scale, (a.quantity, a.line)


@pytest.mark.ccx
@pytest.mark.parametrize("name", ["dloadlinI", "pret3"])
def test_example_totals_are_sums(ccx, tmp_path, name):
    run = solve(example(name, ".inp"), tmp_path)
    assert run.returncode == 0, run.output_tail
    assert assert_totals_are_sums(read_dat(tmp_path / f"{name}.dat")) >= 1
