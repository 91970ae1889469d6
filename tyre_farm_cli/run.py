"""``farm run``: solve one load path locally (no cluster) and print the force table.

Every argument is checked before the solver starts (docs/limits.md), ``--out`` and
``--vtu`` included: a path that cannot be written must not cost a finished solve.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TaskID, TextColumn, TimeElapsedColumn
from rich.table import Table

from farm.ccx.progress import SolverProgress, reporting
from farm.ccx.runner import find_ccx
from farm.errors import SpecError
from farm.experiment import PathResult, run_load_path
from farm.mesh import mesh_for
from farm.presets import describe_model
from farm.specs import (
    MAX_PRESSURE_MPA,
    THREADS,
    TIMEOUT_S,
    LoadPath,
    RoadMotion,
    SolverSettings,
)
from jobs.errors import StudyError
from jobs.validate import limits, scalars
from jobs.wording import plural
from tyre_farm_cli.checks import output_file, output_folder
from tyre_farm_cli.errors import usage
from tyre_farm_cli.jsondoc import dump
from tyre_farm_cli.params import (
    MATERIALS_OPTION,
    MESH_OPTION,
    THREADS_OPTION,
    build_model,
    kpa_hint,
    parse_range,
)
from tyre_farm_cli.progress import LogLines, console, interactive

PEAK_NOTE = ("* the largest nodal contact pressure: mesh-dependent, it does not converge "
             "with refinement (docs/mesh-convergence.md); compare it only on one mesh")


MODEL = typer.Option("full", "--model", "-m", help="Tyre model: full or reduced.")
PRESSURE = typer.Option(
    None, "--pressure", "-p", help="Inflation pressure, kPa [default: 200 full, 0 reduced].")
DEFLECTION = typer.Option(
    "10:40:5", "--deflection", "-d", help="Deflections, mm: start:stop:step or a list.")
ROAD = typer.Option(
    None, "--road", help="Road boundary: iterative or contact [default: contact for the full "
    "model, iterative for the reduced one].")
OVERRIDES = typer.Option(
    [], "--set", help="Override a model setting, e.g. --set mesh.circumferential=80.")
TIMEOUT = typer.Option(1800.0, "--timeout", help="Seconds per ccx run.")
OUT = typer.Option(None, "--out", help="Save the arrays to this .npz file [default: none "
                   "saved].")
KEEP = typer.Option(False, "--keep", help="Keep the solver's scratch directories.")
VTU = typer.Option(None, "--vtu", help="Write the deformed tyre per deflection as ParaView "
                   "VTU files into this folder [default: none].")
FRICTION = typer.Option(0.0, "--friction", help="Combined loads (contact road): Coulomb "
                        "friction coefficient mu, 0-2 [default: 0, none].")
SHIFT_X = typer.Option(0.0, "--shift-x", help="Combined loads: slide the road along x after "
                       "the last deflection, mm, -50 to 50.")
SHIFT_Y = typer.Option(0.0, "--shift-y", help="Combined loads: slide the road along its "
                       "lateral axis after the last deflection, mm.")
TILT = typer.Option(0.0, "--tilt", help="Combined loads: road tilt about x (camber, +y side "
                    "up), degrees, -10 to 10.")
JSON_OPTION = typer.Option(False, "--json", help="Print the results as one JSON document "
                           "instead of the table.")


def run(
    model: str = MODEL, pressure: float = PRESSURE, deflection: str = DEFLECTION,
    road: str = ROAD, materials: str = MATERIALS_OPTION, mesh: str = MESH_OPTION,
    overrides: list[str] = OVERRIDES, threads: int = THREADS_OPTION, timeout: float = TIMEOUT,
    out: Path = OUT, keep: bool = KEEP, vtu: Path = VTU, friction: float = FRICTION,
    shift_x: float = SHIFT_X, shift_y: float = SHIFT_Y, tilt: float = TILT,
    as_json: bool = JSON_OPTION,
) -> None:
    """Solve one load path (one model, one pressure, several deflections) and print a table."""
    with usage():
        spec = build_model(model, materials, road, overrides, mesh)
        kpa = (200.0 if spec.inflated else 0.0) if pressure is None else pressure
        motion = RoadMotion(friction=friction, shift_x=shift_x, shift_y=shift_y, tilt=tilt)
        path, settings = _checked(spec, kpa, deflection, threads, timeout, keep, out, vtu,
                                  motion)
    find_ccx()  # fail before meshing if the solver is missing
    if keep:
        scratch = Path(f"farm-run-{time.strftime('%Y%m%d-%H%M%S')}").resolve()
        os.environ["FARM_SCRATCH_DIR"] = str(scratch)
    result = _solve(spec, path, settings, kpa)
    if as_json:
        dump(_document(result, kpa))
    else:
        _print_table(result, kpa, _patches(result))  # on stdout; the notes on stderr
    if keep:
        Console(stderr=True).print(f"solver files kept in {scratch}")
    _save(result, spec, out, vtu)


def _save(result, spec, out: Path | None, vtu: Path | None) -> None:
    """The arrays (``--out``) and the deformed tyre (``--vtu``), where asked for."""
    if out is not None:
        result.save(out, mesh_for(spec))
        Console(stderr=True).print(f"arrays saved to {out}")
    if vtu is not None:
        from farm.export import path_vtus

        files = path_vtus(result, mesh_for(spec), vtu)
        Console(stderr=True).print(f"{plural(len(files), 'VTU file')} written to {vtu}")


HEARTBEAT_SECONDS = 10.0  # a solve runs for minutes: a line now and then, not a flood


class RunLines:
    """The stages of ``farm run`` on stderr (meshing, solving, done), and while ccx runs
    how far it has got, read from its ``.sta`` file (issue 48; :mod:`farm.ccx.progress`):
    a bar on a terminal, else a line every :data:`HEARTBEAT_SECONDS` (a solve once
    printed nothing for 40-110 s, and then only the seconds)."""

    def __init__(self, lines: LogLines | None = None, bar: bool | None = None) -> None:
        self.lines = lines or LogLines(every=HEARTBEAT_SECONDS)
        self.start = time.perf_counter()
        self.seen: SolverProgress | None = None
        self.bar = interactive() if bar is None else bar
        self._bar: Progress | None = None
        self._task: TaskID | None = None

    def stage(self, text: str) -> None:
        self.lines.log(f"run: {text}")

    def report(self, progress: SolverProgress) -> None:
        """The :func:`farm.ccx.progress.reporting` callback: remember the latest look."""
        self.seen = progress

    def solving(self) -> Callable[[], bool]:
        """The solver's ``should_stop`` poll, used as a clock: it never stops the run."""
        start = time.perf_counter()
        self.lines.last = self.lines.clock()  # the first beat after a period, not at once
        if self.bar:
            self._bar = Progress(TextColumn("run: solving"), BarColumn(),
                                 TextColumn("{task.description}"), TimeElapsedColumn(),
                                 console=console(), transient=True)
            self._bar.start()
            self._task = self._bar.add_task("", total=1.0)

        def poll() -> bool:
            where = self.seen.describe() if self.seen else "starting"
            if self._bar is not None and self._task is not None:
                self._bar.update(self._task, completed=self.seen.fraction if self.seen else 0,
                                 description=where)
            else:
                self.lines.progress(f"run: solving, {where}, "
                                    f"{time.perf_counter() - start:.0f} s")
            return False

        return poll

    def close(self) -> None:
        """Stop the bar, if one runs."""
        if self._bar is not None:
            self._bar.stop()
            self._bar = None


def _solve(spec, path: LoadPath, settings: SolverSettings, kpa: float) -> PathResult:
    """Mesh and solve, saying so on stderr (stdout keeps the results only)."""
    lines = RunLines()
    lines.stage(describe_model(spec))
    if hint := kpa_hint(kpa):
        lines.stage(hint)
    lines.stage(f"meshing the {spec.kind} model (cached after the first run)")
    mesh = mesh_for(spec)
    lines.stage(f"mesh ready: {plural(mesh.n_nodes, 'node')}, "
                f"{time.perf_counter() - lines.start:.1f} s")
    lines.stage(f"solving {plural(len(path.deflections), 'deflection')} at {kpa:g} kPa on the "
                f"{spec.road} road with ccx")
    try:
        with reporting(lines.report):
            result = run_load_path(spec, path, settings, should_stop=lines.solving())
    finally:
        lines.close()
    lines.stage(f"done in {time.perf_counter() - lines.start:.1f} s: "
                f"{plural(result.ccx_runs, 'ccx run')}, "
                f"{plural(result.increments, 'increment')}")
    return result


def _checked(spec, kpa: float, deflection: str, threads: int, timeout: float, keep: bool,
             out: Path | None, vtu: Path | None, motion: RoadMotion | None = None
             ) -> tuple[LoadPath, SolverSettings]:
    """The load path and solver settings, every bound checked (raises SpecError)."""
    try:
        scalars.number(kpa, "--pressure", low=0, high=1000 * MAX_PRESSURE_MPA)
        scalars.integer(threads, "--threads", low=THREADS[0], high=THREADS[1])
        scalars.number(timeout, "--timeout", low=TIMEOUT_S[0], high=TIMEOUT_S[1])
        deflections = parse_range(deflection)
        limits.EXPERIMENTS.check(len(deflections), "--deflection",
                                 f"a path of {len(deflections)} deflections")
        if out is not None:
            output_file(out, "--out")
        if vtu is not None:
            output_folder(vtu, "--vtu")
    except StudyError as e:
        raise SpecError(str(e)) from e
    _inflation(spec, kpa)
    # RoadMotion checked its bounds; check_against refuses it on the iterative road
    path = LoadPath(deflections, kpa / 1000.0, motion)
    path.check_against(spec)
    return path, SolverSettings(threads=threads, timeout=timeout, keep_scratch=keep)


def _inflation(spec, kpa: float) -> None:
    """The inflation check of :meth:`LoadPath.check_against`, in the CLI's kPa: the
    library's own message speaks its MPa ("got 0.2 MPa" for ``--pressure 200``)."""
    if spec.inflated and kpa <= 0:
        raise SpecError(f"--pressure: the {spec.kind} model is inflated: give a pressure "
                        "> 0 kPa, e.g. --pressure 200")
    if not spec.inflated and kpa > 0:
        raise SpecError(f"--pressure: the {spec.kind} model is not inflated (thesis Table "
                        f"3.1): give 0 kPa or leave --pressure out, got {kpa:g} kPa")


def _document(result: PathResult, kpa: float) -> dict:
    """The run as plain JSON: model, load path, one entry per state, the cost."""
    patches, growth = _patches(result)
    states = []
    for m, patch in zip(result.measurements, patches, strict=True):
        state = {"deflection_mm": m.deflection, "force_n": m.total_force.tolist(),
                 "moment_nm": (m.moment / 1e3).tolist(), "contact_nodes": m.contact_nodes,
                 "patch": patch.to_dict(), "solve_s": m.solve_seconds}
        if m.motion is not None:
            state["motion"] = m.motion.to_dict()
        states.append(state)
    return {"model": result.model.to_dict(), "pressure_kpa": kpa, "states": states,
            "inflation_growth_mm": growth, "ccx_runs": result.ccx_runs,
            "increments": result.increments, "solve_s": result.solve_seconds,
            "wall_s": result.wall_seconds, "solver": result.solver}


def _patches(result: PathResult) -> tuple[list, float | None]:
    """Each state's contact patch, and the inflation growth of an inflated model."""
    mesh = mesh_for(result.model)
    return result.patches(mesh), result.growth(mesh) if result.model.inflated else None


def _print_table(result: PathResult, kpa: float,
                 patches: tuple[list, float | None] | None = None) -> None:
    combined = result.path.motion is not None
    cols = ("deflection mm", *(("shift x mm", "shift y mm", "Fx N", "Fy N") if combined
                               else ()),
            "Fz N", "Mx N m", "My N m", "contact nodes",
            *(("area cm²", "peak kPa*") if patches else ()), "solve s")
    rows = [_table_row(m, combined, patches[0][k] if patches else None)
            for k, m in enumerate(result.measurements)]
    table = Table(title=_title(result, kpa), caption=_caption(result, patches))
    # on a narrow console (80 columns off a terminal) rich shrinks columns and cuts the
    # numbers ("3511…"); headers may wrap, values never
    for i, col in enumerate(cols):
        table.add_column(col, justify="right", min_width=max(len(r[i]) for r in rows))
    for row in rows:
        table.add_row(*row)
    Console().print(table, crop=False)


def _title(result: PathResult, kpa: float) -> str:
    spec, motion = result.model, result.path.motion
    moduli = "/".join(f"{m.youngs_modulus:g}" for m in spec.materials.by_region().values())
    title = f"{spec.kind} model, {kpa:g} kPa, {spec.road} road, E = {moduli} MPa"
    if motion is not None:
        title += (f"; mu {motion.friction:g}, tilt {motion.tilt:g} deg, shift "
                  f"({motion.shift_x:g}, {motion.shift_y:g}) mm after the last deflection")
    return title


def _table_row(m, combined: bool, patch) -> tuple[str, ...]:
    """One deflection's row; a combined path adds the shift and Fx, Fy (0 before it)."""
    areas = ((f"{patch.area / 100:.1f}", f"{patch.peak_pressure * 1e3:.0f}")
             if patch is not None else ())
    extra = ((f"{m.motion.shift_x:g}", f"{m.motion.shift_y:g}", f"{m.total_force[0]:.1f}",
              f"{m.total_force[1]:.1f}") if combined and m.motion is not None
             else ("0", "0", f"{m.total_force[0]:.1f}", f"{m.total_force[1]:.1f}")
             if combined else ())
    return (f"{m.deflection:g}", *extra, f"{m.total_force[2]:.1f}",
            f"{m.moment[0] / 1e3:.3f}", f"{m.moment[1] / 1e3:.3f}",
            str(m.contact_nodes), *areas, f"{m.solve_seconds:.1f}")


def _caption(result: PathResult, patches: tuple[list, float | None] | None) -> str:
    """Cost and solver; the inflation growth; and, with patches, what the starred peak
    pressure is (one caption: a table keeps only the last one set)."""
    timing = ("solve s: cumulative along the one-run path" if result.model.road == "contact"
              else "solve s: each deflection's iterations")
    caption = (f"{plural(result.ccx_runs, 'ccx run')}, "
               f"{plural(result.increments, 'increment')}, "
               f"{result.solve_seconds:.1f} s solver, {result.wall_seconds:.1f} s wall, "
               f"{result.solver}; {timing}")
    if patches and patches[1] is not None:
        caption += (f"; inflation growth {patches[1]:.2f} mm (crown, radial; thesis "
                    "§3.3.2: the real tyre at most 4 mm at 200 kPa)")
    return caption + (f"\n{PEAK_NOTE}" if patches else "")
