"""Cost of a rolling experiment (issue 30) vs a slide on the same mesh, and how far a roll
must go before its forces settle (run: .venv/bin/python benchmarks/bench_rolling.py
[--circumferential N] [--wall T,S,B] [--distance MM] [--slip-ratio K] [--radius MM]).

Both cases are one ccx run from rest on the full model with ``table-3.1`` materials at
200 kPa and 15 mm, mu 0.6, the inflation pre-run cached before timing: a slide of 10 mm
along x (a combined-load experiment, :mod:`farm.solve.contact`) and a roll of
``--distance`` mm (:mod:`farm.solve.rolling`) with results at ten fractions. Printed side
by side: wall and CPU seconds of ccx, and their ratio roll / slide; then Fx, Fy, Fz
along the roll and the first travel after which every later Fx stays within 1 % of the
final one (the roll-in distance; "not settled" when only the last one does). Nothing is
asserted (noisy machines).

``--curves``: the rolling tyre's characteristic curves instead (issue 30): Fx against
the slip ratio (``--kappas``, empty: none) and Fy, Mz against the slip angle
(``--alphas``), one roll each at the given radius (``--radius free``: found first), the
values at the end of the roll; printed as tables with the slip stiffness dFx/dkappa and
the cornering stiffness dFy/dalpha fitted through the origin over the points with
|kappa| <= 0.005 and |alpha| <= 1 degree. Fy and Mz are means over the roll's last
element pitch (:mod:`farm.solve.trail`: on a polygon of a tyre Mz swings with where the
tread columns sit within the pitch), with the pneumatic trail -Mz/Fy of those means and
the trail about the centre of pressure. ``--figure PATH`` also draws them (PNG).
``--wall`` sets the elements through the wall.

``--relaxation``: how far Fy needs to roll (issue 30's roll-in), one roll of
``--distance`` mm per slip angle of ``--alphas`` at ``--radius``, results every eighth of
an element pitch; prints the pitch means of Fy, Mz and the trails along the roll, and
fits Fy(s) = F (1 - exp(-(s - s0) / sigma)) to them (scipy): the steady lateral force F,
the relaxation length sigma, and the secant cornering stiffness F / alpha. The fit is an
extrapolation where the roll is shorter than a few sigma (it says how much of F the roll
reached), and meaningless where Fy approaches mu Fz (the Fy/muFz column): a saturating
patch is not a first-order lag.
"""

from __future__ import annotations

import argparse
import dataclasses
import resource
import time

import numpy as np

from farm.errors import SolverError
from farm.experiment import run_load_path
from farm.mesh import mesh_for
from farm.presets import default_model
from farm.solve.contact import touch_height
from farm.solve.rolling import element_pitch, free_rolling_radius, last_pitch, solve_roll
from farm.solve.trail import pitch_mean
from farm.specs import LoadPath, MeshDensity, RoadMotion, Roll, SolverSettings

PRESSURE, DEFLECTION, MU = 0.2, 15.0, 0.6


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _timed(solve):
    cpu, wall = _children_cpu(), time.perf_counter()
    out = solve()
    return out, time.perf_counter() - wall, _children_cpu() - cpu


def settled(travel: np.ndarray, fx: np.ndarray, rtol: float = 0.01) -> float | None:
    """The first travel after which every Fx stays within ``rtol`` of the last (None
    when only the last one does)."""
    inside = np.abs(fx - fx[-1]) <= rtol * max(abs(fx[-1]), 1e-9)
    for k in range(len(fx) - 1):
        if inside[k:].all():
            return float(travel[k])
    return None


def curves(spec, mesh, settings, args) -> None:
    """Fx(kappa), Fy(alpha) and Mz(alpha) at the end of one roll each (see the module)."""
    if args.radius == "free":
        found, tried = free_rolling_radius(spec, mesh, DEFLECTION, PRESSURE,
                                           Roll(friction=MU, distance=args.distance),
                                           settings)
        print(f"free-rolling radius: {found:.2f} mm ({len(tried)} rolls; Fx over the last "
              f"pitch of the last {tried[-1].fx:.1f} N)", flush=True)
        args.radius = found
    base = Roll(friction=MU, distance=args.distance, rolling_radius=float(args.radius))
    kappas = [float(k) for k in args.kappas.split(",") if k.strip()]
    alphas = [float(a) for a in args.alphas.split(",") if a.strip()]

    def end(**kw):
        """The states over the last pitch of one roll, or None when ccx failed (printed:
        data)."""
        roll = dataclasses.replace(base, **kw)
        try:
            return solve_roll(spec, mesh, DEFLECTION, PRESSURE, roll, settings,
                              fractions=last_pitch(spec, roll))
        except SolverError as e:
            print(f"  {kw}: failed, {e.outcome} ({e.where})", flush=True)
            return None

    print(f"{'kappa':>8} {'Fx N':>9} {'Fx/muFz':>8}", flush=True)
    fx, fz = [], []
    for kappa in kappas:
        states = end(slip_ratio=kappa)
        fx.append(np.nan if states is None else float(np.mean([s.force[0] for s in states])))
        fz.append(np.nan if states is None else float(np.mean([s.force[2] for s in states])))
        print(f"{kappa:8.4f} {fx[-1]:9.1f} {fx[-1] / (MU * fz[-1]):8.3f}", flush=True)
    print(f"{'alpha deg':>9} {'Fy N':>9} {'Mz N m':>9} {'Mz range':>15} {'trail mm':>9} "
          f"{'cp trail':>9}", flush=True)
    fy, mz = [], []
    for alpha in alphas:
        states = end(slip_angle=alpha)
        mean = None if states is None else pitch_mean(states, mesh)
        fy.append(np.nan if mean is None else mean.fy)
        fz.append(np.nan if states is None else float(np.mean([s.force[2] for s in states])))
        mz.append(np.nan if mean is None else mean.mz / 1e3)
        if mean is not None:
            low, high = (v / 1e3 for v in mean.mz_range)
            print(f"{alpha:9.2f} {mean.fy:9.1f} {mean.mz / 1e3:9.2f} {low:7.2f}..{high:<6.2f} "
                  f"{mean.trail:9.1f} {mean.pressure_trail:9.1f}", flush=True)
    k, f = np.array(kappas), np.array(fx)
    small = (np.abs(k) <= 0.005) & np.isfinite(f)
    if small.any() and np.any(k[small]):
        c_k = float(k[small] @ f[small] / (k[small] @ k[small]))
        print(f"slip stiffness dFx/dkappa: {c_k:.0f} N per unit slip (small-slip fit)")
    a, f = np.radians(alphas), np.array(fy)
    small = (np.abs(np.array(alphas)) <= 1.0) & np.isfinite(f)
    if small.any() and np.any(a[small]):
        c_a = float(a[small] @ f[small] / (a[small] @ a[small]))
        print(f"cornering stiffness dFy/dalpha: {c_a:.0f} N/rad ({c_a * np.pi / 180:.1f} N/deg)")
    if args.figure:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        panels = ([(kappas, fx, "slip ratio kappa", "Fx (N)")] if kappas else []) + (
            [(alphas, fy, "slip angle (deg)", "Fy (N)"),
             (alphas, mz, "slip angle (deg)", "Mz (N m)")] if alphas else [])
        fig, ax = plt.subplots(1, len(panels), figsize=(4 * len(panels), 3.6), squeeze=False)
        ax = ax[0]
        limit = MU * float(np.nanmean(fz)) if np.isfinite(fz).any() else np.nan
        for axis, (x, y, xlabel, ylabel) in zip(ax, panels, strict=True):
            axis.plot(x, y, "o-")
            axis.set(xlabel=xlabel, ylabel=ylabel)
            if ylabel != "Mz (N m)" and np.isfinite(limit):  # where sliding caps it
                for sign in (1, -1):
                    axis.axhline(sign * limit, ls="--", c="grey", lw=0.8)
                axis.text(x[0], 0.9 * limit, "mu Fz", color="grey", fontsize=8)
        for axis in ax:
            axis.grid(alpha=0.3)
        fig.suptitle(f"rolling, {mesh.n_nodes} nodes, {PRESSURE * 1000:g} kPa, "
                     f"{DEFLECTION:g} mm, mu {MU:g},\nmeans over the last pitch of "
                     f"{args.distance:g} mm rolls, r_e {float(args.radius):.2f} mm",
                     fontsize=9)
        fig.tight_layout()
        fig.savefig(args.figure, dpi=110)
        print(f"figure: {args.figure}")


def relaxation(spec, mesh, settings, args) -> None:
    """Fy along long rolls, its relaxation fitted (see the module)."""
    from scipy.optimize import curve_fit

    for alpha in (float(a) for a in args.alphas.split(",") if a.strip()):
        roll = Roll(friction=MU, slip_angle=alpha, distance=args.distance,
                    rolling_radius=float(args.radius))
        per_pitch = 8
        pitches = int(args.distance // element_pitch(spec, roll))
        n = per_pitch * pitches
        fractions = [k / n * pitches * element_pitch(spec, roll) / args.distance
                     for k in range(1, n + 1)]
        states, wall, _ = _timed(lambda roll=roll, f=fractions: solve_roll(
            spec, mesh, DEFLECTION, PRESSURE, roll, settings, f))
        print(f"alpha {alpha:g} deg, {args.distance:g} mm roll, {wall:.0f} s; pitch means:")
        print(f"{'travel mm':>12} {'Fy N':>9} {'Mz N m':>8} {'trail mm':>9} {'cp trail':>9} "
              f"{'Fy/muFz':>8}", flush=True)
        travel, fy = [], []
        for k in range(pitches):
            part = states[k * per_pitch:(k + 1) * per_pitch]
            mean = pitch_mean(part, mesh)
            fz = float(np.mean([x.force[2] for x in part]))
            travel.append(float(np.mean([x.travelled for x in part])))
            fy.append(mean.fy)
            print(f"{part[0].travelled:5.0f}-{part[-1].travelled:<6.0f} {mean.fy:9.1f} "
                  f"{mean.mz / 1e3:8.2f} {mean.trail:9.1f} {mean.pressure_trail:9.1f} "
                  f"{mean.fy / (MU * fz):8.3f}", flush=True)
        s, f = np.array(travel), np.array(fy)
        if len(s) < 4:
            print("  too few pitches to fit a relaxation (roll at least 4 pitches)")
            continue
        try:
            (steady, sigma, s0), _ = curve_fit(
                lambda x, a, b, c: a * (1 - np.exp(-(x - c) / b)), s, f,
                p0=(2 * f[-1], 0.5 * s[-1], 0.0))
        except RuntimeError as e:  # no convergence: printed, the table stands
            print(f"  relaxation fit failed: {e}")
            continue
        worst = float(np.abs(steady * (1 - np.exp(-(s - s0) / sigma)) - f).max())
        print(f"  fit: steady Fy {steady:.0f} N, relaxation length {sigma:.0f} mm "
              f"(s0 {s0:.0f} mm, worst residual {worst:.2f} N); the roll reached "
              f"{100 * f[-1] / steady:.0f} % of it; secant cornering stiffness "
              f"{abs(steady / alpha):.0f} N/deg ({abs(steady / np.radians(alpha)):.0f} N/rad)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--circumferential", type=int, default=32)
    parser.add_argument("--distance", type=float, default=150.0)
    parser.add_argument("--slip-ratio", type=float, default=0.005)
    parser.add_argument("--radius", default="400.57",
                        help="free-rolling radius, mm (measured on 32 elements round, wall "
                             "4,2,1), or 'free' to find it first (--curves)")
    parser.add_argument("--wall", default="4,2,1",
                        help="elements through the tread, sidewall and bead: 4,2,1 (the "
                             "tests' coarse wall) or 8,5,2 (the thesis', `farm roll`'s)")
    parser.add_argument("--curves", action="store_true",
                        help="Fx(kappa), Fy(alpha), Mz(alpha) instead of the cost")
    parser.add_argument("--relaxation", action="store_true",
                        help="Fy along long rolls and its fitted relaxation instead")
    parser.add_argument("--kappas", default="-0.01,-0.005,-0.002,0,0.002,0.005,0.01")
    parser.add_argument("--alphas", default="-2,-1,-0.5,0.5,1,2,4")
    parser.add_argument("--figure", default=None)
    args = parser.parse_args()
    tread, sidewall, bead = (int(n) for n in args.wall.split(","))
    spec = default_model("full", mesh=MeshDensity(tread=tread, sidewall=sidewall, bead=bead,
                                                  circumferential=args.circumferential))
    if args.radius != "free" or not args.curves:
        args.radius = float(args.radius)
    mesh = mesh_for(spec)
    settings = SolverSettings()
    touch_height(spec, mesh, PRESSURE, settings)  # cached before timing
    if args.curves:
        curves(spec, mesh, settings, args)
        return
    if args.relaxation:
        relaxation(spec, mesh, settings, args)
        return
    _, slide_wall, slide_cpu = _timed(lambda: run_load_path(
        spec, LoadPath((DEFLECTION,), PRESSURE, RoadMotion(friction=MU, shift_x=10.0)),
        settings))
    fractions = tuple(np.round(np.linspace(0.1, 1.0, 10), 6))
    roll = Roll(friction=MU, slip_ratio=args.slip_ratio, distance=args.distance,
                rolling_radius=args.radius)
    states, roll_wall, roll_cpu = _timed(lambda: solve_roll(
        spec, mesh, DEFLECTION, PRESSURE, roll, settings, fractions))
    print(f"mesh: {mesh.n_nodes} nodes ({args.circumferential} elements round); "
          f"{PRESSURE * 1000:g} kPa, {DEFLECTION:g} mm, mu {MU:g}")
    print(f"{'case':<40} {'wall s':>8} {'cpu s':>8}")
    print(f"{'slide 10 mm along x':<40} {slide_wall:8.1f} {slide_cpu:8.1f}")
    print(f"{f'roll {args.distance:g} mm, kappa {args.slip_ratio:g}':<40} "
          f"{roll_wall:8.1f} {roll_cpu:8.1f}")
    print(f"ratio roll / slide: wall {roll_wall / slide_wall:.2f}x, "
          f"cpu {roll_cpu / slide_cpu:.2f}x")
    travel = np.array([s.travelled for s in states])
    fx = np.array([s.force[0] for s in states])
    for s in states:
        print(f"  {s.travelled:7.1f} mm  Fx {s.force[0]:9.1f}  Fy {s.force[1]:8.1f}  "
              f"Fz {s.force[2]:8.1f} N")
    where = settled(travel, fx)
    print("roll-in (Fx within 1 % of its last value from then on): "
          + (f"{where:g} mm" if where is not None else "not settled within the roll"))


if __name__ == "__main__":
    main()
