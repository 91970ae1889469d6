"""How far a running ccx has got, from its own ``.sta`` file (issue 48)."""

from __future__ import annotations

import pytest

from farm.ccx.progress import SolverProgress, progress_of, reporting, step_periods
from farm.experiment import run_load_path
from farm.presets import default_model
from farm.specs import LoadPath, MeshDensity, SolverSettings

DECK = """*HEADING
*NODE
1, 0, 0, 0
*STEP, NLGEOM, INC=500
*STATIC
0.25, 2, 1e-05, 0.5
*END STEP
*STEP
*STATIC, SOLVER=SPOOLES
** a comment line
0.1, 0.5
*END STEP
*STEP
*STATIC
*END STEP
"""


def _rows(text: str) -> list[list[str]]:
    return [line.split() for line in text.strip().splitlines()]


def test_step_periods_are_read_from_each_static_line_with_ccxs_default():
    assert step_periods(DECK) == [2.0, 0.5, 1.0]
    assert step_periods("*HEADING\n") == []


@pytest.mark.parametrize(("sta", "fraction", "step", "increments", "cutbacks"), [
    ("1 1 1 3 0.25 0.25 0.25", 0.25 / 3.5, 1, 1, 0),
    ("1 1 1 3 0.25 0.25 0.25\n1 2 1U 9 0.5 0.5 0.25\n1 2 2 4 0.375 0.375 0.125",
     0.375 / 3.5, 1, 2, 1),
    ("1 9 1 3 2.0 2.0 0.25\n2 1 1 3 2.25 0.25 0.25", 2.25 / 3.5, 2, 2, 0),
    # a restart deck numbers its steps after the run it continues: matched in order
    ("7 1 1 3 0.5 0.5 0.5\n8 1 1 3 2.5 0.5 0.5\n9 1 1 3 3.5 1.0 1.0", 1.0, 3, 3, 0),
    ("1 1 1U 12 0.25 0.25 0.25", 0.0, 1, 0, 1),
])
def test_progress_is_the_share_of_all_steps_time_done(sta, fraction, step, increments,
                                                      cutbacks):
    got = progress_of(_rows(sta), step_periods(DECK))
    assert got == SolverProgress(pytest.approx(fraction), step, 3, increments, cutbacks)
    assert "% of the path (step" in got.describe()


def test_nothing_to_say_before_the_first_row_or_without_steps():
    assert progress_of([], [1.0]) is None
    assert progress_of(_rows("1 1 1 3 1 1 1"), []) is None


@pytest.mark.ccx
def test_a_real_solve_reports_its_progress_up_to_the_whole_path():
    spec = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                  circumferential=16))
    seen: list[SolverProgress] = []
    with reporting(seen.append):
        run_load_path(spec, LoadPath((5.0, 10.0), 0.2), SolverSettings())
    assert seen, "no progress was reported"
    fractions = [p.fraction for p in seen]
    assert all(0 <= f <= 1 for f in fractions)
    assert fractions[-1] == pytest.approx(1.0)  # the last look: the whole path done
    # outside the block nothing is reported
    before = len(seen)
    run_load_path(spec, LoadPath((5.0,), 0.2), SolverSettings())
    assert len(seen) == before


@pytest.mark.ccx
def test_a_display_that_fails_never_stops_the_solve():
    spec = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                  circumferential=16))
    calls = []

    def broken(progress: SolverProgress) -> None:
        calls.append(progress)
        raise RuntimeError("a display bug")

    with reporting(broken):
        result = run_load_path(spec, LoadPath((5.0,), 0.2), SolverSettings())
    assert calls and result.measurements[0].total_force[2] > 0
