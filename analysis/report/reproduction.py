"""The reproduction report (``farm reproduce``): one Markdown page with PNG figures, every
table beside the thesis' values, run times and solver counts, and the provenance of the
numbers. Stages hand in a :class:`StageResult` each; this module only writes.
"""

from __future__ import annotations

import json
import os
import platform
import re
from importlib import metadata
from pathlib import Path

import pandas as pd

from analysis.render.provenance import Run
from analysis.report import findings, readable, table_5_1
from analysis.report.readable import table as md_table
from analysis.report.stage import StageResult  # where the chapters and the CLI take it from

PACKAGES = ("tyre-farm", "numpy", "scipy", "gmsh", "zarr", "xarray", "dask", "distributed",
            "scikit-learn", "pandas", "matplotlib")

# (stage, table key, caption) in report order; missing tables are skipped
CH5_TABLES = [
    ("pca/importance", "Importance of each measurement direction (Figs. 5.1-5.4)"),
    ("plsr/thesis_comparison", "Cumulative % of output variance, modes 1-3: PCR (Fig. 5.7) "
                               "and PLSR (Fig. 5.10), measured vs thesis"),
    ("noise/totals", table_5_1.CAPTION),  # shown through table_5_1.beside_thesis
]
CH5_FIGURES = [
    ("pca/singular_values_displacement", "Singular values, displacement (Fig. 5.1)"),
    ("pca/eigen_maps_displacement", "First eigen-deformation (Fig. 5.2)"),
    ("pca/singular_values_strain", "Singular values, strain (Fig. 5.3)"),
    ("pca/eigen_maps_strain", "First eigen-strain (Fig. 5.4)"),
    ("pcr/predictions_displacement", "PCR tread forces from displacement (Fig. 5.5)"),
    ("pcr/predictions_strain", "PCR tread forces from strain (Fig. 5.6)"),
    ("pcr/variance", "PCR output variance per mode (Fig. 5.7)"),
    ("plsr/predictions_displacement", "PLSR tread forces from displacement (Fig. 5.8)"),
    ("plsr/predictions_strain", "PLSR tread forces from strain (Fig. 5.9)"),
    ("plsr/variance", "PLSR vs PCR variance explained (Fig. 5.10)"),
    ("noise/nodes_displacement", "Noise: mean error and std per node, displacement (Fig. 5.11)"),
    ("noise/nodes_strain", "Noise: mean error and std per node, strain (Fig. 5.11)"),
    ("noise/sweep", "Total force and std over noise levels (Fig. 5.12)"),
]


def provenance(run: Run, *, solver: str, store: str, quick: bool, meshes: str,
               materials: str, scheduler: str | None = None,
               workers: int | None = None) -> pd.DataFrame:
    """Where the numbers come from: the run's command, commit, times, machine and load
    (:class:`analysis.render.provenance.Run`, as every ``farm analyse`` writes them), then
    solver, store, mode, cluster, Python and versions."""
    rows = [*run.table().itertuples(index=False), ("solver", solver),
            ("store", store), ("mode", "quick" if quick else "full"),
            ("meshes", meshes), ("materials", materials),
            ("cluster", scheduler or f"embedded LocalCluster, {workers or 'all'} "
             "workers"), ("Python", platform.python_version())]
    for name in PACKAGES:
        try:
            rows.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            rows.append((name, "not installed"))
    return pd.DataFrame(rows, columns=["item", "value"])


def _figure(path: Path, out: Path, caption: str) -> str:
    return f"![{caption}]({os.path.relpath(path, out)})\n\n*{caption}*"


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", text).strip("_").lower()[:60]


def write(out: Path, stages: list[StageResult], provenance: pd.DataFrame,
          quick: bool) -> Path:
    """Write ``out/report.md`` (every table as CSV in ``tables/``, every study file in
    ``studies/``, the costs in ``report.json``); return its path.

    ``provenance`` is the table of :func:`provenance`.
    """
    (out / "tables").mkdir(parents=True, exist_ok=True)
    (out / "studies").mkdir(parents=True, exist_ok=True)
    lines = [f"# Reproduction of the thesis study ({'quick' if quick else 'full'})", "",
             "Every number below was computed by this run (or by an earlier run whose "
             "experiments the store already held); thesis values are quoted beside them.", "",
             readable.NOTE, "", *_findings(stages),
             "## Provenance", "", md_table(provenance), "",
             "## Run", "", md_table(_costs(stages)), ""]
    by_name = {s.name: s for s in stages}
    if "validation" in by_name:
        lines += _chapter3(by_name["validation"], out)
    if "inverse" in by_name:
        lines += _generic("Chapter 4: FEM-in-the-loop inverse problems", by_name["inverse"], out)
    if "dataset" in by_name:
        lines += _chapter5(by_name["dataset"], out)
    lines += ["## Study files", ""]
    for stage in stages:
        for name, text in stage.studies.items():
            (out / "studies" / f"{name}.toml").write_text(text)
            lines += [f"`studies/{name}.toml`:", "", "```toml", text.strip(), "```", ""]
    for stage in stages:
        for key, frame in stage.tables.items():
            frame.to_csv(out / "tables" / f"{stage.name}__{_slug(key)}.csv", index=False)
    path = out / "report.md"
    path.write_text("\n".join(lines))
    (out / "report.json").write_text(json.dumps(
        {s.name: {"wall_seconds": s.wall_seconds, "ccx_runs": s.ccx_runs,
                  "solver_seconds": s.solver_seconds, "tables": list(s.tables)} for s in stages},
        indent=2))
    return path


def _findings(stages: list[StageResult]) -> list[str]:
    table = findings.findings(stages)
    if table.empty:
        return []
    return ["## Findings", "", findings.summary(table), "", md_table(table), ""]


def _costs(stages: list[StageResult]) -> pd.DataFrame:
    rows = [{"stage": s.name, "wall s": round(s.wall_seconds, 1), "ccx runs": s.ccx_runs,
             "solver s": round(s.solver_seconds, 1)} for s in stages]
    rows.append({"stage": "total", "wall s": round(sum(s.wall_seconds for s in stages), 1),
                 "ccx runs": sum(s.ccx_runs for s in stages),
                 "solver s": round(sum(s.solver_seconds for s in stages), 1)})
    return pd.DataFrame(rows)


def _chapter3(stage: StageResult, out: Path) -> list[str]:
    lines = ["## Chapter 3: the models and their validation", ""]
    for key, frame in stage.tables.items():
        lines += [f"### {key}", "", md_table(frame), ""]
    if "force-deflection" in stage.figures:
        lines += [_figure(stage.figures["force-deflection"], out, "Force-deflection curves, "
                          "thesis reference points as stars (Fig. 3.3)"), ""]
    lines += [*(f"- {n}" for n in stage.notes), ""]
    return lines


def _chapter5(stage: StageResult, out: Path) -> list[str]:
    lines = ["## Chapter 5: regularisation investigation", "", *(f"- {n}" for n in stage.notes),
             ""]
    for key, caption in CH5_TABLES:
        if key in stage.tables:
            frame = stage.tables[key]
            if key == "noise/totals":
                frame = table_5_1.beside_thesis(frame)
            lines += [f"### {caption}", "", md_table(frame), ""]
            if key == "noise/totals":
                lines += [table_5_1.NOTE, ""]
    for key, caption in CH5_FIGURES:
        if key in stage.figures:
            lines += [_figure(stage.figures[key], out, caption), ""]
    return lines


def _generic(title: str, stage: StageResult, out: Path) -> list[str]:
    lines = [f"## {title}", "", *(f"- {n}" for n in stage.notes), ""]
    for key, frame in stage.tables.items():
        lines += [f"### {key}", "", md_table(frame), ""]
    for key, path in stage.figures.items():
        lines += [_figure(path, out, key), ""]
    return lines
