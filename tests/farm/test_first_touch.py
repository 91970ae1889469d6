"""First touch of a tilted frictional road (issue 29, item 3): the rise in a step of its
own (``SolverSettings.split_rise``, :class:`farm.ccx.deck.Split`).

The deck checks read the split deck back and compare it with the one-step deck: the same
loads at the same layout times, held over the cut, nothing touching at the cut. The ccx
checks run one case of ``examples/combined_quick.toml`` that stops at first touch in one
step and goes through split, on the coarse full model (docs/combined-loads.md, "First
touch").
"""

import dataclasses

import numpy as np
import pytest

from farm.ccx import deck as D
from farm.errors import SolverError
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.contact import (
    TILT_TIME,
    path_deck,
    rise_split,
    road_gap,
    solve_contact_path,
    stage,
    tilted_gap,
)
from farm.solve.tree import trunk_deck
from farm.specs import LoadPath, MeshDensity, RoadMotion, SolverSettings
from jobs.guard import smaller_increments

COARSE = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1, circumferential=16))
ONE_STEP, SPLIT = SolverSettings(), SolverSettings(split_rise=True)
MOTIONS = {
    "tilted slide": RoadMotion(friction=0.5, shift_x=1.0, shift_y=-2.0, tilt=3.0),
    "untilted slide": RoadMotion(friction=0.5, shift_x=2.0),
    "friction only": RoadMotion(friction=0.8, tilt=-2.0),
    "normal rise": RoadMotion(friction=0.5, shift_y=1.0, tilt=-3.0, rise="normal"),
}


def _path(motion: RoadMotion) -> LoadPath:
    return LoadPath((10.0, 20.0), 0.2, motion, (0.5, 1.0) if motion.moves else (1.0,))


def _amplitudes(deck: str) -> dict[str, tuple[bool, np.ndarray, np.ndarray]]:
    """Every ``*AMPLITUDE`` of a deck: name -> (in total time, times, values)."""
    out = {}
    lines = deck.splitlines()
    for k, line in enumerate(lines):
        if line.startswith("*AMPLITUDE"):
            name = line.split("NAME=")[1].split(",")[0]
            data: list[float] = []
            for row in lines[k + 1:]:
                if row.startswith("*"):
                    break
                data += [float(v) for v in row.split(",")]
            out[name] = ("TIME=TOTAL TIME" in line, np.array(data[0::2]), np.array(data[1::2]))
    return out


# --- Split and the deck (no solver) -----------------------------------------------------

def test_a_split_holds_the_values_over_its_cut_and_maps_times_both_ways():
    split = D.Split(1.25, hold=0.01)
    points = [(0.0, 0.0), (1.0, 0.0), (2.0, 10.0), (3.0, 12.0)]
    assert split.points(points) == [(0.0, 0.0), (1.0, 0.0), (1.25, 2.5), (1.26, 2.5),
                                    (2.01, 10.0), (3.01, 12.0)]
    for t in (0.0, 1.0, 1.25, 1.7, 3.0):
        assert split.layout(split.time(t)) == pytest.approx(t)
    assert split.layout(1.255) == 1.25  # inside the hold: where the cut is
    assert D.amplitude_lines("A", points, split)[0] == "*AMPLITUDE, NAME=A, TIME=TOTAL TIME"
    assert D.amplitude_lines("A", points) == ["*AMPLITUDE, NAME=A", "0, 0, 1, 0, 2, 10, 3, 12"]


@pytest.mark.parametrize("name", MOTIONS)
def test_the_split_deck_applies_the_one_step_loads_and_holds_them_at_the_cut(name):
    """Every amplitude of the split deck, read in total time, equals the one-step deck's
    at the same layout time, is constant over the hold, and the road is still clear
    there; the output times move by the hold; the second step starts with the hold as
    its first increment."""
    mesh = mesh_for(COARSE)
    path = _path(MOTIONS[name])
    one, times, z = path_deck(COARSE, mesh, path, ONE_STEP, -400.0)
    cut, cut_times, cut_z = path_deck(COARSE, mesh, path, SPLIT, -400.0)
    split = rise_split(COARSE, path, SPLIT)
    assert split is not None and cut_z == z
    assert split.at == pytest.approx(1.0 + (TILT_TIME if path.motion.tilt else 0.0))
    assert cut_times == [split.time(t) for t in times]
    assert cut.count("*STEP, NLGEOM") == 2 and one.count("*STEP, NLGEOM") == 1
    period = 1.0 + (2.0 if path.motion.moves else 1.0)
    assert (f"*STATIC\n0.25, {D.fnum(split.at)}, 1e-05, 0.5\n" in cut and
            f"*STATIC\n{D.fnum(split.hold)}, {D.fnum(period - split.at + split.hold)}, "
            "1e-05, 0.5\n" in cut)
    assert "*TIME POINTS, NAME=OUT, TIME=TOTAL TIME\n" in cut
    before, after = _amplitudes(one), _amplitudes(cut)
    assert after.keys() == before.keys() and all(total for total, _, _ in after.values())
    layout = np.linspace(0.0, period + 0.5, 157)
    for key, (_, t1, v1) in before.items():
        _, t2, v2 = after[key]
        at_cut = np.interp([split.at, split.at + split.hold / 2, split.at + split.hold], t2, v2)
        np.testing.assert_allclose(at_cut, at_cut[0], atol=1e-12, err_msg=key)
        np.testing.assert_allclose(np.interp([split.time(t) for t in layout], t2, v2),
                                   np.interp(layout, t1, v1), atol=1e-9, err_msg=key)
    # nothing touches at the cut: the tilt's turn is done, the rise not started, and the
    # road is still its whole clearance away (at least road_gap, beyond the law's c0)
    gap = tilted_gap(COARSE, path.motion.tilt)
    assert gap >= road_gap(COARSE) > COARSE.contact.clearance
    for t in (split.at, split.at + split.hold / 2, split.at + split.hold):
        assert stage(COARSE, path, t, split) == f"in the rise, {gap:.2f} mm before first touch"


@pytest.mark.parametrize("name", MOTIONS)
def test_a_split_path_names_its_stages_as_the_one_step_path_does(name):
    mesh = mesh_for(COARSE)
    path = _path(MOTIONS[name])
    _, times, _ = path_deck(COARSE, mesh, path, ONE_STEP, -400.0)
    split = rise_split(COARSE, path, SPLIT)
    for t in (0.5, 1.1, *times):
        assert stage(COARSE, path, split.time(t), split) == stage(COARSE, path, t)


def test_what_is_not_split():
    mesh = mesh_for(COARSE)
    vertical = LoadPath((10.0,), 0.2, None)
    assert rise_split(COARSE, vertical, SPLIT) is None
    assert path_deck(COARSE, mesh, vertical, SPLIT, -400.0) == path_deck(
        COARSE, mesh, vertical, ONE_STEP, -400.0)
    assert rise_split(COARSE, _path(MOTIONS["tilted slide"]), ONE_STEP) is None
    # a trunk keeps one step per level (its restart blocks are per step)
    trunk = LoadPath((10.0, 20.0), 0.2, MOTIONS["friction only"])
    assert trunk_deck(COARSE, mesh, trunk, SPLIT, -400.0) == trunk_deck(
        COARSE, mesh, trunk, ONE_STEP, -400.0)


def test_the_guard_retries_with_the_rise_split():
    retry = smaller_increments(ONE_STEP)
    assert retry.split_rise and retry.max_increment == ONE_STEP.max_increment / 4
    assert dataclasses.replace(retry, split_rise=False) != retry


# --- with ccx ---------------------------------------------------------------------------

#: examples/combined_quick.toml's case 9: in one step it stops 0.47 mm before first touch
#: (the stick/slip state of the first tread nodes flips, "increment below minimum")
CASE_9 = LoadPath((11.109725648,), 0.2, RoadMotion(
    friction=0.914098968, shift_x=2.626087713, shift_y=-1.250409206, tilt=-1.099586489))


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
@pytest.mark.ccx
def test_a_case_that_stops_at_first_touch_goes_through_with_the_rise_split():
    mesh = mesh_for(COARSE)
    with pytest.raises(SolverError, match="before first touch"):
        solve_contact_path(COARSE, mesh, CASE_9, ONE_STEP)
    solution = solve_contact_path(COARSE, mesh, CASE_9, smaller_increments(ONE_STEP))
    force = solution.states[-1].road_reaction
    # the road pushes the tyre up, and back against the slide (Coulomb: |Ft| <= mu Fz)
    assert force[2] > 1000.0
    assert np.hypot(force[0], force[1]) <= CASE_9.motion.friction * force[2] * 1.001
    assert force[0] > 0.0  # measured 933 N on the probe: sliding +x drags the tread +x
