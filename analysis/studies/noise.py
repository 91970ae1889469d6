"""`farm analyse noise`: Monte Carlo measurement noise on PLSR (thesis §5.6).

Per input set: a SIMPLS model on the selection (its component count chosen by
cross-validation unless given), the reference experiment's inputs with N(0, σ²) noise,
``draws`` draws per level. Outputs: the models and how their counts were chosen,
per-node mean error and standard deviation at the thesis' level (Fig. 5.11), totals as
mean ± nodal-average std beside the std of each total (Table 5.1), and a sweep over
levels (Fig. 5.12), each with the exact (analytic) std beside the Monte Carlo one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from analysis import data
from analysis.noise import THESIS_SIGMA, monte_carlo, totals_operator
from analysis.pls import SIMPLSRegression
from analysis.report import markdown, plots, tables
from analysis.selection import cross_validate_simpls, default_folds, describe_cv
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
    cv: int | None = None,
) -> Report:
    """Noise sweep over ``multipliers`` x the thesis level, per input set.

    Parameters
    ----------
    n_components : int, optional
        PLS components of every input set's SIMPLS model. By default each input set's
        count is chosen by k-fold cross-validation over the experiments
        (:func:`~analysis.selection.cross_validate_simpls`): leave-one-out for up to 10
        experiments (the thesis' 7), else 10-fold with folds shuffled by ``seed``; the
        count with the least mean squared error of the held-out experiments' tread
        forces wins. The count matters: with all the components 7 experiments support
        (6), the model interpolates its training data and the noise it passes on grows
        several-fold. The count and how it was chosen are in the ``models`` table (and
        the per-count errors in ``cross_validation``).
    cv : int, optional
        Folds of that cross-validation (default: leave-one-out up to 10 experiments).
    multipliers, draws, seed, sampling
        Noise levels as multiples of the thesis' level, draws per level, seed of the
        draws (and of the folds), see :func:`~analysis.noise.monte_carlo`.
    reference_deflection : float, optional
        Deflection of the reference experiment (thesis: 30 mm); default the median.
    """
    needed, why = _experiments_needed(n_components)
    sel = Selection.of(
        ds,
        component,
        reference_deflection,
        study="The noise study (thesis §5.6)",
        needed=needed,
        why=why,
    )
    report = Report(Path(out))
    levels = np.unique(np.append(np.asarray(multipliers, dtype=float), 1.0))
    at_thesis = int(np.flatnonzero(levels == 1.0)[0])
    G = totals_operator(sel.tread[["x", "y"]].to_numpy())
    y_ref = sel.y_ref
    totals, nodes, sweeps, figures, models, cvs = [], [], [], [], [], []
    for k, name in enumerate(model_inputs(ds, inputs)):
        model, chosen_by, cv_table = _model(sel, name, n_components, cv, seed)
        models.append((name, model.n_components, chosen_by, thesis_sigma(name)))
        if cv_table is not None:
            cvs.append(cv_table)
        result = monte_carlo(
            model,
            sel.x_ref(name),
            levels * thesis_sigma(name),
            totals=G,
            n_draws=draws,
            seed=seed + k,
            sampling=sampling,
        )
        label = f"SIMPLS, {model.n_components} components"
        totals.append(tables.noise_totals(name, result, at_thesis, y_ref, G, label))
        nodes.append(tables.noise_nodes(name, sel.tread, result, at_thesis, y_ref))
        sweeps.append(tables.noise_sweep(name, result, levels, y_ref))
        figures.append(
            (f"Mean error and std over the tread, {name}", _node_figure(report, nodes[-1], name))
        )
    cols = ["inputs", "n_components", "chosen_by", "thesis_sigma"]
    report.csv("models", pd.DataFrame(models, columns=cols))
    if cvs:
        report.csv("cross_validation", pd.concat(cvs, ignore_index=True))
    report.csv("totals", _merge_reference(totals))
    report.csv("table_5_1", tables.table_5_1(report.tables["totals"]))
    report.csv("nodes", pd.concat(nodes, ignore_index=True))
    report.csv("sweep", pd.concat(sweeps, ignore_index=True))
    path = plots.noise_sweep(report.tables["sweep"], report.out / "sweep.png")
    figures.append(("Noise sweep (Fig. 5.12)", path))
    report.files += [p for _, p in figures]
    _summary(report, sel, f"{draws} draws per level ({sampling} sampling)", figures)
    return report


def _experiments_needed(n_components: int | None) -> tuple[int, str]:
    """How many experiments the study needs, and why (for the error message)."""
    if n_components is None:
        return 3, (
            "choosing the PLS components by cross-validation trains on all experiments "
            "but one, and a model needs two; pass --components 1 to skip the choice"
        )
    return n_components + 1, f"{n_components} PLS components, after centring"


def _model(sel: Selection, name: str, n_components: int | None, cv: int | None, seed: int):
    """SIMPLS model of one input set: (model, how its count was chosen, CV table or None)."""
    moments = sel.moments(name)
    if n_components is not None:
        return SIMPLSRegression(n_components).fit_moments(moments), "given", None
    X, Y = sel.X(name), sel.Y
    if X.nbytes < 2**28:  # small: read once, not once per fold
        X, Y = np.asarray(X.compute()), np.asarray(Y.compute())
    K = X.shape[0]
    folds = default_folds(K) if cv is None else cv
    supported = fit_simpls(moments, None).n_components  # what X̄ᵀȲ of all K supports
    best, table = cross_validate_simpls(X, Y, cv=folds, max_components=supported, seed=seed)
    how = f"{describe_cv(folds, K)}, least mean squared error of the held-out tread forces"
    table = table.assign(inputs=name, chosen=table["n_components"] == best)
    table = table[["inputs", *table.columns.drop("inputs")]]
    return SIMPLSRegression(best).fit_moments(moments), how, table


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


def _summary(report: Report, sel: Selection, draws: str, figures) -> None:
    sweep = report.tables["sweep"]
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = sweep["Fz_nodal_avg_std"] / sweep["Fz_nodal_avg_std_analytic"]
    agreement = (
        sweep.assign(mc_over_analytic=ratio.replace(np.inf, np.nan))
        .groupby("inputs", as_index=False)["mc_over_analytic"]
        .agg(["min", "mean", "max"])
    )
    links = "\n\n".join(markdown.figure(p, report.out, c) for c, p in figures)
    sections = [
        ("Selection", sel.describe()),
        (
            "Models (PLS components per input set, and how they were chosen)",
            report.tables["models"],
        ),
        (
            "About the models",
            f"SIMPLS on each input set; thesis σ as listed. {draws}. Moments "
            "Mx = Σ y F, My = -Σ x F about the contact centre (tread_xyz x, y), in N m.",
        ),
    ]
    if "cross_validation" in report.tables:
        sections.append(
            (
                "Cross-validation (mean squared error of held-out tread forces, N²)",
                report.tables["cross_validation"],
            )
        )
    sections += [
        ("Totals at the thesis' noise level (Table 5.1)", report.tables["table_5_1"]),
        ("About Table 5.1", tables.TABLE_5_1_NOTE),
        ("Monte Carlo over analytic nodal-average std, across levels", agreement),
        ("Figures", links),
    ]
    report.files.append(
        markdown.write(report.out / "summary.md", "Measurement noise (thesis §5.6)", sections)
    )
