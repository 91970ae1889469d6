"""`farm analyse noise`: Monte Carlo measurement noise on PLSR (thesis §5.6).

Per input set: a SIMPLS model on the selection (its component count chosen by
cross-validation unless given), the reference experiment's inputs with N(0, σ²) noise,
``draws`` draws per level. Outputs: the models and how their counts were chosen,
per-node mean error and standard deviation at the thesis' level (Fig. 5.11), totals as
mean ± nodal-average std beside the std of each total (Table 5.1), and a sweep over
levels (Fig. 5.12), each with the exact (analytic) std beside the Monte Carlo one.

Column ``training`` of the totals, nodes and sweep tables: ``clean`` is the thesis'
setting, the model trained on the noise-free FE data and noise on the reference inputs
only; ``noisy`` refits it (same component count) on training inputs with noise of the
same σ, as a model trained on measurements sees them (issue 25;
:func:`~analysis.noise.monte_carlo_noisy_training`). Both train on every selected
experiment, the reference among them, as the thesis does: the reference is a training
experiment predicted from noisy inputs, not a held-out one. Noisy training has no
analytic std (NaN in the ``*_analytic`` columns).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import dask.array as da
import numpy as np
import pandas as pd
import xarray as xr

from analysis import data
from analysis.noise import (
    THESIS_SIGMA,
    NoiseResult,
    monte_carlo,
    monte_carlo_noisy_training,
    totals_operator,
)
from analysis.pls import SIMPLSRegression
from analysis.render import markdown, plots, tables
from analysis.selection import cross_validate_simpls, default_folds, describe_cv
from analysis.studies.common import Report, Selection, directions_of, fit_simpls, model_inputs

DEFAULT_MULTIPLIERS = tuple(np.round(np.linspace(0.0, 2.0, 21), 10))
#: refits on noisy training inputs per noise level (training "noisy")
DEFAULT_FITS = 20


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
    train_noise: bool = True,
    fits: int = DEFAULT_FITS,
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
    train_noise : bool
        Also run every level with noise in training (rows ``training == "noisy"``):
        ``fits`` refits on noisy copies of all the training inputs, each predicting
        ceil(draws / fits) (at least 2) noisy copies of the reference inputs, so both
        settings pool about ``draws`` predictions per level.
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
    G = totals_operator(sel.tread[["x", "y"]].to_numpy())
    sweep = _Sweep(levels, G, draws, seed, sampling, fits if train_noise else 0)
    parts = [_input_set(report, sel, name, sweep, n_components, cv, seed + k)
             for k, name in enumerate(model_inputs(ds, inputs))]
    _write_tables(report, parts)
    figures = [(p.caption, p.figure) for p in parts]
    sweep_table = report.tables["sweep"]
    path = plots.noise_sweep(sweep_table[sweep_table["training"] == "clean"],
                             report.out / "sweep.png")
    figures.append(("Noise sweep (Fig. 5.12)", path))
    report.files += [p for _, p in figures]
    how = f"{draws} draws per level ({sampling} sampling)"
    if train_noise:
        how += f"; noisy training: {fits} refits x {sweep.draws_per_fit} draws per level"
    _summary(report, sel, how, figures)
    return report


@dataclass(frozen=True)
class _Sweep:
    """The Monte Carlo settings every input set shares."""

    levels: np.ndarray  # multiples of the thesis' sigma, 1.0 among them
    totals: np.ndarray  # G: nodal forces -> Fz, Mx, My
    draws: int
    seed: int
    sampling: str
    fits: int  # refits on noisy training inputs per level; 0: clean training only

    @property
    def at_thesis(self) -> int:
        return int(np.flatnonzero(self.levels == 1.0)[0])

    @property
    def draws_per_fit(self) -> int:
        return max(2, -(-self.draws // max(self.fits, 1)))


@dataclass(frozen=True)
class _Part:
    """One input set's rows of every table, and its node figure."""

    model: tuple
    cv: pd.DataFrame | None
    totals: pd.DataFrame
    nodes: pd.DataFrame
    sweep: pd.DataFrame
    caption: str
    figure: Path


def _input_set(report: Report, sel: Selection, name: str, sweep: _Sweep,
               n_components: int | None, cv: int | None, draw_seed: int) -> _Part:
    """Fit one input set's model, run its Monte Carlo sweep (draws seeded ``draw_seed``),
    tabulate the result and draw its node figure."""
    model, chosen_by, cv_table = _model(sel, name, n_components, cv, sweep.seed)
    sigmas = sweep.levels * thesis_sigma(name)
    results = {"clean": monte_carlo(
        model,
        sel.x_ref(name),
        sigmas,
        totals=sweep.totals,
        n_draws=sweep.draws,
        seed=draw_seed,
        sampling=sweep.sampling,
    )}
    if sweep.fits:
        results["noisy"] = _noisy_training(sel, name, model, sigmas, sweep, draw_seed)
    label = f"SIMPLS, {model.n_components} components"
    totals, nodes, levels = _rows(sel, name, results, sweep, label)
    return _Part(
        model=(name, model.n_components, chosen_by, thesis_sigma(name)),
        cv=cv_table,
        totals=_training_second(pd.concat(totals, ignore_index=True)),
        nodes=_training_second(pd.concat(nodes, ignore_index=True)),
        sweep=_training_second(pd.concat(levels, ignore_index=True)),
        caption=f"Mean error and std over the tread, {name}",
        figure=_node_figure(report, nodes, name),
    )


def _rows(sel: Selection, name: str, results: dict[str, NoiseResult], sweep: _Sweep,
          label: str) -> tuple[list[pd.DataFrame], list[pd.DataFrame], list[pd.DataFrame]]:
    """Totals, nodes and sweep rows of each training ("clean" first), so labelled."""
    y_ref, at = sel.y_ref, sweep.at_thesis
    totals, nodes, levels = [], [], []
    for training, result in results.items():
        rows = tables.noise_totals(name, result, at, y_ref, sweep.totals, label)
        rows = rows.assign(training=np.where(rows["case"] == "reference", "", training))
        # noise-free rows are the clean model's under either training: listed once
        totals.append(rows if training == "clean" else rows[rows["sigma"] > 0])
        nodes.append(tables.noise_nodes(name, sel.tread, result, at, y_ref)
                     .assign(training=training))
        levels.append(tables.noise_sweep(name, result, sweep.levels, y_ref)
                      .assign(training=training))
    return totals, nodes, levels


def _noisy_training(sel: Selection, name: str, model, sigmas: np.ndarray, sweep: _Sweep,
                    draw_seed: int) -> NoiseResult:
    """The sweep with noise in training too: refits of ``model`` on every selected
    experiment's noisy inputs (the reference among them, as in the clean fit)."""
    X, Y = np.asarray(sel.X(name).compute()), np.asarray(sel.Y.compute())
    return monte_carlo_noisy_training(
        model, X, Y, sel.x_ref(name), sigmas, totals=sweep.totals, n_fits=sweep.fits,
        n_draws=sweep.draws_per_fit, seed=draw_seed, sampling=sweep.sampling,
    )


def _training_second(frame: pd.DataFrame) -> pd.DataFrame:
    """``training`` right after the first column (case or inputs), where it is read."""
    cols = [c for c in frame.columns if c != "training"]
    return frame[[cols[0], "training", *cols[1:]]]


def _write_tables(report: Report, parts: list[_Part]) -> None:
    cols = ["inputs", "n_components", "chosen_by", "thesis_sigma"]
    report.csv("models", pd.DataFrame([p.model for p in parts], columns=cols))
    cvs = [p.cv for p in parts if p.cv is not None]
    if cvs:
        report.csv("cross_validation", pd.concat(cvs, ignore_index=True))
    report.csv("totals", _merge_reference([p.totals for p in parts]))
    table = tables.table_5_1(report.tables["totals"])
    table.insert(1, "training", report.tables["totals"]["training"].to_numpy())
    report.csv("table_5_1", table)
    report.csv("nodes", pd.concat([p.nodes for p in parts], ignore_index=True))
    report.csv("sweep", pd.concat([p.sweep for p in parts], ignore_index=True))


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
    X: da.Array | np.ndarray
    Y: da.Array | np.ndarray
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


def _node_figure(report: Report, nodes: list[pd.DataFrame], name: str) -> Path:
    """Fig. 5.11 from the clean rows; a third map, the std with noisy training, if run."""
    clean = nodes[0]
    panels = {
        "mean error [N]": clean["mean_error"].to_numpy(),
        "standard deviation [N]": clean["std"].to_numpy(),
    }
    if len(nodes) > 1:
        panels["std, noisy training [N]"] = nodes[1]["std"].to_numpy()
    sigma = clean["sigma"].iloc[0]
    return plots.node_maps(
        clean,
        panels,
        report.out / f"nodes_{name}.png",
        f"PLSR from {name} + N(0, {sigma:g}²) (Fig. 5.11)",
    )


def _summary(report: Report, sel: Selection, draws: str, figures) -> None:
    sweep = report.tables["sweep"]
    sweep = sweep[sweep["training"] == "clean"]  # noisy training has no analytic std
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
        *_training_sections(report.tables["totals"]),
        ("Monte Carlo over analytic nodal-average std, across levels", agreement),
        ("Figures", links),
    ]
    report.files.append(
        markdown.write(report.out / "summary.md", "Measurement noise (thesis §5.6)", sections)
    )


def _training_sections(totals: pd.DataFrame) -> list[tuple[str, str | pd.DataFrame]]:
    """Clean beside noisy training at the thesis' level, with their ratio (issue 25)."""
    noisy = totals[totals["training"] == "noisy"]
    if noisy.empty:
        return []
    clean = totals[(totals["training"] == "clean") & (totals["sigma"] > 0)]
    pair = clean.merge(noisy, on=["inputs", "sigma"], suffixes=(" clean", " noisy"))
    frame = pair[["inputs", "sigma"]].copy()
    truth = totals.loc[totals["case"] == "reference", "Fz"].iloc[0]
    for training in ("clean", "noisy"):  # the std is not the whole error: bias, too
        frame[f"Fz mean error {training}"] = pair[f"Fz {training}"] - truth
    for t in ("Fz", "Mx", "My"):
        col = f"{t}_nodal_avg_std"
        frame[f"{col} clean"] = pair[f"{col} clean"]
        frame[f"{col} noisy"] = pair[f"{col} noisy"]
        with np.errstate(invalid="ignore", divide="ignore"):
            frame[f"{t} noisy/clean"] = pair[f"{col} noisy"] / pair[f"{col} clean"]
    ratios = ", ".join(f"{r['inputs']} {r['Fz noisy/clean']:.2f}" for _, r in frame.iterrows())
    text = (
        "The thesis (and the rows `training: clean`) trains on noise-free FE data and adds "
        "noise to the reference inputs only. A model trained on measurements sees the noise "
        "in training too: rows `training: noisy` refit the model (same component count) on "
        "noisy copies of every training experiment's inputs, the reference among them, and "
        "pool the refits' predictions of noisy reference inputs. Ratio noisy/clean of the "
        f"nodal-average std of Fz at the thesis' σ: {ratios}. Refitting on noisy inputs "
        "also moves the mean (errors-in-variables shrink the coefficients): 'Fz mean error' "
        "is the mean predicted total minus the reference's."
    )
    return [("Noise in training (issue 25)", text),
            ("Nodal-average std at the thesis' σ, clean vs noisy training", frame)]
