"""``farm calibrate``: fit region moduli (and thicknesses) to force-deflection points."""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import typer
from rich.console import Console

from jobs.progress import Progress, ccx_of
from jobs.wording import plural
from tyre_farm_cli.errors import usage
from tyre_farm_cli.frames import print_frame
from tyre_farm_cli.jsondoc import JSON, dump, records
from tyre_farm_cli.options import SCHEDULER, WORKERS, with_cluster
from tyre_farm_cli.params import MESH_HELP
from tyre_farm_cli.progress import LogLines, interactive
from tyre_farm_cli.progress import console as stderr_console

CCX_EVERY_SECONDS = 30.0  # how often a calibration says how far its running solves are


class CalibrationLines(Progress):
    """Progress of a calibration (:class:`jobs.progress.Progress`) on stderr: one line per
    new parameter set - budget, rounds, best cost, worst point. On a terminal every one;
    elsewhere timestamped and rate-limited (:class:`tyre_farm_cli.progress.LogLines`)."""

    def __init__(self, console: Console | None = None, lines: LogLines | None = None) -> None:
        self.last = -1
        self.console = console if console is not None else (
            stderr_console() if interactive() and lines is None else None)
        self.lines = lines or LogLines()
        self.session: Any = None
        self.ccx_at = 0.0

    def started(self, session, state) -> None:
        self.session = session
        self._say(f"{session.where}   workers: {session.workers}", now=True)

    def finished(self, report) -> None:
        self.lines.flush()

    def advanced(self, state) -> None:
        ccx = ccx_of(self.session)
        if ccx and state.parameter_sets == self.last and \
                time.monotonic() - self.ccx_at >= CCX_EVERY_SECONDS:
            self.ccx_at = time.monotonic()  # a round of the converged mesh takes minutes
            self._say(f"parameter sets {state.parameter_sets}/{state.budget}, solving: {ccx}")
        if state.parameter_sets != self.last:
            self.last = state.parameter_sets
            self._say(f"parameter sets {state.parameter_sets}/{state.budget}  load paths "
                      f"{state.stats.evaluations}  rounds {state.stats.rounds}  best cost "
                      f"{state.best:.4g}  worst point {100 * state.worst_point:.2f} %")

    def _say(self, text: str, now: bool = False) -> None:
        if self.console is not None:
            self.console.print(text, markup=False)
        elif now:
            self.lines.log(f"calibrate: {text}")
        else:
            self.lines.progress(f"calibrate: {text}")


MODEL = typer.Option("reduced", "--model", "-m", help="Tyre model: full or reduced.")
REFERENCES = typer.Option(
    None, "--references", help="CSV of reference points (model, deflection_mm, "
    "pressure_kpa, force_n) [default: the thesis' points of the model].")
PARAMETERS = typer.Option(
    None, "--parameters", help="Comma list of: modulus, tread, sidewall, bead, "
    "tread_thickness, sidewall_thickness, bead_thickness [default: modulus for the "
    "reduced model, tread,sidewall,bead for the full one].")
THICKNESS = typer.Option(False, "--thickness", help="Also fit the three wall thicknesses "
                         "(a new mesh per evaluation).")
READING = typer.Option(
    "80kPa", "--reading", help="Which pressure the thesis' 4475.5 N point at 30 mm is "
    "read at: 80kPa (§3.3.2, Fig. 3.2; the reading a tyre with cords can meet together "
    "with the measured stiffness ratio, docs/reinforcement.md) or 200kPa (chapter 5, "
    "Table 5.1); the full model's default points only. `farm compare` shows a model "
    "under both.")
RATIO = typer.Option(
    False, "--ratio", help="Also fit the measured 200/80 kPa stiffness ratio (1.636, "
    "§3.4): adds the reading's 30 mm point at the other pressure, scaled by it (full "
    "model, the thesis' points).")
MEASURED = typer.Option(
    False, "--measured", help="Also fit the measured tyre's point the thesis lets one "
    "derive: 4195 N at 25 mm / 80 kPa (3933 N + its largest error, §3.4; full model).")
MATERIALS = typer.Option("table-3.1", "--materials", help="Start material preset.")
MESH = typer.Option("thesis", "--mesh", help=MESH_HELP)
OVERRIDES = typer.Option(
    [], "--set", help="Override a model setting, e.g. --set mesh.circumferential=8.")
MAX_EVALUATIONS = typer.Option(60, "--max-evaluations", help="Evaluation budget (one "
                               "evaluation = one parameter set).")
PRIOR_WEIGHT = typer.Option(1e-4, "--prior-weight", help="Weight of the pull towards the "
                            "start values (per e-fold, squared).")
OUT = typer.Option(Path("calibration"), "--out", help="Folder for the tables, the figure "
                   "and the fitted preset (JSON).")
CACHE = typer.Option(None, "--cache", help="Evaluation cache [default: <out>/evaluations]; "
                     "a re-run replays it without ccx.")


@with_cluster
def calibrate(
    model: str = MODEL, references: Path = REFERENCES, parameters: str = PARAMETERS,
    thickness: bool = THICKNESS, reading: str = READING, ratio: bool = RATIO,
    measured: bool = MEASURED, materials: str = MATERIALS, mesh: str = MESH,
    overrides: list[str] = OVERRIDES, max_evaluations: int = MAX_EVALUATIONS,
    prior_weight: float = PRIOR_WEIGHT, scheduler: str = SCHEDULER, workers: int = WORKERS,
    out: Path = OUT, cache: Path = CACHE, as_json: bool = JSON, cluster=None,
) -> None:
    """Fit Young's moduli (and thicknesses) to force-deflection points, on the farm.

    By default the thesis' points: reduced 359 N at 30 mm; full 3933 N at 25 mm / 80 kPa
    and 4476 N at 30 mm, at 200 kPa or 80 kPa (--reading: the thesis says both). Prints
    the fitted values and each point's residual;
    writes tables, a force-deflection figure and fitted.json to --out.
    """
    from farm.ccx.runner import find_ccx
    from jobs.calibrate.fit import CalibrationSettings
    from jobs.calibrate.run import run_calibration

    base, params = _parameters(model, materials, overrides, mesh, parameters, thickness)
    points = _points(base, reading, ratio, measured, references)
    _check_budget(max_evaluations, prior_weight, out, cache)
    if cluster.embedded:
        find_ccx()
    console = Console(width=None if sys.stdout.isatty() else 160)
    report = run_calibration(
        params, points, str(cache or out / "evaluations"), cluster=cluster,
        progress=CalibrationLines(),
        cal=CalibrationSettings(max_evaluations=max_evaluations, prior_weight=prior_weight))
    frames = _write(report, points, out)
    if as_json:
        dump(_document(report, frames, out))
    else:
        _print(console, report, frames, out)
    raise typer.Exit(0 if report.ok else 1)


def _parameters(model: str, materials: str, overrides: list[str], mesh: str,
                parameters: str | None, thickness: bool):
    """The start model and the parameters fitted on it, as the user typed them."""
    from farm.errors import SpecError
    from jobs.calibrate.params import Parameters, default_parameters
    from jobs.validate import messages
    from tyre_farm_cli.params import build_model

    with usage():
        if model not in ("reduced", "full"):
            raise SpecError(f"unknown model {messages.shown(model)}: choose 'reduced' or "
                            "'full'")
        base = build_model(model, materials, None, overrides, mesh)
        names = (tuple(s.strip() for s in parameters.split(",") if s.strip()) if parameters
                 else default_parameters(model, thickness))
        return base, Parameters(names, base)


def _check_budget(max_evaluations: int, prior_weight: float, out: Path,
                  cache: Path | None) -> None:
    from jobs.validate import limits, scalars
    from tyre_farm_cli.checks import output_folder

    with usage():
        scalars.integer(max_evaluations, "--max-evaluations", low=2,
                        high=limits.MAX_EVALUATIONS)
        scalars.number(prior_weight, "--prior-weight", low=0)
        output_folder(out, "--out")
        if cache is not None:
            output_folder(cache, "--cache")


def _points(base, reading: str, ratio: bool, measured: bool, references: Path | None):
    """The reference points: the file's, or the thesis' under ``reading`` with the
    derived ones asked for (said on a log line)."""
    from farm.errors import SpecError
    from jobs.calibrate.references import MEASURED_POINTS, read_points, thesis_points, with_ratio

    model = base.kind
    with usage():
        default_points = thesis_points(model, reading)
        for flag, on in (("--ratio", ratio), ("--measured", measured)):
            if on and (model != "full" or references):
                raise SpecError(f"{flag} derives a point from the thesis' full-model "
                                "points: use it with --model full and without --references")
        if ratio:
            default_points = with_ratio(default_points)
        if measured:
            default_points = (*default_points, *MEASURED_POINTS)
    # the references file's content is data, not usage (exit 1, see tyre_farm_cli's docstring)
    if references:
        return read_points(references, base)
    if model == "full":
        LogLines().log(f"calibrate: the thesis' points under the {reading} reading of its "
                       "4475.5 N point (the other: --reading "
                       f"{'80kPa' if reading == '200kPa' else '200kPa'})"
                       + (", with the measured stiffness ratio's derived point" if ratio else "")
                       + (", with the measured tyre's derived point" if measured else ""))
    return default_points


def _print(console: Console, report, frames: dict, out: Path) -> None:
    result = report.result
    print_frame(console, f"fitted parameters ({result.status})", frames["parameters"],
                digits=4)
    print_frame(console, "reference points: force N, residual %",
                frames["points"].drop(columns="source"), digits=4)
    s = result.stats
    console.print(f"{plural(s.evaluations, 'evaluation')} in {plural(s.rounds, 'round')} "
                  f"({plural(s.solved, 'load path')} solved, {s.cached} from the cache), "
                  f"{report.wall_seconds:.0f} s wall; "
                  f"tables, figure and fitted.json in {out}")


def _document(report, frames: dict, out: Path) -> dict:
    """``farm calibrate --json``: the two tables and the cost line, as numbers."""
    s = report.result.stats
    return {"status": report.result.status, "ok": report.ok,
            "parameters": records(frames["parameters"]), "points": records(frames["points"]),
            "evaluations": s.evaluations, "rounds": s.rounds, "solved": s.solved,
            "cached": s.cached, "wall_seconds": round(report.wall_seconds, 3), "out": out}


def _write(report, points, out: Path) -> dict:
    """Write the tables, history, curves, figure and fitted.json into ``out``; return
    the parameter and point tables."""
    import numpy as np
    import pandas as pd

    from analysis.report.calibration import force_deflection
    from jobs.calibrate.run import parameter_table, point_table

    result = report.result
    params = result.parameters  # rebased where a start lay on a bound (fit.start_inside)
    start = params.start()
    out.mkdir(parents=True, exist_ok=True)
    frames = {"parameters": parameter_table(result), "points": point_table(result)}
    for name, frame in frames.items():
        frame.to_csv(out / f"{name}.csv", index=False)
    history = pd.DataFrame(np.exp(result.theta_history) * [start[n] for n in params.names],
                           columns=list(params.names)).assign(cost=result.cost_history)
    history.to_csv(out / "history.csv", index_label="parameter_set")
    if not report.curves.empty:
        report.curves.to_csv(out / "curves.csv", index=False)
        force_deflection(report.curves, [(p.deflection, p.force) for p in points],
                         out / "force_deflection.png")
        failed = report.curves[report.curves["fz_n"].isna()]
        for (label, kpa), _ in failed.groupby(["model", "pressure_kpa"]):
            stderr_console().print(f"warning: the {label} model did not converge along the "
                                   f"{kpa:g} kPa curve (see {out / 'curves.csv'})",
                                   style="yellow", markup=False)
    (out / "fitted.json").write_text(json.dumps(_fitted(result), indent=2))
    return frames


def _fitted(result) -> dict:
    """fitted.json: the fitted model's materials, wall thicknesses and cord moduli (what a
    preset needs), the residuals in % and the fit's status."""
    spec = result.spec()
    preset = {region: {"youngs_modulus": m.youngs_modulus, "poisson_ratio": m.poisson_ratio}
              for region, m in spec.materials.by_region().items()}
    geometry = {n: getattr(spec.geometry, n) for n in
                ("tread_thickness", "sidewall_thickness", "bead_thickness")}
    cords = (None if spec.reinforcement is None else
             {layer: getattr(spec.reinforcement, layer).modulus for layer in ("carcass", "belt")})
    return {"model": spec.kind, "materials": preset, "geometry": geometry,
            "cord_modulus_gpa": cords,
            "residuals_pct": list(100 * result.residuals), "status": result.status}
