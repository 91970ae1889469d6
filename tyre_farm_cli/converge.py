"""``farm converge``: the full model's mesh-convergence study (issue 24).

Solves every refinement level x load case of :mod:`jobs.convergence.levels` on the
cluster, then writes ``OUT/convergence.json`` (every record) and
``OUT/convergence.md`` (the level-by-level table with Richardson estimates, and the
cost table); docs/mesh-convergence.md holds a measured run and what it decided.
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


@with_cluster
def converge(
    quick: bool = typer.Option(False, "--quick", help="Test-sized levels and two cases "
                               "(minutes: for the pipeline, not for conclusions)."),
    replay: bool = typer.Option(False, "--replay", help="Solve nothing: redraw the tables "
                                "from OUT/convergence.json of an earlier run."),
    cases: list[str] = typer.Option(
        [], "--case", help="Solve only this load case (repeatable): one of the study's "
        "cases, or roll-150mm (a rolling tyre, issue 30). Default: the study's cases."),
    out: Path = typer.Option(Path("convergence"), "--out", help="Output folder."),
    materials: str = typer.Option("table-3.1", "--materials", help="Material preset."),
    scheduler: str = SCHEDULER,
    workers: int = WORKERS,
    cluster=None,
) -> None:
    """Solve the mesh-convergence study and write OUT/convergence.md."""
    from farm.ccx.runner import find_ccx
    from jobs.convergence import levels as lv
    from jobs.convergence.run import run_study
    from jobs.validate import reading
    from tyre_farm_cli.checks import output_folder

    with usage():
        check_materials(materials)
        output_folder(out, "--out")
        chosen = lv.chosen_cases(cases, quick)
        if replay:
            saved = reading.read_text(out / "convergence.json", "convergence records")
    if replay:
        doc = json.loads(saved)
        _write(out, doc["records"], doc["sequence"], doc["materials"], doc["quick"])
        return
    find_ccx()
    levels = lv.QUICK_LEVELS if quick else lv.LEVELS
    log = LogLines()

    def note(record: dict) -> None:
        what = ("done" if record["status"] == "done"
                else f"failed ({record['reason'][:80]})")
        log.log(f"converge: {record['level']} / {record['case']}: {what}, "
                f"{record['wall_s']:.0f} s")

    with cluster.client() as client:
        records = run_study(levels, chosen, client, materials, on_record=note)
    _write(out, records, [level.name for level in levels if level.ratio], materials, quick)


def _write(out: Path, records: list[dict], sequence: list[str], materials: str,
           quick: bool) -> None:
    """OUT/convergence.json and OUT/convergence.md, and the verdict on stdout."""
    from jobs.convergence.table import markdown, rows, verdict

    table = rows(records, sequence)
    out.mkdir(parents=True, exist_ok=True)
    (out / "convergence.json").write_text(json.dumps(
        {"materials": materials, "quick": quick, "sequence": sequence,
         "records": records, "rows": table}, indent=1, default=float))
    decided = verdict(table)
    summary = (f"finest step: {decided['judged'] - len(decided['failing'])} of "
               f"{decided['judged']} judged rows within issue 24's limits (totals 2 %, "
               "window fields 5 %)")
    (out / "convergence.md").write_text(
        f"# Mesh convergence, full model, {materials}\n\n{summary}\n\n"
        + markdown(table, records, sequence))
    failed = sum(r["status"] != "done" for r in records)
    Console().print(f"{out / 'convergence.md'}: {summary}"
                    + (f"; {failed} of {plural(len(records), 'solve')} failed" if failed
                       else ""))
