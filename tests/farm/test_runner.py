"""The ccx choke-point: outcomes from exit code and output, timeouts, cancellation."""

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

from farm.ccx.outcome import Outcome, classify
from farm.ccx.runner import (
    KEEP_MARKER,
    ccx_version,
    clean_stale_scratch,
    read_sta,
    run_ccx,
    scratch_dir,
    scratch_host,
)
from farm.errors import CcxNotFoundError, SolverError

CUBE = """*NODE, NSET=ALL
1, 0,0,0
2, 1,0,0
3, 1,1,0
4, 0,1,0
5, 0,0,1
6, 1,0,1
7, 1,1,1
8, 0,1,1
*ELEMENT, TYPE=C3D8, ELSET=E
1, 1,2,3,4,5,6,7,8
*NSET, NSET=BOT
1,2,3,4
*NSET, NSET=TOP
5,6,7,8
*MATERIAL, NAME=M
*HYPERELASTIC, NEO HOOKE
1.0, 0.01
*SOLID SECTION, ELSET=E, MATERIAL=M
"""


def _deck(step: str, top: float = -0.3, boundary: str = "BOT") -> str:
    return CUBE + (f"{step}\n*BOUNDARY\n{boundary}, 1, 3, 0\nTOP, 3, 3, {top}\n"
                   "*NODE FILE\nU\n*END STEP\n")


DECKS = {
    Outcome.CONVERGED: _deck("*STEP, NLGEOM\n*STATIC\n0.25, 1., 1e-5, 0.25"),
    Outcome.INCREMENT_BELOW_MINIMUM: _deck("*STEP, NLGEOM, INC=5\n*STATIC\n1., 1., 1., 1.", -0.999),
    Outcome.MAX_INCREMENTS: _deck("*STEP, NLGEOM, INC=3\n*STATIC\n0.01, 1., 1e-5, 0.01", -0.5),
    Outcome.INPUT_ERROR: _deck("*STEP\n*STATIC", boundary="NOPE"),
}
SLOW = _deck("*STEP, NLGEOM, INC=10000000\n*STATIC, DIRECT\n1e-7, 1.", -0.5)


@pytest.mark.ccx
@pytest.mark.parametrize("outcome", list(DECKS))
def test_outcome_of_real_runs(outcome, tmp_path):
    run = run_ccx(DECKS[outcome], tmp_path, check=False)
    assert run.outcome is outcome, run.output_tail
    if outcome is Outcome.CONVERGED:
        assert run.returncode == 0 and run.file("frd").exists()
        assert run.increments == 4 and run.cutbacks == 0  # 0.25 steps, no trouble
        assert [t for t, _ in run.progress] == pytest.approx([0.25, 0.5, 0.75, 1.0])
    else:
        assert run.returncode == 201  # ccx's stop()


@pytest.mark.ccx
def test_failure_raises_with_command_code_and_tail(tmp_path):
    with pytest.raises(SolverError) as info:
        run_ccx(DECKS[Outcome.INCREMENT_BELOW_MINIMUM], tmp_path)
    err = info.value
    assert err.outcome == "increment_below_minimum" and err.returncode == 201
    assert err.command[1:] == ["-i", "job"] and "increment size smaller" in err.tail
    assert "increment_below_minimum" in str(err) and "\n" not in str(err)
    assert err.reached == 0.0 and "no increment converged" in str(err)


@pytest.mark.ccx
def test_a_failure_says_where_its_path_stopped_and_keeps_it_across_processes(tmp_path):
    import pickle

    with pytest.raises(SolverError) as info:
        run_ccx(DECKS[Outcome.MAX_INCREMENTS], tmp_path)  # 3 increments of 0.01 converge
    err = info.value
    assert err.reached == pytest.approx(0.03)
    assert "last converged increment at step time 0.03" in str(err)
    located = err.located("in the rise, 1.20 mm deflection")
    assert "step time 0.03 (in the rise, 1.20 mm deflection). Raise" in str(located)
    back = pickle.loads(pickle.dumps(located))  # a worker's error reaches the client whole
    assert str(back) == str(located) and back.reached == located.reached


def _ccx_children_in(workdir: Path) -> list[psutil.Process]:
    found = []
    for p in psutil.process_iter(["name", "cwd"]):
        try:
            if p.info["name"] == "ccx" and p.info["cwd"] and Path(p.info["cwd"]) == workdir:
                found.append(p)
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
    return found


@pytest.mark.ccx
def test_timeout_kills_the_solver(tmp_path):
    start = time.monotonic()
    with pytest.raises(SolverError) as info:
        run_ccx(SLOW, tmp_path, timeout=1.0)
    assert info.value.outcome == "timeout" and info.value.returncode is None
    assert time.monotonic() - start < 15
    assert _ccx_children_in(tmp_path) == []


@pytest.mark.ccx
def test_should_stop_cancels_the_solver(tmp_path):
    stop = threading.Event()
    threading.Timer(0.5, stop.set).start()
    run = run_ccx(SLOW, tmp_path, should_stop=stop.is_set, check=False)
    assert run.outcome is Outcome.CANCELLED
    assert _ccx_children_in(tmp_path) == []


@pytest.mark.ccx
def test_an_exception_in_the_caller_kills_the_solver(tmp_path, monkeypatch):
    def boom(*args, **kwargs):
        time.sleep(0.5)
        raise KeyboardInterrupt

    monkeypatch.setattr("farm.ccx.runner._wait", boom)
    with pytest.raises(KeyboardInterrupt):
        run_ccx(SLOW, tmp_path)
    time.sleep(0.2)
    assert _ccx_children_in(tmp_path) == []


def test_missing_solver_is_a_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("FARM_CCX", "no-such-ccx-binary")
    with pytest.raises(CcxNotFoundError, match="apt-get install calculix-ccx"):
        run_ccx(DECKS[Outcome.CONVERGED], tmp_path)


@pytest.mark.ccx
def test_version_and_environment(tmp_path):
    assert ccx_version()[0].isdigit()
    run_ccx(DECKS[Outcome.CONVERGED], tmp_path, threads=2)


@pytest.mark.parametrize(
    "code, text, expected",
    [
        (0, "...\n Job finished\n", Outcome.CONVERGED),
        (0, " *ERROR: too many cutbacks\n Job finished\n", Outcome.TOO_MANY_CUTBACKS),
        (201, " *ERROR: too many cutbacks\n", Outcome.TOO_MANY_CUTBACKS),
        (201, " *ERROR in e_c3d: nonpositive jacobian determinant in element 4\n",
         Outcome.NONPOSITIVE_JACOBIAN),
        (201, " *ERROR: solution seems to diverge; please try \n", Outcome.DIVERGED),
        (0, "STEP 1\n", Outcome.CRASH),  # exit 0 without finishing
        (-11, "", Outcome.CRASH),  # segfault
        (201, " *ERROR reading *MATERIAL\n", Outcome.INPUT_ERROR),
    ],
)
def test_classify(code, text, expected):
    assert classify(code, text) is expected


def test_read_sta_counts_increments_and_cutbacks(tmp_path):
    sta = tmp_path / "job.sta"
    sta.write_text(
        "SUMMARY OF JOB INFORMATION\n"
        "  STEP      INC     ATT  ITRS     TOT TIME     STEP TIME      INC TIME\n"
        "     1          1     1     4  0.200000E+00  0.200000E+00  0.200000E+00\n"
        "     1          2     1U    6  0.400000E+00  0.400000E+00  0.200000E+00\n"
        "     1          2     2    15  0.300000E+00  0.300000E+00  0.100000E+00\n"
    )
    assert read_sta(sta) == (2, 1)


def test_scratch_dir_is_removed_unless_kept(tmp_path, monkeypatch):
    monkeypatch.setenv("FARM_SCRATCH_DIR", str(tmp_path))
    with scratch_dir() as a:
        (a / "x").write_text("1")
    with scratch_dir(keep=True) as b:
        pass
    assert not a.exists() and b.exists() and b.parent == tmp_path


# ---------------------------------------------------------------- scratch of dead processes
# A SIGKILLed worker never reaches scratch_dir's clean-up: its folders carry the owner's host
# and pid, and the next process to make a scratch folder removes those whose owner is gone.

def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def _fake_scratch(base: Path, pid: int, *, host: str | None = None, age: float = 3600,
                  keep: bool = False, name: str | None = None) -> Path:
    path = base / (name or f"ccx-{host or scratch_host()}-{pid}-iterative-abcd1234")
    path.mkdir()
    (path / "job.frd").write_text("results")
    if keep:
        (path / KEEP_MARKER).touch()
    old = time.time() - age
    os.utime(path, (old, old))
    return path


def test_scratch_dir_names_carry_host_and_pid(tmp_path, monkeypatch):
    monkeypatch.setenv("FARM_SCRATCH_DIR", str(tmp_path))
    with scratch_dir(prefix="iterative-") as a, scratch_dir() as b:
        assert a.name.startswith(f"ccx-{scratch_host()}-{os.getpid()}-iterative-")
        assert b.name.startswith(f"ccx-{scratch_host()}-{os.getpid()}-")
        assert "-" not in scratch_host()  # the name stays parseable


def test_kept_scratch_is_marked(tmp_path, monkeypatch):
    monkeypatch.setenv("FARM_SCRATCH_DIR", str(tmp_path))
    with scratch_dir(keep=True) as kept:
        pass
    assert (kept / KEEP_MARKER).exists()


def test_stale_scratch_of_dead_processes_is_removed(tmp_path):
    dead = _dead_pid()
    stale = _fake_scratch(tmp_path, dead)
    kept = _fake_scratch(tmp_path, dead, keep=True, name=f"ccx-{scratch_host()}-{dead}-kept")
    young = _fake_scratch(tmp_path, dead, age=0, name=f"ccx-{scratch_host()}-{dead}-young")
    other_host = _fake_scratch(tmp_path, dead, host="elsewhere")
    unrelated = _fake_scratch(tmp_path, dead, name="ccx-abcd1234")  # no owner in the name
    assert clean_stale_scratch(tmp_path) == [stale]
    assert not stale.exists()
    assert all(p.exists() for p in (kept, young, other_host, unrelated))


def test_scratch_of_a_live_owner_stays(tmp_path):
    owner = subprocess.Popen(["sleep", "30"])
    try:
        time.sleep(0.1)
        live = _fake_scratch(tmp_path, owner.pid, age=0)
        dead = _fake_scratch(tmp_path, _dead_pid(), age=0)
        assert clean_stale_scratch(tmp_path, min_age=0) == [dead]
        assert live.exists()
    finally:
        owner.kill()
        owner.wait()


def test_scratch_older_than_its_pid_owner_is_stale(tmp_path):
    # the pid was reused: the process holding it now started after the folder was last written
    started = psutil.Process().create_time()
    reused = _fake_scratch(tmp_path, os.getpid(), age=time.time() - started + 3600)
    assert clean_stale_scratch(tmp_path) == [reused]


def test_first_scratch_dir_of_a_process_cleans_up(tmp_path, monkeypatch):
    monkeypatch.setenv("FARM_SCRATCH_DIR", str(tmp_path))
    monkeypatch.setattr("farm.ccx.runner._cleaned", set())
    stale = _fake_scratch(tmp_path, _dead_pid())
    with scratch_dir():
        assert not stale.exists()
    dead = _dead_pid()
    later = _fake_scratch(tmp_path, dead, name=f"ccx-{scratch_host()}-{dead}-later")
    with scratch_dir():  # once per process and base: a scan is not repeated on every solve
        assert later.exists()
