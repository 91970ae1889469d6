"""`farm analyse pcr`: principal component regression (thesis §5.4, Figs. 5.5-5.7)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from analysis.pcr import PCRegression
from analysis.render import markdown, plots, tables
from analysis.studies.common import Report, Selection, model_inputs


def run(
    ds: xr.Dataset,
    out: Path,
    *,
    inputs: str | None = None,
    max_modes: int = 5,
    reference_deflection: float | None = None,
    component: str = "z",
) -> Report:
    """PCR with 1..max_modes modes per input set; predictions at the reference experiment."""
    sel = Selection.of(ds, component, reference_deflection, study="PCR (thesis §5.4)")
    report = Report(Path(out))
    ratios: dict[str, np.ndarray] = {}  # label -> variance explained per mode
    frames: list[pd.DataFrame] = []
    figures: list[tuple[str, Path]] = []
    for name in model_inputs(ds, inputs):
        moments = sel.moments(name)
        full = PCRegression().fit_moments(moments)
        ratios.setdefault("output", full.y_explained_variance_ratio_)
        ratios[f"input: {name}"] = full.x_explained_variance_ratio_
        modes = range(1, min(max_modes, full.n_components_) + 1)
        x_ref = sel.x_ref(name)[None, :]
        preds = {r: PCRegression(r).fit_moments(moments).predict(x_ref)[0] for r in modes}
        frames.append(tables.predictions(sel.tread, sel.y_ref, preds, name))
        path = plots.predictions(
            sel.tread, sel.y_ref, preds, report.out / f"predictions_{name}.png", f"PCR from {name}"
        )
        figures.append((f"Tread forces predicted from {name}", path))
    variance = tables.variance_explained(ratios, max(max_modes, 10))
    report.csv("variance_explained", variance)
    report.csv("predictions", pd.concat(frames, ignore_index=True))
    report.csv("thesis_comparison", tables.thesis_comparison({("pcr", "output"): ratios["output"]}))
    path = plots.variance_bars(
        variance[variance["label"] == "output"],
        report.out / "variance.png",
        "PCR: output variance explained per mode (Fig. 5.7)",
    )
    report.files += [p for _, p in figures] + [path]
    _summary(report, sel, [*figures, ("Output variance per mode", path)])
    return report


def _summary(report: Report, sel: Selection, figures) -> None:
    var = report.tables["variance_explained"]
    errors = tables.prediction_errors(report.tables["predictions"])
    links = "\n\n".join(markdown.figure(p, report.out, c) for c, p in figures)
    path = markdown.write(
        report.out / "summary.md",
        "Principal component regression (thesis §5.4)",
        [
            ("Selection", sel.describe()),
            (
                "Output variance explained per mode (eigenvalues of ȲᵀȲ, Fig. 5.7)",
                var[var["label"] == "output"].drop(columns="label"),
            ),
            ("Measured vs thesis (cumulative %, modes 1-3)", report.tables["thesis_comparison"]),
            ("About the thesis' values", tables.THESIS_NOTE),
            ("Prediction error at the reference experiment", errors),
            ("Figures", links),
        ],
    )
    report.files.append(path)
