"""The farm's page on the Dask dashboard (issue 48): ``/farm`` and ``/farm.json``.

Registered the ecosystem's way, as routes of the scheduler's HTTP server: every
scheduler the farm starts (embedded, SLURM) lists this module in
``distributed.scheduler.http.routes`` (:data:`jobs.cluster.SCHEDULER_CONFIG`); a
scheduler started by hand gets it with ``dask scheduler --preload jobs.dashboard``
(:func:`dask_setup`) or that config key. It reads only what the scheduler holds: its
tasks, and the farm's events (:mod:`jobs.events`) - studies in flight with their counts,
each running task's load case (its key names it: ``path-200kPa-10to40mm-<hash>``) and
how far its ccx has got, failures with their reasons, ccx seconds per case.
"""

from __future__ import annotations

import html
import time
from collections import Counter
from typing import Any

from distributed.http.utils import RequestHandler

from jobs.events import FINISHED, PROGRESS, STUDIES

RECENT = 20  # finished solves shown
REFRESH_SECONDS = 2


def _latest(events: Any, by: tuple[str, ...]) -> dict[tuple, tuple[float, dict]]:
    out: dict[tuple, tuple[float, dict]] = {}
    for stamp, msg in events:
        if isinstance(msg, dict):
            out[tuple(msg.get(k) for k in by)] = (stamp, msg)
    return out


def farm_state(scheduler: Any) -> dict[str, Any]:
    """What the page shows, from ``scheduler``'s tasks and the farm's events."""
    now = time.time()
    progress = _latest(scheduler.get_events(PROGRESS), ("key",))
    finished = list(scheduler.get_events(FINISHED))
    studies = _latest(scheduler.get_events(STUDIES), ("client", "study"))
    running = []
    for key, ts in scheduler.tasks.items():
        if ts.state != "processing":
            continue
        stamp, p = progress.get((str(key),), (None, {}))
        running.append({"key": str(key), "worker": getattr(ts.processing_on, "address", ""),
                        "fraction": p.get("fraction"), "step": p.get("step"),
                        "steps": p.get("steps"), "increments": p.get("increments"),
                        "cutbacks": p.get("cutbacks"),
                        "seen_s_ago": None if stamp is None else round(now - stamp, 1)})
    states = Counter(ts.state for ts in scheduler.tasks.values())
    failures = [m for _, m in finished if isinstance(m, dict) and m.get("status") == "failed"]
    return {
        "studies": [{**m, "seen_s_ago": round(now - t, 1)} for t, m in studies.values()
                    if not m.get("ended")],
        "tasks": dict(sorted(states.items())),
        "running": sorted(running, key=lambda r: r["key"]),
        "failures": failures[-RECENT:],
        "recent": [m for _, m in finished if isinstance(m, dict)][-RECENT:],
    }


def _table(headers: list[str], rows: list[list[str]], empty: str) -> str:
    if not rows:
        return f"<p class='empty'>{html.escape(empty)}</p>"
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _e(value: Any) -> str:
    return "" if value is None else html.escape(str(value))


def _bar(fraction: float | None) -> str:
    if fraction is None:
        return "<span class='empty'>no ccx yet</span>"
    pct = 100 * float(fraction)
    return f"<progress max='100' value='{pct:.0f}'></progress> {pct:.0f} %"


def render(state: dict[str, Any]) -> str:
    """The page's HTML (refreshes itself every :data:`REFRESH_SECONDS`)."""
    studies = _table(["study", "kind", "counts"], [
        [_e(s["study"]), _e(s["kind"]),
         _e(", ".join(f"{k} {v:g}" for k, v in s.get("state", {}).items()))]
        for s in state["studies"]], "no study in flight")
    tasks = _table(["state", "tasks"], [[_e(k), _e(v)] for k, v in state["tasks"].items()],
                   "no tasks")
    running = _table(["load case (task key)", "worker", "ccx progress", "step",
                      "increments", "cutbacks"], [
        [_e(r["key"]), _e(r["worker"]), _bar(r["fraction"]),
         _e(f"{r['step']} of {r['steps']}" if r["step"] else ""), _e(r["increments"]),
         _e(r["cutbacks"])] for r in state["running"]], "nothing running")
    failures = _table(["load case (task key)", "reason", "ccx s"], [
        [_e(f["key"]), _e(f.get("reason")), _e(f.get("ccx_seconds"))]
        for f in reversed(state["failures"])], "no failure")
    recent = _table(["load case (task key)", "status", "ccx s", "worker"], [
        [_e(f["key"]), _e(f.get("status")), _e(f.get("ccx_seconds")), _e(f.get("worker"))]
        for f in reversed(state["recent"])], "no solve finished yet")
    return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>tyre-farm</title>
<meta http-equiv="refresh" content="{REFRESH_SECONDS}">
<style>body{{font-family:sans-serif;margin:1.5em;color:#222}}
table{{border-collapse:collapse;margin-bottom:1em}}td,th{{border:1px solid #ccc;
padding:.25em .6em;text-align:left;font-size:90%}}th{{background:#eef}}
.empty{{color:#888}}progress{{width:10em}}</style></head>
<body><h1>tyre-farm</h1>
<p>Studies, load cases and ccx progress on this scheduler (<a href="status">Dask's
status page</a>, <a href="farm.json">JSON</a>).</p>
<h2>Studies in flight</h2>{studies}
<h2>Tasks by state</h2>{tasks}
<h2>Running</h2>{running}
<h2>Failures</h2>{failures}
<h2>Recent solves</h2>{recent}
</body></html>"""


class FarmPage(RequestHandler):
    """``/farm``: the page."""

    def get(self) -> None:
        self.set_header("Content-Type", "text/html; charset=utf-8")
        self.write(render(farm_state(self.server)))


class FarmJSON(RequestHandler):
    """``/farm.json``: what the page shows, as JSON."""

    def get(self) -> None:
        self.write(farm_state(self.server))


#: read by distributed when this module is in ``distributed.scheduler.http.routes``
routes: list[tuple] = [(r"farm", FarmPage, {}), (r"farm.json", FarmJSON, {})]


def dask_setup(scheduler: Any) -> None:
    """``dask scheduler --preload jobs.dashboard``: add the routes to its HTTP server
    (served at the root: a scheduler with ``--dashboard-prefix`` gets them there by the
    config key instead)."""
    from distributed.http.utils import get_handlers

    app = getattr(scheduler, "http_application", None)
    if app is not None:  # listed in the routes config as well: tornado serves the first
        app.add_handlers(r".*", get_handlers(scheduler, [__name__]))
