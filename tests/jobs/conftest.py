"""Fixtures of the job-layer tests: small studies and a ccx that counts its runs."""

from __future__ import annotations

import os
import stat
import textwrap
import uuid
from pathlib import Path

import pytest

QUICK_MODEL = """
[model]
kind = "reduced"
road = "contact"
[model.mesh]
tread = 4
sidewall = 2
bead = 1
circumferential = 8
"""


def study_text(store: Path, deflections: str = "{ start = 5, stop = 30, step = 5 }",
               solver: str = "max_path_length = 1", group: str | None = None) -> str:
    head = f'[study]\nname = "test"\nstore = "{store}"\n'
    if group:
        head += f'group = "{group}"\n'
    return head + QUICK_MODEL + f"\n[loads]\ndeflection_mm = {deflections}\n\n[solver]\n{solver}\n"


@pytest.fixture
def write_study(tmp_path):
    def write(name="study.toml", **kwargs) -> Path:
        path = tmp_path / name
        path.write_text(study_text(tmp_path / "store.zarr", **kwargs))
        return path

    return write


@pytest.fixture
def counting_ccx(tmp_path, monkeypatch, ccx):
    """Point FARM_CCX at a wrapper that logs every solve (not `ccx -v`); returns the log."""
    log = tmp_path / "ccx-runs.log"
    wrapper = tmp_path / "ccx-counting"
    wrapper.write_text(textwrap.dedent(f"""\
        #!/bin/sh
        [ "$1" = "-i" ] && echo "$$ $(pwd)" >> {log}
        exec {ccx} "$@"
        """))
    wrapper.chmod(wrapper.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("FARM_CCX", str(wrapper))
    log.touch()
    return log


def ccx_runs(log: Path) -> int:
    return len(log.read_text().splitlines()) if log.exists() else 0


# Every process this test session starts (workers, schedulers, ccx) inherits this mark,
# so that ccx_processes() sees this session's solvers only, not those of other jobs
# on a shared machine - even after a killed worker's ccx was re-parented to init.
# setdefault: this file may be imported twice (by pytest, and as `conftest` by a test
# module), and both copies must agree on the mark.
SESSION_MARK = ("FARM_TEST_SESSION",
                os.environ.setdefault("FARM_TEST_SESSION", uuid.uuid4().hex))


def ccx_processes(mark: tuple[str, str] = SESSION_MARK) -> list:
    """Live ccx processes started by this test session (psutil), or by the processes
    whose environment holds ``mark`` (one client of a test)."""
    import psutil

    found = []
    for p in psutil.process_iter(["name", "status"]):
        try:
            if (p.info["name"] == "ccx" and p.info["status"] != psutil.STATUS_ZOMBIE
                    and p.environ().get(mark[0]) == mark[1]):
                found.append(p)
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
    return found

