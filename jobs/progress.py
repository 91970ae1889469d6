"""What a run tells its front end: the cluster it got (:class:`Session`), the summary
every report shares (:class:`RunReport`) and the callbacks of a progress display
(:class:`Progress`).

Apart from :mod:`jobs.driver`, which fills them in, so that a front end (the CLI, at
start-up) names these types without importing dask.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Session:
    """The cluster a run has: client, the workers' solver version, dashboard, workers."""

    client: Any
    solver: str
    dashboard: str
    workers: int
    feed: Any = None  # a jobs.events.CcxFeed: the running solves' ccx progress

    def ccx(self) -> str:
        """What the running solves' ccx has done (``'ccx 43 %, 12 %'``), or ''."""
        return self.feed.summary() if self.feed is not None else ""

    @property
    def where(self) -> str:
        """``dashboard: URL   farm page: URL`` (the farm's page, :mod:`jobs.dashboard`,
        sits beside Dask's status page on every scheduler the farm starts)."""
        if not self.dashboard.endswith("/status"):
            return f"dashboard: {self.dashboard}"
        return (f"dashboard: {self.dashboard}   farm page: "
                f"{self.dashboard.removesuffix('status')}farm")


def ccx_of(session: Any) -> str:
    """:meth:`Session.ccx` of a session, '' for any other object a display is handed
    (scripts and tests pass their own)."""
    ccx = getattr(session, "ccx", None)
    return ccx() if callable(ccx) else ""


@dataclass(kw_only=True)
class RunReport:
    """What every run reports beside its own results (filled in by :func:`jobs.driver.drive`)."""

    dashboard: str = ""
    workers: int = 0
    solver: str = ""
    wall_seconds: float = 0.0

    @property
    def ok(self) -> bool:  # pragma: no cover - every report says what success is
        raise NotImplementedError


class Progress:
    """Callbacks a front end implements to follow a run (all optional).

    ``state`` is the strategy's live view (:meth:`jobs.driver.Strategy.state`).
    """

    def started(self, session: Session, state: Any) -> None: ...
    def advanced(self, state: Any) -> None: ...
    def finished(self, report: RunReport) -> None: ...
