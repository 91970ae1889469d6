"""A damaged store never gives a wrong answer (issue 14).

A small synthetic store (written through the storage API, no solver) is damaged in each
way a disk, a copy or a hand can damage it; then ``verify`` must name the damage, the
analyses' read path must refuse with one line naming the damaged experiments (or give
exactly the undamaged data), the CLI must print one line and exit non-zero, never a
traceback, and ``farm sweep verify --repair`` must leave a store whose done experiments
are all intact.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from store_helpers import GROUP, make_attrs, make_info, make_mesh, make_result

import storage
import tyre_farm_cli as cli
from analysis import data
from analysis.errors import EmptySelectionError
from storage.paths import publish
from storage.verify import verify

IDS = [f"e{i}" for i in range(6)]  # e0-e3 done, e4 failed, e5 pending
DEFLECTION = [11.1, 17.3, 23.7, 29.9, 33.3, 38.9]  # not round: their bytes are findable
PRESSURE = 0.2
N_INNER, N_TREAD = 12, 5
DONE_IDS = IDS[:4]


def build(path: Path) -> Path:
    storage.create_group(path, GROUP, make_mesh(N_INNER, N_TREAD), make_attrs())
    storage.reserve(path, GROUP, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    for e in DONE_IDS:
        storage.write_experiment(path, GROUP, e, make_result(e, N_INNER, N_TREAD), make_info(e))
    storage.write_failure(path, GROUP, "e4", "boom", {"ccx_runs": 1})
    return path


@pytest.fixture(scope="module")
def template(tmp_path_factory) -> Path:
    return build(tmp_path_factory.mktemp("template") / "farm.zarr")


@pytest.fixture
def built(template, tmp_path) -> Path:
    """A fresh copy of the six-experiment store (copying is faster than writing)."""
    path = tmp_path / "farm.zarr"
    shutil.copytree(template, path, ignore=shutil.ignore_patterns(".farm.lock", ".claims"))
    return path


# --- the kinds of damage ------------------------------------------------------------------


def _flip(path: Path, needle: bytes | None = None, high: bool = True) -> None:
    """Flip one byte of a file: the high (exponent) byte of ``needle`` where it is found
    verbatim (a float in a raw chunk, or in a compressed chunk's literals), else the
    middle byte."""
    raw = bytearray(path.read_bytes())
    at = raw.find(needle) if needle is not None else -1
    at = at + (len(needle) - 1 if high else 0) if at >= 0 else len(raw) // 2
    raw[at] ^= 0xFF
    path.write_bytes(bytes(raw))


def _write_status(path: Path, i: int, value: int) -> None:
    """Write slot ``i``'s status chunk as a valid one holding ``value``: its byte and
    its CRC32C (a changed status that still decodes, as a hand's or a bug's would)."""
    import google_crc32c

    byte = bytes([value % 256])
    crc = int(google_crc32c.value(byte)).to_bytes(4, "little")
    (path / GROUP / "status" / "c" / str(i)).write_bytes(byte + crc)


def _value(e: str, name: str, flat: int) -> bytes:
    return np.float64(make_result(e, N_INNER, N_TREAD)[name].ravel()[flat]).tobytes()


@dataclass(frozen=True)
class Damage:
    """How to damage a store, and what must then be named."""

    do: Callable[[Path], None]
    ids: frozenset[str] = frozenset()  # experiments that must be reported damaged
    words: tuple[str, ...] = ()  # words the report (and the one-line errors) must hold
    structural: bool = False  # damage of metadata/ids/status, not of one experiment
    refuses: bool = True  # the analyses' read must refuse (else it must be exact)
    exact: bool = True  # ``ids`` are all the experiments damaged (else: at least those)


def _chunk(path: Path, name: str, i: int) -> Path:
    base = path / GROUP / name / "c" / str(i)
    return base / "0" / "0" if name in ("displacement", "reaction_force") else base


def _truncate(rel: str) -> Callable[[Path], None]:
    def do(path: Path) -> None:
        f = path / rel
        f.write_bytes(f.read_bytes()[: len(f.read_bytes()) // 2])

    return do


DAMAGES = {
    "flip-displacement-chunk": Damage(
        lambda p: _flip(_chunk(p, "displacement", 1), _value("e1", "displacement", 4)),
        ids=frozenset({"e1"})),
    "flip-compressed-chunk": Damage(  # reaction_force is zstd-compressed
        lambda p: _flip(_chunk(p, "reaction_force", 2), _value("e2", "reaction_force", 7)),
        ids=frozenset({"e2"})),
    "flip-deflection-chunk": Damage(
        # zstd may copy the flipped literal into other values: e4's changes too
        lambda p: _flip(p / GROUP / "deflection" / "c" / "0", np.float64(17.3).tobytes()),
        ids=frozenset({"e1"}), exact=False),
    "flip-status-failed-to-done": Damage(
        lambda p: _write_status(p, 4, storage.DONE), ids=frozenset({"e4"})),
    "delete-displacement-chunk": Damage(
        lambda p: _chunk(p, "displacement", 2).unlink(), ids=frozenset({"e2"})),
    "delete-id-chunk": Damage(
        lambda p: (p / GROUP / "experiment" / "c" / "0").unlink(),
        words=("experiment",), structural=True),
    "truncate-array-zarr-json": Damage(
        _truncate(f"{GROUP}/displacement/zarr.json"),
        words=(f"{GROUP}/displacement/zarr.json",), structural=True),
    "truncate-group-zarr-json": Damage(
        _truncate(f"{GROUP}/zarr.json"), words=(f"{GROUP}/zarr.json",), structural=True),
    "truncate-root-zarr-json": Damage(
        _truncate("zarr.json"), words=("zarr.json",), structural=True, refuses=False),
    "delete-status-array": Damage(
        lambda p: shutil.rmtree(p / GROUP / "status"), words=("status",), structural=True),
}
KINDS = sorted(DAMAGES)


@pytest.fixture(params=KINDS)
def damaged(request, built) -> tuple[Path, Damage]:
    damage = DAMAGES[request.param]
    damage.do(built)
    return built, damage


def _cli(*args: str) -> int:
    """Run ``farm ARGS...`` in-process; its exit code (0 when it returns normally)."""
    try:
        cli.main(list(args))
    except SystemExit as e:
        return int(e.code or 0)
    return 0


def _one_line(text: str) -> str:
    lines = [ln for ln in text.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, f"expected one line, got:\n{text}"
    assert "Traceback" not in text
    return lines[0]


def _exact(ds) -> None:
    """Every experiment ``ds`` holds is done and carries exactly what was written."""
    for e in ds["experiment"].values.tolist():
        assert e in DONE_IDS
        want = make_result(e, N_INNER, N_TREAD)
        got = ds.sel(experiment=e)
        np.testing.assert_array_equal(got["displacement"].values, want["displacement"])
        np.testing.assert_array_equal(got["reaction_force"].values, want["reaction_force"])
        assert float(got["deflection"]) == DEFLECTION[IDS.index(e)]


# --- the clean store -------------------------------------------------------------------------


def test_clean_store_verifies(built):
    report = verify(built)
    assert report.ok, report.lines()
    assert report.damaged_ids == set()
    (g,) = report.groups
    assert (g.checked, g.ok, g.unverifiable) == (5, 5, 0)  # 4 done + 1 failed


def test_every_experiment_carries_a_checksum(built):
    ds = storage.open_dataset(built, GROUP).load()
    sums = dict(zip(ds["experiment"].values.tolist(), ds["checksum"].values.tolist(),
                    strict=True))
    assert all(sums[e] for e in IDS[:5]) and sums["e5"] == ""
    assert len({sums[e] for e in IDS[:5]}) == 5


def test_clean_store_reads_exactly(built):
    ds = data.load(built, GROUP)
    assert sorted(ds["experiment"].values.tolist()) == DONE_IDS
    _exact(ds)


def test_clean_cli_verify_exits_zero(built, capsys):
    code = _cli("sweep", "verify", str(built))
    assert code == 0
    out = capsys.readouterr().out
    assert "5 checked" in out and "0 damaged" in out


# --- each kind of damage ---------------------------------------------------------------------


def test_verify_names_the_damage(damaged):
    path, damage = damaged
    report = verify(path)
    assert not report.ok
    text = "\n".join(report.lines())
    if damage.ids:
        assert report.damaged_ids == set(damage.ids) or (
            not damage.exact and report.damaged_ids >= set(damage.ids)), text
    for word in damage.words:
        assert word in text, text


def test_analysis_read_refuses_or_is_exact(damaged):
    path, damage = damaged
    try:
        ds = data.load(path, GROUP)
    except storage.StoreError as e:
        line = _one_line(str(e))
        assert "farm sweep verify" in line
        for e_id in damage.ids:
            assert e_id in line
        return
    assert not damage.refuses, "a damaged store was read without complaint"
    _exact(ds)


def test_done_refuses_damaged_experiments(damaged):
    path, damage = damaged
    if damage.structural:
        pytest.skip("structural damage: the one-line errors are checked in the other tests")
    with pytest.raises(storage.StoreError, match="farm sweep verify") as err:
        storage.done(storage.open_dataset(path, GROUP))
    for e_id in damage.ids:
        assert e_id in str(err.value)


def test_cli_analyse_is_one_line(damaged, capsys, tmp_path):
    path, damage = damaged
    if not damage.refuses:
        pytest.skip("the read is exact (test_analysis_read_refuses_or_is_exact): a full PCA")
    code = _cli("analyse", "pca", str(path), "--group", GROUP, "--out", str(tmp_path / "o"))
    err = capsys.readouterr().err
    if damage.refuses:
        assert code != 0
    if code != 0:
        line = _one_line(err)
        assert line.startswith("farm: error:")
        for e_id in damage.ids:
            assert e_id in line


def test_cli_status_never_silently_wrong(damaged, capsys):
    path, damage = damaged
    code = _cli("sweep", "status", str(path))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    if code == 0:  # then the counts must be the truth
        assert not damage.structural or not damage.refuses
        assert "4 done, 1 failed, 1 pending" in out or damage.ids, out
    else:
        assert _one_line(err).startswith("farm: error:")


def test_cli_verify_reports_and_exits_one(damaged, capsys):
    path, damage = damaged
    code = _cli("sweep", "verify", str(path))
    assert code == 1
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    for word in (*damage.ids, *damage.words):
        assert word in out + err


def test_cli_verify_json(damaged, capsys):
    path, damage = damaged
    code = _cli("sweep", "verify", str(path), "--json")
    assert code == 1
    report = json.loads(capsys.readouterr().out)
    assert report["ok"] is False
    assert set(damage.ids) <= set(report["damaged_ids"])


def test_repair_leaves_only_intact_done_experiments(damaged, capsys):
    path, damage = damaged
    _cli("sweep", "verify", str(path), "--repair")
    capsys.readouterr()
    if damage.ids:  # experiment damage: marked pending, the rest reads and is exact
        ds = storage.done(storage.open_dataset(path, GROUP))
        kept = set(ds["experiment"].values.tolist())
        assert kept <= set(DONE_IDS) - set(damage.ids)
        assert not damage.exact or kept == set(DONE_IDS) - set(damage.ids)
        _exact(ds)
        status = storage.statuses(path, GROUP, sorted(damage.ids))
        assert set(status.values()) == {storage.PENDING}
        assert verify(path).ok
        return
    try:  # structural damage: whatever repair could do, reads stay exact or refuse
        ds = data.load(path, GROUP)
    except storage.StoreError as e:
        assert "farm sweep verify" in _one_line(str(e))
        return
    except EmptySelectionError as e:  # e.g. ids lost: every slot marked pending
        _one_line(str(e))
        return
    _exact(ds)


# --- read-side guards --------------------------------------------------------------------


def test_status_refuses_done_slots_without_ids(built):
    (built / GROUP / "experiment" / "c" / "0").unlink()
    with pytest.raises(storage.StoreError, match="farm sweep verify"):
        storage.status_counts(built, GROUP)


def test_deleted_status_array_is_one_line(built):
    shutil.rmtree(built / GROUP / "status")
    with pytest.raises(storage.StoreError, match="status") as err:
        storage.statuses(built, GROUP)
    _one_line(str(err.value))


# --- groups written before checksums --------------------------------------------------------


@pytest.fixture
def old_group(tmp_path) -> Path:
    """A group as written before checksums: no ``checksum`` array."""
    path = tmp_path / "old.zarr"
    storage.create_group(path, GROUP, make_mesh(N_INNER, N_TREAD), make_attrs())
    shutil.rmtree(path / GROUP / "checksum")
    publish(storage.open_store(path))
    storage.reserve(path, GROUP, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    for e in DONE_IDS:
        storage.write_experiment(path, GROUP, e, make_result(e, N_INNER, N_TREAD), make_info(e))
    storage.write_failure(path, GROUP, "e4", "boom", {})
    return path


def test_old_group_stays_readable_and_writable(old_group):
    ds = data.load(old_group, GROUP)
    _exact(ds)
    assert sorted(ds["experiment"].values.tolist()) == DONE_IDS


def test_old_group_is_reported_unverifiable(old_group, capsys):
    report = verify(old_group)
    (g,) = report.groups
    assert (g.checked, g.unverifiable) == (5, 5)
    assert report.ok  # nothing found damaged, nothing could be proven intact
    code = _cli("sweep", "verify", str(old_group))
    assert code == 0
    assert "unverifiable (no checksums)" in capsys.readouterr().out


def test_repair_recovers_a_lost_status_array_from_checksums(built):
    want = storage.statuses(built, GROUP)
    shutil.rmtree(built / GROUP / "status")
    report = verify(built, repair=True)
    assert not report.ok and report.after is not None and report.after.ok
    assert storage.statuses(built, GROUP) == want  # 4 done, 1 failed, 1 pending again
    _exact(data.load(built, GROUP))


def test_repair_restores_array_metadata_exactly(built):
    key = built / GROUP / "displacement" / "zarr.json"
    before = json.loads(key.read_text())
    DAMAGES["truncate-array-zarr-json"].do(built)
    verify(built, repair=True)
    assert json.loads(key.read_text()) == before
    _exact(data.load(built, GROUP))


# --- a status lost or reset under an intact experiment (issue 26) ----------------------------


@pytest.mark.parametrize(("slot", "how", "state"), [
    (1, "delete", storage.DONE), (2, "pending", storage.DONE), (4, "pending", storage.FAILED)])
def test_a_lost_status_is_found_and_given_back(built, slot, how, state, capsys):
    chunk = built / GROUP / "status" / "c" / str(slot)
    if how == "delete":
        chunk.unlink()  # reads as the fill value: pending
    else:
        chunk.write_bytes(bytes([storage.PENDING]))
    report = verify(built)
    assert not report.ok and report.damaged_ids == {IDS[slot]}
    assert "its status is pending but its checksum matches it" in "\n".join(report.lines())
    assert _cli("sweep", "verify", str(built)) == 1
    capsys.readouterr()
    assert _cli("sweep", "verify", str(built), "--repair") == 1  # 1: it was damaged
    assert "after repair: no damage left" in capsys.readouterr().out
    assert storage.statuses(built, GROUP, [IDS[slot]]) == {IDS[slot]: state}
    assert verify(built).ok
    _exact(storage.done(storage.open_dataset(built, GROUP)))
    assert set(storage.done(storage.open_dataset(built, GROUP))["experiment"].values) == set(
        DONE_IDS)


def test_a_slot_never_written_is_not_taken_for_a_lost_status(built):
    report = verify(built)  # e5 is pending with no checksum: nothing to report
    assert report.ok and report.damaged_ids == set()


def test_a_lock_that_is_a_directory_is_named_and_repair_refuses(built, capsys):
    (built / ".farm.lock").mkdir()
    report = verify(built)
    assert not report.ok and "is not a regular file" in "\n".join(report.lines())
    code = _cli("sweep", "verify", str(built), "--repair")
    assert code == 1
    assert "cannot repair" in _one_line(capsys.readouterr().err)


def test_a_flipped_byte_in_a_checksum_chunk_is_one_line_for_the_analyses(built, capsys,
                                                                        tmp_path):
    _flip(built / GROUP / "checksum" / "c" / "1")
    code = _cli("analyse", "pca", str(built), "--group", GROUP, "--out", str(tmp_path / "o"))
    line = _one_line(capsys.readouterr().err)
    assert code == 1 and "farm sweep verify" in line and "checksum" in line


def test_garbage_group_metadata_is_one_line_in_a_fresh_process(built):
    """The noise came at interpreter exit (asyncio's report of zarr's sibling tasks):
    only a real process shows it."""
    import subprocess
    import sys

    (built / GROUP / "zarr.json").write_text("garbage{")
    for command in ("list", "status"):
        run = subprocess.run([sys.executable, "-m", "farm", "sweep", command, str(built)],
                             capture_output=True, text=True, timeout=120)
        assert run.returncode == 1
        assert _one_line(run.stderr).startswith("farm: error:"), run.stderr


def test_a_group_whose_creation_stopped_is_named_by_verify_and_status(built, capsys):
    import zarr

    half = zarr.open_group(str(built), mode="a").create_group("mesh-b")
    half.create_array("inner_node", shape=(3,), dtype="int64")  # then the disk was full
    assert storage.unfinished_groups(built) == ["mesh-b"]
    report = verify(built)
    assert not report.ok and "mesh-b: the group's creation never finished" in "\n".join(
        report.lines())
    assert _cli("sweep", "status", str(built)) == 1
    out, err = capsys.readouterr()
    assert "4 done" in out and "'mesh-b'" in _one_line(err) and "never finished" in err
    # submitting again rebuilds it (create_group treats a half-made group as its own)
    from store_helpers import make_attrs, make_mesh

    storage.create_group(built, "mesh-b", make_mesh(N_INNER, N_TREAD), make_attrs())
    assert storage.unfinished_groups(built) == [] and "mesh-b" in storage.list_groups(built)


@pytest.mark.parametrize("name", ["pressure", "deflection"])
def test_a_lost_load_case_keeps_its_results_and_resume_restores_it(built, name, capsys):
    """Before: repair marked every experiment of a deleted parameter chunk pending, and
    resume refused them ("pressure=nan, not 0.2"): 0 of 4 done, all results lost."""
    (built / GROUP / name / "c" / "0").unlink()
    report = verify(built)
    assert report.damaged_ids == {*DONE_IDS, "e4"}
    assert "its load case is lost" in "\n".join(report.lines())
    _cli("sweep", "verify", str(built), "--repair")
    assert "kept as they are" in capsys.readouterr().out
    assert storage.statuses(built, GROUP, IDS[:5]) == {
        **dict.fromkeys(DONE_IDS, storage.DONE), "e4": storage.FAILED}
    # what `farm sweep resume STUDY` does first: reserve the study's ids again
    storage.reserve(built, GROUP, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    assert verify(built).ok
    ds = storage.done(storage.open_dataset(built, GROUP))
    assert set(ds["experiment"].values) == set(DONE_IDS)
    _exact(ds)


@pytest.mark.parametrize("name", ["pressure", "deflection"])
def test_a_load_case_chunk_that_does_not_decode_is_no_loop_of_repair_and_resume(
        built, name, capsys):
    """Issue 50: a flipped byte in a compressed parameter chunk. Repair said resume would
    restore the load case, and resume (reading the chunk) said run verify: a loop. Repair
    now removes the chunk (its values were lost anyway), and resume restores it."""
    chunk = built / GROUP / name / "c" / "0"
    data = chunk.read_bytes()  # the zstd frame's magic kept, its block garbled
    chunk.write_bytes(data[:4] + bytes(b ^ 0xFF for b in data[4:]))
    assert "does not decode" in "\n".join(verify(built).lines())
    _cli("sweep", "verify", str(built), "--repair")
    out = capsys.readouterr().out
    assert "kept as they are" in out and "load-case chunk(s) that do not decode removed" in out
    assert not chunk.exists()
    storage.reserve(built, GROUP, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    assert verify(built).ok
    ds = storage.done(storage.open_dataset(built, GROUP))
    assert set(ds["experiment"].values) == set(DONE_IDS)  # nothing to solve again
    _exact(ds)


def test_a_lost_load_case_is_restored_only_from_the_same_id(built):
    (built / GROUP / "pressure" / "c" / "0").unlink()
    # a different value for a slot whose value is intact is still a conflict
    with pytest.raises(storage.ParameterConflictError, match="deflection"):
        storage.reserve(built, GROUP, IDS, {"deflection": [1.0] * 6, "pressure": PRESSURE})
    # and nothing was written by the refused call
    assert np.isnan(storage.open_dataset(built, GROUP)["pressure"].values).all()


def test_an_edited_load_case_is_restored_by_resume_from_the_signed_label(built, capsys):
    """Before: an edited deflection made repair mark the slot pending and resume refuse
    it ("deflection=99.5, not 17.3"): 3 of 4 done for good. The worker's checksum label
    is the id with its true load case, so the study's value is proven and written back;
    the slot (pending after repair) is solved again."""
    import zarr

    zarr.open_array(str(built / GROUP / "deflection"), mode="r+")[1] = 99.5
    _cli("sweep", "verify", str(built), "--repair")
    capsys.readouterr()
    assert storage.statuses(built, GROUP, ["e1"]) == {"e1": storage.PENDING}
    storage.reserve(built, GROUP, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    ds = storage.open_dataset(built, GROUP)
    assert ds["deflection"].values.tolist() == DEFLECTION
    assert verify(built).ok
    # a load case no signature proves is still a conflict
    with pytest.raises(storage.ParameterConflictError, match="deflection"):
        storage.reserve(built, GROUP, ["e0"], {"deflection": [12.0], "pressure": PRESSURE})


def test_swapped_ids_are_put_back_where_their_checksums_were_signed(built, capsys):
    """Before: two swapped ids cost both experiments (marked pending, and resume could
    not re-reserve them with their load cases). Their checksums name the true ids."""
    import zarr

    ids = zarr.open_array(str(built / GROUP / "experiment"), mode="r+")
    ids[1], ids[2] = "e2", "e1"
    report = verify(built)
    assert report.damaged_ids == {"e1", "e2"}
    assert "its checksum was signed as 'e1'" in "\n".join(report.lines())
    _cli("sweep", "verify", str(built), "--repair")
    assert "id(s) put back" in capsys.readouterr().out
    assert verify(built).ok
    ds = storage.done(storage.open_dataset(built, GROUP))
    assert set(ds["experiment"].values) == set(DONE_IDS)
    _exact(ds)


def test_a_single_wrong_id_proves_nothing_and_goes_pending(built, capsys):
    import zarr

    zarr.open_array(str(built / GROUP / "experiment"), mode="r+")[1] = "e9"
    _cli("sweep", "verify", str(built), "--repair")
    capsys.readouterr()
    assert storage.statuses(built, GROUP, ["e9"]) == {"e9": storage.PENDING}


# --- status counts only valid states (issue 50) ------------------------------------------


def _status_byte(value: int) -> Callable[[Path], None]:
    return lambda p: _write_status(p, 3, value)


def _repeat_id(p: Path) -> None:
    import zarr

    ids = zarr.open_array(p / GROUP / "experiment", mode="r+")
    ids[2] = "e1"  # a hand's edit: the chunk still decodes


@pytest.mark.parametrize(("damage", "needle"), [
    (_status_byte(7), "status is none of pending, done, failed (experiment 'e3': 7)"),
    (_status_byte(-1), "status is none of pending, done, failed (experiment 'e3': -1)"),
    (_repeat_id, "experiment id 'e1' in more than one slot"),
])
def test_status_counts_only_valid_states_and_says_to_verify(built, capsys, damage, needle):
    damage(built)
    with pytest.raises(storage.StoreError, match="farm sweep verify") as err:
        storage.status_counts(built, GROUP)
    assert needle in _one_line(str(err.value))
    code = _cli("sweep", "status", str(built))
    out, err_text = capsys.readouterr()
    assert code != 0 and "done" not in out
    assert needle in _one_line(err_text)
    assert _cli("sweep", "verify", str(built)) == 1  # verify names it too


@pytest.mark.parametrize("repair", [False, True])
def test_group_metadata_that_is_json_but_not_an_object_is_damage_not_a_crash(built, capsys,
                                                                             repair):
    (built / GROUP / "zarr.json").write_text("[1, 2, 3]")
    code = _cli("sweep", "verify", str(built), *(["--repair"] if repair else []))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err and f"{GROUP}/zarr.json" in out + err
    if repair:  # restored from the consolidated copy
        assert verify(built).ok
        assert storage.status_counts(built, GROUP) == {"pending": 1, "done": 4, "failed": 1}
    else:
        assert code == 1


def test_verify_of_a_group_that_is_not_there_names_the_groups_and_touches_nothing(built,
                                                                                  capsys):
    before = {p: p.read_bytes() for p in built.rglob("*") if p.is_file()}
    code = _cli("sweep", "verify", str(built), "--group", "nope")
    out, err = capsys.readouterr()
    assert code == 2 and "DAMAGED" not in out
    line = _one_line(err)
    assert "no group 'nope'" in line and GROUP in line
    assert {p: p.read_bytes() for p in built.rglob("*") if p.is_file()} == before


# --- what a group was made as (issue 50: storage.identity) --------------------------------


def _edit_attr(name: str, value: str) -> Callable[[Path], None]:
    def do(p: Path) -> None:
        doc = json.loads((p / GROUP / "zarr.json").read_text())
        doc["attributes"][name] = value
        (p / GROUP / "zarr.json").write_text(json.dumps(doc))
    return do


def _edit_xyz(p: Path) -> None:
    import zarr

    xyz = zarr.open_array(p / GROUP / "inner_xyz", mode="r+")
    xyz[3, 1] = xyz[3, 1] + 1.0  # one coordinate, 1 mm


def _delete_xyz_chunk(p: Path) -> None:
    chunks = sorted((p / GROUP / "inner_xyz" / "c").rglob("*"))
    next(c for c in chunks if c.is_file()).unlink()


@pytest.mark.parametrize(("damage", "part"), [
    (_edit_xyz, "mesh"),
    (_delete_xyz_chunk, "mesh"),
    (_edit_attr("model_spec", '{"kind": "full"}'), "model_spec"),
    (_edit_attr("mesh_key", "mesh-0000"), "mesh_key"),
])
def test_a_group_that_is_not_what_it_was_made_as_is_named_and_not_read(built, capsys,
                                                                        damage, part):
    damage(built)
    code = _cli("sweep", "verify", str(built))
    out, err = capsys.readouterr()
    assert code == 1 and f"{GROUP}/{part}" in out + err, out + err
    with pytest.raises(storage.StoreError, match="farm sweep verify") as e:
        storage.open_dataset(built, GROUP)
    assert "differs from what the group was made with" in _one_line(str(e.value))
    before = storage.statuses(built, GROUP)
    _cli("sweep", "verify", str(built), "--repair")
    assert storage.statuses(built, GROUP) == before  # no side is provably right: untouched


@pytest.mark.parametrize("how", ["renamed", "copied"])
def test_a_renamed_or_copied_group_folder_is_named(built, capsys, how):
    (shutil.copytree if how == "copied" else shutil.move)(built / GROUP, built / "other")
    publish(built)  # as a later client would
    code = _cli("sweep", "verify", str(built))
    out, err = capsys.readouterr()
    assert code == 1 and "other/group" in out + err and "renamed or copied" in out + err
    with pytest.raises(storage.StoreError, match="folder name"):
        storage.open_dataset(built, "other")
    if how == "copied":
        assert storage.open_dataset(built, GROUP).sizes["experiment"] == len(IDS)


def test_a_clean_group_carries_its_identity(built):
    import zarr

    from storage.identity import IDENTITY, PARTS

    attrs = zarr.open_group(built / GROUP, mode="r").attrs
    assert set(attrs[IDENTITY]) == {*PARTS, "version"}
    assert verify(built).ok


@pytest.mark.parametrize("length", [3, 9])
def test_repair_gives_an_edited_length_back_from_the_consolidated_copy(built, capsys, length):
    """Issue 50: a status shape of 3 for 6 ids made repair raise BoundsCheckError."""
    meta = built / GROUP / "status" / "zarr.json"
    doc = json.loads(meta.read_text())
    doc["shape"] = [length]
    meta.write_text(json.dumps(doc))
    assert _cli("sweep", "verify", str(built)) == 1
    assert _cli("sweep", "verify", str(built), "--repair") == 1  # damage was found
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err and "length restored" in out + err
    assert verify(built).ok
    assert storage.status_counts(built, GROUP) == {"pending": 1, "done": 4, "failed": 1}


def test_repair_rebuilds_a_lost_root_from_its_intact_groups(built, capsys):
    """Issue 50: with the root's zarr.json deleted, repair refused ("not a Zarr v3
    store") although every group was intact."""
    (built / "zarr.json").unlink()
    assert _cli("sweep", "verify", str(built)) == 1
    _cli("sweep", "verify", str(built), "--repair")
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert verify(built).ok
    assert storage.status_counts(built, GROUP) == {"pending": 1, "done": 4, "failed": 1}
    _exact(storage.done(storage.open_dataset(built, GROUP)))


def test_a_renamed_group_is_not_built_again_under_its_own_name(built):
    """Issue 50: resume then solved all experiments again into a new group."""
    shutil.move(built / GROUP, built / "moved")
    publish(built)
    with pytest.raises(storage.StoreError, match="rename 'moved' back"):
        storage.create_group(built, GROUP, make_mesh(N_INNER, N_TREAD), make_attrs())
    assert not (built / GROUP).exists()


def test_an_identity_of_another_version_is_not_checked_and_never_damage(built):
    """A later change of how digests are made must not make every store damaged."""
    meta = built / GROUP / "zarr.json"
    doc = json.loads(meta.read_text())
    doc["attributes"]["identity"] = {**doc["attributes"]["identity"], "version": 99,
                                     "mesh": "0" * 64}
    meta.write_text(json.dumps(doc))
    publish(built)
    assert verify(built).ok
    assert storage.open_dataset(built, GROUP).sizes["experiment"] == len(IDS)


@pytest.mark.parametrize(("slot", "damage"), [
    (2, "empty"), (2, "duplicate"), (0, "duplicate"),  # done slots: the checksum proves
    (4, "empty"),  # a failed slot: signed too
])
def test_resume_gives_a_lost_or_duplicated_id_back(built, slot, damage):
    """Issue 50: an id emptied or copied over another slot's. Repair could not tell which
    id was lost, and resume refused the group ("empty experiment id before reserved
    ones", or a duplicate's load-case conflict): 19 of 20 for good. Reserving the study's
    ids again now restores the id its checksum label proves (or, for a pending slot, the
    one whose load case it holds), and nothing is solved again."""
    import zarr

    ids = zarr.open_array(str(built / GROUP / "experiment"), mode="r+")
    ids[slot] = "" if damage == "empty" else IDS[(slot + 1) % len(IDS)]
    assert not verify(built).ok
    if damage == "empty":
        with pytest.raises(storage.SchemaError, match="empty experiment id"):
            storage.statuses(built, GROUP)
    got = storage.reserve(built, GROUP, IDS, {"deflection": DEFLECTION, "pressure": PRESSURE})
    assert got == {e: i for i, e in enumerate(IDS)}  # every id back in its own slot
    assert verify(built).ok
    assert storage.statuses(built, GROUP) == {
        **dict.fromkeys(DONE_IDS, storage.DONE), "e4": storage.FAILED, "e5": storage.PENDING}
    _exact(storage.done(storage.open_dataset(built, GROUP)))


def test_a_pending_slots_id_is_proven_by_its_load_case_and_never_guessed(built):
    """A pending slot has no checksum: its id comes back when exactly one id given now
    has its load case; two pending slots of one load case that both lost their ids are
    left alone (nothing tells them apart), and the refusal stays."""
    import zarr

    extra = ["e6", "e7", "e8"]
    storage.reserve(built, GROUP, extra, {"deflection": [50.0, 50.0, 60.0],
                                          "pressure": PRESSURE})
    ids = zarr.open_array(str(built / GROUP / "experiment"), mode="r+")
    every = IDS + extra
    values = {"deflection": [*DEFLECTION, 50.0, 50.0, 60.0], "pressure": PRESSURE}
    ids[5] = ""  # pending e5 at 38.9 mm: one id given has that load case
    assert storage.reserve(built, GROUP, every, values)["e5"] == 5
    ids[6], ids[7] = "", ""  # e6 and e7: both pending at 50 mm
    with pytest.raises(storage.SchemaError, match="empty experiment id"):
        storage.reserve(built, GROUP, every, values)
    assert ids[6] == "" and ids[7] == ""  # nothing guessed


# --- chunks that prove themselves (CRC32C, issue 50) -------------------------------------


def _repaired(path: Path) -> dict[str, int]:
    _cli("sweep", "verify", str(path), "--repair")
    assert verify(path).ok
    return storage.statuses(path, GROUP, IDS)


@pytest.mark.parametrize("lose", ["flip", "delete", "truncate"])
def test_a_lost_checksum_of_intact_data_is_signed_again_not_solved_again(built, lose):
    """Issue 50: checksum-only damage marked intact experiments pending (six re-solves in
    one fuzz case). Every data chunk of e1 passes its CRC32C: repair signs it again."""
    chunk = built / GROUP / "checksum" / "c" / "1"
    if lose == "flip":
        _flip(chunk)
    elif lose == "delete":
        chunk.unlink()
    else:
        chunk.write_bytes(chunk.read_bytes()[:5])
    report = verify(built)
    assert not report.ok and report.damaged_ids == {"e1"}
    assert "repair signs it again (no re-solve)" in "\n".join(report.lines())
    status = _repaired(built)
    assert [status[e] for e in DONE_IDS] == [storage.DONE] * 4
    ds = storage.done(storage.open_dataset(built, GROUP))
    assert ds["experiment"].values.tolist() == DONE_IDS
    _exact(ds)


@pytest.mark.parametrize("data", ["flip", "delete"])
def test_a_lost_checksum_beside_damaged_data_is_solved_again(built, data):
    """Nothing proves e1 intact when a data chunk fails too: pending, its bad chunk
    removed so that the experiments beside it still read."""
    (built / GROUP / "checksum" / "c" / "1").unlink()
    chunk = _chunk(built, "displacement", 1)
    _flip(chunk, _value("e1", "displacement", 4)) if data == "flip" else chunk.unlink()
    assert verify(built).damaged_ids == {"e1"}
    status = _repaired(built)
    assert status["e1"] == storage.PENDING
    assert [status[e] for e in ("e0", "e2", "e3")] == [storage.DONE] * 3
    _exact(storage.done(storage.open_dataset(built, GROUP)))


def test_a_flipped_data_byte_is_named_by_its_crc_and_its_chunk_removed(built):
    _flip(_chunk(built, "displacement", 2), _value("e2", "displacement", 4))
    report = verify(built)
    assert report.damaged_ids == {"e2"}
    assert "CRC32C" in "\n".join(report.lines()) or "checksum" in "\n".join(report.lines())
    status = _repaired(built)
    assert status["e2"] == storage.PENDING and not _chunk(built, "displacement", 2).exists()
    _exact(storage.done(storage.open_dataset(built, GROUP)))


def test_a_flipped_status_byte_gets_its_status_back_from_the_checksum(built):
    """The status chunk fails its CRC32C; the slot's checksum proves it failed (e4) or
    done (e2): repair gives that back, nothing is solved again."""
    for i in (2, 4):
        _flip(built / GROUP / "status" / "c" / str(i))
    assert not verify(built).ok
    status = _repaired(built)
    assert status == {"e0": 1, "e1": 1, "e2": 1, "e3": 1, "e4": 2, "e5": 0}


def test_a_lost_status_and_checksum_is_named_as_what_resume_will_solve(built, capsys):
    """Issue 50: with e1's status and checksum chunks both deleted, verify said nothing
    while the analyses used 3 of 4. A stopped write leaves the same bytes, so it is a
    note (resume solves it again), not damage."""
    for name in ("status", "checksum"):
        (built / GROUP / name / "c" / "1").unlink()
    report = verify(built)
    assert report.ok  # a killed worker's slot looks just so
    (group,) = report.groups
    assert len(group.notes) == 1 and group.notes[0].startswith("e1 (slot 1): pending, but")
    assert _cli("sweep", "verify", str(built), "--json") == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["groups"][0]["notes"] == list(group.notes)
    assert not verify(build(built.parent / "intact.zarr")).groups[0].notes


def test_lost_group_attributes_are_restored_not_solved_again(built):
    """Issue 50: a group whose attributes were deleted looked unfinished; resume then
    rebuilt it and solved all of it again. The consolidated copy holds them."""
    meta = built / GROUP / "zarr.json"
    doc = json.loads(meta.read_text())
    want = doc["attributes"]
    meta.write_text(json.dumps({**doc, "attributes": {}}))
    report = verify(built)
    assert not report.ok and "attributes are lost" in "\n".join(report.lines())
    assert storage.list_groups(built) == []
    repaired = verify(built, repair=True)
    assert repaired.after is None or repaired.after.ok, repaired.lines()
    assert json.loads(meta.read_text())["attributes"] == want
    assert storage.statuses(built, GROUP, IDS) == {
        "e0": 1, "e1": 1, "e2": 1, "e3": 1, "e4": 2, "e5": 0}
    _exact(storage.done(storage.open_dataset(built, GROUP)))
