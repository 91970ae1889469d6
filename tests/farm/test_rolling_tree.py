"""Rolling trees (issue 45, farm/solve/rolling_tree.py) against physics, on the real solver.

Model: the coarse full model of tests/farm/test_rolling.py (16 elements round,
table-3.1), 200 kPa, 15 mm. A branch reads the trunk's end state from ccx's restart
file and rolls on in a new step; on a frictionless road nothing remembers the path, so
a branch must be the roll done in one run, to the solver's tolerance. With friction the
patch remembers its increments (docs/rolling.md), so the frictional checks hold by
symmetry and ordering: mirrored slip angles mirror Fy and Mz, Fx grows with the slip
ratio, the tread forces balance the road's reaction.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from farm.errors import SpecError
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.rolling import solve_roll
from farm.solve.rolling_tree import solve_rolling_branch, solve_rolling_trunk
from farm.specs import MeshDensity, Roll, SolverSettings

PRESSURE, DEFLECTION, MU = 0.2, 15.0, 0.6
R_E = 403.8  # the coarse model's free-rolling radius (tests/farm/test_rolling.py)
TRUNK, BRANCH = 40.0, 30.0  # mm

pytestmark = pytest.mark.ccx


@pytest.fixture(scope="module")
def coarse():
    spec = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                   circumferential=16))
    return spec, mesh_for(spec)


def _trunk(coarse, friction: float):
    spec, mesh = coarse
    return solve_rolling_trunk(spec, mesh, DEFLECTION, PRESSURE,
                               Roll(friction=friction, distance=TRUNK, rolling_radius=R_E),
                               SolverSettings(), branch_mm=BRANCH, fractions=(0.5, 1.0),
                               branch_fractions=(0.5, 1.0))


@pytest.fixture(scope="module")
def gripping(coarse):
    return _trunk(coarse, MU)


def _branch(trunk, **kw):
    roll = Roll(**{"friction": trunk.roll.friction, "distance": BRANCH,
                   "rolling_radius": R_E, **kw})
    return solve_rolling_branch(trunk, roll, SolverSettings())


def _balanced(state, rtol=5e-3):
    np.testing.assert_allclose(state.tread_force.sum(axis=0), state.force,
                               atol=rtol * abs(state.force[2]))


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_frictionless_branch_is_the_roll_done_in_one_run(coarse):
    """Restart, road and rim carried on from the trunk's end: with no friction to
    remember the path, the branch's states are those of one roll of the whole travel,
    forces and every camera displacement (a wrong spin, a road that jumps or a rim that
    starts over would show at once)."""
    spec, mesh = coarse
    trunk = _trunk(coarse, 0.0)
    branch = _branch(trunk, slip_angle=2.0)
    one = solve_roll(spec, mesh, DEFLECTION, PRESSURE,
                     Roll(friction=0.0, distance=TRUNK + BRANCH, rolling_radius=R_E),
                     SolverSettings(),
                     fractions=(TRUNK / 2 / (TRUNK + BRANCH), TRUNK / (TRUNK + BRANCH), 1.0))
    for mine, its in zip(trunk.states, one, strict=False):  # the trunk is that roll
        np.testing.assert_allclose(mine.force, its.force, atol=1e-4 * its.force[2])
    turned = Roll(friction=0.0, distance=BRANCH, rolling_radius=R_E, slip_angle=2.0)
    end = branch[-1]
    assert end.travelled == pytest.approx(TRUNK + BRANCH)
    assert end.spin == pytest.approx(one[-1].spin + turned.spin
                                     - BRANCH / R_E)  # cos(2 deg) of the branch's travel
    # a frictionless road takes no shear, and a slip angle changes nothing else
    for state in (*trunk.states, *branch):
        assert np.abs(state.force[:2]).max() < 1e-3 * state.force[2]
        _balanced(state)
    straight = _branch(trunk)[-1]
    np.testing.assert_allclose(straight.force, one[-1].force, atol=1e-3 * one[-1].force[2])
    scale = np.abs(one[-1].camera).max()
    np.testing.assert_allclose(straight.camera, one[-1].camera, atol=1e-3 * scale)
    np.testing.assert_allclose(straight.displacement, one[-1].displacement,
                               atol=1e-3 * scale)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_branch_of_a_trunk_risen_without_friction_is_the_roll_done_in_one_run(coarse):
    """friction_from = "roll" (issue 45): the trunk's deck has two steps (the rise, the
    roll that switches the friction on), so its restart file two blocks; the branch rolls
    on from the last, with the roll's mu (a restart that kept the rise's 1e-4 would carry
    no Fx). Straight branch against the 70 mm roll from rest, same history: measured
    2026-11-30 within 0.004 % of |F| and 0.06 % of the camera field's RMS."""
    spec, mesh = coarse
    trunk = solve_rolling_trunk(spec, mesh, DEFLECTION, PRESSURE,
                                Roll(friction=MU, distance=TRUNK, rolling_radius=R_E,
                                     friction_from="roll"),
                                SolverSettings(), branch_mm=BRANCH, branch_fractions=(0.5, 1.0))
    branch = _branch(trunk, friction_from="roll")
    one = solve_roll(spec, mesh, DEFLECTION, PRESSURE,
                     Roll(friction=MU, distance=TRUNK + BRANCH, rolling_radius=R_E,
                          friction_from="roll"), SolverSettings(),
                     fractions=((TRUNK + BRANCH / 2) / (TRUNK + BRANCH), 1.0))
    for b, r in zip(branch, one, strict=True):
        assert b.travelled == pytest.approx(r.travelled)
        assert np.linalg.norm(b.force - r.force) <= 5e-3 * np.linalg.norm(r.force)
        rms = np.sqrt(np.mean(r.camera ** 2))
        assert np.sqrt(np.mean((b.camera - r.camera) ** 2)) <= 1e-2 * rms
    assert branch[0].force[0] > 50.0  # the friction is on in the branch
    with pytest.raises(SpecError, match="friction_from"):
        _branch(trunk)  # a branch keeps its trunk's history


def test_branches_at_mirrored_slip_angles_mirror_fy_and_mz(gripping):
    left, right = (_branch(gripping, slip_angle=a)[-1] for a in (3.0, -3.0))
    mirror = np.array([1.0, -1.0, 1.0])
    np.testing.assert_allclose(right.force, mirror * left.force, atol=1e-3 * left.force[2])
    np.testing.assert_allclose(right.moment, -mirror * left.moment,
                               atol=1e-3 * abs(left.moment).max())
    assert left.force[1] < 0  # the road pushes against the wheel's lateral travel
    _balanced(left)


@pytest.mark.slow
def test_fx_of_branches_grows_with_their_slip_ratio(gripping):
    fx = [_branch(gripping, slip_ratio=k)[-1].force[0] for k in (-0.05, 0.0, 0.05)]
    assert fx[0] < fx[1] < fx[2]
    assert fx[0] < 0 < fx[2]


@pytest.mark.parametrize(("change", "field"), [
    ({"friction": 0.3}, "friction"), ({"tilt": 2.0}, "tilt"),
    ({"rolling_radius": 400.0}, "rolling_radius"), ({"distance": BRANCH + 1}, "made for"),
])
def test_a_branch_that_does_not_continue_its_trunk_is_refused(gripping, change, field):
    roll = dataclasses.replace(Roll(friction=MU, distance=BRANCH, rolling_radius=R_E),
                               **change)
    with pytest.raises(SpecError, match=field):
        solve_rolling_branch(gripping, roll, SolverSettings())


def test_the_trunk_s_states_are_experiments_along_its_roll(gripping):
    half, end = gripping.states
    assert (half.travelled, end.travelled) == pytest.approx((TRUNK / 2, TRUNK))
    assert end.spin == pytest.approx(TRUNK / R_E)
    for state in gripping.states:
        _balanced(state)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_branch_that_stops_keeps_the_states_it_reached(gripping):
    """Out of increments between its two states (24 of the 26 the branch takes with
    ccx 2.20), a branch raises with the state it reached, equal to the whole branch's:
    the same deck up to there."""
    from farm.errors import SolverError

    whole = _branch(gripping, slip_angle=3.0)
    roll = Roll(friction=MU, distance=BRANCH, rolling_radius=R_E, slip_angle=3.0)
    with pytest.raises(SolverError, match="max_increments") as info:
        solve_rolling_branch(gripping, roll, SolverSettings(max_increments=24))
    [reached] = info.value.partial
    assert reached.travelled == pytest.approx(TRUNK + BRANCH / 2)
    np.testing.assert_allclose(reached.force, whole[0].force, rtol=1e-9)
    np.testing.assert_allclose(reached.camera, whole[0].camera, rtol=1e-9, atol=1e-12)


def test_a_trunk_that_stops_keeps_the_states_it_reached(coarse, gripping):
    """Out of increments between its two states (28 of the 31 the trunk takes with
    ccx 2.20), a trunk raises with the state it reached, equal to the whole trunk's."""
    from farm.errors import SolverError

    spec, mesh = coarse
    with pytest.raises(SolverError, match="max_increments") as info:
        solve_rolling_trunk(spec, mesh, DEFLECTION, PRESSURE,
                            Roll(friction=MU, distance=TRUNK, rolling_radius=R_E),
                            SolverSettings(max_increments=28), branch_mm=BRANCH,
                            fractions=(0.5, 1.0), branch_fractions=(0.5, 1.0))
    [reached] = info.value.partial
    assert reached.travelled == pytest.approx(TRUNK / 2)
    np.testing.assert_allclose(reached.force, gripping.states[0].force, rtol=1e-9)
    np.testing.assert_allclose(reached.camera, gripping.states[0].camera, rtol=1e-9,
                               atol=1e-12)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_saved_trunk_reads_back_as_the_trunk_its_branches_roll_on_from(coarse, gripping):
    """What a rolling tree keeps in its store (farm/solve/rolling_trunk_file.py): read
    back on the model's mesh it writes the same branch deck, and a branch rolled on from
    it is the branch rolled on from the trunk itself, bit for bit; bytes cut short, or a
    trunk of another mesh, are refused."""
    from farm.errors import ResultsError
    from farm.solve import rolling_trunk_file
    from farm.solve.rolling_tree import branch_deck

    _, mesh = coarse
    data = rolling_trunk_file.dumps(gripping)
    back = rolling_trunk_file.loads(data, mesh)
    roll = Roll(friction=MU, distance=BRANCH, rolling_radius=R_E, slip_angle=3.0,
                slip_ratio=0.02)
    assert branch_deck(back, roll, SolverSettings()) == branch_deck(gripping, roll,
                                                                     SolverSettings())
    assert back.roll == gripping.roll and back.restart == gripping.restart
    np.testing.assert_array_equal(back.solved.nodes, gripping.solved.nodes)
    for a, b in zip(_branch(gripping, slip_angle=3.0, slip_ratio=0.02),
                    _branch(back, slip_angle=3.0, slip_ratio=0.02), strict=True):
        np.testing.assert_array_equal(a.force, b.force)
        np.testing.assert_array_equal(a.camera, b.camera)
    with pytest.raises(ResultsError, match="does not read back"):
        rolling_trunk_file.loads(data[:len(data) // 2], mesh)
    other = dataclasses.replace(mesh, nodes=mesh.nodes[:-1])
    with pytest.raises(ResultsError, match="nodes"):
        rolling_trunk_file.loads(data, other)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_tree_on_a_windowed_mesh_ends_its_straight_branch_as_the_roll_from_rest():
    """A windowed mesh's trunk starts with the window ahead by the trunk's and a straight
    branch's spin (trunk_start), as the roll from rest of both lengths does, so a
    frictionless straight branch ends as that roll: with the window under the road, read
    at the stored mesh's own nodes (turn 0)."""
    spec = default_model("full", mesh=MeshDensity(tread=2, sidewall=2, bead=1,
                                                   circumferential=24, window=32.0,
                                                   window_elements=4))
    mesh = mesh_for(spec)
    trunk = solve_rolling_trunk(spec, mesh, DEFLECTION, PRESSURE,
                                Roll(friction=0.0, distance=TRUNK, rolling_radius=R_E),
                                SolverSettings(), branch_mm=BRANCH)
    [end] = solve_rolling_branch(trunk, Roll(friction=0.0, distance=BRANCH,
                                             rolling_radius=R_E), SolverSettings())
    [one] = solve_roll(spec, mesh, DEFLECTION, PRESSURE,
                       Roll(friction=0.0, distance=TRUNK + BRANCH, rolling_radius=R_E),
                       SolverSettings())
    assert trunk.start == pytest.approx(-(TRUNK + BRANCH) / R_E)
    assert end.turn == pytest.approx(0.0, abs=1e-12) and one.turn == pytest.approx(0.0)
    np.testing.assert_allclose(end.force, one.force, atol=1e-3 * one.force[2])
    scale = np.abs(one.camera).max()
    np.testing.assert_allclose(end.camera, one.camera, atol=1e-3 * scale)


@pytest.mark.slow
def test_a_gripping_branch_is_the_roll_done_in_one_run_on_32_elements_round():
    """Issue 45's rule for a speed-up, with friction: on 32 elements round (mu 0.6), a
    kappa-0 branch of 40 mm from a 60 mm trunk against the 100 mm roll from rest - forces
    within 0.5 % of |F|, the camera field within 1 % of its RMS, at the branch's middle
    and end (measured 2026-11-29: 1.1e-4 and 3.3e-4 at most)."""
    spec = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1,
                                                   circumferential=32))
    mesh = mesh_for(spec)
    trunk = solve_rolling_trunk(spec, mesh, DEFLECTION, PRESSURE,
                                Roll(friction=MU, distance=60.0, rolling_radius=R_E),
                                SolverSettings(), branch_mm=40.0, branch_fractions=(0.5, 1.0))
    branch = solve_rolling_branch(trunk, Roll(friction=MU, distance=40.0, rolling_radius=R_E),
                                  SolverSettings())
    one = solve_roll(spec, mesh, DEFLECTION, PRESSURE,
                     Roll(friction=MU, distance=100.0, rolling_radius=R_E), SolverSettings(),
                     fractions=(0.8, 1.0))
    for b, r in zip(branch, one, strict=True):
        assert b.travelled == pytest.approx(r.travelled)
        assert np.linalg.norm(b.force - r.force) <= 5e-3 * np.linalg.norm(r.force)
        rms = np.sqrt(np.mean(r.camera ** 2))
        assert np.sqrt(np.mean((b.camera - r.camera) ** 2)) <= 1e-2 * rms
        assert abs(r.force[0]) > 1.0  # a gripping roll: Fx is not zero by symmetry
