"""Counts in messages agree with their nouns (issue 25: "1 ccx runs", "1 workers")."""

from __future__ import annotations

import io
import types

import pytest

from jobs.sweep import SweepReport
from jobs.wording import plural
from tyre_farm_cli.progress import LogLines
from tyre_farm_cli.sweep import SweepLines


@pytest.mark.parametrize(("count", "noun", "many", "text"), [
    (0, "worker", None, "0 workers"), (1, "worker", None, "1 worker"),
    (2, "ccx run", None, "2 ccx runs"), (1, "ccx run", None, "1 ccx run"),
    (1, "analysis", "analyses", "1 analysis"), (3, "analysis", "analyses", "3 analyses"),
])
def test_plural(count, noun, many, text):
    assert plural(count, noun, many) == text


def _report(total: int, runs: int) -> SweepReport:
    study = types.SimpleNamespace(name="s", location="s.zarr", models=None, group_name="g")
    return SweepReport(study, total, ccx_runs=runs)  # type: ignore[arg-type]


def test_a_sweep_summary_of_one():
    text = _report(1, 1).summary()
    assert text.startswith("1 experiment (") and "1 ccx run," in text
    assert "runs" not in text and "experiments" not in text
    assert "2 experiments" in _report(2, 2).summary() and "2 ccx runs" in _report(2, 2).summary()


def test_a_sweep_of_one_worker_says_worker():
    stream = io.StringIO()
    lines = SweepLines("s", LogLines(stream))
    session = types.SimpleNamespace(dashboard="http://x", workers=1)
    lines.started(session, types.SimpleNamespace(total=1, skipped=0))
    text = stream.getvalue()
    assert "1 worker," in text and "1 experiment (" in text
    assert "workers" not in text and "experiments" not in text
