"""README is the front door (issue 48): short, every link alive, the user guide mapped,
and its quick start runs as written (end-to-end set: real ccx, a real Dask cluster)."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_LINES = 250  # issue 48: "at most about 250 lines"


def _text() -> str:
    return README.read_text(encoding="utf-8")


def _section(title: str) -> str:
    """The body of README's ``## title`` section."""
    m = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", _text(), re.M | re.S)
    assert m, f"README has no section {title!r}"
    return m.group(1)


def _blocks(text: str, language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", text, re.M | re.S)


def test_readme_stays_a_front_door():
    assert len(_text().splitlines()) <= MAX_LINES


def test_every_relative_link_of_readme_resolves():
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", _text())
    local = [x for x in links if "://" not in x]
    assert local, "README links to nothing"
    missing = [x for x in local if not (ROOT / x).exists()]
    assert not missing, missing


def test_readme_maps_every_page_of_the_guide_and_the_reference():
    text = _text()
    pages = sorted((ROOT / "docs").glob("*.md")) + sorted((ROOT / "docs/guide").glob("*.md"))
    unlinked = [str(p.relative_to(ROOT)) for p in pages
                if f"]({p.relative_to(ROOT)})" not in text]
    assert not unlinked, f"README's documentation map misses {unlinked}"


def test_every_link_of_the_guide_resolves():
    broken = []
    for page in sorted((ROOT / "docs/guide").glob("*.md")):
        for link in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text(encoding="utf-8")):
            if "://" not in link and not (page.parent / link).exists():
                broken.append(f"{page.name}: {link}")
    assert not broken, broken


def test_the_quick_start_has_its_commands_and_a_python_snippet():
    quick = _section("Quick start: ten minutes")
    (shell,) = _blocks(quick, "bash")
    commands = [c for c in shell.splitlines() if c.strip() and not c.startswith("#")]
    verbs = {c.split()[1] for c in commands if c.startswith("farm ")}
    assert {"run", "sweep", "fit", "measure", "predict"} <= verbs
    (snippet,) = _blocks(quick, "python")
    compile(snippet, "README quick start", "exec")


@pytest.mark.ccx
@pytest.mark.e2e
def test_the_quick_start_runs_as_written(tmp_path):
    """Every line of the quick start, in a fresh folder holding a copy of examples/:
    each command must exit 0, the prediction must print forces, the snippet must run."""
    quick = _section("Quick start: ten minutes")
    (shell,) = _blocks(quick, "bash")
    (snippet,) = _blocks(quick, "python")
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    venv = Path(sys.executable).parent
    env = {**os.environ, "PATH": f"{venv}{os.pathsep}{os.environ['PATH']}",
           "PYTHONPATH": str(ROOT)}
    (tmp_path / ".venv").symlink_to(venv.parent)  # `source .venv/bin/activate` as written
    script = "set -euo pipefail\n" + shell
    done = subprocess.run(["bash", "-c", script], cwd=tmp_path, env=env, text=True,
                          capture_output=True, timeout=1200)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Fz" in done.stdout and "Fz_lower" in done.stdout, done.stdout[-2000:]
    ran = subprocess.run([sys.executable, "-c", snippet], cwd=tmp_path, env=env, text=True,
                         capture_output=True, timeout=300)
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert "experiment" in ran.stdout
