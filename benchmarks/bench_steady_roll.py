"""A steady lateral force within a short roll: rolls at a slip angle started with a
lateral lead, side by side with the roll from rest (issue 45: "steady state on the
converged mesh"; docs/rolling.md, "A steady roll"); and the slip-ratio and camber rolls
of the same tyre.

    .venv/bin/python benchmarks/bench_steady_roll.py [--mesh PRESET | --wall T,S,B
        --circumferential N] [--materials NAME] [--pressure KPA] [--deflection MM]
        [--friction MU] [--radius MM] [--alphas DEG,..] [--sigmas MM,..] [--leads MM,..]
        [--kappas K,..] [--leads-x MM,..] [--tilts DEG,..] [--distance MM] [--windows N]
        [--from-rest]

Fy relaxes over about 0.7 m (a first-order lag of length sigma): a roll from rest would
need 3 m to come within 1 % of its steady value, more than a windowed mesh can roll
with the patch in its window. In the stretched-string model the steady carcass
deflection at the patch's leading edge is sigma tan(alpha); a roll whose road leads by
that much (``Roll.lead`` = -sigma tan(alpha), eased in over its first 96 mm) starts
there. For each slip angle and each ``--sigmas`` value (the lead it gives) or
``--leads`` value (mm, as given), and with ``--from-rest`` also without a lead: one roll
of ``--distance`` mm; printed, the pitch means of Fx, Fy, Mz (the road's axes) and the
trail over ``--windows`` element pitches spread from the ramp's end to the roll's end,
the drift of the force between the first and the last of them (% of the last, and N per
100 mm); then, over the led rolls of a slip angle, the steady Fy and the relaxation
length of the first-order lag through their ends (F = F_ss - sigma dF/ds: two rolls fix
both). Leads on both sides of the right one bracket the steady value: their drifts have
opposite signs. ``--kappas``: rolls at those slip ratios, led along x by each of
``--leads-x`` (``Roll.lead_x``, the longitudinal lead: Fx bracketed as Fy is) or from
rest (Fx on ``lean`` has not settled within 200 mm from rest), and the slope of Fx in
kappa: the slip stiffness; ``--tilts``: rolls at those cambers (the camber force Fy in
the road's axes, led by ``--leads`` where given, else from rest). Nothing is asserted
(noisy machines); each solve's wall seconds are printed.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

import numpy as np
from rolled_model import model

from analysis.relaxation import flat_lead, secant
from farm.measure.axes import in_road_axes
from farm.mesh import mesh_for
from farm.solve.contact import touch_height
from farm.solve.rolling import element_pitch, estimated_radius, solve_roll
from farm.specs import LEAD_RAMP_MM, Roll, SolverSettings

PER_PITCH = 8


def _args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mesh", default="", help="a mesh preset (e.g. lean); else --wall")
    p.add_argument("--wall", default="8,5,2", help="tread, sidewall, bead elements")
    p.add_argument("--circumferential", type=int, default=32)
    p.add_argument("--materials", default="table-3.1")
    p.add_argument("--pressure", type=float, default=200.0, help="kPa")
    p.add_argument("--deflection", type=float, default=15.0, help="mm")
    p.add_argument("--friction", type=float, default=0.6)
    p.add_argument("--radius", default="404.86", help="rolling radius, mm, or 'estimate' "
                   "(R - 0.59 d, farm.solve.rolling.estimated_radius)")
    p.add_argument("--alphas", default="0.5", help="slip angles, degrees ('' for none)")
    p.add_argument("--sigmas", default="671", help="relaxation lengths (mm) whose leads "
                   "-sigma tan(alpha) are rolled")
    p.add_argument("--distance", type=float, default=320.0, help="each roll, mm")
    p.add_argument("--windows", type=int, default=3, help="pitch means along the roll")
    p.add_argument("--leads", default="", help="leads (mm, the road's lateral axis) "
                   "rolled at every slip angle and camber")
    p.add_argument("--kappas", default="", help="slip ratios rolled (Fx), led by "
                   "--leads-x where given, else from rest")
    p.add_argument("--leads-x", default="", help="longitudinal leads (mm, the road's x; > 0 "
                   "with a driving slip) rolled at every slip ratio")
    p.add_argument("--tilts", default="", help="cambers, degrees (road tilt about +x)")
    p.add_argument("--from-rest", action="store_true", help="also each roll without lead")
    p.add_argument("--timeout", type=float, default=10800.0, help="seconds a roll may take")
    p.add_argument("--grow-after", type=int, default=4, help="ccx's IG (solver.grow_after; "
                   "the answer's study rolls `lean` with 10)")
    return p.parse_args()


def windows(spec, roll: Roll, n: int) -> list[list[float]]:
    """Fractions of ``n`` element pitches of ``PER_PITCH`` states each, the last ending at
    the roll's end, the first starting where a lead's ramp ends (or at a pitch)."""
    pitch = element_pitch(spec, roll)
    first_end = max(LEAD_RAMP_MM, pitch) + pitch
    ends = np.linspace(first_end, roll.distance, n) if n > 1 else [roll.distance]
    if ends[0] > roll.distance:
        raise SystemExit(f"--distance {roll.distance:g} mm is too short for a pitch of "
                         f"{pitch:.1f} mm after the {LEAD_RAMP_MM:g} mm ramp")
    return [[(end - pitch + k * pitch / PER_PITCH) / roll.distance
             for k in range(1, PER_PITCH + 1)] for end in ends]


def one(spec, mesh, a, roll: Roll, label: str, axis: int = 1) -> tuple[float, float]:
    """Roll once; print its pitch means (forces and Mz in the road's axes) and the drift
    of force component ``axis`` (0 Fx, 1 Fy); return (its last mean, its slope N/mm)."""
    parts = windows(spec, roll, a.windows)
    fractions = sorted({round(f, 9) for part in parts for f in part})
    t0 = time.perf_counter()
    states = solve_roll(spec, mesh, a.deflection, a.pressure / 1000.0, roll,
                        SolverSettings(timeout=a.timeout, grow_after=a.grow_after), fractions)
    wall = time.perf_counter() - t0
    at = {round(f, 9): s for f, s in zip(fractions, states, strict=True)}
    print(f"alpha {roll.slip_angle:g} deg, kappa {roll.slip_ratio:g}, camber "
          f"{roll.tilt:g} deg, {label}: {wall:.0f} s", flush=True)
    means, travel = [], []
    for part in parts:
        chunk = [at[round(f, 9)] for f in part]
        force = in_road_axes(np.array([s.force for s in chunk]), roll.tilt).mean(axis=0)
        mz = in_road_axes(np.array([s.moment for s in chunk]), roll.tilt)[:, 2].mean()
        means.append(force[axis])
        travel.append(chunk[-1].travelled)
        # the trail -Mz/Fy (road axes) means nothing without a lateral force, nor under
        # camber, whose Mz is not that of a force behind the contact centre
        lateral = abs(force[1]) > 0.01 * force[2] and not roll.tilt
        trail = -mz / force[1] if lateral else math.nan
        print(f"  {chunk[0].travelled:6.1f}-{chunk[-1].travelled:6.1f} mm  Fx {force[0]:8.1f} N"
              f"  Fy {force[1]:9.1f} N  Mz {mz / 1e3:7.2f} N m  trail {trail:6.1f} mm  "
              f"Fz {force[2]:7.1f} N")
    first, last = means[0], means[-1]
    slope = (last - first) / (travel[-1] - travel[0])
    print(f"  drift of F{'xy'[axis]} {100.0 * (last - first) / abs(last):+.2f} % "
          f"({100 * slope:+.2f} N per 100 mm)", flush=True)
    return last, slope


def _led(spec, mesh, a, roll: Roll, leads: list[tuple[float, str]], axis: int = 1
         ) -> float:
    """The led rolls of one slip angle or camber (``axis`` 1: lateral leads, Fy) or slip
    ratio (0: longitudinal leads, Fx), their secant, and the roll from rest; returns the
    secant's steady force (with one lead, that roll's last mean; none: the roll from
    rest's)."""
    name = ("lead_x", "lead")[axis]
    ends = [one(spec, mesh, a, dataclasses.replace(roll, **{name: round(lead, 3)}), label,
                axis) for lead, label in leads]
    steady = ends[0][0] if ends else math.nan
    if len(ends) > 1:
        steady, sigma = secant(ends)
        flat = flat_lead([lead for lead, _ in leads], [slope for _, slope in ends])
        print(f"alpha {roll.slip_angle:g} deg, kappa {roll.slip_ratio:g}, camber "
              f"{roll.tilt:g} deg: steady F{'xy'[axis]} {steady:.1f} N, sigma {sigma:.0f} mm "
              f"(first-order secant over the {len(ends)} led rolls; leads whose drifts "
              f"have opposite signs bracket the steady force); flat lead {flat:.2f} mm "
              f"(the drifts interpolated), the carcass's stiffness {abs(steady / flat):.0f} "
              "N/mm", flush=True)
    if a.from_rest or not leads:
        rest = one(spec, mesh, a, roll, "from rest", axis)[0]
        steady = rest if not leads else steady
    return steady


def _floats(text: str) -> list[float]:
    return [float(x) for x in text.split(",") if x.strip()]


def main() -> None:
    a = _args()
    spec = model(a)
    mesh = mesh_for(spec)
    touch_height(spec, mesh, a.pressure / 1000.0, SolverSettings())  # cached first
    a.radius = (estimated_radius(spec, mesh, a.deflection, a.pressure / 1000.0,
                                 SolverSettings()) if a.radius == "estimate" else float(a.radius))
    print(f"{mesh.n_nodes} nodes; {a.pressure:g} kPa, {a.deflection:g} mm, mu "
          f"{a.friction:g}, r_e {a.radius:.2f} mm, {a.distance:g} mm rolls", flush=True)
    roll = Roll(friction=a.friction, distance=a.distance, rolling_radius=a.radius)
    given = [(lead, f"lead {lead:.2f} mm") for lead in _floats(a.leads)]
    for alpha in _floats(a.alphas):
        leads = [(-s * math.tan(math.radians(alpha)), s) for s in _floats(a.sigmas)]
        _led(spec, mesh, a, dataclasses.replace(roll, slip_angle=alpha),
             [(lead, f"lead {lead:.2f} mm (sigma {s:g})") for lead, s in leads] + given)
    for tilt in _floats(a.tilts):
        _led(spec, mesh, a, dataclasses.replace(roll, tilt=tilt), given)
    _slip_ratios(spec, mesh, a, roll)


def _slip_ratios(spec, mesh, a, roll: Roll) -> None:
    """Fx at each of ``--kappas`` (led by ``--leads-x``, else from rest) and the slip
    stiffness through them."""
    leads = [(lead, f"lead along x {lead:.2f} mm") for lead in _floats(a.leads_x)]
    ends = {k: _led(spec, mesh, a, dataclasses.replace(roll, slip_ratio=k), leads, 0)
            for k in _floats(a.kappas)}
    if len(ends) > 1:
        stiffness, offset = np.polyfit(list(ends), list(ends.values()), 1)
        of = "the secants" if len(leads) > 1 else "the last windows"
        print(f"Fx: {stiffness / 1e3:.1f} kN per unit slip, Fx(0) {offset:.1f} N (least "
              f"squares over kappa {min(ends):g}..{max(ends):g} of {of}; a slip stiffness "
              "only where the drifts above bracket or are small)", flush=True)


if __name__ == "__main__":
    main()
