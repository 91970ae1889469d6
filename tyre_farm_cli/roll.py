"""``farm roll``: roll the inflated, deflected tyre once (issue 30) and print its forces.

One quasi-static roll in one ccx run (:mod:`farm.solve.rolling`, docs/rolling.md): slip
ratio, slip angle and camber, with forces, moments and stick/slip counts at points along
the roll. ``--rolling-radius free`` first finds the free-rolling radius (a few rolls).
Every argument is checked before the solver starts.
"""

from __future__ import annotations

import dataclasses
import math

import typer
from rich.console import Console
from rich.table import Table

from farm.ccx.progress import reporting
from farm.ccx.runner import find_ccx
from farm.errors import SpecError
from farm.experiment import RollOnce, roll_once
from farm.measure.axes import in_road_axes
from farm.presets import describe_model, mesh_name
from farm.solve.rolling import RolledState
from farm.specs import MAX_PRESSURE_MPA, THREADS, TIMEOUT_S, LoadPath, Roll, SolverSettings
from jobs.errors import StudyError
from jobs.validate import scalars
from tyre_farm_cli.errors import usage
from tyre_farm_cli.jsondoc import dump
from tyre_farm_cli.params import (
    MATERIALS_OPTION,
    MESH_OPTION,
    THREADS_OPTION,
    build_model,
    kpa_hint,
)
from tyre_farm_cli.progress import LogLines

MAX_SAMPLES = 100


PRESSURE = typer.Option(200.0, "--pressure", "-p", help="Inflation pressure, kPa.")
DEFLECTION = typer.Option(15.0, "--deflection", "-d", help="Deflection, mm.")
FRICTION = typer.Option(0.6, "--friction", help="Coulomb mu, 0-2.")
SLIP_RATIO = typer.Option(0.0, "--slip-ratio", help="Longitudinal slip kappa (SAE): > 0 "
                          "drives, < 0 brakes, -1 locks the wheel.")
SLIP_ANGLE = typer.Option(0.0, "--slip-angle", help="Slip angle, degrees, -20 to 20.")
TILT = typer.Option(0.0, "--tilt", help="Road tilt about x (camber), degrees.")
DISTANCE = typer.Option(150.0, "--distance", help="Road travel of the roll, mm.")
LEAD = typer.Option(0.0, "--lead", help="The road's lateral offset, mm, eased in over the "
                    "roll's first 96 mm: about the steady Fy over the carcass's lateral "
                    "stiffness (on lean -Fy/190 N/mm) starts a slip angle's roll at its "
                    "steady lateral force (docs/rolling.md, 'A steady roll').")
LEAD_X = typer.Option(0.0, "--lead-x", help="The road's offset along x, mm, eased in as "
                      "--lead is: about the steady Fx over the carcass's longitudinal "
                      "stiffness (on lean Fx/520 N/mm; > 0 with a driving slip) starts a "
                      "slip ratio's roll at its steady Fx (docs/rolling.md, 'A "
                      "longitudinal lead').")
ROLLING_RADIUS = typer.Option(
    "free", "--rolling-radius", help="Free-rolling radius r_e in mm that turns travel into "
    "spin, or 'free' to find it first (rolls until Fx = 0 at kappa = 0).")
SAMPLES = typer.Option(10, "--samples", help="States written along the roll.")
OVERRIDES = typer.Option(
    [], "--set", help="Override a model setting, e.g. --set mesh.circumferential=64.")
TIMEOUT = typer.Option(3600.0, "--timeout", help="Seconds per ccx run.")
RESTART_EVERY = typer.Option(
    0.0, "--restart-every", help="Restart points every so many mm of travel (10-10000; 0: "
    "none): a roll that stops, run again with the same arguments, goes on from its last "
    "point (kept in $FARM_CACHE_DIR; docs/rolling.md, 'Restart points').")
JSON_OPTION = typer.Option(False, "--json", help="Print one JSON document.")


def roll(
    pressure: float = PRESSURE, deflection: float = DEFLECTION, friction: float = FRICTION,
    slip_ratio: float = SLIP_RATIO, slip_angle: float = SLIP_ANGLE, tilt: float = TILT,
    distance: float = DISTANCE, lead: float = LEAD, lead_x: float = LEAD_X,
    rolling_radius: str = ROLLING_RADIUS,
    samples: int = SAMPLES, materials: str = MATERIALS_OPTION, mesh: str = MESH_OPTION,
    overrides: list[str] = OVERRIDES, threads: int = THREADS_OPTION,
    timeout: float = TIMEOUT, restart_every: float = RESTART_EVERY,
    as_json: bool = JSON_OPTION,
) -> None:
    """Roll the tyre once: forces, moments and stick/slip along the roll."""
    with usage():
        spec = build_model("full", materials, "contact", overrides, mesh)
        settings, fixed = _checked(spec, pressure, deflection, samples, threads, timeout,
                                   rolling_radius)
        settings = _with_restart_points(settings, restart_every)
        # every bound of the roll checked now (a placeholder radius when it is found later)
        motion = Roll(friction=friction, slip_ratio=slip_ratio, slip_angle=slip_angle,
                      tilt=tilt, distance=distance, rolling_radius=fixed or 400.0,
                      lead=lead, lead_x=lead_x)
    find_ccx()
    lines = LogLines(every=10.0)
    lines.log(f"roll: {describe_model(spec)}")
    if hint := kpa_hint(pressure):
        lines.log(f"roll: {hint}")
    lines.log(f"roll: meshing the full model ({mesh_name(spec) or 'a mesh of its own'})")
    stage = ["meshing"]

    def say(text: str) -> None:
        stage[0] = text
        lines.log(f"roll: {text}")
    with reporting(lambda p: lines.progress(f"roll: {stage[0]}, {p.describe()}")):
        done = roll_once(spec, deflection, pressure / 1000.0, motion, settings, samples,
                         find_radius=fixed is None, say=say)
    lines.flush()
    if as_json:
        dump(_document(spec, pressure, deflection, done))
    else:
        _print(pressure, deflection, done)


def _checked(spec, kpa: float, deflection: float, samples: int, threads: int,
             timeout: float, radius: str) -> tuple[SolverSettings, float | None]:
    """Solver settings and the fixed rolling radius (None: find it), bounds checked."""
    try:
        scalars.number(kpa, "--pressure", low=0, high=1000 * MAX_PRESSURE_MPA, strict=True)
        scalars.integer(samples, "--samples", low=1, high=MAX_SAMPLES)
        scalars.integer(threads, "--threads", low=THREADS[0], high=THREADS[1])
        scalars.number(timeout, "--timeout", low=TIMEOUT_S[0], high=TIMEOUT_S[1])
    except StudyError as e:
        raise SpecError(str(e)) from e
    LoadPath((deflection,), kpa / 1000.0).check_against(spec)
    if radius == "free":
        fixed = None
    else:
        try:
            fixed = float(radius)
        except ValueError:
            raise SpecError(f"--rolling-radius: give a radius in mm or 'free', got "
                            f"{radius!r}") from None
    return SolverSettings(threads=threads, timeout=timeout), fixed


def _with_restart_points(settings: SolverSettings, every: float) -> SolverSettings:
    """``settings`` with restart points every ``every`` mm; a bad spacing is one line
    naming the option."""
    try:
        return dataclasses.replace(settings, restart_every_mm=every)
    except SpecError as e:
        raise SpecError(f"--restart-every: {e}") from e


def _row(s: RolledState, tilt: float = 0.0) -> dict:
    """One state: forces and moments in the wheel's axes and, beside them, the road's
    (:mod:`farm.measure.axes`; the same where the road is not tilted)."""
    return {"travel_mm": s.travelled, "spin_deg": math.degrees(s.spin),
            "force_n": s.force.tolist(), "moment_nm": (s.moment / 1e3).tolist(),
            "force_road_axes_n": in_road_axes(s.force, tilt).tolist(),
            "moment_road_axes_nm": (in_road_axes(s.moment, tilt) / 1e3).tolist(),
            "stick_nodes": int((s.contact_status == 1).sum()),
            "slip_nodes": int((s.contact_status == 2).sum())}


def _found(done: RollOnce) -> dict | None:
    """The free-rolling search (None: the radius was given): Fx and Fz of each roll are
    means over its last element pitch, or its end state when shorter."""
    if not done.tried:
        return None
    return {"radius_mm": done.motion.rolling_radius,
            "tried": [{"radius_mm": t.radius, "fx_n": t.fx, "fz_n": t.fz} for t in done.tried]}


def _document(spec, kpa, deflection, done: RollOnce) -> dict:
    return {"model": spec.to_dict(), "pressure_kpa": kpa, "deflection_mm": deflection,
            "roll": dataclasses.asdict(done.motion), "inflated_radius_mm": done.inflated_radius,
            "free_rolling": _found(done),
            "states": [_row(s, done.motion.tilt) for s in done.states]}


def _print(kpa, deflection, done: RollOnce) -> None:
    motion, radius0 = done.motion, done.inflated_radius
    title = (f"roll of {motion.distance:g} mm at {kpa:g} kPa, {deflection:g} mm: mu "
             f"{motion.friction:g}, kappa {motion.slip_ratio:g}, slip angle "
             f"{motion.slip_angle:g} deg, tilt {motion.tilt:g} deg"
             + (f", lead {motion.lead:g} mm" if motion.lead else "")
             + (f", lead along x {motion.lead_x:g} mm" if motion.lead_x else ""))
    table = Table(title=title)
    # a tilted road: the road's axes (TYDEX, ISO 8855) beside the wheel's
    road = ("Fy road N", "Fz road N", "Mz road N m") if motion.tilt else ()
    cols = ("travel mm", "spin deg", "Fx N", "Fy N", "Fz N", "Mx N m", "My N m", "Mz N m",
            *road, "stick", "slip")
    rows = [(f"{r['travel_mm']:.1f}", f"{r['spin_deg']:.2f}",
             *(f"{v:.1f}" for v in r["force_n"]), *(f"{v:.2f}" for v in r["moment_nm"]),
             *((f"{r['force_road_axes_n'][1]:.1f}", f"{r['force_road_axes_n'][2]:.1f}",
                f"{r['moment_road_axes_nm'][2]:.2f}") if road else ()),
             str(r["stick_nodes"]), str(r["slip_nodes"]))
            for r in (_row(s, motion.tilt) for s in done.states)]
    for i, col in enumerate(cols):
        table.add_column(col, justify="right", min_width=max(len(r[i]) for r in rows))
    for row in rows:
        table.add_row(*row)
    table.caption = (f"r_e {motion.rolling_radius:.2f} mm"
                     + (f" (free rolling, {len(done.tried)} rolls)" if done.tried else "")
                     + f"; inflated radius {radius0:.2f} mm, loaded {radius0 - deflection:.2f}"
                     " mm; forces of the road on the tyre, moments about the contact centre"
                     + ("; wheel axes, and the road's (x, y in its plane, z its normal)"
                        if road else ""))
    Console().print(table, crop=False)
