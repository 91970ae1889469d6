"""A study's provenance (analysis.render.provenance): the commit read from a checkout's
.git files in each form git leaves them, and the rows written beside a study's results."""

from __future__ import annotations

import shutil
import subprocess

import pandas as pd
import pytest

from analysis.render.provenance import Run, code_changes, code_commit, record

SHA = "0123456789abcdef0123456789abcdef01234567"


def _git(root, head: str, *, loose: str | None = None, packed: str | None = None):
    git = root / ".git"
    (git / "refs" / "heads").mkdir(parents=True)
    (git / "HEAD").write_text(head + "\n")
    if loose is not None:
        (git / "refs" / "heads" / "main").write_text(loose + "\n")
    if packed is not None:
        (git / "packed-refs").write_text(f"# pack-refs with: peeled\n{packed} "
                                         "refs/heads/main\n")
    return root


@pytest.mark.parametrize(("layout", "expected"), [
    (dict(head="ref: refs/heads/main", loose=SHA), SHA),
    (dict(head="ref: refs/heads/main", packed=SHA), SHA),
    (dict(head=SHA), SHA),  # detached
    (dict(head="ref: refs/heads/main"), "unknown (refs/heads/main has no commit yet)"),
])
def test_the_commit_is_read_as_git_leaves_it(tmp_path, layout, expected):
    assert code_commit(_git(tmp_path, **layout)) == expected


def test_a_worktree_s_git_file_and_an_installed_copy(tmp_path):
    real = _git(tmp_path / "real", "ref: refs/heads/main", loose=SHA)
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / ".git").write_text(f"gitdir: {real / '.git'}\n")
    assert code_commit(tree) == SHA
    assert code_commit(tmp_path / "nowhere") == "unknown (not a git checkout)"


def test_a_run_is_recorded_beside_the_results_and_at_the_summary_s_end(tmp_path):
    run = Run("farm analyse pca s.zarr --out x", started=1_000_000_000.0, load=1.5)
    rows = dict(run.table(ended=1_000_000_090.0).itertuples(index=False))
    assert rows["command"] == "farm analyse pca s.zarr --out x"
    assert rows["started"] == "2001-09-09 01:46:40 UTC" and rows["wall seconds"] == "90"
    assert rows["load average (1 min) at start / end"].startswith("1.50 / ")
    assert record(run, tmp_path) == [tmp_path / "provenance.csv"]  # no summary: csv only
    (tmp_path / "summary.md").write_text("# A study\n\nfindings\n")
    assert record(run, tmp_path) == [tmp_path / "provenance.csv", tmp_path / "summary.md"]
    text = (tmp_path / "summary.md").read_text()
    assert text.startswith("# A study\n\nfindings\n") and "\n## Provenance\n" in text
    assert "- command: `farm analyse pca s.zarr --out x`" in text
    frame = pd.read_csv(tmp_path / "provenance.csv")
    assert list(frame["item"])[:2] == ["command", "commit"]


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_the_code_s_uncommitted_changes_are_named_and_a_store_s_are_not(tmp_path):
    (tmp_path / "plain").mkdir()
    assert code_changes(tmp_path / "plain") == "unknown (not a git checkout)"
    tmp_path = tmp_path / "repo"

    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), "-c", "user.name=t", "-c",
                        "user.email=t@t", *args], check=True, capture_output=True)

    for path in ("farm/a.py", "jobs/b.py", "results/s.zarr/zarr.json", "docs/x.md"):
        (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / path).write_text("1\n")
    git("init", "-q")
    git("add", ".")
    git("commit", "-q", "-m", "first")
    assert code_changes(tmp_path) == "none"
    for path in ("results/s.zarr/zarr.json", "docs/x.md"):  # a store and a page: not code
        (tmp_path / path).write_text("2\n")
    assert code_changes(tmp_path) == "none"
    (tmp_path / "farm/a.py").write_text("2\n")  # changed
    (tmp_path / "analysis").mkdir()
    (tmp_path / "analysis/new.py").write_text("1\n")  # not added yet
    assert code_changes(tmp_path) == "2 files: analysis/new.py, farm/a.py"
