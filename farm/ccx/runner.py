"""The one place that runs ``ccx``.

Every solve goes through :func:`run_ccx`: a scratch directory per run, an argument list
(never a shell string), ``LC_ALL=C`` and an explicit thread count (a Dask nanny sets
``OMP_NUM_THREADS=1`` for its children), a timeout, and the whole process group killed on
timeout, cancellation or any exception. On Linux the solver also gets a parent-death
signal, so a ccx never outlives the worker process that started it (a SIGKILLed Dask
worker would otherwise leave an orphan solver running). The outcome is classified from
the exit code and the output (:mod:`farm.ccx.outcome`); failures raise
:class:`~farm.errors.SolverError` with the class, command, exit code and output tail.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import psutil

from farm.ccx.outcome import HINTS, Outcome, classify
from farm.ccx.progress import current_reporter, progress_of, step_periods
from farm.errors import CcxNotFoundError, SolverError

TAIL_LINES = 40
POLL_SECONDS = 0.1


@dataclass(frozen=True)
class CcxRun:
    """A finished ccx run and where its files are."""

    command: tuple[str, ...]
    workdir: Path
    jobname: str
    returncode: int | None
    seconds: float
    outcome: Outcome
    output_tail: str
    increments: int
    cutbacks: int
    progress: tuple[tuple[float, float], ...] = ()
    """(total time, seconds since start) at which each increment converged."""

    def seconds_to(self, total_time: float) -> float:
        """Seconds the solver took to reach ``total_time`` (the run's total if unknown)."""
        return seconds_to(self.progress, total_time, self.seconds)

    def file(self, suffix: str) -> Path:
        """Path of ``jobname.<suffix>`` (``frd``, ``dat``, ``sta``, ``inp``)."""
        return self.workdir / f"{self.jobname}.{suffix}"


def seconds_to(progress: Sequence[tuple[float, float]], total_time: float,
               otherwise: float) -> float:
    """Of a run's ``progress`` ((total time, seconds) an increment), the seconds at which
    it reached ``total_time``; ``otherwise`` where it never did."""
    for t, s in progress:
        if t >= total_time - 1e-9:
            return s
    return otherwise


def find_ccx() -> str:
    """Absolute path of the solver: ``$FARM_CCX`` if set, else ``ccx`` on ``PATH``."""
    name = os.environ.get("FARM_CCX", "ccx")
    exe = shutil.which(name)
    if exe is None:
        raise CcxNotFoundError(
            f"CalculiX solver {name!r} not found on PATH: install it with "
            "`sudo apt-get install calculix-ccx` (or run scripts/setup.sh), "
            "or point FARM_CCX at the executable"
        )
    return exe


@lru_cache(maxsize=4)
def ccx_version(exe: str | None = None) -> str:
    """Version string printed by ``ccx -v``, e.g. ``"2.20"`` (part of experiment ids)."""
    exe = exe or find_ccx()
    out = subprocess.run([exe, "-v"], capture_output=True, text=True, timeout=30,
                         env={**os.environ, "LC_ALL": "C"}).stdout
    for word in out.split():
        if word[:1].isdigit():
            return word
    return out.strip() or "unknown"


KEEP_MARKER = ".keep"
STALE_AFTER_SECONDS = 60.0
_OWNED = re.compile(r"^ccx-(?P<host>[^-/]+)-(?P<pid>\d+)-")
_cleaned: set[str] = set()  # scratch bases this process has swept for dead owners
_clean_lock = threading.Lock()


def scratch_host() -> str:
    """This machine's name as scratch folders carry it (``-`` would make names ambiguous)."""
    return socket.gethostname().replace("-", "_") or "localhost"


def _scratch_base() -> str | None:
    base = os.environ.get("FARM_SCRATCH_DIR")
    if base:
        Path(base).mkdir(parents=True, exist_ok=True)
    return base


@contextlib.contextmanager
def scratch_dir(keep: bool = False, prefix: str = "") -> Iterator[Path]:
    """A fresh directory under ``$FARM_SCRATCH_DIR`` (default: the system temp dir).

    Named ``ccx-<host>-<pid>-<prefix>XXXXXXXX`` after the process that owns it. Removed on
    exit unless ``keep`` (then marked with a ``.keep`` file and reported by its path). A
    SIGKILLed Dask worker never reaches that clean-up, so the first call of each process
    removes the folders of owners that are gone (:func:`clean_stale_scratch`).
    """
    base = _scratch_base()
    _clean_once(base)
    owner = f"ccx-{scratch_host()}-{os.getpid()}-"
    path = Path(tempfile.mkdtemp(prefix=owner + prefix, dir=base))
    if keep:  # marked at once: a kept folder stays even if its owner dies mid-run
        (path / KEEP_MARKER).touch()
    try:
        yield path
    finally:
        if not keep:
            shutil.rmtree(path, ignore_errors=True)


def _clean_once(base: str | None) -> None:
    key = str(Path(base or tempfile.gettempdir()).resolve())
    with _clean_lock:
        if key in _cleaned:
            return
        _cleaned.add(key)
    clean_stale_scratch(key)


def _owner_gone(pid: int, written: float) -> bool:
    """True unless ``pid`` runs a process that may have written at time ``written``."""
    try:
        started = psutil.Process(pid).create_time()
    except psutil.NoSuchProcess:
        return True
    except psutil.Error:  # another user's process, say: not ours to judge
        return False
    return started > written + 1.0  # the pid was reused by a younger process


def clean_stale_scratch(base: str | Path | None = None,
                        min_age: float = STALE_AFTER_SECONDS) -> list[Path]:
    """Remove the scratch folders on this host whose owning process is gone; return them.

    Only folders named by :func:`scratch_dir` for this host are considered; kept ones
    (``.keep``) and those written in the last ``min_age`` seconds are left alone. Other
    hosts sharing the base clean their own.
    """
    root = Path(base or tempfile.gettempdir())
    host, now = scratch_host(), time.time()
    removed: list[Path] = []
    try:
        entries = list(os.scandir(root))
    except OSError:
        return removed
    for entry in entries:
        match = _OWNED.match(entry.name)
        if match is None or match["host"] != host:
            continue
        try:
            if not entry.is_dir(follow_symlinks=False):
                continue
            written = entry.stat(follow_symlinks=False).st_mtime
        except OSError:
            continue
        path = Path(entry.path)
        if (now - written < min_age or (path / KEEP_MARKER).exists()
                or not _owner_gone(int(match["pid"]), written)):
            continue
        shutil.rmtree(path, ignore_errors=True)
        removed.append(path)
    return removed


def _die_with_parent() -> None:  # runs in the child between fork and exec
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG


def _solver_env(threads: int) -> dict[str, str]:
    env = dict(os.environ)
    n = str(threads)
    env.update(LC_ALL="C", OMP_NUM_THREADS=n, CCX_NPROC_EQUATION_SOLVER=n,
               CCX_NPROC_STIFFNESS=n, CCX_NPROC_RESULTS=n, NUMBER_OF_CPUS=n)
    return env


def _kill_group(proc: subprocess.Popen) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGKILL)
    with contextlib.suppress(Exception):
        proc.wait(timeout=10)


class _Progress:
    """Watches the ``.sta`` file: when (in seconds since start) each increment converged,
    and, inside :func:`farm.ccx.progress.reporting`, how far the run has got (the deck's
    step periods are parsed only then). One read of the file per change serves both."""

    def __init__(self, sta: Path, start: float, deck: str = "") -> None:
        self.sta, self.start, self.size = sta, start, 0
        self.marks: list[tuple[float, float]] = []
        self.reporter = current_reporter()
        self.periods = step_periods(deck) if self.reporter is not None else []

    def poll(self) -> None:
        try:
            size = self.sta.stat().st_size
        except OSError:
            return
        if size == self.size:
            return
        self.size = size
        now = time.perf_counter() - self.start
        rows = _sta_attempts(self.sta)
        seen = {t for t, _ in self.marks}
        for fields in _converged(rows):
            t = float(fields[4])
            if t not in seen:
                self.marks.append((t, now))
        if self.reporter is not None:
            with contextlib.suppress(Exception):  # a display must never stop a solve
                got = progress_of(rows, self.periods)
                if got is not None:
                    self.reporter(got)


def _wait(proc: subprocess.Popen, timeout: float, should_stop,
          progress: _Progress) -> Outcome | None:
    """Wait for the solver; return TIMEOUT/CANCELLED if it had to be killed."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            proc.wait(timeout=POLL_SECONDS)
            progress.poll()
            return None
        except subprocess.TimeoutExpired:
            progress.poll()
            if time.monotonic() > deadline:
                _kill_group(proc)
                return Outcome.TIMEOUT
            if should_stop is not None and should_stop():
                _kill_group(proc)
                return Outcome.CANCELLED


def _sta_attempts(path: Path) -> list[list[str]]:
    """Rows of every increment attempt in a ``.sta`` file, split into fields."""
    rows = []
    with contextlib.suppress(OSError):
        for line in path.read_text(errors="replace").splitlines():
            fields = line.split()
            if len(fields) >= 7 and fields[0].isdigit():
                rows.append(fields)
    return rows


def _converged(rows: list[list[str]]) -> list[list[str]]:
    """The converged increments among attempt rows (failed attempts end in 'U')."""
    return [f for f in rows if f[2].isdigit()]


def _sta_lines(path: Path) -> list[list[str]]:
    """Rows of converged increments in a ``.sta`` file."""
    return _converged(_sta_attempts(path))


def _sta_rows(path: Path) -> list[float]:
    """Total times of the converged increments in a ``.sta`` file."""
    return [float(f[4]) for f in _sta_lines(path)]


def read_sta(path: Path) -> tuple[int, int]:
    """(converged increments, cutbacks) from a ccx ``.sta`` file; (0, 0) if absent."""
    rows = _sta_lines(path)
    return len(rows), sum(int(f[2]) - 1 for f in rows)


def _tail(path: Path, lines: int = TAIL_LINES) -> str:
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return ""


def run_ccx(
    deck: str,
    workdir: Path,
    *,
    jobname: str = "job",
    threads: int = 1,
    timeout: float = 1800.0,
    should_stop: Callable[[], bool] | None = None,
    check: bool = True,
    inputs: Mapping[str, bytes] | None = None,
) -> CcxRun:
    """Write ``deck`` to ``workdir/jobname.inp``, run ccx on it and classify the outcome.

    Parameters
    ----------
    deck : str
        The input deck text.
    workdir : Path
        An existing, private directory (see :func:`scratch_dir`).
    threads : int
        Solver threads (all of ccx's thread variables are set to it).
    timeout : float
        Wall-clock limit in seconds; the process group is killed when it passes.
    should_stop : callable, optional
        Polled while the solver runs; returning True kills it (outcome ``cancelled``).
    check : bool
        Raise :class:`SolverError` unless the run converged.
    inputs : mapping of str to bytes, optional
        Further input files by suffix, written as ``workdir/jobname.<suffix>`` first
        (``{"rin": ...}``: the restart file a ``*RESTART, READ`` deck continues from).
    """
    exe = find_ccx()
    (workdir / f"{jobname}.inp").write_text(deck)
    for suffix, data in (inputs or {}).items():
        (workdir / f"{jobname}.{suffix}").write_bytes(data)
    command = (exe, "-i", jobname)
    log = workdir / f"{jobname}.log"
    start = time.perf_counter()
    progress = _Progress(workdir / f"{jobname}.sta", start, deck)
    proc, killed = _run(command, workdir, log, threads, timeout, should_stop, progress)
    seconds = time.perf_counter() - start
    tail = _tail(log)
    returncode = None if killed else proc.returncode
    outcome = killed or classify(returncode, log.read_text(errors="replace"))
    increments, cutbacks = read_sta(workdir / f"{jobname}.sta")
    run = CcxRun(command, workdir, jobname, returncode, seconds, outcome, tail,
                 increments, cutbacks, tuple(progress.marks))
    if check and outcome is not Outcome.CONVERGED:
        raise failure(run)
    return run


def _run(command: tuple[str, ...], workdir: Path, log: Path, threads: int, timeout: float,
         should_stop: Callable[[], bool] | None, progress: _Progress,
         ) -> tuple[subprocess.Popen, Outcome | None]:
    """Start ccx in a session of its own (its output into ``log``) and wait for it: the
    process and the outcome that killed it (None: it ended by itself). The whole group
    is killed on any exception (a KeyboardInterrupt, a cancelled task)."""
    with open(log, "wb") as out:
        proc = subprocess.Popen(
            command, cwd=workdir, stdout=out, stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL, env=_solver_env(threads),
            start_new_session=True, preexec_fn=_die_with_parent,
        )
        try:
            return proc, _wait(proc, timeout, should_stop, progress)
        except BaseException:
            _kill_group(proc)
            raise


def failure(run: CcxRun) -> SolverError:
    """The :class:`SolverError` of a run that did not converge (``run_ccx(check=True)``
    raises it), with the step time of its last converged increment."""
    reached = _sta_rows(run.file("sta"))
    return SolverError(run.outcome.value, list(run.command), run.returncode, run.output_tail,
                       HINTS.get(run.outcome, ""), reached[-1] if reached else 0.0)
