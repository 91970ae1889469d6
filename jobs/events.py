"""What the farm tells the Dask scheduler while it runs, for its dashboard page (issue 48).

Three event topics on the scheduler (Dask's own event log: ``Worker.log_event``,
``Client.log_event``, read back with ``Scheduler.get_events``):

- :data:`PROGRESS`: a running task's ccx, read from the solver's ``.sta`` file
  (:mod:`farm.ccx.progress`): ``{"key", "worker", "fraction", "step", "steps",
  "increments", "cutbacks"}``, at most one per :data:`EVERY_SECONDS` per task unless the
  fraction moved by :data:`EVERY_FRACTION` (the scheduler keeps the last 1000 events of a
  topic);
- :data:`FINISHED`: a task's solve that ended, ``{"key", "worker", "status": "done" |
  "failed", "reason", "ccx_seconds"}`` (a failure's reason is the recorded one: failures
  are data);
- :data:`STUDIES`: a client's study in flight, ``{"client", "study", "kind", "state",
  "ended"}`` with the counts its progress display shows.

Everything here is best effort: outside a Dask worker or client it does nothing, and a
failure to send never stops a solve. :mod:`jobs.dashboard` draws the page from them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Iterator
from typing import Any

from farm.ccx.progress import SolverProgress, reporting

PROGRESS, FINISHED, STUDIES = "farm-progress", "farm-finished", "farm-studies"
EVERY_SECONDS = 1.0
EVERY_FRACTION = 0.05


def _worker_and_key() -> tuple[Any, str] | None:
    try:
        from distributed import get_worker
        from distributed.worker import thread_state

        return get_worker(), str(thread_state.key)
    except (ImportError, ValueError, AttributeError):
        return None


def _send(sender: Any, topic: str, msg: dict) -> None:
    with contextlib.suppress(Exception):  # a page must never stop a solve or a study
        sender.log_event(topic, msg)


@contextlib.contextmanager
def publishing() -> Iterator[None]:
    """Inside a Dask task: send the progress of every ccx run of the block (the
    :data:`PROGRESS` topic). Elsewhere: nothing."""
    here = _worker_and_key()
    if here is None:
        yield
        return
    worker, key = here
    last = [-EVERY_SECONDS, -1.0]

    def report(p: SolverProgress) -> None:
        now = time.monotonic()
        if (now - last[0] < EVERY_SECONDS and p.fraction - last[1] < EVERY_FRACTION
                and p.fraction < 1.0):
            return
        last[:] = [now, p.fraction]
        _send(worker, PROGRESS, {"key": key, "worker": worker.address,
                                 **dataclasses.asdict(p)})

    with reporting(report):
        yield


def finished(status: str, seconds: float, reason: str = "") -> None:
    """Inside a Dask task: say its solve ended (:data:`FINISHED`)."""
    here = _worker_and_key()
    if here is not None:
        worker, key = here
        _send(worker, FINISHED, {"key": key, "worker": worker.address, "status": status,
                                 "reason": reason[:500], "ccx_seconds": round(seconds, 3)})


class StudyEvents:
    """A client's study on the scheduler's :data:`STUDIES` topic: one event when it
    starts, then at most one per ``every`` seconds while its state changes, one at the
    end."""

    def __init__(self, client: Any, study: str, kind: str, every: float = 2.0) -> None:
        self.client, self.study, self.kind, self.every = client, study, kind, every
        self.last: float = -every
        self.sent: dict[str, float] | None = None

    def update(self, state: Any, *, ended: bool = False) -> None:
        try:
            counts = _counts(state)
        except Exception:  # a page must never stop a study
            return
        now = time.monotonic()
        if not ended and (counts == self.sent or now - self.last < self.every):
            return
        self.last, self.sent = now, counts
        _send(self.client, STUDIES, {"client": str(getattr(self.client, "id", "")),
                                     "study": self.study, "kind": self.kind,
                                     "state": counts, "ended": ended})


def _counts(state: Any) -> dict[str, float]:
    """The numbers of a progress state (a dataclass of counts), for the page: its own
    fields only, read as they are (``dataclasses.asdict`` deep-copies, and a state may
    hold locks: a calibration's did)."""
    if not dataclasses.is_dataclass(state) or isinstance(state, type):
        return {}
    values = {f.name: getattr(state, f.name, None) for f in dataclasses.fields(state)}
    return {k: v for k, v in values.items()
            if isinstance(v, int | float) and not isinstance(v, bool)}


class CcxFeed:
    """The client's view of its running solves: the latest :data:`PROGRESS` event of each
    task, until its :data:`FINISHED` one (``Client.subscribe_topic``; filled on the
    client's event loop). :meth:`summary` is what progress lines append."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.running: dict[str, float] = {}
        for topic, handler in ((PROGRESS, self._progress), (FINISHED, self._finished)):
            with contextlib.suppress(Exception):
                client.subscribe_topic(topic, handler)

    def _progress(self, event: Any) -> None:
        msg = event[1] if isinstance(event, tuple | list) and len(event) == 2 else event
        if isinstance(msg, dict) and "key" in msg:
            self.running[str(msg["key"])] = float(msg.get("fraction") or 0.0)

    def _finished(self, event: Any) -> None:
        msg = event[1] if isinstance(event, tuple | list) and len(event) == 2 else event
        if isinstance(msg, dict):
            self.running.pop(str(msg.get("key")), None)

    def summary(self) -> str:
        """``'ccx 43 %, 12 %'`` for the solves running now, '' for none."""
        shares = sorted(self.running.values(), reverse=True)
        return "ccx " + ", ".join(f"{100 * f:.0f} %" for f in shares[:8]) if shares else ""

    def close(self) -> None:
        for topic in (PROGRESS, FINISHED):
            with contextlib.suppress(Exception):
                self.client.unsubscribe_topic(topic)
