"""What an adaptive study has chosen so far, kept in its store group (issue 28).

The record (``storage.rounds``, attribute ``adaptive_rounds``, ``docs/schema.md``)::

    {"version": 1, "study": "...",
     "design": {"names": [...], "ranges": [[low, high], ...],   # [loads.sample]'s ranges
                "initial": {"method": "lhs", "n": 8, "seed": 0}},
     "rounds": [{"round": 1, "fitted_on": 8, "errors": {"Fz": 3.1, ...},
                 "points": [[...], ...]}, ...],
     "final": {"fitted_on": 16, "errors": {...}, "stopped": "budget"} or null}

A round's ``points`` are the experiments it chose, in the design's internal units (the
same values :func:`jobs.expand.cases` turns into ids), its ``errors`` the held-out errors
(% of range; null: the output does not vary) of the surrogate that chose them, fitted on
``fitted_on`` done experiments. A study may grow (more rounds, another batch size or
candidate count: they change what comes next only), but not change its design: the
stored points would then belong to another study, and :func:`read` refuses it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

import storage
from jobs.errors import StudyError
from jobs.study import Study

VERSION = 1


@dataclass(frozen=True)
class Fit:
    """One fit of the surrogate: on how many done experiments, and its held-out errors."""

    fitted_on: int
    errors: dict[str, float | None] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"fitted_on": self.fitted_on,
                "errors": {k: (None if v is None or not np.isfinite(v) else float(v))
                           for k, v in self.errors.items()}}


@dataclass(frozen=True)
class Round:
    """The points round ``index`` chose, and the fit that chose them."""

    index: int
    points: tuple[tuple[float, ...], ...]
    fit: Fit

    def to_json(self) -> dict[str, Any]:
        return {"round": self.index, **self.fit.to_json(),
                "points": [list(p) for p in self.points]}


@dataclass(frozen=True)
class Log:
    """The rounds chosen so far, and the last fit when the study stopped."""

    design: dict[str, Any]
    rounds: tuple[Round, ...] = ()
    final: Fit | None = None
    stopped: str | None = None  # "budget" or "target" once final

    def points(self) -> tuple[tuple[float, ...], ...]:
        """Every point the rounds chose, in order."""
        return tuple(p for r in self.rounds for p in r.points)

    def to_json(self, study: str) -> dict[str, Any]:
        final = None if self.final is None else {**self.final.to_json(), "stopped": self.stopped}
        return {"version": VERSION, "study": study, "design": self.design,
                "rounds": [r.to_json() for r in self.rounds], "final": final}


def design(study: Study) -> dict[str, Any]:
    """What the stored points depend on: the sampled ranges and the initial design."""
    s = study.sampling
    assert s is not None and study.adaptive is not None, "an adaptive study samples its loads"
    return {"names": [name for name, _, _ in s.ranges],
            "ranges": [[low, high] for _, low, high in s.ranges],
            "initial": {"method": s.method, "n": s.n, "seed": s.seed}}


def with_points(study: Study, log: Log) -> Study:
    """The study as one sweep: its initial design and every point chosen so far."""
    assert study.sampling is not None
    return replace(study, sampling=replace(study.sampling, points=log.points()))


def _fit(data: dict) -> Fit:
    return Fit(int(data["fitted_on"]), {k: (None if v is None else float(v))
                                        for k, v in data["errors"].items()})


def parse(record: dict[str, Any], study: Study) -> Log:
    """The log of a stored record, checked against the study's design."""
    if record.get("version") != VERSION:
        raise StudyError(f"group {study.group_name!r} holds an adaptive record of version "
                         f"{record.get('version')!r}; this farm reads version {VERSION}")
    want = design(study)
    if record["design"] != want:
        raise StudyError(
            f"study.adaptive: group {study.group_name!r} of {study.location} holds the rounds "
            f"of an adaptive study with another design ({_shown(record['design'])}; this "
            f"study: {_shown(want)}): restore the study's [loads.sample], or give it another "
            "store or study.group")
    rounds = tuple(Round(int(r["round"]), tuple(tuple(float(x) for x in p) for p in r["points"]),
                         _fit(r)) for r in record["rounds"])
    final = record.get("final")
    return Log(want, rounds, None if final is None else _fit(final),
               None if final is None else final.get("stopped"))


def _shown(d: dict[str, Any]) -> str:
    ranges = ", ".join(f"{n} [{lo:g}, {hi:g}]" for n, (lo, hi) in zip(d["names"], d["ranges"],
                                                                        strict=True))
    i = d["initial"]
    return f"{i['method']} n = {i['n']} seed = {i['seed']} over {ranges}"


def read(study: Study) -> Log:
    """The study's log: stored in its group, or empty (no group, no record yet)."""
    try:
        record = storage.read_rounds(study.store, study.group_name)
    except (storage.GroupNotFoundError, storage.NotAStoreError):
        record = None
    return Log(design(study)) if record is None else parse(record, study)


def write(study: Study, log: Log) -> None:
    """Store the log in the study's group (which the first round's sweep made)."""
    storage.write_rounds(study.store, study.group_name, log.to_json(study.name))
