"""Run an adaptive study: sweep, fit, choose, sweep again (issue 28).

Round 0 is the study's ``[loads.sample]`` design. After each sweep the chooser - a
surrogate of the done experiments (:class:`analysis.adaptive.SurrogateChooser`, passed
in by the CLI: jobs does not import analysis) - is fitted, reports its held-out errors
and picks the next ``batch`` points among this round's Sobol' candidates; the points are
stored in the group (:mod:`jobs.adaptive.log`) *before* they are swept, and the next
sweep is the study with every point chosen so far: an ordinary sweep, so experiments
already done are skipped, ids are those a plain study with those points would give, and
a study killed at any moment resumes at its round (the stored points are swept again,
what is done is skipped, and no round is chosen twice). The loop stops after
``rounds`` rounds, or earlier once every output of ``outputs`` has a held-out error of at
most ``target_pct``; a last fit on everything is stored as ``final``.

Failed experiments are data (a reason in the store, as in any sweep); the surrogate
fits the done ones.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from scipy.stats import qmc

from jobs.adaptive import log as rounds_log
from jobs.adaptive.log import Fit, Log, Round
from jobs.errors import StudyError
from jobs.study import Study
from jobs.sweep import SweepReport, run_sweep


class Choice(Protocol):
    """What a chooser returns: the candidates' rows to run next, and its fit."""

    @property
    def picks(self) -> Sequence[int]: ...

    @property
    def errors(self) -> Mapping[str, float | None]: ...

    @property
    def fitted_on(self) -> int: ...


class Chooser(Protocol):
    """Fits a surrogate on a group's done experiments and picks ``size`` candidates.

    ``names`` are the store parameters of the candidates' columns (``[loads.sample]``'s
    ranges, in order), ``candidates`` (K, len(names)) in the store's units; ``size`` 0:
    fit and report the errors only."""

    def __call__(self, store: Any, group: str, names: tuple[str, ...], field: str,
                 candidates: np.ndarray, size: int) -> Choice: ...


@dataclass
class AdaptiveReport:
    """How an adaptive study ended: one sweep report per round run by this call."""

    study: Study
    log: Log
    sweeps: list[SweepReport] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """The last sweep holds every experiment chosen as done (none failed)."""
        return bool(self.sweeps) and self.sweeps[-1].ok

    @property
    def experiments(self) -> int:
        return self.sweeps[-1].total if self.sweeps else 0


def candidates(study: Study, index: int) -> np.ndarray:
    """The Sobol' points round ``index`` chooses among (K, D), in the store's units."""
    s, spec = study.sampling, study.adaptive
    assert s is not None and spec is not None
    rng = np.random.default_rng([spec.seed, index])  # each round its own draw, reproducibly
    engine = qmc.Sobol(d=len(s.ranges), scramble=True, seed=rng)
    return qmc.scale(engine.random(spec.candidates), [lo for _, lo, _ in s.ranges],
                     [hi for _, _, hi in s.ranges])


def met(errors: Mapping[str, float | None], outputs: Sequence[str],
        target: float | None) -> bool:
    """Whether every judged output is within ``target`` % of its range (outputs that do
    not vary count as met; none at all is not a reason to stop)."""
    if target is None:
        return False
    judged = [e for e in (errors.get(o) for o in outputs) if e is not None]
    return bool(judged) and all(e <= target for e in judged)


def run_adaptive(study: Study, chooser: Chooser, *,
                 sweep: Callable[..., SweepReport] = run_sweep,
                 on_round: Callable[[int, Fit, int], None] | None = None,
                 **sweep_options: Any) -> AdaptiveReport:
    """Run (or resume) the adaptive ``study``; ``sweep_options`` go to every sweep.

    ``on_round(index, fit, chosen)`` is called after each fit: the round it chose for
    (``chosen`` points; 0 when the study stops there)."""
    spec = study.adaptive
    if spec is None or study.sampling is None:
        raise StudyError(f"{study.source}: not an adaptive study (no [study.adaptive])")
    names = tuple(name for name, _, _ in study.sampling.ranges)
    log = rounds_log.read(study)
    report = AdaptiveReport(study, log)
    while True:
        report.sweeps.append(sweep(rounds_log.with_points(study, log), **sweep_options))
        index = len(log.rounds) + 1  # the round this fit chooses for
        last = index > spec.rounds
        pool = candidates(study, index)
        choice = chooser(study.store, study.group_name, names, spec.field, pool,
                         0 if last else spec.batch)
        fit = Fit(int(choice.fitted_on), dict(choice.errors))
        stop = "budget" if last else ("target" if met(fit.errors, spec.outputs,
                                                      spec.target_pct) else None)
        if stop:
            log = Log(log.design, log.rounds, fit, stop)
        else:
            picked = tuple(tuple(float(x) for x in pool[int(k)]) for k in choice.picks)
            log = Log(log.design, (*log.rounds, Round(index, picked, fit)))
        rounds_log.write(study, log)  # before the sweep: a kill resumes at this round
        report.log = log
        if on_round is not None:
            on_round(index, fit, 0 if stop else spec.batch)
        if stop:
            return report
