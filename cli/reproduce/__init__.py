"""``farm reproduce``: the thesis study end to end - validation, dataset, analyses,
inverse problems - with a report that puts every number beside the thesis' own."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from cli.options import SCHEDULER, WORKERS


def reproduce(
    quick: bool = typer.Option(True, "--quick/--full", help="A reduced set of inverse "
                               "conditions and noise draws (--full: all, 10 repeats)."),
    out: Path = typer.Option(Path("reproduction"), "--out", help="Report folder."),
    store: str = typer.Option(None, "--store", help="Zarr store [default: OUT/thesis.zarr]."),
    scheduler: str = SCHEDULER,
    workers: int = WORKERS,
    coarse: bool = typer.Option(False, "--coarse", help="Test-sized coarse meshes (minutes, "
                                "not for conclusions)."),
    materials: str = typer.Option("table-3.1", "--materials", help="Material preset."),
) -> None:
    """Run the thesis study (chapters 3-5) on the farm and write OUT/report.md."""
    from cli.reproduce import inverse, report, stages
    from farm.ccx.runner import ccx_version, find_ccx
    from farm.errors import SpecError
    from farm.presets import MATERIAL_PRESETS

    if materials not in MATERIAL_PRESETS:
        raise SpecError(f"unknown material preset {materials!r}: choose one of "
                        f"{', '.join(MATERIAL_PRESETS)}")
    find_ccx()
    out = out.resolve()
    opts = stages.Options(out=out, store=store or str(out / "thesis.zarr"), quick=quick,
                          coarse=coarse, materials=materials, scheduler=scheduler,
                          workers=workers)
    console = Console()
    done = []
    for name, stage in (("chapter 3: validation", stages.validation),
                        ("chapter 5: dataset analyses", stages.dataset),
                        ("chapter 4: inverse problems", inverse.inverse)):
        console.rule(name)
        done.append(stage(opts))
    path = report.write(opts, done, f"CalculiX {ccx_version()}")
    console.print(f"report: {path}")
