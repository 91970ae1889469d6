"""``farm compare``: a full model beside every statement the thesis makes (issue 24).

Solves the 80 and 200 kPa force-deflection curves (5-40 mm) on the cluster and prints,
for each statement of :mod:`jobs.calibrate.statements`, the thesis' value, ours, the
error and whether issue 24's goal holds, under both readings of the 4475.5 N point;
``--out DIR`` also writes ``compare.md`` and ``compare.json``.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from tyre_farm_cli.errors import usage
from tyre_farm_cli.options import SCHEDULER, WORKERS, with_cluster
from tyre_farm_cli.params import MATERIALS_HELP, MESH_HELP, build_model


@with_cluster
def compare(
    materials: str = typer.Option("table-3.1", "--materials", help=MATERIALS_HELP),
    mesh: str = typer.Option("thesis", "--mesh", help=MESH_HELP),
    overrides: list[str] = typer.Option(
        [], "--set", help="Override a model setting, e.g. --set mesh.tread=12."),
    out: Path = typer.Option(None, "--out", help="Also write compare.md and compare.json "
                             "into this folder [default: print only]."),
    scheduler: str = SCHEDULER,
    workers: int = WORKERS,
    cluster=None,
) -> None:
    """Solve a full model at 80 and 200 kPa and put it beside every thesis statement."""
    from farm.ccx.runner import find_ccx
    from jobs.calibrate import compare as cmp
    from jobs.calibrate.statements import READINGS
    from tyre_farm_cli.checks import output_folder

    with usage():
        spec = build_model("full", materials, None, overrides, mesh)
        if out is not None:
            output_folder(out, "--out")
    find_ccx()
    with cluster.client() as client:
        curves = cmp.solve_curves(spec, client)
    rows = cmp.evaluate(curves)
    head = (f"# {materials} on the {mesh} mesh"
            + (f" ({', '.join(overrides)})" if overrides else "") + "\n\n"
            + "\n".join(f"- {cmp.summary(rows, r)} ({text})" for r, text in READINGS.items()))
    text = f"{head}\n\n{cmp.markdown(rows)}\n{cmp.curves_table(curves)}"
    typer.echo(text)  # Markdown: never wrapped to the terminal
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "compare.md").write_text(text)
        (out / "compare.json").write_text(json.dumps(
            {"materials": materials, "mesh": mesh, "overrides": overrides,
             "model": spec.to_dict(), "curves": {str(p): c for p, c in curves.items()},
             "statements": rows}, indent=1))
