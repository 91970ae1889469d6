"""The ``[study.adaptive]`` table of a study file, validated once (issue 28; the loop is
:mod:`jobs.adaptive`)::

    [study.adaptive]
    rounds = 4              # rounds after the initial design ([loads.sample])
    batch = 4               # experiments chosen per round (spread over the workers)
    candidates = 512        # Sobol' points per round the surrogate scores (a power of 2)
    seed = 0                # of the candidates (round r draws with [seed, r])
    target_pct = 2.0        # optional: stop early once every output's held-out error
                            #   (leave-one-out, % of its range) is at most this
    field = "displacement"  # the inner-surface field the surrogate maps ("strain")
    outputs = ["field", "Fx", "Fy", "Fz", "Mz"]   # what target_pct judges
    acquisition = "variance"  # or "integrated": the variance a pick removes over all candidates

The initial design is the study's ``[loads.sample]`` (its ``n`` points); every load that
varies must be sampled there, since the rounds choose points of those ranges. A listed
load with one value is fixed for every round.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from jobs.validate import limits, scalars
from jobs.validate.messages import fail

KEYS = {"rounds", "batch", "candidates", "seed", "target_pct", "field", "outputs",
        "acquisition"}
#: How a round chooses among its candidates (analysis.surrogate.FieldSurrogate.next_batch):
#: where the surrogate is least sure, or where running would remove the most predictive
#: variance over the whole load space.
ACQUISITIONS = ("variance", "integrated")
FIELDS = ("displacement", "strain")
#: What the surrogate predicts and a target may judge: the field, then the six totals
#: (analysis.studies.combined.TOTALS).
OUTPUTS = ("field", "Fx", "Fy", "Fz", "Mx", "My", "Mz")
DEFAULT_OUTPUTS = ("field", "Fx", "Fy", "Fz", "Mz")
MAX_CANDIDATES = 2**16  # scored by every GP of the surrogate each round


@dataclass(frozen=True)
class AdaptiveSpec:
    """A validated ``[study.adaptive]``."""

    rounds: int
    batch: int
    candidates: int = 512
    seed: int = 0
    target_pct: float | None = None
    field: str = "displacement"
    outputs: tuple[str, ...] = DEFAULT_OUTPUTS
    acquisition: str = "variance"

    def budget(self, initial: int) -> int:
        """Experiments of the study at most: the initial design and every round."""
        return initial + self.rounds * self.batch


def parse_adaptive(data: Any, where: str = "study.adaptive") -> AdaptiveSpec:
    """Validate the table (the study's loads are checked by :func:`check_loads`)."""
    t = scalars.table(data, where, KEYS, {"rounds", "batch"})
    rounds = scalars.integer(t["rounds"], f"{where}.rounds", low=1, high=1000)
    batch = scalars.integer(t["batch"], f"{where}.batch", low=1, high=limits.EXPERIMENTS.value())
    candidates = scalars.integer(t.get("candidates", 512), f"{where}.candidates", low=1,
                                 high=MAX_CANDIDATES)
    if candidates & (candidates - 1):
        raise fail(f"{where}.candidates", "must be a power of 2 (a Sobol' sequence is "
                   f"balanced at 2^k points), got {candidates}")
    if candidates < batch:
        raise fail(f"{where}.candidates", f"must be at least batch = {batch} (each round "
                   f"picks its batch among them), got {candidates}")
    seed = scalars.integer(t.get("seed", 0), f"{where}.seed", low=0, high=limits.MAX_SEED)
    target = (scalars.number(t["target_pct"], f"{where}.target_pct", low=0, high=100,
                             strict=True) if "target_pct" in t else None)
    field = scalars.choice(t.get("field", "displacement"), f"{where}.field", FIELDS)
    outputs = (scalars.choices(t["outputs"], f"{where}.outputs", OUTPUTS)
               if "outputs" in t else DEFAULT_OUTPUTS)
    acquisition = scalars.choice(t.get("acquisition", "variance"), f"{where}.acquisition",
                                 ACQUISITIONS)
    return AdaptiveSpec(rounds, batch, candidates, seed, target, field, outputs, acquisition)


def check_loads(spec: AdaptiveSpec, sampled: tuple[str, ...], listed: dict[str, tuple],
                initial: int, models: bool) -> None:
    """An adaptive study samples every load that varies, has no model design, and its
    budget is within the experiment limit."""
    if models:
        raise fail("study.adaptive", "chooses load cases of one model; a study with [models] "
                   "cannot be adaptive (drop one of the two)")
    if not sampled:
        raise fail("study.adaptive", "starts from the study's [loads.sample] design: add one "
                   "(method, n and the ranges the rounds may choose from)")
    for key, values in listed.items():
        if len(values) > 1:
            raise fail(f"loads.{key}", f"lists {len(values)} values, but an adaptive study "
                       "chooses what varies: give it as a range in [loads.sample], or one value")
    limits.EXPERIMENTS.check(spec.budget(initial), "study.adaptive",
                             f"{initial} initial experiments + {spec.rounds} rounds x "
                             f"{spec.batch}")
