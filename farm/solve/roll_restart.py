"""A roll's restart points (issue 45): a roll that stops is retried from the last one.

ccx writes its restart state only at a step's end. A roll from rest whose solver
settings ask for restart points (:attr:`farm.specs.SolverSettings.restart_every_mm`) is
therefore cut into steps every so many mm of road travel
(:func:`farm.solve.rolling.roll_split`; each cut holds the loads for its step's first
increment, as a rolling branch's start does) and writes a restart block at each step's
end. When such a roll stops, its last block, its ``.frd`` as far as it got and the
seconds at which it reached each time are kept on disk under the roll's content key,
beside the solver's other caches (:func:`farm.mesh.cache.cache_dir`). The next run of
the same roll - the guard's retry with smaller increments, or a study's
``--retry-failed`` resume on the same cache - reads that block (``*RESTART, READ``) and
runs only the steps after it; its states up to the point are read from the kept
``.frd``. A roll that then finishes drops its point; one that stops again keeps it.

Why: on the credible tyre a roll of 150 mm costs about 14 min of ccx, and the guard's
retry rolled a stopped one again from rest at a quarter of the increments.
"""

from __future__ import annotations

import contextlib
import gzip
import json
import shutil
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from farm.atomic import write_bytes, write_text
from farm.ccx import deck as D
from farm.ccx.frd import FrdFile, read_frd
from farm.ccx.runner import CcxRun, ccx_version, seconds_to
from farm.errors import ResultsError
from farm.mesh.cache import cache_dir
from farm.solve.tree import split_restart
from farm.specs import content_hash

KIND = "roll-restart"


@dataclass(frozen=True, eq=False)
class RestartPoint:
    """Where a stopped roll can go on from.

    ``step``: the steps its restart block holds (1: the first); ``time``: the total time
    at that step's end; ``block``: the block (ccx's ``.rin``); ``frd``: the stopped run's
    results up to where it stopped; ``progress``: (total time, seconds) at which that run
    converged each increment up to ``time``.
    """

    step: int
    time: float
    block: bytes
    frd: FrdFile
    progress: tuple[tuple[float, float], ...]

    @property
    def seconds(self) -> float:
        """Seconds the stopped run took to reach the point."""
        return self.seconds_to(self.time)

    def seconds_to(self, total_time: float) -> float:
        """Seconds the stopped run took to reach ``total_time`` (at most the point's)."""
        return seconds_to(self.progress, total_time,
                          self.progress[-1][1] if self.progress else 0.0)


def key(deck: str) -> dict[str, Any]:
    """What a roll's point belongs to: its deck (model, loads, output times, cuts and
    holds) but for its increments, which a retry makes smaller and which go on from the
    point the first try passed (the ``*STEP`` and ``*STATIC`` data lines), and the
    solver's version."""
    lines = deck.splitlines()
    kept = [line for i, line in enumerate(lines)
            if not line.startswith("*STEP") and not (i and lines[i - 1] == "*STATIC")]
    return {"deck": content_hash({"lines": kept}), "solver": ccx_version()}


def _folder(point_key: dict[str, Any]) -> Path:
    return cache_dir() / KIND / content_hash(point_key)[:32]


def save(point_key: dict[str, Any], run: CcxRun, split: D.Split) -> None:
    """Keep the last restart block a stopped ``run`` wrote (none written: nothing kept),
    with its ``.frd`` and progress up to that block. The point's record is written last,
    so a half-written point is never read; a cache that cannot be written only costs the
    retry the roll from rest."""
    try:
        blocks = split_restart(run.file("rout").read_bytes())
        frd = run.file("frd").read_bytes()
    except (OSError, ResultsError):
        return
    step = len(blocks)
    # the last step's end is the roll's; a frictionless rise's end (the cut at the
    # roll's start, step time 2) is an output time, which a restart there cannot pass
    if not 1 <= step <= len(split.cuts) or split.cuts[step - 1] <= 2.0:
        return
    time = split.step_end(step)
    folder = _folder(point_key)
    with contextlib.suppress(OSError):
        folder.mkdir(parents=True, exist_ok=True)
        write_bytes(folder / "roll.rin.z", zlib.compress(blocks[-1], 1))
        write_bytes(folder / "roll.frd.gz", gzip.compress(frd, 1))
        progress = [(t, s) for t, s in run.progress if t <= time + 1e-9]
        write_text(folder / "point.json", json.dumps({"step": step, "time": time,
                                                      "progress": progress}))


def load(point_key: dict[str, Any]) -> RestartPoint | None:
    """The point a stopped run of this roll kept, or None (none, or unreadable)."""
    folder = _folder(point_key)
    try:
        doc = json.loads((folder / "point.json").read_text())
        block = zlib.decompress((folder / "roll.rin.z").read_bytes())
        frd = read_frd(folder / "roll.frd.gz", allow_truncated=True)
        return RestartPoint(int(doc["step"]), float(doc["time"]), block, frd,
                            tuple((float(t), float(s)) for t, s in doc["progress"]))
    except (OSError, ValueError, KeyError, TypeError, zlib.error, ResultsError):
        return None


def drop(point_key: dict[str, Any]) -> None:
    """Forget the roll's point (it has been rolled to its end)."""
    shutil.rmtree(_folder(point_key), ignore_errors=True)


def resumed_deck(deck: str, step: int) -> str:
    """``deck`` (a roll cut into steps) as a restart run that reads the state at the end
    of its ``step``-th step and runs the steps after it."""
    lines = deck.splitlines()
    starts = [i for i, line in enumerate(lines) if line.startswith("*STEP")]
    if not 1 <= step < len(starts):
        raise ResultsError(f"a restart point after step {step} of a deck of "
                           f"{len(starts)} steps has nothing to resume")
    return "\n".join([*D.restart_lines(read=True, write=False), *lines[starts[step]:]]) + "\n"
