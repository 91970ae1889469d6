"""Where a study's figures come from: the command, the code's commit and the machine's load
(the house rule: a figure names the command, commit and machine load that produced it).

A :class:`Run` is taken when a study starts (``farm analyse``, tyre_farm_cli/analyse.py)
and written beside its results when it ends: ``provenance.csv`` and a "Provenance"
section at the end of ``summary.md``, so a table copied from a summary into the docs
(the answer's, docs/answer.md) carries its own origin.

The commit is read from the checkout's ``.git`` files (HEAD, its ref or ``packed-refs``),
without running git; an installed copy (no ``.git`` beside the packages) reports none.
A commit alone would hide a figure made by code that was not committed (issue 45's
benchmarks named "commit X plus the change in the working tree" by hand), so the code's
uncommitted changes are listed too (:func:`code_changes`: ``git status`` of the
packages, benchmarks and study files, not of stores or results kept in the checkout).
The load is the 1-minute load average
(``os.getloadavg``) at the start and at the end, beside the machine's core count: a
study timed on a busy machine says so.
"""

from __future__ import annotations

import os
import platform
import subprocess
import time
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[2]  # the checkout holding analysis/


def code_commit(root: Path = ROOT) -> str:
    """The commit checked out at ``root`` (40 hex digits), or why there is none."""
    git = root / ".git"
    if git.is_file():  # a worktree or submodule: "gitdir: <path>"
        text = git.read_text().strip()
        git = (root / text.removeprefix("gitdir:").strip()).resolve()
    head = git / "HEAD"
    if not head.is_file():
        return "unknown (not a git checkout)"
    ref = head.read_text().strip()
    if not ref.startswith("ref:"):
        return ref  # a detached HEAD holds the commit itself
    name = ref.removeprefix("ref:").strip()
    loose = git / name
    if loose.is_file():
        return loose.read_text().strip()
    packed = git / "packed-refs"
    for line in packed.read_text().splitlines() if packed.is_file() else []:
        sha, _, packed_name = line.partition(" ")
        if packed_name == name:
            return sha
    return f"unknown ({name} has no commit yet)"


#: What "the code" is: the packages, the benchmarks and the study files. A store kept
#: in the checkout (results/, docs/answer.md) changes as a sweep runs; it is not code.
CODE_PATHS = ("farm", "jobs", "analysis", "storage", "tyre_farm_cli", "benchmarks",
              "examples", "scripts", "pyproject.toml")


def code_changes(root: Path = ROOT, timeout: float = 10.0) -> str:
    """The code's files at ``root`` that differ from its commit (changed, added,
    untracked): ``"none"``, ``"3 files: farm/a.py, jobs/b.py, ..."``, or why unknown."""
    command = ["git", "-C", str(root), "status", "--porcelain=v1", "--untracked-files=all",
               "--", *CODE_PATHS]
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=timeout,
                              check=False)
    except (OSError, subprocess.TimeoutExpired) as e:  # no git, or a hung one
        return f"unknown (git status: {type(e).__name__})"
    if done.returncode != 0:
        return "unknown (not a git checkout)"
    paths = sorted({line[3:].split(" -> ")[-1] for line in done.stdout.splitlines() if line})
    if not paths:
        return "none"
    shown = ", ".join(paths[:5]) + (", ..." if len(paths) > 5 else "")
    return f"{len(paths)} file{'s' if len(paths) > 1 else ''}: {shown}"


def _load() -> float:
    try:
        return os.getloadavg()[0]
    except OSError:  # not every platform has one
        return float("nan")


@dataclass(frozen=True)
class Run:
    """One study's run: its command line, when it started and the load then."""

    command: str
    started: float = field(default_factory=time.time)
    load: float = field(default_factory=_load)

    def table(self, ended: float | None = None) -> pd.DataFrame:
        """(item, value) rows: command, commit, the code's uncommitted changes, start and
        end (UTC), wall seconds, machine, the 1-minute load average at the start and at
        the end."""
        ended = time.time() if ended is None else ended
        stamp = "%Y-%m-%d %H:%M:%S UTC"
        rows = [("command", self.command), ("commit", code_commit()),
                ("uncommitted changes to the code", code_changes()),
                ("started", time.strftime(stamp, time.gmtime(self.started))),
                ("ended", time.strftime(stamp, time.gmtime(ended))),
                ("wall seconds", f"{ended - self.started:.0f}"),
                ("machine", f"{platform.machine()}, {os.cpu_count()} cores"),
                ("load average (1 min) at start / end", f"{self.load:.2f} / {_load():.2f}")]
        return pd.DataFrame(rows, columns=["item", "value"])

    def rows(self) -> dict[str, str]:
        """:meth:`table` as a mapping, item to value (JSON, a model's manifest)."""
        return dict(self.table().itertuples(index=False))


def line(rows: dict[str, str]) -> str:
    """:meth:`Run.rows` as one line, for a command that prints its results."""
    return "provenance: " + "; ".join(f"{item} {value}" for item, value in rows.items())


def record(run: Run, out: Path) -> list[Path]:
    """Write ``out/provenance.csv`` and end ``out/summary.md`` (where the study wrote
    one) with the same rows; returns the files written or changed."""
    frame = run.table()
    path = out / "provenance.csv"
    frame.to_csv(path, index=False)
    summary = out / "summary.md"
    if not summary.is_file():
        return [path]
    lines = ["", "## Provenance", "", *(f"- {item}: `{value}`" for item, value in
                                        frame.itertuples(index=False)), ""]
    with summary.open("a") as f:
        f.write("\n".join(lines))
    return [path, summary]
