"""The solver family: how ``ccx`` runs (:class:`SolverSettings`), with its bounds."""

from __future__ import annotations

from dataclasses import dataclass

from farm.errors import SpecError, shown
from farm.specs.bounds import within

# Bounds of the solver's settings (docs/limits.md has the table)
THREADS = (1, 256)  # ccx threads per run
TIMEOUT_S = (1.0, 7 * 86400.0)  # wall-clock seconds per ccx run: a second to a week
#: ccx's most iterations in one increment (IC of *CONTROLS, TIME INCREMENTATION, its
#: default): what ``grow_after`` may be at most
MAX_ITERATIONS = 16
MIN_INCREMENT = 1e-12  # smallest min_increment (a fraction of a load ramp)
MAX_INCREMENTS = 1_000_000
#: a roll's restart points' spacing, mm of road travel (``restart_every_mm``; 0: none):
#: at least two increments of the roll's 5 mm travel cap a step
RESTART_EVERY_MM = (10.0, 10_000.0)


@dataclass(frozen=True)
class SolverSettings:
    """How to run ``ccx``; none of these change a converged result.

    ``initial_increment``, ``min_increment`` and ``max_increment`` are fractions of a
    load ramp (one unit of step time);
    ``timeout`` is wall-clock seconds per ccx run; ``threads`` is passed explicitly
    because a Dask nanny sets ``OMP_NUM_THREADS=1`` for its children.
    """

    threads: int = 1
    timeout: float = 1800.0
    # Fractions of one load ramp. Measured on the full model (200 kPa, 10-30 mm path):
    # 0.1/0.25 took 22 increments, 0.5/0.5 took 15 and 40 % less time, same forces
    # to 0.01 %; the time points cap the road ramp's increments anyway.
    initial_increment: float = 0.25
    min_increment: float = 1e-5
    max_increment: float = 0.5
    max_increments: int = 500
    keep_scratch: bool = False
    # Combined loads: the rise begins a second step (the road still clear of the tyre,
    # held for that step's first increment), so that ccx's increments start small again
    # before contact (farm.ccx.deck.Split; docs/combined-loads.md, "First touch").
    split_rise: bool = False
    # Frictional paths (issue 45): ccx grows an increment only after two in a row that
    # converged within this many iterations (IG of *CONTROLS, TIME INCREMENTATION; ccx's
    # default 4). Contact under friction takes 5-9 iterations an increment, so at 4 its
    # increments never grow after a cutback (docs/rolling.md, "Increments that grow").
    grow_after: int = 4
    # Rolls from rest (issue 45): the roll cut into steps every this many mm of road
    # travel, each step's end kept as a restart point, so that a roll that stops is
    # retried from the last one it passed instead of from rest (0: one step, no points;
    # farm.solve.roll_restart). Each cut holds the loads for a step's first increment.
    restart_every_mm: float = 0.0

    def __post_init__(self) -> None:
        low, high = THREADS
        if not (isinstance(self.threads, int) and not isinstance(self.threads, bool)
                and low <= self.threads <= high):
            raise SpecError(f"solver.threads must be an integer in [{low}, {high}], "
                            f"got {self.threads!r}")
        within("solver.timeout", self.timeout, TIMEOUT_S, "s")
        if not 0 < self.min_increment <= self.initial_increment <= self.max_increment <= 1:
            raise SpecError(
                "solver increments must satisfy 0 < min_increment <= initial_increment <= "
                f"max_increment <= 1, got {self.min_increment}, {self.initial_increment}, "
                f"{self.max_increment}"
            )
        if self.min_increment < MIN_INCREMENT:  # ccx would cut back for ever
            raise SpecError(f"solver.min_increment must be >= {MIN_INCREMENT:g}, got "
                            f"{self.min_increment!r}")
        if not (isinstance(self.max_increments, int) and not isinstance(self.max_increments, bool)
                and 1 <= self.max_increments <= MAX_INCREMENTS):
            raise SpecError(f"solver.max_increments must be an integer in [1, {MAX_INCREMENTS}], "
                            f"got {self.max_increments!r}")
        if not (isinstance(self.grow_after, int) and not isinstance(self.grow_after, bool)
                and 1 <= self.grow_after <= MAX_ITERATIONS):
            raise SpecError(f"solver.grow_after must be an integer in [1, {MAX_ITERATIONS}] "
                            f"(iterations; ccx's default 4), got {shown(self.grow_after)}")
        if not (isinstance(self.restart_every_mm, (int, float))
                and not isinstance(self.restart_every_mm, bool)
                and (self.restart_every_mm == 0
                     or RESTART_EVERY_MM[0] <= self.restart_every_mm <= RESTART_EVERY_MM[1])):
            raise SpecError(f"solver.restart_every_mm must be 0 (no restart points) or in "
                            f"[{RESTART_EVERY_MM[0]:g}, {RESTART_EVERY_MM[1]:g}] mm of road "
                            f"travel, got {shown(self.restart_every_mm)}")
        if not isinstance(self.split_rise, bool):
            raise SpecError("solver.split_rise must be true or false, got "
                            f"{shown(self.split_rise)}")
