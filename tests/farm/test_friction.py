"""Combined loads with Coulomb friction (issue 13): spec, deck and physics with real ccx.

The ccx checks use the smallest full-model mesh (jobs/reproduce COARSE_MESH, 160
hexahedra) at 20 mm and 200 kPa: each combined path is one ccx run of a few seconds,
its motion sampled at several fractions. That mesh touches the road with only 3-5 tread
nodes, which is enough for balances and limits that hold node by node; the default-mesh
checks are slow tests.
"""

import dataclasses
import math

import numpy as np
import pytest

from farm.ccx import deck as D
from farm.errors import SpecError
from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.contact import TILT_TIME, path_deck, stage
from farm.solve.states import OPEN, SLIP, STICK
from farm.specs import LoadPath, MeshDensity, RoadMotion, SolverSettings

COARSE = default_model("full", mesh=MeshDensity(tread=4, sidewall=2, bead=1, circumferential=16))
SETTINGS = SolverSettings()
DEFLECTION, PRESSURE = 20.0, 0.2
MU = 0.3
SHIFT = 20.0  # mm: beyond full sliding at mu = 0.3 on this mesh (about 11 mm)
FRACTIONS = (0.125, 0.25, 1.0)
TILT = 3.0


def _path(motion: RoadMotion | None, fractions=(1.0,)) -> LoadPath:
    return LoadPath((DEFLECTION,), PRESSURE, motion, fractions)


def _normal(tilt_deg: float) -> np.ndarray:
    """The road's normal after a tilt about +x (the +y side rises)."""
    a = math.radians(tilt_deg)
    return np.array([0.0, -math.sin(a), math.cos(a)])


# --- spec and deck (no solver) ----------------------------------------------------------

@pytest.mark.parametrize("motion", [None, RoadMotion(friction=0.5, shift_y=3.0, tilt=TILT)],
                         ids=["vertical", "slide"])
def test_a_failure_time_is_named_by_what_the_path_does_then(motion):
    """stage() reads the deck's own time layout: at each deflection's output time it names
    that deflection, at the slide's output times the fraction of the slide."""
    mesh = mesh_for(COARSE)
    path = LoadPath((10.0, DEFLECTION), PRESSURE, motion, (0.25, 1.0) if motion else (1.0,))
    _, times, _ = path_deck(COARSE, mesh, path, SETTINGS, -400.0)
    for t, d in zip(times, path.deflections, strict=False):
        assert stage(COARSE, path, t) == f"in the rise, {d:.2f} mm deflection"
    assert stage(COARSE, path, 0.5) == "in the inflation, 50 % of the pressure"
    start = 1.0 + (TILT_TIME if motion else 0.0)  # the rise starts, the road still clear
    assert stage(COARSE, path, start).startswith("in the rise, ")
    assert stage(COARSE, path, start).endswith(" mm before first touch")
    if motion:
        assert stage(COARSE, path, 1.0 + TILT_TIME / 2) == \
            "while the road turns to its tilt, 50 % of it"
        assert [stage(COARSE, path, t) for t in times[2:]] == [
            "in the slide, 25 % of it", "in the slide, 100 % of it"]

def test_no_motion_is_the_vertical_path_and_its_deck():
    mesh = mesh_for(COARSE)
    plain = _path(None)
    for still in (RoadMotion(), RoadMotion(friction=0.0, shift_x=0, tilt=-0.0)):
        path = _path(still)
        assert path.motion is None and path == plain and hash(path) == hash(plain)
        assert path_deck(COARSE, mesh, path, SETTINGS, -400.0) == path_deck(
            COARSE, mesh, plain, SETTINGS, -400.0)
    deck = path_deck(COARSE, mesh, plain, SETTINGS, -400.0)[0]
    assert "*FRICTION" not in deck and "ROAD_MOVE" not in deck and "*CONTROLS" not in deck
    assert "ROAD, 1, 2, 0\nROAD, 3, 3, 21.25\n" in deck  # the road as before issue 13


def test_friction_deck_has_the_coulomb_card_and_a_motion_ramp():
    mesh = mesh_for(COARSE)
    deck, times, _ = path_deck(COARSE, mesh, _path(RoadMotion(0.5, 0, 10.0, 0), (0.5, 1.0)),
                               SETTINGS, -400.0)
    lam = math.log(100) * COARSE.contact.pressure / COARSE.contact.clearance
    assert D.stick_slope(COARSE.contact) == pytest.approx(lam) == pytest.approx(4.605, rel=1e-3)
    assert f"EXPONENTIAL\n0.5, 0.5\n*FRICTION\n0.5, {lam:.12g}\n*CONTACT PAIR" in deck
    assert times == [2.0, 2.5, 3.0]  # rise over [1, 2], move over [2, 3]
    assert "*TIME POINTS, NAME=OUT\n1\n2\n2.5\n3\n" in deck
    assert "\n0.25, 3, 1e-05, 0.5\n*CONTROLS, PARAMETERS=TIME INCREMENTATION\n" \
        f"4, 8, 9, 16, 10, 4, , {D.FRICTION_CUTBACKS}\n" in deck  # more cutbacks, in the step
    growing = path_deck(COARSE, mesh, _path(RoadMotion(0.5, 0, 10.0, 0), (0.5, 1.0)),
                        dataclasses.replace(SETTINGS, grow_after=10), -400.0)[0]
    assert f"4, 8, 9, 16, 10, 10, , {D.FRICTION_CUTBACKS}\n" in growing  # IG (issue 45)
    frictionless = path_deck(COARSE, mesh, _path(RoadMotion(0.0, 0, 10.0, 0)), SETTINGS,
                             -400.0)[0]
    assert "*CONTROLS" not in frictionless and "ROAD_MOVE" in frictionless
    # friction without motion: the vertical path's times and step, with the card
    deck, times, _ = path_deck(COARSE, mesh, _path(RoadMotion(0.5, stick_slope=2.0)),
                               SETTINGS, -400.0)
    assert times == [2.0] and "*FRICTION\n0.5, 2\n" in deck and "\n0.25, 2, 1e-05" in deck


def _final_road_displacement(deck: str, road: D.Road) -> np.ndarray:
    """Each road node's displacement at the end of the motion, read back from the deck."""
    amp = {}
    lines = deck.splitlines()
    for k, line in enumerate(lines):
        if line.startswith("*AMPLITUDE, NAME=ROAD_"):
            data = []
            for row in lines[k + 1:]:
                if row.startswith("*"):
                    break
                data.append([float(v) for v in row.split(",")])
            # ccx reads at most four (time, value) pairs from a data line
            assert all(len(row) % 2 == 0 and len(row) <= 8 for row in data)
            amp[line.split("=")[1]] = data[-1][-1]
    ids = road.first_node + np.arange(len(road.xyz))
    u = np.full((len(ids), 3), np.nan)
    current = None
    for line in lines:
        if line.startswith("*"):
            current = line.split("AMPLITUDE=")[1] if "AMPLITUDE=ROAD_" in line else None
            continue
        if current is None:
            continue
        node, first, _, value = (v.strip() for v in line.split(","))
        rows = slice(None) if node == "ROAD" else int(node) - road.first_node
        u[rows, int(first) - 1] = float(value) * amp[current]
    return u


@pytest.mark.parametrize(("shift", "tilt"), [((0.0, 0.0), 4.0), ((7.5, -12.0), -6.0),
                                              ((0.0, 9.0), 0.0)])
def test_road_motion_is_rigid_and_keeps_the_contact_centre_on_the_road(shift, tilt):
    mesh = mesh_for(COARSE)
    road = D.road_slab(mesh, -400.0, 320.0, 168.0)
    amps, bcs = D.road_motion_lines(road, 21.25, shift, tilt, 1.0, 0.25 if tilt else 0.0)
    u = _final_road_displacement("\n".join(["*X", *amps, *bcs]), road)
    assert np.isfinite(u).all()
    moved = road.xyz + u
    # rigid: every distance kept
    d0 = np.linalg.norm(road.xyz[:, None] - road.xyz[None], axis=-1)
    d1 = np.linalg.norm(moved[:, None] - moved[None], axis=-1)
    assert np.abs(d1 - d0).max() < 1e-6
    # the top plane has the tilted normal and passes through the risen contact centre,
    # however far it slid (in its own plane)
    top = moved[len(moved) // 2:]
    np.testing.assert_allclose((top - [0.0, 0.0, -400.0 + 21.25]) @ _normal(tilt), 0.0,
                               atol=1e-6)
    np.testing.assert_allclose(u[:, 0], shift[0])
    slid = (moved - _final_road_displacement(
        "\n".join(["*X", *D.road_motion_lines(road, 21.25, (0.0, 0.0), tilt, 1.0, 0.25)[0],
                   *D.road_motion_lines(road, 21.25, (0.0, 0.0), tilt, 1.0, 0.25)[1]]), road)
        - road.xyz)
    a = math.radians(tilt)
    np.testing.assert_allclose(slid, np.tile([shift[0], shift[1] * math.cos(a),
                                              shift[1] * math.sin(a)], (len(u), 1)), atol=1e-8)


@pytest.mark.parametrize("tilt", [4.0, -6.0])
def test_a_normal_rise_ends_on_the_same_plane_without_sliding_in_it(tilt):
    """rise = "normal" pushes the tilted road along its normal (a camber rig); the
    vertical rise reaches the same plane but slides the road within it by
    travel sin(tilt) along its lateral axis (farm.ccx.deck._rise)."""
    mesh = mesh_for(COARSE)
    road = D.road_slab(mesh, -400.0, 320.0, 168.0)

    def end(travel, rise):
        amps, bcs = D.road_motion_lines(road, travel, (0.0, 0.0), tilt, 1.0, 0.25, rise)
        return _final_road_displacement("\n".join(["*X", *amps, *bcs]), road)

    a, travel = math.radians(tilt), 21.25
    turned = end(0.0, "normal")  # the tilt alone
    np.testing.assert_allclose(end(travel, "normal") - turned,
                               np.tile(travel * math.cos(a) * _normal(tilt), (len(turned), 1)),
                               atol=1e-8)
    lateral = np.array([0.0, math.cos(a), math.sin(a)])
    np.testing.assert_allclose(end(travel, "vertical") - end(travel, "normal"),
                               np.tile(travel * math.sin(a) * lateral, (len(turned), 1)),
                               atol=1e-8)
    # and the tree's steps place the road where the ramp does
    placed = D.road_position_lines(road, travel, (0.0, 0.0), tilt, "normal")
    values = {(int(n), int(d)): float(v) for n, d, _, v in
              (line.split(",") for line in placed[1:])}
    k = road.first_node + 3
    np.testing.assert_allclose([values[(k, d)] for d in (1, 2, 3)],
                               end(travel, "normal")[3], atol=1e-8)


def test_rise_is_part_of_a_tilted_motion_only():
    tilted = RoadMotion(friction=0.5, tilt=2.0, rise="normal")
    assert tilted.to_dict()["rise"] == "normal" and RoadMotion.from_dict(
        tilted.to_dict()) == tilted
    assert "rise" not in RoadMotion(friction=0.5, tilt=2.0).to_dict()  # ids as before
    assert RoadMotion(friction=0.5, rise="normal") == RoadMotion(friction=0.5)  # untilted
    with pytest.raises(SpecError, match=r"motion\.rise = 'up'"):
        RoadMotion(tilt=1.0, rise="up")


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"friction": -0.1}, r"motion\.friction must be a number in \[0, 2\].*-0\.1"),
    ({"friction": 2.5}, r"motion\.friction .* got 2\.5"),
    ({"friction": float("nan")}, r"motion\.friction"),
    ({"shift_y": 60.0}, r"motion\.shift_y must be a number in \[-50, 50\] mm, got 60"),
    ({"shift_x": True}, r"motion\.shift_x"),
    ({"tilt": 12.0}, r"motion\.tilt must be a number in \[-10, 10\] degrees, got 12"),
    ({"stick_slope": 0.0}, r"motion\.stick_slope .* N/mm\^3, got 0"),
])
def test_bad_motion_is_refused_naming_the_key(kwargs, match):
    with pytest.raises(SpecError, match=match):
        RoadMotion(**kwargs)


def test_motion_round_trips_and_leaves_the_derived_stick_slope_out():
    m = RoadMotion(friction=0.8, shift_y=-5, tilt=2)
    assert m.to_dict() == {"friction": 0.8, "shift_x": 0.0, "shift_y": -5.0, "tilt": 2.0}
    assert RoadMotion.from_dict(m.to_dict()) == m
    assert RoadMotion.from_dict({"friction": 1}) == RoadMotion(friction=1.0)
    with pytest.raises(SpecError, match=r"unknown key motion\.mu"):
        RoadMotion.from_dict({"mu": 0.5})
    assert m.scaled(0.5) == RoadMotion(0.8, 0.0, -2.5, 2.0)  # the tilt comes first, whole


@pytest.mark.parametrize(("motion", "fractions", "match"), [
    (None, (0.5, 1.0), "need a road shift"),
    (RoadMotion(friction=0.5, tilt=1.0), (0.5, 1.0), "need a road shift"),
    (RoadMotion(shift_y=1.0), (0.5, 0.9), "end at 1"),
    (RoadMotion(shift_y=1.0), (0.5, 0.5, 1.0), "strictly increasing"),
    (RoadMotion(shift_y=1.0), (0.0, 1.0), r"\(0, 1\]"),
])
def test_bad_motion_fractions_are_refused(motion, fractions, match):
    with pytest.raises(SpecError, match=match):
        _path(motion, fractions)


def test_motion_needs_the_contact_road_and_room_for_the_tilt():
    motion = RoadMotion(friction=0.5, shift_y=5)
    with pytest.raises(SpecError, match="need the contact road"):
        LoadPath((20.0,), 0.0, motion).check_against(default_model("reduced"))
    LoadPath((20.0,), 0.0, motion).check_against(
        dataclasses.replace(default_model("reduced"), road="contact"))
    with pytest.raises(SpecError, match="tilted road's rise"):
        LoadPath((165.0,), 0.2, RoadMotion(tilt=10.0)).check_against(COARSE)
    LoadPath((165.0,), 0.2).check_against(COARSE)


# --- physics with ccx ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def vertical(ccx):
    return run_load_path(COARSE, _path(None), SETTINGS)


@pytest.fixture(scope="module")
def lateral(ccx):
    """Friction mu = 0.3, then the road shifted sideways by +SHIFT and by -SHIFT."""
    return {sign: run_load_path(COARSE, _path(RoadMotion(MU, shift_y=sign * SHIFT), FRACTIONS),
                                SETTINGS)
            for sign in (1, -1)}


@pytest.fixture(scope="module")
def frictionless(ccx):
    """mu = 0: the road slid sideways by 10 mm after the deflection."""
    return run_load_path(COARSE, _path(RoadMotion(0.0, shift_y=10.0), (0.5, 1.0)), SETTINGS)


@pytest.fixture(scope="module")
def tilted(ccx):
    """Frictionless: the road tilted by TILT degrees before it meets the tyre."""
    return run_load_path(COARSE, _path(RoadMotion(0.0, tilt=TILT)), SETTINGS)


def _all_states(lateral, tilted):
    return [m for r in (*lateral.values(), tilted) for m in r.measurements]


def test_states_carry_their_load_case(lateral):
    r = lateral[1]
    assert [m.deflection for m in r.measurements] == [DEFLECTION] * 4
    assert [m.motion.shift_y for m in r.measurements] == [0.0, 2.5, 5.0, 20.0]
    assert all(m.motion.friction == MU for m in r.measurements)
    assert set(r.measurements[-1].combined_arrays()) == {
        "contact_status", "tread_slip", "road_reaction", "road_moment"}
    assert r.measurements[0].arrays().keys() == {
        "displacement", "strain", "surface_strain", "reaction_force", "total_force", "moment"}


def test_frictionless_combined_path_reproduces_the_vertical_path(vertical, frictionless):
    alone = vertical.measurements[0]
    assert alone.motion is None and [m.motion.shift_y for m in frictionless.measurements] == [
        0.0, 5.0, 10.0]
    # mu = 0: the deflection state is the vertical one, and sliding the road moves nothing
    for m in frictionless.measurements:
        np.testing.assert_allclose(m.total_force, alone.total_force,
                                   atol=1e-3 * alone.total_force[2])
        np.testing.assert_allclose(m.reaction_force, alone.reaction_force,
                                   atol=1e-3 * np.abs(alone.reaction_force).max())
        np.testing.assert_allclose(m.displacement, alone.displacement,
                                   atol=1e-3 * np.abs(alone.displacement).max())
        np.testing.assert_allclose(m.strain, alone.strain, atol=1e-3 * np.abs(alone.strain).max())


def test_nodal_forces_sum_to_the_road_reaction(lateral, tilted):
    for m in _all_states(lateral, tilted):
        size = np.linalg.norm(m.road_reaction)
        assert size > 1000.0
        # every component within 0.5 % of the force (x is ~0 without a longitudinal load)
        assert np.abs(m.total_force - m.road_reaction).max() < 5e-3 * size
        # moments differ by the force times the tread's float above the road (< c0)
        gap = COARSE.contact.clearance
        assert np.abs(m.moment - m.road_moment).max() < gap * size


def test_each_node_obeys_coulomb(lateral):
    for r in lateral.values():
        for m in r.measurements:
            f = m.reaction_force
            fn = f[:, 2]  # untilted road: normal z
            ft = np.hypot(f[:, 0], f[:, 1])
            assert np.all(fn >= 0)
            assert np.all(ft <= MU * fn * (1 + 1e-3) + 1e-9)
            slips = m.contact_status == SLIP
            np.testing.assert_allclose(ft[slips], MU * fn[slips], rtol=1e-3)
            assert np.all(ft[m.contact_status == STICK] < MU * fn[m.contact_status == STICK])
            assert np.all(f[m.contact_status == OPEN] == 0)


@pytest.mark.e2e  # slow: out of the ~15-min default run; CI runs it with the e2e set
def test_a_high_friction_slide_on_a_soft_tyre_gets_through(ccx):
    """80 kPa, 21.5 mm, mu 0.87, a 3.95 mm longitudinal slide: its first increment needs
    the step cut to ~1e-3 of the ramp, which ccx's default 5 cutbacks never reach ("too
    many cutbacks", also with the guard's 4x smaller increments); the deck's
    FRICTION_CUTBACKS let it through. The patch sticks: Fx grows with the slide, below mu Fz.
    """
    path = LoadPath((21.53,), 0.08, RoadMotion(0.87, shift_x=3.95), (0.5, 1.0))
    r = run_load_path(COARSE, path, SETTINGS)
    fx = [m.total_force[0] for m in r.measurements]
    fz = r.measurements[-1].total_force[2]
    assert 0 < fx[1] < fx[2] < 0.87 * fz and fz > 4000.0
    for m in r.measurements:
        size = np.linalg.norm(m.road_reaction)
        assert np.abs(m.total_force - m.road_reaction).max() < 5e-3 * size


def test_lateral_force_grows_with_the_shift_then_saturates_at_mu_fz(lateral):
    m = lateral[1].measurements
    fy = np.array([x.total_force[1] for x in m])
    fz = np.array([x.total_force[2] for x in m])
    assert abs(fy[0]) < 1e-6 * fz[0]  # before the motion: no lateral load
    assert 0 < fy[1] < fy[2] < fy[3]  # the road drags the tread along +y
    assert fy[2] == pytest.approx(2 * fy[1], rel=0.05)  # sticking: linear in the shift
    assert fy[2] < 0.7 * MU * fz[2]
    # 20 mm: the whole patch slides, the force is the Coulomb limit
    assert fy[3] == pytest.approx(MU * fz[3], rel=2e-3)
    status = m[3].contact_status
    assert np.count_nonzero(status) >= 3 and np.all(status[status != OPEN] == SLIP)


def _mirror_index(mesh):
    """Index of each tread node's mirror image in y (grid order)."""
    xyz = mesh.xyz(mesh.tread_nodes)
    image = xyz * [1.0, -1.0, 1.0]
    dist = np.linalg.norm(xyz[None] - image[:, None], axis=-1)
    index = dist.argmin(axis=1)
    assert dist[np.arange(len(xyz)), index].max() < 1e-6
    return index


def test_mirrored_lateral_shift_gives_mirrored_forces(lateral):
    mirror = _mirror_index(mesh_for(COARSE))
    flip = np.array([1.0, -1.0, 1.0])
    for plus, minus in zip(lateral[1].measurements, lateral[-1].measurements, strict=True):
        assert plus.motion.shift_y == -minus.motion.shift_y
        scale = plus.total_force[2]
        np.testing.assert_allclose(minus.total_force, plus.total_force * flip, atol=1e-3 * scale)
        np.testing.assert_allclose(minus.reaction_force, plus.reaction_force[mirror] * flip,
                                   atol=1e-3 * np.abs(plus.reaction_force).max())
        np.testing.assert_array_equal(minus.contact_status, plus.contact_status[mirror])
        # Mx = y Fz - z Fy and Mz = x Fy - y Fx change sign with the mirror, My does not
        np.testing.assert_allclose(minus.moment, plus.moment * [-1, 1, -1],
                                   atol=0.1 * scale)


def test_tilted_road_pushes_along_its_normal_and_loads_the_rising_side(tilted):
    (m,) = tilted.measurements
    assert m.motion == RoadMotion(tilt=TILT) and m.deflection == DEFLECTION
    fx, fy, fz = m.total_force
    # frictionless: every nodal force is along the tilted normal, so is their sum
    assert fy / fz == pytest.approx(-math.tan(math.radians(TILT)), rel=1e-3)
    assert abs(fx) < 1e-6 * fz
    f = m.reaction_force
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), f @ _normal(TILT), atol=1e-6 * fz)
    # the road rises on the +y side: more load there, Mx = sum(y Fz - z Fy) > 0
    assert m.moment[0] > 10.0 * fz
    y = mesh_for(COARSE).xyz(mesh_for(COARSE).tread_nodes)[:, 1]
    assert f[y > 1, 2].sum() > f[y < -1, 2].sum()


# --- the default full mesh (slow) ---------------------------------------------------------

FULL = default_model("full")


@pytest.mark.slow
@pytest.mark.ccx
def test_default_mesh_frictionless_motion_reproduces_the_vertical_store_values():
    alone = run_load_path(FULL, LoadPath((30.0,), PRESSURE), SETTINGS).measurements[0]
    slid = run_load_path(FULL, LoadPath((30.0,), PRESSURE, RoadMotion(0.0, 10.0, -10.0)),
                         SETTINGS).measurements
    fz = alone.total_force[2]
    scale = {"total_force": fz, "reaction_force": np.abs(alone.reaction_force).max(),
             "moment": 100.0 * fz}  # moments: N mm, levers ~100 mm (Mx, My are ~0 here)
    for m in slid:
        for name, value in alone.arrays().items():
            size = scale.get(name, np.abs(value).max())
            np.testing.assert_allclose(m.arrays()[name], value, atol=1e-3 * size, err_msg=name)


@pytest.mark.slow
@pytest.mark.ccx
def test_default_mesh_combined_load_balances_obeys_coulomb_and_cambers():
    motion = RoadMotion(0.8, shift_x=5.0, shift_y=5.0, tilt=2.0)
    result = run_load_path(FULL, LoadPath((30.0,), PRESSURE, motion, (0.5, 1.0)), SETTINGS)
    n = _normal(motion.tilt)
    for m in result.measurements:
        size = np.linalg.norm(m.road_reaction)
        assert np.abs(m.total_force - m.road_reaction).max() < 5e-3 * size
        assert np.abs(m.moment - m.road_moment).max() < FULL.contact.clearance * size
        f = m.reaction_force
        fn = f @ n
        ft = np.linalg.norm(f - np.outer(fn, n), axis=1)
        assert np.all(fn >= 0) and np.all(ft <= motion.friction * fn * (1 + 1e-3) + 1e-9)
    first, last = result.measurements[0], result.measurements[-1]
    # the road slid forward and sideways: it drags the tread along both
    assert last.total_force[0] > first.total_force[0] + 100
    assert last.total_force[1] > first.total_force[1] + 100
    assert first.moment[0] > 0 and first.total_force[1] < 0  # camber: load on the +y side


@pytest.mark.slow
@pytest.mark.ccx
def test_default_mesh_longitudinal_force_saturates_at_mu_fz():
    # measured: Fx = 1346 N at 3.75 mm, 1698.6 N = 0.3 Fz from 7.5 mm on (17 nodes sliding);
    # a 40 mm slide stopped with "too many cutbacks" (docs/combined-loads.md)
    result = run_load_path(FULL, LoadPath((30.0,), PRESSURE, RoadMotion(0.3, shift_x=15.0),
                                          (0.25, 1.0)), SETTINGS)
    quarter, last = result.measurements[1:]
    assert 0 < quarter.total_force[0] < last.total_force[0]
    assert last.total_force[0] == pytest.approx(0.3 * last.total_force[2], rel=5e-3)
    assert abs(last.total_force[1]) < 1e-3 * last.total_force[2]


def _step_road(lines: list[str], road: D.Road, before: np.ndarray, t: float) -> np.ndarray:
    """Road displacements at step time ``t`` of a step written by road_step_lines, as ccx
    evaluates them: an amplitude scales its value, a plain value ramps from the last."""
    amps: dict[str, np.ndarray] = {}
    u = np.full(before.shape, np.nan)
    current: str | None = None
    k = 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("*AMPLITUDE, NAME="):
            data = []
            while k + 1 < len(lines) and not lines[k + 1].startswith("*"):
                data += [float(v) for v in lines[k + 1].split(",")]
                k += 1
            amps[line.split("=")[1]] = np.reshape(data, (-1, 2))
        elif line.startswith("*BOUNDARY"):
            current = line.split("AMPLITUDE=")[1] if "AMPLITUDE=" in line else None
        else:
            node, dof, _, value = (v.strip() for v in line.split(","))
            n, d = int(node) - road.first_node, int(dof) - 1
            if current is None:
                u[n, d] = before[n, d] + (float(value) - before[n, d]) * t
            else:
                times, values = amps[current].T
                u[n, d] = float(value) * np.interp(t, times, values)
        k += 1
    return u


@pytest.mark.parametrize("tilt", [0.0, 4.0, -6.0])
@pytest.mark.parametrize("rise", ["vertical", "normal"])
@pytest.mark.parametrize(("before", "after"), [
    ((15.0, (0.0, 0.0)), (22.5, (0.0, 0.0))),  # a trunk's next level
    ((22.5, (0.0, 0.0)), (22.5, (-6.0, 8.0))),  # a slide
    ((22.5, (3.0, 0.0)), (22.5, (0.0, 2.0))),  # back to x = 0: that dof cannot be held
])
def test_a_new_step_holds_the_road_then_moves_it_to_its_new_place(tilt, rise, before, after):
    """road_step_lines: still at the old place through the dwell (ccx's first increment,
    which must not move a prescribed dof: deck.road_step_lines says why), then linear
    to the place road_position_lines gives."""
    road = D.road_slab(mesh_for(COARSE), -400.0, 320.0, 168.0)
    lines = D.road_step_lines(road, before, after, tilt, rise, "S")

    def placed(travel, shift):
        values = {(int(n), int(d)): float(v) for n, d, _, v in
                  (line.split(",") for line in D.road_position_lines(
                      road, travel, shift, tilt, rise)[1:])}
        return np.array([[values[(road.first_node + i, d)] for d in (1, 2, 3)]
                         for i in range(len(road.xyz))])

    old, new = placed(*before), placed(*after)
    dwell = D.STEP_DWELL
    np.testing.assert_allclose(_step_road(lines, road, old, 1.0), new, atol=1e-9)
    ramped = np.abs(new) <= 1e-9  # no ratio of a zero reaches the old value
    for t in (0.0, dwell / 2, dwell):
        u = _step_road(lines, road, old, t)
        np.testing.assert_allclose(u[~ramped], old[~ramped], atol=1e-9)
        np.testing.assert_allclose(u[ramped], (old + (new - old) * t)[ramped], atol=1e-9)
    # between the dwell and the end every held dof moves linearly in step time
    s = 0.4
    u = _step_road(lines, road, old, dwell + s * (1 - dwell))
    np.testing.assert_allclose(u[~ramped], (old + (new - old) * s)[~ramped], atol=1e-9)
    unheld = ramped & (np.abs(new - old) > 1e-9)  # moves in the first increment
    assert unheld.any() == (before[1][0] != 0.0)


def test_a_step_without_motion_writes_no_amplitude():
    road = D.road_slab(mesh_for(COARSE), -400.0, 320.0, 168.0)
    lines = D.road_step_lines(road, (20.0, (1.0, 2.0)), (20.0, (1.0, 2.0)), 3.0, "vertical", "S")
    assert not any(line.startswith("*AMPLITUDE") for line in lines)
    assert lines[0] == "*BOUNDARY" and len(lines) == 1 + 3 * len(road.xyz)
    with pytest.raises(ValueError, match="dwell"):
        D.road_step_lines(road, (20.0, (0.0, 0.0)), (25.0, (0.0, 0.0)), 0.0, "vertical", "S",
                          dwell=1.0)
