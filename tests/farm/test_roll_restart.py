"""A roll's restart points (issue 45, farm/solve/roll_restart.py): a roll cut into steps
whose stopped run is retried from the last step's end, on the real solver.

Model: the coarse full model (16 elements round, table-3.1), 200 kPa, 15 mm, as
tests/farm/test_rolling.py. The cuts change the load history by a hold at each (the
issue's rule: forces within 0.5 % of |F|, the camera field within 1 % of its RMS); a
roll resumed from a point is the same run from there on, so its states equal the
whole run's to round-off.
"""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

from farm.ccx import deck as D
from farm.errors import ResultsError, SolverError, SpecError
from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve import roll_restart, rolling
from farm.solve.tree import split_restart
from farm.specs import LoadPath, MeshDensity, RoadMotion, Roll, SolverSettings
from jobs.guard import Failed, guarded, smaller_increments

PRESSURE, DEFLECTION = 0.2, 15.0
GRIP = Roll(friction=0.6, slip_ratio=0.01, slip_angle=1.0, distance=60.0,
            rolling_radius=403.8)
THIRDS = (1 / 3, 2 / 3, 1.0)


@pytest.fixture(scope="module")
def coarse():
    spec = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                   circumferential=16))
    return spec, mesh_for(spec)


@pytest.fixture(autouse=True)
def _own_cache(tmp_path, monkeypatch):
    """Points are kept beside the solver's caches: each test its own (the touch
    height is recomputed, a few seconds)."""
    monkeypatch.setenv("FARM_CACHE_DIR", str(tmp_path / "cache"))


def test_a_split_with_several_cuts_holds_at_each_and_maps_times_both_ways():
    split = D.Split(2.0, 0.01, (2.2, 2.4))
    assert split.cuts == (2.0, 2.2, 2.4)
    for t in (0.5, 2.0, 2.1, 2.2, 2.3, 2.4, 2.9):
        assert split.layout(split.time(t)) == pytest.approx(t)
    assert split.time(2.3) == pytest.approx(2.32)  # two holds before it
    assert [split.step_end(k) for k in (1, 2, 3)] == pytest.approx([2.0, 2.21, 2.42])
    assert split.layout(2.215) == pytest.approx(2.2)  # within the second hold
    points = split.points([(0.0, 0.0), (2.0, 0.0), (3.0, 1.0)])
    held = [(t, v) for t, v in points if 2.2 <= t <= 2.44]
    np.testing.assert_allclose(held, [(2.21, 0.2), (2.22, 0.2), (2.42, 0.4), (2.43, 0.4)])
    with pytest.raises(ValueError, match="must increase"):
        D.Split(2.0, 0.01, (1.5,))


@pytest.mark.parametrize(("friction_from", "cuts_mm"), [("touch", (20.25, 40.25)),
                                                        ("roll", (0.0, 20.25, 40.25))])
def test_restart_points_cut_a_roll_past_every_so_many_mm(friction_from, cuts_mm):
    roll = dataclasses.replace(GRIP, friction_from=friction_from)
    split = rolling.roll_split(roll, 20.0)
    assert split is not None and split.hold == rolling.STEP_HOLD
    travel = [(c - 2.0) / rolling.roll_time(roll) * roll.distance for c in split.cuts]
    assert travel == pytest.approx(list(cuts_mm))
    assert rolling.roll_split(GRIP, 0.0) is None


def test_a_cut_roll_s_deck_writes_a_restart_block_a_step_and_keeps_its_friction(coarse):
    """Each step ends in a restart block; the rise keeps the roll's friction (a cut is
    not a frictionless rise: until it was built, a split deck meant one); the steps
    after a cut grow their increments as a branch's (IG 10)."""
    spec, mesh = coarse
    text, times, _, _ = rolling.roll_deck(spec, mesh, DEFLECTION, PRESSURE, GRIP,
                                          SolverSettings(), -400.0, THIRDS, every=20.0)
    steps = text.split("*STEP")[1:]
    assert len(steps) == 3 and "*RESTART, WRITE, FREQUENCY=1" in text
    assert "*CHANGE FRICTION" not in text and "\n*FRICTION\n0.6, " in text
    grown = "\n".join(D.friction_controls_lines(rolling.STEP_GROW_AFTER))
    assert grown not in steps[0] and all(grown in s for s in steps[1:])
    hold = rolling.STEP_HOLD
    assert times == pytest.approx([2 + 1 / 3, 2 + 2 / 3 + hold, 3 + 2 * hold])
    with pytest.raises(SpecError, match="falls on one of its restart points"):
        rolling.roll_deck(spec, mesh, DEFLECTION, PRESSURE, GRIP, SolverSettings(), -400.0,
                          (20.25 / 60, 1.0), every=20.0)


def test_a_point_belongs_to_its_roll_whatever_the_increments(coarse):
    """The guard's retry (smaller increments) finds the first try's point; another
    roll, or other cuts, do not."""
    spec, mesh = coarse

    def key(roll: Roll, settings: SolverSettings, every: float = 20.0) -> dict:
        deck = rolling.roll_deck(spec, mesh, DEFLECTION, PRESSURE, roll, settings, -400.0,
                                 THIRDS, every=every)[0]
        return roll_restart.key(deck)

    first = key(GRIP, SolverSettings())
    assert key(GRIP, smaller_increments(SolverSettings())) == first
    assert key(dataclasses.replace(GRIP, slip_angle=1.5), SolverSettings()) != first
    assert key(GRIP, SolverSettings(), every=25.0) != first


def test_a_resumed_deck_reads_the_point_and_runs_the_steps_after_it(coarse):
    spec, mesh = coarse
    deck = rolling.roll_deck(spec, mesh, DEFLECTION, PRESSURE, GRIP, SolverSettings(), -400.0,
                             THIRDS, every=20.0)[0]
    resumed = roll_restart.resumed_deck(deck, 2)
    assert resumed.startswith("*RESTART, READ\n*STEP") and resumed.count("*STEP") == 1
    assert resumed.split("*STEP")[1] == deck.split("*STEP")[3]
    with pytest.raises(Exception, match="nothing to resume"):
        roll_restart.resumed_deck(deck, 3)


@pytest.fixture(scope="module")
def whole(coarse, tmp_path_factory):
    """GRIP cut every 20 mm, rolled whole: its states, and the stopped run it would be
    had ccx stopped in its last step (its files with the first two blocks alone)."""
    spec, mesh = coarse
    runs = []
    keeping = rolling.run_deck_keeping

    def spy(deck, *args, **kw):
        out = keeping(deck, *args, **kw)
        runs.append((deck, out[0]))
        return out

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("FARM_CACHE_DIR", str(tmp_path_factory.mktemp("cache")))
        mp.setattr(rolling, "run_deck_keeping", spy)
        states = rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, GRIP,
                                    SolverSettings(restart_every_mm=20.0, keep_scratch=True),
                                    THIRDS)
    deck, run = runs[-1]
    stopped = tmp_path_factory.mktemp("stopped")
    blocks = split_restart(run.file("rout").read_bytes())
    assert len(blocks) == 3
    (stopped / "roll.rout").write_bytes(b"".join(blocks[:2]))
    shutil.copy(run.file("frd"), stopped / "roll.frd")
    shutil.rmtree(run.workdir, ignore_errors=True)
    return states, deck, dataclasses.replace(run, workdir=stopped)


def _rule(a, b) -> tuple[float, float]:
    """(largest force difference / |F|, camera field difference RMS / its RMS)."""
    force = float(np.abs(b.force - a.force).max() / np.linalg.norm(a.force))
    field = float(np.sqrt(np.mean((b.camera - a.camera) ** 2))
                  / np.sqrt(np.mean(a.camera ** 2)))
    return force, field


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_cuts_change_a_gripping_roll_within_the_rule(coarse, whole):
    """Measured 2026-12-01: the same state at 20 mm (before the first cut), within
    0.010 % of |F| and 0.012 % of the field at 40 mm, 0.004 % and 0.028 % at 60 mm."""
    spec, mesh = coarse
    one = rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, GRIP, SolverSettings(), THIRDS)
    for a, b in zip(one, whole[0], strict=True):
        force, field = _rule(a, b)
        assert force <= 5e-3 and field <= 1e-2
        assert b.travelled == pytest.approx(a.travelled)


@pytest.mark.ccx
def test_a_roll_resumed_from_its_point_is_the_whole_run_from_there(coarse, whole):
    """A point kept after the second step (as a run stopped in the third would keep
    it): the next run of the roll reads it, runs the third step alone, and its states
    are the whole run's - before the point read from the stopped run's results, after
    it solved again - to round-off; the point is dropped once the roll is whole."""
    spec, mesh = coarse
    states, deck, stopped = whole
    settings = SolverSettings(restart_every_mm=20.0)
    split = rolling.roll_split(GRIP, 20.0)
    key = roll_restart.key(deck)
    roll_restart.save(key, stopped, split)
    point = roll_restart.load(key)
    assert point is not None and (point.step, point.time) == (2, split.step_end(2))
    again = rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, GRIP, settings, THIRDS)
    for a, b in zip(states, again, strict=True):
        np.testing.assert_allclose(b.force, a.force, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(b.camera, a.camera, rtol=1e-9, atol=1e-9)
    assert again[0].solved.solve_seconds == states[0].solved.solve_seconds  # the point's
    assert again[-1].solved.solve_seconds > point.seconds
    assert roll_restart.load(key) is None


def _blocks(scratch) -> int:
    """Restart blocks a running roll has written so far (0 while one is half written)."""
    try:
        return max((len(split_restart(f.read_bytes())) for f in scratch.glob("*/roll.rout")),
                   default=0)
    except (OSError, ResultsError):  # a block being written is not one yet
        return 0


@pytest.mark.ccx
def test_a_roll_stopped_after_its_second_step_keeps_its_point_and_goes_on_from_it(
        coarse, whole, tmp_path, monkeypatch):
    """A real stop: GRIP's run stopped (cancelled, as a job being stopped is) once it has
    written its second block keeps the point there and raises; the next run of the roll
    goes on from it and ends where the whole run ends, to round-off."""
    spec, mesh = coarse
    scratch = tmp_path / "scratch"
    monkeypatch.setenv("FARM_SCRATCH_DIR", str(scratch))
    settings = SolverSettings(restart_every_mm=20.0)
    with pytest.raises(SolverError, match="cancel"):
        rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, GRIP, settings, THIRDS,
                           should_stop=lambda: _blocks(scratch) >= 2)
    point = roll_restart.load(roll_restart.key(whole[1]))
    assert point is not None and point.step == 2
    again = rolling.solve_roll(spec, mesh, DEFLECTION, PRESSURE, GRIP, settings, THIRDS)
    for a, b in zip(whole[0], again, strict=True):
        np.testing.assert_allclose(b.force, a.force, rtol=1e-9, atol=1e-9)
    assert roll_restart.load(roll_restart.key(whole[1])) is None


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_the_guard_s_retry_goes_on_from_the_point_a_stopped_roll_kept(coarse):
    """A real stop through the sweeps' failure policy: mu 0.5, kappa 0.01, 2 degrees over
    100 mm cut every 20 mm stops at 61.7 mm, some 1.5 mm after its cut at 60.25 mm where
    a tread node of the 16-sided polygon enters the patch (docs/rolling.md, "A cut is a
    new place to stop"). The guard's retry (smaller increments) goes on from the point at
    that cut instead of rolling from rest, and stops there again; the failure keeps the
    three states before it and says where the retry began."""
    spec, _ = coarse
    motion = RoadMotion(friction=0.5, roll=100.0, slip_ratio=0.01, slip_angle=2.0,
                        rolling_radius=402.9)
    path = LoadPath((DEFLECTION,), PRESSURE, motion, (0.2, 0.4, 0.6, 0.8, 1.0))
    tries: list[SolverSettings] = []

    def solve(settings: SolverSettings):
        tries.append(settings)
        return run_load_path(spec, path, settings)

    out = guarded(solve, SolverSettings(restart_every_mm=20.0))
    assert isinstance(out, Failed) and len(tries) == 2
    assert tries[1].max_increment < tries[0].max_increment  # the retry's smaller ones
    assert "rolled on from its restart point at 60.2 mm" in out.reason
    assert out.partial is not None
    assert [m.motion.roll for m in out.partial.measurements] == pytest.approx([20, 40, 60])
