"""The farm's events and its dashboard page, without a cluster (issue 48); the page on a
real scheduler in a real browser is tests/jobs/test_jobs_dashboard_page.py (e2e)."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import pytest

import jobs.events as events
from farm.ccx.progress import SolverProgress
from farm.specs import RoadMotion
from jobs.dashboard import farm_state, render
from jobs.identity import load_label, path_key
from jobs.progress import Session


class Recorder:
    def __init__(self):
        self.sent: list[tuple[str, dict]] = []
        self.address, self.id = "tcp://w", "client-1"

    def log_event(self, topic, msg):
        self.sent.append((topic, msg))


def test_outside_a_dask_task_nothing_is_published():
    with events.publishing():
        pass
    events.finished("done", 1.0)  # no worker: no error, nothing to send to


def test_progress_is_rate_limited_but_the_end_always_goes(monkeypatch):
    worker, now = Recorder(), [0.0]
    monkeypatch.setattr(events, "_worker_and_key", lambda: (worker, "path-200kPa-10mm-ab"))
    monkeypatch.setattr(events.time, "monotonic", lambda: now[0])
    from farm.ccx.progress import current_reporter

    with events.publishing():
        report = current_reporter()
        assert report is not None
        for t, f in [(0.0, 0.10), (0.2, 0.12), (0.4, 0.20), (1.5, 0.21), (1.6, 1.0)]:
            now[0] = t
            report(SolverProgress(f, 1, 1, 3, 0))
    assert current_reporter() is None
    sent = [m["fraction"] for topic, m in worker.sent if topic == events.PROGRESS]
    assert sent == [0.10, 0.20, 0.21, 1.0]  # 0.12: too soon and too close
    assert worker.sent[0][1]["key"] == "path-200kPa-10mm-ab"


def test_a_study_is_announced_on_change_and_at_its_end(monkeypatch):
    @dataclass
    class State:
        total: int = 4
        done: int = 0
        note: str = "not a count"
        flags: list = field(default_factory=list)

    client, now = Recorder(), [0.0]
    monkeypatch.setattr(events.time, "monotonic", lambda: now[0])
    page = events.StudyEvents(client, "s", "sweep", every=2.0)
    page.update(State())
    page.update(State())  # unchanged
    now[0] = 1.0
    page.update(State(done=1))  # changed, but too soon
    now[0] = 3.0
    page.update(State(done=2))
    page.update(State(done=2), ended=True)
    states = [(m["state"]["done"], m["ended"]) for _, m in client.sent]
    # a state holding what cannot be copied (a calibration's holds a lock) is no crash
    import threading

    @dataclass
    class Locked:
        sets: int = 3
        lock: object = field(default_factory=threading.Lock)

    page.update(Locked(), ended=True)
    assert client.sent[-1][1]["state"] == {"sets": 3}
    assert states == [(0, False), (2, False), (2, True)]
    assert set(client.sent[0][1]["state"]) == {"total", "done"}


def _scheduler(events_by_topic, tasks):
    return SimpleNamespace(get_events=lambda topic: events_by_topic.get(topic, ()),
                           tasks=tasks)


def test_the_page_joins_tasks_with_their_progress_failures_and_studies():
    key = path_key(["e1"], load_label(0.2, [10, 20]))
    other = path_key(["e2"], load_label(0.08, [25], RoadMotion(friction=0.6)), "slide")
    tasks = {key: SimpleNamespace(state="processing",
                                  processing_on=SimpleNamespace(address="tcp://w1")),
             other: SimpleNamespace(state="processing", processing_on=None),
             "x": SimpleNamespace(state="waiting", processing_on=None)}
    ev = {events.PROGRESS: [(1.0, {"key": key, "fraction": 0.2, "step": 1, "steps": 1,
                                   "increments": 2, "cutbacks": 0}),
                            (2.0, {"key": key, "fraction": 0.5, "step": 1, "steps": 1,
                                   "increments": 5, "cutbacks": 1})],
          events.FINISHED: [(3.0, {"key": "path-a", "status": "failed",
                                   "reason": "increment_below_minimum <&>", "ccx_seconds": 4}),
                            (4.0, {"key": "path-b", "status": "done", "ccx_seconds": 9})],
          events.STUDIES: [(1.0, {"client": "c", "study": "s1", "kind": "sweep",
                                  "state": {"total": 3}, "ended": False}),
                           (1.0, {"client": "c", "study": "s2", "kind": "sweep",
                                  "state": {}, "ended": False}),
                           (2.0, {"client": "c", "study": "s2", "kind": "sweep",
                                  "state": {}, "ended": True})]}
    state = farm_state(_scheduler(ev, tasks))
    assert [s["study"] for s in state["studies"]] == ["s1"]  # s2 ended
    assert state["tasks"] == {"processing": 2, "waiting": 1}
    by_key = {r["key"]: r for r in state["running"]}
    assert by_key[key]["fraction"] == 0.5 and by_key[key]["worker"] == "tcp://w1"
    assert by_key[other]["fraction"] is None
    assert [f["key"] for f in state["failures"]] == ["path-a"]
    page = render(state)
    assert "200kPa-10to20mm" in page and "80kPa-25mm-mu0.6" in page
    assert "increment_below_minimum &lt;&amp;&gt;" in page  # escaped
    assert "<progress max='100' value='50'>" in page and "no ccx yet" in page


def test_an_empty_scheduler_has_an_empty_page():
    page = render(farm_state(_scheduler({}, {})))
    for empty in ("no study in flight", "nothing running", "no failure",
                  "no solve finished yet"):
        assert empty in page


@pytest.mark.parametrize(("dashboard", "where"), [
    ("http://127.0.0.1:8787/status",
     "dashboard: http://127.0.0.1:8787/status   farm page: http://127.0.0.1:8787/farm"),
    ("(no dashboard)", "dashboard: (no dashboard)"),
])
def test_the_session_says_where_the_farm_page_is(dashboard, where):
    assert Session(None, "CalculiX 2.20", dashboard, 2).where == where


@pytest.mark.parametrize(("args", "label"), [
    ((0.2, [10, 20, 30]), "200kPa-10to30mm"),
    ((0.08, [25]), "80kPa-25mm"),
    ((0.2, [15], RoadMotion(friction=0.6, shift_y=-3, tilt=2)), "200kPa-15mm-mu0.6-sy-3-tilt2"),
])
def test_a_key_names_its_load_case(args, label):
    assert load_label(*args) == label
    key = path_key(["a", "b"], load_label(*args))
    assert key.startswith(f"path-{label}-") and len(key.rsplit("-", 1)[1]) == 24
    assert "/" not in key and " " not in key  # a claim is a file named by the key


def test_the_clients_feed_keeps_running_solves_until_they_finish():
    class Client:
        def __init__(self):
            self.handlers = {}

        def subscribe_topic(self, topic, handler):
            self.handlers[topic] = handler

        def unsubscribe_topic(self, topic):
            self.handlers.pop(topic)

    client = Client()
    feed = events.CcxFeed(client)
    assert feed.summary() == ""
    client.handlers[events.PROGRESS]((1.0, {"key": "a", "fraction": 0.12}))
    client.handlers[events.PROGRESS]((2.0, {"key": "b", "fraction": 0.43}))
    client.handlers[events.PROGRESS]((3.0, {"key": "a", "fraction": 0.5}))
    assert feed.summary() == "ccx 50 %, 43 %"
    client.handlers[events.FINISHED]((4.0, {"key": "a", "status": "done"}))
    assert feed.summary() == "ccx 43 %"
    assert Session(None, "", "", 1, feed).ccx() == "ccx 43 %"
    assert Session(None, "", "", 1).ccx() == ""
    feed.close()
    assert client.handlers == {}


def test_sweep_lines_say_how_far_ccx_has_got():
    import io

    from jobs.sweep import SweepState
    from tyre_farm_cli.progress import LogLines
    from tyre_farm_cli.sweep import SweepLines

    stream = io.StringIO()
    lines = SweepLines("s", LogLines(stream, every=0.0))
    session = SimpleNamespace(dashboard="d", workers=2, ccx=lambda: "ccx 43 %")
    lines.started(session, SweepState(4, 0, 0, 0, 0))
    lines.advanced(SweepState(4, 0, 1, 0, 1))
    assert stream.getvalue().splitlines()[-1].endswith("sweep s: 1/4 done, 0 failed; ccx 43 %")
