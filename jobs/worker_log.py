"""The embedded cluster's worker log: a file, not the user's terminal.

A task that fails in a worker is reported by the client as one line (the CLI's error
boundary). Its worker also logs it, ``distributed.worker - ERROR - Compute Failed`` with
the task's traceback, on the terminal: a full disk mid-sweep printed 82 lines, ten
worker tracebacks, before the one line (issue 50). The embedded cluster therefore keeps
its workers' stream output at CRITICAL (``silence_logs``), and :class:`WorkerLog`, a
worker plugin, writes what they log at WARNING and above to a file instead. The file is
made at its first record only; when a run fails, the error names it
(:func:`name_the_log`), so the tracebacks are one look away, not in the way.
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path
from typing import Any

from distributed import WorkerPlugin

LEVEL = logging.WARNING
LOGGER = "distributed"  # the worker's, its tasks' and its nanny's records


def log_path() -> Path:
    """A new worker-log file name under the farm's cache folder (``logs/``)."""
    from farm.mesh.cache import cache_dir

    stamp = time.strftime("%Y%m%dT%H%M%S")
    return cache_dir() / "logs" / f"workers-{stamp}-{os.getpid()}.log"


class _QuietFileHandler(logging.FileHandler):
    """A file handler that never prints: the disk it writes to may be the full one."""

    def handleError(self, record: logging.LogRecord) -> None:
        return


class WorkerLog(WorkerPlugin):
    """Each worker appends its :data:`LEVEL` and higher records to ``path``."""

    name = "farm-worker-log"

    def __init__(self, path: str | Path) -> None:
        self.path = str(path)
        self._handler: logging.Handler | None = None

    def setup(self, worker: Any) -> None:
        try:
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        except OSError:
            return  # no log then; the error line still says what failed
        handler = _QuietFileHandler(self.path, delay=True)  # no file until a record
        handler.setLevel(LEVEL)
        handler.setFormatter(logging.Formatter(
            f"%(asctime)s {worker.address} %(name)s %(levelname)s %(message)s"))
        logging.getLogger(LOGGER).addHandler(handler)
        self._handler = handler

    def teardown(self, worker: Any) -> None:
        if self._handler is not None:
            logging.getLogger(LOGGER).removeHandler(self._handler)
            self._handler.close()
            self._handler = None


def name_the_log(error: BaseException, path: Path) -> None:
    """Add ``worker log: PATH`` to ``error``'s notes when the workers logged anything."""
    try:
        written = path.stat().st_size > 0
    except OSError:
        written = False
    if written:
        error.add_note(f"worker log: {path}")
