"""Load paths with frictionless contact against a rigid road plane (thesis §3.2).

The full model is first inflated alone, which gives the height at which the road first
touches the inflated tyre (deflection zero; cached per model, pressure and solver). The
load path itself is then ONE ccx run: inflation ramps over step time [0, 1] with the
road held clear (the exponential law diverges if the road starts within its clearance or
touches during inflation), then the road rises over [1, 2] and results are written at
the time of every deflection. Ramping to 40 mm costs about as much as ramping to 10 mm,
so a whole path costs about one run (prototype: 14.8 s for 10-40 mm, 1 core).

Per-node road forces: in node-to-surface contact the slave nodes are free (their RF is
zero), so the force on each tread node is its contact pressure times its slave area.
ccx's slave area is a quarter of each adjacent slave face in the current configuration;
with that, the tread forces sum to the road's reaction within 0.01 % (measured).

Combined loads (issue 13, docs/combined-loads.md): a path with a ``RoadMotion`` adds
Coulomb friction (``*FRICTION``), tilts the road before it meets the tyre and slides it
after the deflection in a ramp of its own; the tread forces are then 3-D (CPRESS and
CSHEAR in ccx's contact frame), with a stick/slip state per node.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from farm.ccx import deck as D
from farm.ccx.frd import FrdFile, read_frd
from farm.ccx.outcome import Outcome
from farm.ccx.runner import CcxRun, ccx_version, failure, run_ccx, scratch_dir
from farm.errors import ResultsError, SolverError
from farm.mesh.tyremesh import HEX_FACES, REGIONS, TyreMesh
from farm.solve.entries import read_entry, write_entry
from farm.solve.states import (
    OPEN,
    SLIP,
    STICK,
    PathSolution,
    SolvedState,
    inner_strain,
    node_field,
)
from farm.specs import LoadPath, ModelSpec, RoadMotion, SolverSettings

TIME_RTOL = 1e-5  # the .frd prints times below 1 with 6 digits only


def road_gap(spec: ModelSpec) -> float:
    """Initial clearance of the road below the unloaded tyre, mm (beyond c0)."""
    return 1.5 * spec.contact.clearance + 0.5


def run_deck(deck: str, settings: SolverSettings, should_stop,
             jobname: str) -> tuple[CcxRun, FrdFile]:
    run, frd, error = run_deck_keeping(deck, settings, should_stop, jobname, keep=False)
    if error is not None:
        raise error
    assert frd is not None
    return run, frd


def run_deck_keeping(deck: str, settings: SolverSettings, should_stop, jobname: str, *,
                     keep: bool = True, inputs: dict[str, bytes] | None = None,
                     on_stop: Callable[[CcxRun], None] | None = None
                     ) -> tuple[CcxRun, FrdFile | None, SolverError | None]:
    """Run ``deck`` in a scratch directory: (run, frd, None) when it converged; with
    ``keep`` (a roll, issue 45: it keeps what it reached when it stops), (run, the
    ``.frd`` as far as ccx wrote it or None where nothing can be read, the error) when it
    did not; without, (run, None, the error), the ``.frd`` unread. A cancellation
    raises: there is nothing to keep for a job being stopped. ``inputs``: files beside
    the deck (a restart block, ``{"rin": ...}``); ``on_stop`` is called with a run that
    stopped, cancelled too, while its files are still there (a roll's restart point)."""
    with scratch_dir(keep=settings.keep_scratch, prefix=f"{jobname}-") as workdir:
        run = run_ccx(deck, workdir, jobname=jobname, threads=settings.threads,
                      timeout=settings.timeout, should_stop=should_stop, check=False,
                      inputs=inputs)
        if run.outcome is Outcome.CONVERGED:
            return run, read_frd(run.file("frd")), None
        error = failure(run)
        if on_stop is not None:
            on_stop(run)
        if run.outcome is Outcome.CANCELLED:
            raise error
        if not keep:
            return run, None, error
        try:
            # a diverged run's last output (its residuals) is set apart by the reader
            frd: FrdFile | None = read_frd(run.file("frd"), allow_truncated=True)
        except ResultsError:
            frd = None
        return run, frd, error


def inflate(spec: ModelSpec, mesh: TyreMesh, pressure: float, settings: SolverSettings,
            should_stop: Callable[[], bool] | None = None) -> tuple[CcxRun, float]:
    """Inflate the tyre alone; return the run and the lowest tread z afterwards."""
    deck = D.assemble(
        D.mesh_lines(mesh), D.material_lines(spec.materials), D.cord_lines(spec, mesh),
        D.measured_set_lines(("TREAD_OUTER",)),
        D.static_step_lines(1.0, settings), D.support_lines(spec),
        D.cavity_pressure_lines(mesh, pressure, None),
        ["*NODE FILE, NSET=MEASURED", "U", "*END STEP"],
    )
    run, frd = run_deck(deck, settings, should_stop, "inflate")
    block = frd.results_named("DISP")[-1]
    z = mesh.xyz(block.node_ids)[:, 2] + block.values[:, 2]
    return run, float(z.min())


def touch_height(spec: ModelSpec, mesh: TyreMesh, pressure: float, settings: SolverSettings,
                 should_stop: Callable[[], bool] | None = None) -> tuple[float, CcxRun | None]:
    """Where the road first touches the inflated tyre: cached per model, pressure, solver.

    Every load path at one pressure needs the same inflation pre-run; a sweep that splits
    paths (or re-runs one) reads it from the cache instead. Returns the height and the
    run, or ``None`` when the cache answered.
    """
    key = {"model": spec.to_dict(), "mesh": mesh.mesh_key, "pressure": pressure,
           "solver": ccx_version()}
    entry = read_entry("inflation", key)
    if entry is not None and isinstance(entry.get("touch_z"), float):
        return entry["touch_z"], None
    run, z = inflate(spec, mesh, pressure, settings, should_stop)
    write_entry("inflation", key, {"touch_z": z})
    return z, run


def path_deck(spec: ModelSpec, mesh: TyreMesh, path: LoadPath, settings: SolverSettings,
              touch_z: float, *, model: Sequence[str] = (),
              then: Sequence[str] = ()) -> tuple[str, list[float], float]:
    """The one-run deck of a load path; returns (deck, output times, road start z).

    The output times are those of the deflections, then (combined loads) those of the
    motion fractions: ``t0 + 1 + f`` for each f of ``path.motion_fractions``. ``model``
    lines go at the end of the model definition, ``then`` after the step (a trunk's
    restart output and further steps, :mod:`farm.solve.tree`).
    """
    if path.motion is not None:
        return _combined_deck(spec, mesh, path, settings, touch_z, model, then)
    gap = road_gap(spec)
    travel = gap + path.deflections[-1]
    t0 = 1.0 if spec.inflated else 0.0
    times = [t0 + (gap + d) / travel for d in path.deflections]
    z_road = touch_z - gap
    road = road_of(spec, mesh, z_road)
    amplitudes = ["*AMPLITUDE, NAME=ROAD_RAMP", f"0, 0, {t0}, 0, {t0 + 1}, 1"]
    pressure: list[str] = []
    if spec.inflated:
        amplitudes += ["*AMPLITUDE, NAME=INFLATE", "0, 0, 1, 1, 2, 1"]
        pressure = D.cavity_pressure_lines(mesh, path.pressure, "INFLATE")
    out_times = ([1.0] if spec.inflated else []) + times
    deck = D.assemble(
        D.mesh_lines(mesh), D.material_lines(spec.materials), D.cord_lines(spec, mesh), road.lines,
        D.contact_lines(mesh, spec.contact), amplitudes, D.time_points_lines(out_times),
        D.measured_set_lines((*D.written_sets(mesh), "ROAD")), model,
        D.static_step_lines(t0 + 1.0, settings), D.support_lines(spec),
        ["*BOUNDARY, AMPLITUDE=ROAD_RAMP", "ROAD, 1, 2, 0", f"ROAD, 3, 3, {travel!r}"],
        pressure, D.output_lines(time_points=True, contact=True), ["*END STEP"], then,
    )
    return deck, times, z_road


def stage(spec: ModelSpec, path: LoadPath, time: float,
          split: D.Split | None = None) -> str:
    """What a path's deck does at total ``time`` (:func:`path_deck`'s time layout, cut by
    ``split`` when it was, :func:`rise_split`): the inflation, a tilted road's turn, the
    rise (at which deflection: first touch is 0), or the slide (how far along it)."""
    time = split.layout(time) if split is not None else time
    t0 = 1.0 if spec.inflated else 0.0
    if time < t0:
        return f"in the inflation, {100 * time:.0f} % of the pressure"
    motion = path.motion
    gap = _combined_gap(spec, path) if motion is not None else road_gap(spec)
    tilt = TILT_TIME if motion is not None and motion.tilt else 0.0
    if time < t0 + tilt:
        return f"while the road turns to its tilt, {100 * (time - t0) / tilt:.0f} % of it"
    if time <= t0 + 1.0 or motion is None or not motion.moves:
        travel = gap + path.deflections[-1]
        d = travel * min(1.0, (time - t0 - tilt) / (1.0 - tilt)) - gap
        return (f"in the rise, {d:.2f} mm deflection" if d >= 0 else
                f"in the rise, {-d:.2f} mm before first touch")
    return f"in the slide, {100 * min(1.0, time - t0 - 1.0):.0f} % of it"


def road_of(spec: ModelSpec, mesh: TyreMesh, z_road: float) -> D.Road:
    return D.road_slab(mesh, z_road, half_length=0.8 * spec.geometry.outer_radius,
                       half_width=0.6 * spec.geometry.section_width)


TILT_TIME = 0.25  # fraction of the rise ramp in which a tilted road turns, still clear


def _motion(path: LoadPath) -> RoadMotion:
    """The road motion of a combined path."""
    # path_deck and solve_contact_path dispatch here only when path.motion is set
    assert path.motion is not None, "combined-load helpers need a path with a motion"
    return path.motion


def _combined_gap(spec: ModelSpec, path: LoadPath) -> float:
    """Initial clearance of a combined path's road (:func:`tilted_gap`)."""
    return tilted_gap(spec, _motion(path).tilt)


def tilted_gap(spec: ModelSpec, tilt: float) -> float:
    """Initial clearance of a road tilted by ``tilt`` degrees: it must turn clear of the
    tyre, whose tread spans +-section_width/2 (the tilt lifts one side by that times the
    sine); :func:`road_gap` for an untilted one."""
    lift = 0.5 * spec.geometry.section_width * math.sin(math.radians(abs(tilt)))
    return road_gap(spec) + lift


def _combined_times(spec: ModelSpec, path: LoadPath) -> list[float]:
    """Output times of a combined path: its deflections, then its shift fractions."""
    gap = _combined_gap(spec, path)
    travel = gap + path.deflections[-1]
    t0 = 1.0 if spec.inflated else 0.0
    motion = _motion(path)
    s = TILT_TIME if motion.tilt else 0.0
    times = [t0 + s + (1.0 - s) * (gap + d) / travel for d in path.deflections]
    return times + ([t0 + 1.0 + f for f in path.motion_fractions] if motion.moves else [])


def _combined_deck(spec: ModelSpec, mesh: TyreMesh, path: LoadPath, settings: SolverSettings,
                   touch_z: float, model: Sequence[str] = (),
                   then: Sequence[str] = ()) -> tuple[str, list[float], float]:
    """Combined loads (issue 13): friction throughout, a tilt before the rise, a shift after.

    The shift gets a ramp of its own, one unit of step time after the rise (increments
    stay fractions of a ramp, as for the vertical path): [t0 + 1, t0 + 2]. A tilted road
    first turns in the first TILT_TIME of the rise ramp, started lower by the tilt's
    lift, so that its plane passes through the contact centre at each deflection's height
    (deflection keeps its meaning: the travel of the road under the wheel centre from the
    untilted road's first touch).
    """
    motion = _motion(path)
    gap = _combined_gap(spec, path)
    travel = gap + path.deflections[-1]
    t0 = 1.0 if spec.inflated else 0.0
    split = rise_split(spec, path, settings)
    times = _combined_times(spec, path)
    z_road = touch_z - gap
    road = road_of(spec, mesh, z_road)
    amplitudes, boundary = D.road_motion_lines(
        road, travel, (motion.shift_x, motion.shift_y), motion.tilt, t0,
        TILT_TIME if motion.tilt else 0.0, motion.rise, split)
    pressure: list[str] = []
    if spec.inflated:
        amplitudes += D.inflate_amplitude_lines(split)
        pressure = D.cavity_pressure_lines(mesh, path.pressure, "INFLATE")
    lam = motion.stick_slope if motion.stick_slope is not None else D.stick_slope(spec.contact)
    out_times = ([1.0] if spec.inflated else []) + times
    period = t0 + (2.0 if motion.moves else 1.0)
    controls = D.friction_controls_lines(settings.grow_after) if motion.friction > 0 else []
    outputs = D.output_lines(time_points=True, contact=True)
    rest: list[str] = []
    if split is not None:  # loads, boundaries and amplitudes carry over into the new step
        rest = [*D.static_step_lines(period - split.at + split.hold, settings,
                                     first=split.hold), *controls, *outputs, "*END STEP"]
    deck = D.assemble(
        D.mesh_lines(mesh), D.material_lines(spec.materials), D.cord_lines(spec, mesh), road.lines,
        D.contact_lines(mesh, spec.contact, (motion.friction, lam)), amplitudes,
        D.time_points_lines(out_times, split),
        D.measured_set_lines((*D.written_sets(mesh), "ROAD")), model,
        D.static_step_lines(period if split is None else split.at, settings), controls,
        D.support_lines(spec), boundary, pressure, outputs, ["*END STEP"], rest, then,
    )
    return deck, [split.time(t) for t in times] if split else times, z_road


def rise_split(spec: ModelSpec, path: LoadPath, settings: SolverSettings) -> D.Split | None:
    """Where a combined path's one-run deck is cut in two (``settings.split_rise``): at
    the start of the rise, after the inflation and the tilted road's turn, with the road
    still clear of the tyre by at least :func:`road_gap` (so nothing touches yet and the
    cut changes no physics). None when the path is not cut (no split asked, no motion, or
    nothing before the rise)."""
    if not settings.split_rise or path.motion is None:
        return None
    at = (1.0 if spec.inflated else 0.0) + (TILT_TIME if path.motion.tilt else 0.0)
    return D.Split(at) if at > 0 else None


def slave_faces(mesh: TyreMesh) -> np.ndarray:
    """Node ids of the contact slave faces (outer faces of tread elements), (F, 4)."""
    # outer_face 0: an element of a layered wall inside the tread (farm/mesh/layers.py)
    tread = np.flatnonzero((mesh.element_region == REGIONS.index("tread"))
                           & (mesh.outer_face > 0))
    return np.array([mesh.elements[e][HEX_FACES[mesh.outer_face[e] - 1]] for e in tread])


def slave_areas(faces: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Area of each slave node: a quarter of every adjacent face, indexed by node id - 1.

    ``positions`` holds the current coordinates of all tyre nodes, (n_nodes, 3).
    """
    p = positions[faces - 1]  # (F, 4, 3)
    area = 0.5 * np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=1)
    out = np.zeros(len(positions))
    np.add.at(out, faces.ravel() - 1, np.repeat(area / 4.0, 4))
    return out


def contact_forces(frd: FrdFile, mesh: TyreMesh, time: float, positions: np.ndarray,
                   faces: np.ndarray) -> np.ndarray:
    """Road force on each outer tread node (grid order), (n_tread, 3), N.

    Frictionless flat road: the force is the contact pressure (CPRESS) times the slave
    area along the road normal +z.
    """
    force = np.zeros((mesh.n_nodes, 3))
    blocks = [b for b in frd.results_named("CONTACT")
              if abs(b.time - time) <= TIME_RTOL * max(1.0, abs(time))]
    if blocks and len(blocks[-1].node_ids):
        block = blocks[-1]
        cpress = block.values[:, block.components.index("CPRESS")]
        ids = block.node_ids
        force[ids - 1, 2] = cpress * slave_areas(faces, positions)[ids - 1]
    tread = mesh.tread_nodes
    outside = np.ones(mesh.n_nodes, dtype=bool)
    outside[tread - 1] = False
    if np.any(force[outside] != 0):
        raise ResultsError("contact pressure on a node outside the outer tread")
    return force[tread - 1]


def road_frame(frd: FrdFile, mesh: TyreMesh, road: D.Road, time: float) -> np.ndarray:
    """Rows n, t1, t2 of the road's contact frame at ``time``, (3, 3).

    n is the normal of the (rigid, flat) road top in its current position, from the
    displaced top-layer nodes; t1, t2 are the tangents ccx uses for node-to-surface
    friction (``springforc_n2f``): t1 is the global x axis projected on the road (the
    z axis if the normal is x), t2 = n x t1. On an untilted road n, t1, t2 = z, x, y.
    """
    block = frd.at("DISP", time)
    ids = road.first_node + np.arange(len(road.xyz))
    top = ids[len(ids) // 2:]  # road_slab numbers the bottom layer first
    pos = road.xyz[len(ids) // 2:] + block.values_at(top)[:, :3]
    _, _, vt = np.linalg.svd(pos - pos.mean(axis=0))
    n = vt[2] * np.sign(vt[2][2])
    t1 = (np.array([0.0, 0.0, 1.0]) - n[2] * n if 1.0 - abs(n[0]) < 1.5231e-6
          else np.array([1.0, 0.0, 0.0]) - n[0] * n)
    t1 /= np.linalg.norm(t1)
    return np.stack([n, t1, np.cross(n, t1)])


# a node slips when its shear stress reaches mu p; .frd values carry 6 digits
SLIP_RTOL = 1e-4


def friction_forces(frd: FrdFile, mesh: TyreMesh, time: float, positions: np.ndarray,
                    faces: np.ndarray, frame: np.ndarray,
                    friction: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Road force, contact status and slip of each outer tread node (combined loads).

    The force is the contact stress times the slave area: pressure CPRESS along the
    road normal, shear CSHEAR1/CSHEAR2 along the tangents t1/t2 of :func:`road_frame`.
    ccx reports the shear as the tangential penalty spring's force on the slave over
    its area, i.e. the reaction of the tyre on the road: the road's force on the tyre
    is minus it (checked by equilibrium with the road's reactions, tests/farm/
    test_friction.py).

    Returns force (n_tread, 3) in N, status (n_tread,) int8 (see
    :data:`farm.solve.states.OPEN`) and slip (n_tread, 3) in mm, grid order.
    """
    n_nodes = mesh.n_nodes
    force, slip = np.zeros((n_nodes, 3)), np.zeros((n_nodes, 3))
    status = np.zeros(n_nodes, dtype=np.int8)
    blocks = [b for b in frd.results_named("CONTACT")
              if abs(b.time - time) <= TIME_RTOL * max(1.0, abs(time))]
    if blocks and len(blocks[-1].node_ids):
        block = blocks[-1]
        ids = block.node_ids
        p, s1, s2 = (block.column(c) for c in ("CPRESS", "CSHEAR1", "CSHEAR2"))
        c1, c2 = block.column("CSLIP1"), block.column("CSLIP2")
        n, t1, t2 = frame
        area = slave_areas(faces, positions)[ids - 1]
        force[ids - 1] = area[:, None] * (np.outer(p, n) - np.outer(s1, t1) - np.outer(s2, t2))
        slip[ids - 1] = np.outer(c1, t1) + np.outer(c2, t2)
        sliding = np.hypot(s1, s2) >= friction * p * (1.0 - SLIP_RTOL)
        status[ids - 1] = np.where(p > 0, np.where(sliding, SLIP, STICK), OPEN)
    tread = mesh.tread_nodes
    outside = np.ones(n_nodes, dtype=bool)
    outside[tread - 1] = False
    if np.any(force[outside] != 0):
        raise ResultsError("contact stress on a node outside the outer tread")
    return force[tread - 1], status[tread - 1], slip[tread - 1]


def combined_state(frd: FrdFile, mesh: TyreMesh, faces: np.ndarray, road: D.Road,
                    time: float, deflection: float, road_z: float, motion: RoadMotion,
                    seconds: float = np.nan) -> SolvedState:
    """A state of a combined-load path: 3-D tread forces, status, slip, road moment."""
    u = node_field(frd, "DISP", time, mesh.n_nodes)
    forc = frd.at("FORC", time)
    on_road = forc.node_ids > mesh.n_nodes
    rf = forc.values[on_road, :3]
    disp = frd.at("DISP", time)
    road_pos = (road.xyz[forc.node_ids[on_road] - road.first_node]
                + disp.values_at(forc.node_ids[on_road])[:, :3])
    centre = np.array([0.0, 0.0, road_z])
    positions = mesh.nodes + np.nan_to_num(u)
    force, status, slip = friction_forces(frd, mesh, time, positions, faces,
                                          road_frame(frd, mesh, road, time), motion.friction)
    return SolvedState(
        deflection=deflection, road_z=road_z, displacement=u,
        strain=inner_strain(frd, mesh, time), tread_force=force,
        road_reaction=rf.sum(axis=0), solve_seconds=seconds, motion=motion,
        contact_status=status, tread_slip=slip,
        road_moment=np.cross(road_pos - centre, rf).sum(axis=0),
    )


def path_state(frd: FrdFile, mesh: TyreMesh, faces: np.ndarray, time: float,
           deflection: float, road_z: float, seconds: float = np.nan) -> SolvedState:
    u = node_field(frd, "DISP", time, mesh.n_nodes)
    forc = frd.at("FORC", time)
    road = forc.values[forc.node_ids > mesh.n_nodes, :3].sum(axis=0)
    positions = mesh.nodes + np.nan_to_num(u)
    return SolvedState(
        deflection=deflection, road_z=road_z, displacement=u,
        strain=inner_strain(frd, mesh, time),
        tread_force=contact_forces(frd, mesh, time, positions, faces),
        road_reaction=road, solve_seconds=seconds,
    )


def solve_contact_path(spec: ModelSpec, mesh: TyreMesh, path: LoadPath,
                       settings: SolverSettings,
                       should_stop: Callable[[], bool] | None = None) -> PathSolution:
    """Solve ``path`` with rigid-road contact: one inflation run (if inflated) + one path run."""
    runs: list[CcxRun] = []
    touch_z = mesh.bottom_z
    if spec.inflated:
        touch_z, run = touch_height(spec, mesh, path.pressure, settings, should_stop)
        runs += [run] if run is not None else []
    deck, times, z_start = path_deck(spec, mesh, path, settings, touch_z)
    try:
        run, frd = run_deck(deck, settings, should_stop, "path")
    except SolverError as e:  # say where along the path it stopped (issue 29: failures are data)
        where = stage(spec, path, e.reached, rise_split(spec, path, settings)) \
            if e.reached is not None else None
        raise (e.located(where) if where is not None else e) from e
    runs.append(run)
    faces = slave_faces(mesh)
    gap = road_gap(spec)
    if path.motion is not None:
        return _combined_solution(spec, mesh, path, frd, faces, runs, times, z_start)
    if spec.inflated:
        reference = path_state(frd, mesh, faces, 1.0, 0.0, np.nan)
    else:
        reference = SolvedState(0.0, np.nan, np.zeros((mesh.n_nodes, 3)),
                                np.zeros((mesh.inner_nodes.size, 6)),
                                np.zeros((mesh.tread_nodes.size, 3)), np.zeros(3))
    before = sum(r.seconds for r in runs[:-1])  # the inflation run
    states = tuple(
        path_state(frd, mesh, faces, t, d, z_start + gap + d, before + run.seconds_to(t))
        for t, d in zip(times, path.deflections, strict=True)
    )
    return PathSolution(reference, states, sum(r.seconds for r in runs), len(runs),
                        sum(r.increments for r in runs))


def _combined_solution(spec: ModelSpec, mesh: TyreMesh, path: LoadPath, frd: FrdFile,
                       faces: np.ndarray, runs: list[CcxRun], times: list[float],
                       z_start: float) -> PathSolution:
    """States of a combined-load path: the deflections (friction, tilt), then the shift.

    The contact centre stays at (0, 0, height of the road under the wheel centre at the
    last deflection): the tilted road's plane passes through it, the wheel centre does
    not move, and a shift slides the road in its own plane.
    """
    gap = _combined_gap(spec, path)
    road = road_of(spec, mesh, z_start)
    run = runs[-1]
    before = sum(r.seconds for r in runs[:-1])
    motion = _motion(path)
    still = RoadMotion(friction=motion.friction, stick_slope=motion.stick_slope)
    if spec.inflated:  # inflated, road clear and not yet tilted
        reference = combined_state(frd, mesh, faces, road, 1.0, 0.0, np.nan, still)
    else:
        n_tread = mesh.tread_nodes.size
        reference = SolvedState(0.0, np.nan, np.zeros((mesh.n_nodes, 3)),
                                np.zeros((mesh.inner_nodes.size, 6)), np.zeros((n_tread, 3)),
                                np.zeros(3), motion=still,
                                contact_status=np.zeros(n_tread, dtype=np.int8),
                                tread_slip=np.zeros((n_tread, 3)), road_moment=np.zeros(3))
    cases = [(d, z_start + gap + d, motion.scaled(0.0)) for d in path.deflections]
    last = path.deflections[-1]
    if motion.moves:  # friction alone has no motion ramp (path_deck's times)
        cases += [(last, z_start + gap + last, motion.scaled(f)) for f in path.motion_fractions]
    states = tuple(
        combined_state(frd, mesh, faces, road, t, d, z, m, before + run.seconds_to(t))
        for t, (d, z, m) in zip(times, cases, strict=True)
    )
    return PathSolution(reference, states, sum(r.seconds for r in runs), len(runs),
                        sum(r.increments for r in runs))
