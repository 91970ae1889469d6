"""``farm converge``: the full model's mesh-convergence study (issue 24).

Solves every refinement level x load case of :mod:`jobs.convergence.levels` on the
cluster, then writes ``OUT/convergence.json`` (every record) and
``OUT/convergence.md`` (the level-by-level table with Richardson estimates, and the
cost table); docs/mesh-convergence.md holds a measured run and what it decided.
``--direction`` (issue 44) refines a base mesh preset (``--mesh``, default ``patch``)
in one direction at a time instead, and writes one table per direction.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer
from rich.console import Console

from jobs.wording import plural
from tyre_farm_cli.errors import usage
from tyre_farm_cli.options import SCHEDULER, WORKERS, with_cluster
from tyre_farm_cli.params import check_materials
from tyre_farm_cli.progress import LogLines

QUICK = typer.Option(False, "--quick", help="Test-sized levels and two cases (minutes: for "
                     "the pipeline, not for conclusions).")
REPLAY = typer.Option(False, "--replay", help="Solve nothing: redraw the tables from "
                      "OUT/convergence.json of an earlier run.")
CASES = typer.Option(
    [], "--case", help="Solve only this load case (repeatable): one of the study's cases, "
    "or roll-150mm (a rolling tyre, issue 30). Default: the study's cases.")
DIRECTIONS = typer.Option(
    [], "--direction", help="Refine the --mesh preset in this direction alone, 2 and 4 x "
    "(repeatable): circumferential, tread, sidewall, bead, through, together (2 x in every "
    "one at once), or all. Cases: the calibration's vertical points (point-80kPa at 25 "
    "mm, point-200kPa at 30 mm) unless --case names others.")
MESH = typer.Option("patch", "--mesh", help="With --direction: the mesh preset refined (the "
                    "full model's).")
FACTORS = typer.Option("", "--factors", help="With --direction: the refinement factors, e.g. "
                       "2,4,8 [default: 2,4; together 2].")
OUT = typer.Option(Path("convergence"), "--out", help="Output folder.")
MATERIALS = typer.Option("table-3.1", "--materials", help="Material preset.")
TIMEOUT = typer.Option(
    1800.0, "--timeout", help="Wall-clock seconds per ccx run: a roll or a tilt on a wall "
    "refined twice can need more than the default half hour.")


@with_cluster
def converge(
    quick: bool = QUICK, replay: bool = REPLAY, cases: list[str] = CASES,
    directions: list[str] = DIRECTIONS, mesh: str = MESH, factors: str = FACTORS,
    out: Path = OUT, materials: str = MATERIALS, timeout: float = TIMEOUT,
    scheduler: str = SCHEDULER, workers: int = WORKERS, cluster=None,
) -> None:
    """Solve the mesh-convergence study and write OUT/convergence.md."""
    from farm.ccx.runner import find_ccx
    from jobs.convergence.run import run_study

    levels, sequences, chosen, settings, saved = _plan(
        quick, replay, cases, directions, mesh, factors, out, materials, timeout)
    if saved is not None:
        doc = json.loads(saved)
        sequences = doc.get("sequences") or {"levels": doc["sequence"]}
        _write(out, doc["records"], sequences, doc["materials"], doc["quick"])
        return
    find_ccx()
    log = LogLines()

    def note(record: dict) -> None:
        what = ("done" if record["status"] == "done"
                else f"failed ({record['reason'][:80]})")
        log.log(f"converge: {record['level']} / {record['case']}: {what}, "
                f"{record['wall_s']:.0f} s")

    with cluster.client() as client:
        records = run_study(levels, chosen, client, materials, settings, on_record=note)
    _write(out, records, sequences, materials, quick)


def _plan(quick, replay, cases, directions, mesh, factors, out, materials, timeout):
    """The options as typed, checked: (levels, sequences, cases, solver settings, the
    earlier run's JSON with --replay else None)."""
    from farm.specs import TIMEOUT_S, SolverSettings
    from jobs.convergence import levels as lv
    from jobs.validate import reading, scalars
    from tyre_farm_cli.checks import output_folder

    with usage():
        check_materials(materials)
        output_folder(out, "--out")
        scalars.number(timeout, "--timeout", low=TIMEOUT_S[0], high=TIMEOUT_S[1])
        settings = SolverSettings(timeout=timeout)
        if directions:
            levels, sequences = lv.direction_study(
                lv.chosen_directions(directions), mesh, quick, _factors(factors))
            chosen = lv.chosen_cases(cases, quick, default=lv.POINT_CASES)
        else:
            levels = lv.QUICK_LEVELS if quick else lv.LEVELS
            sequences = {"levels": [level.name for level in levels if level.ratio]}
            chosen = lv.chosen_cases(cases, quick)
        saved = (reading.read_text(out / "convergence.json", "convergence records")
                 if replay else None)
    return levels, sequences, chosen, settings, saved


def _write(out: Path, records: list[dict], sequences: dict[str, list[str]], materials: str,
           quick: bool) -> None:
    """OUT/convergence.json and OUT/convergence.md, and the verdict on stdout.

    ``sequences``: the extrapolated levels of each direction, coarse to fine (one,
    ``levels``, for the study of :data:`jobs.convergence.levels.LEVELS`).
    """
    from jobs.convergence.table import direction_markdown

    text, summary, tables = direction_markdown(records, sequences)
    out.mkdir(parents=True, exist_ok=True)
    single = list(sequences) == ["levels"]  # the study of LEVELS: its JSON as before
    doc = {"materials": materials, "quick": quick,
           **({"sequence": sequences["levels"]} if single else {"sequences": sequences}),
           "records": records, "rows": tables["levels"] if single else tables}
    (out / "convergence.json").write_text(json.dumps(doc, indent=1, default=float))
    (out / "convergence.md").write_text(
        f"# Mesh convergence, full model, {materials}\n\n{text}")
    failed = sum(r["status"] != "done" for r in records)
    Console().print(f"{out / 'convergence.md'}: {summary}"
                    + (f"; {failed} of {plural(len(records), 'solve')} failed" if failed
                       else ""))


def _factors(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(f) for f in text.split(",") if f.strip())
    except ValueError:
        raise typer.BadParameter(f"--factors takes whole numbers separated by commas, got "
                                 f"{text!r}") from None
