"""`farm analyse noise`: Monte Carlo measurement noise on PLSR (thesis §5.6).

Per input set: a SIMPLS model on the selection, the reference experiment's inputs with
N(0, σ²) noise, ``draws`` draws per level. Outputs: per-node mean error and standard
deviation at the thesis' level (Fig. 5.11), totals as mean ± std (Table 5.1), and a
sweep over levels (Fig. 5.12), each with the exact (analytic) std beside the Monte Carlo
one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from analysis import data
from analysis.noise import THESIS_SIGMA, monte_carlo, totals_operator
from analysis.report import markdown, plots, tables
from analysis.studies.common import Report, Selection, directions_of, fit_simpls, model_inputs

DEFAULT_MULTIPLIERS = tuple(np.round(np.linspace(0.0, 2.0, 21), 10))


def thesis_sigma(input_set: str) -> float:
    """The thesis' noise level for an input set: 1 mm (displacement), 4e-4 (strain)."""
    return THESIS_SIGMA[data.family(directions_of(input_set)[0])]


def run(
    ds: xr.Dataset,
    out: Path,
    *,
    inputs: str | None = None,
    n_components: int | None = None,
    multipliers=DEFAULT_MULTIPLIERS,
    draws: int = 100,
    seed: int = 0,
    reference_deflection: float | None = None,
    component: str = "z",
    sampling: str = "inputs",
) -> Report:
    """Noise sweep over ``multipliers`` x the thesis level, per input set."""
    sel = Selection.of(ds, component, reference_deflection)
    report = Report(Path(out))
    levels = np.unique(np.append(np.asarray(multipliers, dtype=float), 1.0))
    at_thesis = int(np.flatnonzero(levels == 1.0)[0])
    G = totals_operator(sel.tread[["x", "y"]].to_numpy())
    y_ref = sel.y_ref
    totals, nodes, sweeps, figures, models = [], [], [], [], []
    for k, name in enumerate(model_inputs(ds, inputs)):
        model = fit_simpls(sel.moments(name), n_components)
        models.append((name, model.n_components, thesis_sigma(name)))
        result = monte_carlo(
            model,
            sel.x_ref(name),
            levels * thesis_sigma(name),
            totals=G,
            n_draws=draws,
            seed=seed + k,
            sampling=sampling,
        )
        totals.append(tables.noise_totals(name, result, at_thesis, y_ref, G))
        nodes.append(tables.noise_nodes(name, sel.tread, result, at_thesis, y_ref))
        sweeps.append(tables.noise_sweep(name, result, levels, y_ref))
        figures.append(
            (f"Mean error and std over the tread, {name}", _node_figure(report, nodes[-1], name))
        )
    report.csv("totals", _merge_reference(totals))
    report.csv("nodes", pd.concat(nodes, ignore_index=True))
    report.csv("sweep", pd.concat(sweeps, ignore_index=True))
    path = plots.noise_sweep(report.tables["sweep"], report.out / "sweep.png")
    figures.append(("Noise sweep (Fig. 5.12)", path))
    report.files += [p for _, p in figures]
    _summary(report, sel, models, f"{draws} draws per level ({sampling} sampling)", figures)
    return report


def _merge_reference(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """Table 5.1 layout: one reference row, then each input set's two rows."""
    first, rest = frames[0], [f[f["case"] != "reference"] for f in frames[1:]]
    return pd.concat([first, *rest], ignore_index=True)


def _node_figure(report: Report, nodes: pd.DataFrame, name: str) -> Path:
    panels = {
        "mean error [N]": nodes["mean_error"].to_numpy(),
        "standard deviation [N]": nodes["std"].to_numpy(),
    }
    sigma = nodes["sigma"].iloc[0]
    return plots.node_maps(
        nodes,
        panels,
        report.out / f"nodes_{name}.png",
        f"PLSR from {name} + N(0, {sigma:g}²) (Fig. 5.11)",
    )


def _summary(report: Report, sel: Selection, models, draws: str, figures) -> None:
    sweep = report.tables["sweep"]
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = (sweep["nodal_avg_std"] / sweep["nodal_avg_std_analytic"]).replace(np.inf, np.nan)
    agreement = (
        sweep.assign(mc_over_analytic=ratio)
        .groupby("inputs", as_index=False)["mc_over_analytic"]
        .agg(["min", "mean", "max"])
    )
    model_text = "; ".join(
        f"{n}: SIMPLS with {a} components, thesis σ = {s:g}" for n, a, s in models
    )
    links = "\n\n".join(markdown.figure(p, report.out, c) for c, p in figures)
    report.files.append(
        markdown.write(
            report.out / "summary.md",
            "Measurement noise (thesis §5.6)",
            [
                ("Selection", sel.describe()),
                (
                    "Models",
                    f"{model_text}. {draws}. Moments Mx = Σ y F, My = -Σ x F "
                    "about the contact centre (tread_xyz x, y), in N m.",
                ),
                ("Totals at the thesis' noise level (Table 5.1)", report.tables["totals"]),
                ("Monte Carlo over analytic nodal-average std, across levels", agreement),
                ("Figures", links),
            ],
        )
    )
