"""Atomic writes (farm/atomic.py, issue 25): never a torn file, never a stray temporary.

The inflation cache once named its temporary file by pid alone: two threads of one
worker writing the same entry shared it, one truncating what the other wrote, and the
second rename found no file. The tests here make writers overlap on purpose.
"""

from __future__ import annotations

import hashlib
import os
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

import farm.atomic as atomic
from farm.presets import default_model
from farm.solve import contact
from farm.specs import SolverSettings

WRITES = 150


def _payload(writer: int, seq: int) -> bytes:
    """A self-checking file: its length varies, and its last line is the body's digest."""
    body = f"{writer}:{seq}:".encode() + bytes([65 + writer]) * (1000 + 37 * (seq % 50))
    return body + b"\n" + hashlib.sha256(body).hexdigest().encode()


def _whole(data: bytes) -> bool:
    body, _, digest = data.rpartition(b"\n")
    return hashlib.sha256(body).hexdigest().encode() == digest


def _write_in_pieces(target: Path, data: bytes) -> None:
    """Write in small flushed pieces with a yield between them, so writers interleave."""
    with atomic.replacing(target) as tmp, open(tmp, "wb") as f:
        for i in range(0, len(data), 256):
            f.write(data[i:i + 256])
            f.flush()
            time.sleep(0)


def test_two_threads_writing_one_file_never_tear_it(tmp_path):
    target = tmp_path / "entry.bin"
    errors: list[BaseException] = []
    torn: list[bytes] = []
    done = threading.Event()

    def writer(w: int) -> None:
        try:
            for seq in range(WRITES):
                _write_in_pieces(target, _payload(w, seq))
        except BaseException as e:  # reported by the test below
            errors.append(e)

    def reader() -> None:
        while not done.is_set():
            try:
                data = target.read_bytes()
            except FileNotFoundError:
                continue
            if not _whole(data):
                torn.append(data[:40])

    threads = [threading.Thread(target=writer, args=(w,)) for w in (0, 1)]
    watcher = threading.Thread(target=reader)
    for t in (*threads, watcher):
        t.start()
    for t in threads:
        t.join()
    done.set()
    watcher.join()
    assert not errors, errors[:3]
    assert not torn, f"{len(torn)} torn reads, e.g. {torn[0]!r}"
    assert _whole(target.read_bytes())
    assert os.listdir(tmp_path) == ["entry.bin"], "a temporary file was left behind"


def test_a_failing_writer_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "entry.json"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="disk full"), atomic.replacing(target) as tmp:
        tmp.write_text("half of the ne")
        raise RuntimeError("disk full")
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["entry.json"]


def test_a_failing_rename_leaves_no_temporary(tmp_path):
    target = tmp_path / "entry"
    target.mkdir()  # a folder in the way: os.replace of a file onto it fails
    with pytest.raises(OSError):
        atomic.write_text(target, "new")
    assert os.listdir(tmp_path) == ["entry"] and target.is_dir()


def test_temporary_names_are_unique_and_beside_the_target(tmp_path):
    target = tmp_path / "mesh.npz"
    names = {atomic.temp_name(target, ".npz") for _ in range(100)}
    assert len(names) == 100
    for name in names:
        assert name.parent == tmp_path and name.name.endswith(".tmp.npz")
        assert f".{os.getpid()}.{threading.get_ident()}." in name.name


@pytest.mark.parametrize("durable", [False, True])
def test_data_is_fsynced_before_the_rename(tmp_path, monkeypatch, durable):
    events: list[str] = []
    fsync, replace = atomic._fsync, os.replace
    monkeypatch.setattr(atomic, "_fsync", lambda p, flags: (
        events.append("fsync dir" if Path(p).is_dir() else "fsync file"), fsync(p, flags)))
    monkeypatch.setattr(os, "replace", lambda a, b: (events.append("replace"), replace(a, b)))
    atomic.write_text(tmp_path / "entry", "x", durable=durable)
    assert events == ["fsync file", "replace", *(["fsync dir"] if durable else [])]


def test_two_threads_share_no_temporary_in_the_inflation_cache(tmp_path, monkeypatch):
    """Two threads of one worker miss the same inflation entry and both write it.

    Their renames are held until both have written (a barrier in ``os.replace``), so the
    writes overlap. With the pid-only temporary name both wrote one file, and the second
    rename raised FileNotFoundError (which the cache swallowed).
    """
    monkeypatch.setenv("FARM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(contact, "ccx_version", lambda: "CalculiX test")
    z_of = {"w0": -301.5, "w1": -301.25000000000003}  # reprs of different lengths
    monkeypatch.setattr(contact, "inflate", lambda *a, **k: (
        "run", z_of[threading.current_thread().name]))
    barrier = threading.Barrier(2, timeout=20)
    renames: list[tuple[str, BaseException | None]] = []
    replace = os.replace

    def held_replace(src, dst):
        barrier.wait()
        try:
            replace(src, dst)
        except BaseException as e:
            renames.append((str(src), e))
            raise
        renames.append((str(src), None))

    monkeypatch.setattr(os, "replace", held_replace)
    spec, mesh = default_model("full"), SimpleNamespace(mesh_key="mesh-test")
    answers: dict[str, tuple] = {}

    def solve():
        answers[threading.current_thread().name] = contact.touch_height(
            spec, mesh, 0.2, SolverSettings())

    threads = [threading.Thread(target=solve, name=name) for name in z_of]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    monkeypatch.setattr(os, "replace", replace)
    assert {name: z for name, (z, _) in answers.items()} == z_of  # both ran the pre-run
    assert [e for _, e in renames] == [None, None], renames
    assert len({src for src, _ in renames}) == 2, "the two threads shared a temporary file"
    entries = list((tmp_path / "inflation").iterdir())
    assert len(entries) == 1 and entries[0].suffix == ".json", entries
    # the entry is whole, and the next call reads it without a solve
    z, run = contact.touch_height(spec, mesh, 0.2, SolverSettings())
    assert run is None and z in z_of.values()
