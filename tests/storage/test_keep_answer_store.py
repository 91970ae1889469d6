"""scripts/keep_answer_store.sh: the answer's store brought from its sweep's clone into a
checkout, checked (issue 46: a store of some 15 h outlives a session only in the
repository). A copy that verifies replaces the kept store, with its saved trunks and
without the clone's claims and lock; a damaged copy is refused and the kept store stays
as it was."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from store_helpers import GROUP, make_attrs, make_info, make_mesh, make_result

import storage
from storage import saved

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "keep_answer_store.sh"
STORE = "results/t2cam_rolling.zarr"
IDS = ["e0", "e1", "e2"]


def _clone(root: Path) -> Path:
    """A sweep's clone whose store holds two done experiments, a saved trunk and a claim."""
    path = root / STORE
    storage.create_group(path, GROUP, make_mesh(12, 5), make_attrs())
    storage.reserve(path, GROUP, IDS, {"deflection": [11.1, 17.3, 23.7], "pressure": 0.2})
    for e in IDS[:2]:
        storage.write_experiment(path, GROUP, e, make_result(e, 12, 5), make_info(e))
    saved.save(path, GROUP, "tree-0", b"a trunk's restart")
    (path / ".claims").mkdir(exist_ok=True)
    (path / ".claims" / "tree-0").write_text("worker 1")
    return root


def _keep(clone: Path, dest: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    return subprocess.run(["bash", str(SCRIPT), str(clone), str(dest)], capture_output=True,
                          text=True, env=env, timeout=300, check=False)


def _done(path: Path) -> list[str]:
    ds = storage.done(storage.open_dataset(path, GROUP))
    return sorted(str(e) for e in ds["experiment"].values)


@pytest.fixture
def dest(tmp_path) -> Path:
    (tmp_path / "dest").mkdir()
    return tmp_path / "dest"


def test_a_verified_copy_is_kept_with_its_saved_trunks_without_claims_or_lock(tmp_path,
                                                                              dest):
    clone = _clone(tmp_path / "clone")
    done = _keep(clone, dest)
    assert done.returncode == 0, done.stderr
    kept = dest / STORE
    assert _done(kept) == ["e0", "e1"]
    assert not (kept / ".claims").exists()
    assert saved.load(kept, GROUP, "tree-0") == b"a trunk's restart"
    assert not (dest / f"{STORE}.incoming").exists()
    src = storage.open_dataset(clone / STORE, GROUP)["displacement"].values
    np.testing.assert_array_equal(storage.open_dataset(kept, GROUP)["displacement"].values, src)


def test_a_damaged_copy_is_refused_and_the_kept_store_is_untouched(tmp_path, dest):
    clone = _clone(tmp_path / "clone")
    assert _keep(clone, dest).returncode == 0
    before = {p: p.read_bytes() for p in (dest / STORE).rglob("*") if p.is_file()}
    chunk = clone / STORE / GROUP / "displacement" / "c" / "1" / "0" / "0"
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF  # a torn or damaged chunk of a done experiment
    chunk.write_bytes(bytes(raw))
    refused = _keep(clone, dest)
    assert refused.returncode == 1
    assert "is damaged" in refused.stderr and "is unchanged" in refused.stderr
    after = {p: p.read_bytes() for p in (dest / STORE).rglob("*") if p.is_file()
             and p.name != ".farm.lock"}
    assert after == {p: b for p, b in before.items() if p.name != ".farm.lock"}
    assert not (dest / f"{STORE}.incoming").exists()


def test_no_store_in_the_clone_is_one_line(tmp_path, dest):
    refused = _keep(tmp_path, dest)
    assert refused.returncode == 1 and refused.stderr.count("\n") == 1
    assert "no store at" in refused.stderr
