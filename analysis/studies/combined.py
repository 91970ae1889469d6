"""`farm analyse combined`: which forces can the camera recover under combined loads (issue 13).

From one group of a combined-load study (load parameters ``friction``, ``shift_x``,
``shift_y``, ``tilt`` beside ``deflection`` and ``pressure``; docs/combined-loads.md):

- PCA per input direction and input set: components to 99 % and 99.9 % of the variance
  and the eigenvalue-gap count (:func:`analysis.combined.latent_count`), beside the
  number of load parameters that vary in the group (the truth the fields encode);
- PLSR (SIMPLS) and PCR from displacements, strains, CST surface strains and
  displacements + strains (each set one block, standardised per block), predicting the
  nodal 3-D force map and the totals Fx, Fy, Fz, Mx, My, Mz; a seeded held-out test
  split, the component count chosen by k-fold CV on the training part only;
- measurement noise at the T2Cam levels (1 mm on displacements; 0.04 % = 4e-4, the
  thesis' level, and 0.5 % = 5e-3, T2Cam's strain band) added to the held-out inputs
  (CV folds and test set), the models trained on the noise-free FE data, as
  :mod:`analysis.studies.noise` does, and again on noisy training inputs (column
  ``training``: what a model trained on measurements sees; issue 25); the count is
  chosen again at each noise level and training;
- held-out RMSE per total as % of its range over all selected experiments (the design's
  load range: a test set of a few experiments has an arbitrary, often tiny range), per
  nodal component as % of the range of that component's nodal forces over all selected
  experiments, beside the published anchors and the issue's goal.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr

from analysis import data
from analysis.combined import (
    BlockRegression,
    BlockScaler,
    add_noise,
    cross_validate,
    latent_count,
)
from analysis.data import TOTALS, totals
from analysis.errors import (
    MissingVariableError,
    NoVarianceError,
    ParameterError,
    TooFewExperimentsError,
)
from analysis.render import markdown, plots
from analysis.splits import path_groups, split
from analysis.studies.common import Report

#: load parameters of a combined-load group (docs/combined-loads.md, RoadMotion.to_dict)
MOTION_PARAMETERS = ("friction", "shift_x", "shift_y", "tilt")
#: a rolling group's (issue 30, docs/rolling.md): predicted too, as the field asks
ROLL_PARAMETERS = ("slip_ratio", "slip_angle")
LOAD_PARAMETERS = ("deflection", "pressure", *MOTION_PARAMETERS, *ROLL_PARAMETERS)
ROLL_UNITS = {"slip_ratio": "1", "slip_angle": "deg"}
#: input sets; "both" = displacement and strain side by side, one block each
INPUT_SETS = {
    "displacement": ("displacement",),
    "strain": ("strain",),
    "surface_strain": ("surface_strain",),
    "both": ("displacement", "strain"),
}
#: noise scenarios: (displacement sigma in mm, strain sigma); T2Cam levels
SCENARIOS = {
    "noise-free": (0.0, 0.0),
    "1 mm, 0.04 %": (1.0, 4e-4),
    "1 mm, 0.5 %": (1.0, 5e-3),
}
#: published FE-plus-learning recovery from inner-liner strains on combined loads,
#: % of range (issue 13), and the issue's goal for noise-free displacements + strains
ANCHORS = {"Fz": (1.8, 1.5), "Fy": (3.0, 3.0), "Fx": (4.7, 4.0)}
METHODS = ("plsr", "pcr")


def varying_parameters(ds: xr.Dataset) -> list[str]:
    """Load parameters with more than one value in the selection (stored ones only)."""
    out = []
    for name in LOAD_PARAMETERS:
        if name in ds.variables:
            v = np.asarray(ds[name].values, dtype=float)
            if np.unique(v[np.isfinite(v)]).size > 1:
                out.append(name)
    return out


def check_combined(ds: xr.Dataset) -> list[str]:
    """The varying load parameters; :class:`NoVarianceError` unless a motion one varies."""
    varying = varying_parameters(ds)
    if not any(p in varying for p in (*MOTION_PARAMETERS, *ROLL_PARAMETERS)):
        shown = ", ".join(varying) or "none"
        raise NoVarianceError(
            f"group {ds.attrs.get('group', '?')!r} is not a combined-load selection: none of "
            f"{', '.join((*MOTION_PARAMETERS, *ROLL_PARAMETERS))} varies (varying: {shown}); "
            "run a combined study "
            "(e.g. examples/combined_quick.toml) or use `farm analyse plsr`"
        )
    return varying


def field_matrix(ds: xr.Dataset, var: str) -> np.ndarray:
    """(K, N x components) of inner-surface field ``var``, component-major: the first
    component of every inner node, then the second, ..."""
    if var not in ds:
        raise MissingVariableError(f"group {ds.attrs.get('group', '?')!r} has no {var!r}")
    arr = ds[var].transpose("experiment", "inner_node", ...)
    a = np.asarray(arr.values, dtype=float)  # (K, N, 3), component-major below
    return np.concatenate([a[:, :, j] for j in range(a.shape[2])], axis=1)


def _sigma(var: str, scenario: str) -> float:
    sd, se = SCENARIOS[scenario]
    return sd if var == "displacement" else se


def run(
    ds: xr.Dataset,
    out: Path,
    *,
    inputs: str | None = None,
    test_fraction: float = 0.25,
    folds: int = 5,
    seed: int = 0,
    max_components: int = 15,
    draws: int = 10,
    methods=METHODS,
) -> Report:
    """Run the combined-load analysis on one selection; write tables, figures, summary.

    Parameters
    ----------
    inputs : str, optional
        Comma list of input sets (displacement, strain, surface_strain, both); default
        those the group has.
    test_fraction : float
        Share of the experiments held out for testing (seeded by ``seed``).
    folds : int
        Folds of the CV on the training part that chooses each component count.
    max_components : int
        Largest count the CV tries (also capped by the training folds' size).
    draws : int
        Noise draws per held-out experiment (test set and each CV fold).
    """
    varying = check_combined(ds)
    train, test = _checked_split(ds, test_fraction, folds, seed)
    if draws < 1:
        raise ParameterError(f"draws must be >= 1, got {draws}")
    report = Report(Path(out))
    sets = _input_sets(ds, inputs)
    targets = _targets(ds)
    setup = _Setup(train, test, folds, max_components, draws, seed, methods,
                   targets["nodal"][0].shape[1] // 3, path_groups(ds))
    tread = data.tread_index(ds)
    report.csv("pca", _pca_table(ds, sets, varying))
    results = _Results()
    for name in sets:
        _study_input_set(ds, name, targets, setup, results)
    results.write(report)
    figures = _figures(report, tread, sets, results)
    report.files += [p for _, p in figures]
    cap = min(max_components, train.size - int(np.ceil(train.size / folds)) - 1)
    _summary(report, ds, varying, train, test, folds, draws, figures, cap)
    return report


@dataclass(frozen=True)
class _Setup:
    """What every fit of one run shares: the split, the CV and noise settings."""

    train: np.ndarray
    test: np.ndarray
    folds: int
    max_components: int
    draws: int
    seed: int
    methods: Sequence[str]
    tread_nodes: int  # M: the nodal map's columns are Fx, Fy, Fz of M nodes each
    groups: np.ndarray | None = None  # (K,) load path of each experiment (analysis.splits)


@dataclass
class _Results:
    """Rows of the tables as the fits produce them; the noise-free PLSR ones for figures."""

    models: list[dict] = field(default_factory=list)
    cvs: list[pd.DataFrame] = field(default_factory=list)
    totals: list[pd.DataFrame] = field(default_factory=list)
    nodal: list[pd.DataFrame] = field(default_factory=list)
    maps: dict[str, np.ndarray] = field(default_factory=dict)
    preds: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    def record(self, key: dict, P: np.ndarray, Yt: np.ndarray, Y: np.ndarray,
               setup: _Setup) -> None:
        """The held-out errors of one model's predictions ``P`` of ``Yt``."""
        shown = key["scenario"] == "noise-free" and key["method"] == "plsr"
        if key["target"] == "slip":
            self.totals.append(_total_errors(P, Yt, Y, key, tuple(ROLL_UNITS)))
        elif key["target"] == "totals":
            self.totals.append(_total_errors(P, Yt, Y, key))
            if shown:
                self.preds[key["inputs"]] = (Y[setup.test], P)
        else:
            frame, node_rmse = _nodal_errors(P, Yt, Y, setup.tread_nodes, key)
            self.nodal.append(frame)
            if shown:
                self.maps[key["inputs"]] = node_rmse

    def write(self, report: Report) -> None:
        report.csv("models", pd.DataFrame(self.models))
        report.csv("cross_validation", pd.concat(self.cvs, ignore_index=True))
        report.csv("totals", pd.concat(self.totals, ignore_index=True))
        report.csv("nodal", pd.concat(self.nodal, ignore_index=True))
        report.csv("anchors", anchors(report.tables["totals"]))


def _checked_split(ds: xr.Dataset, test_fraction: float, folds: int,
                   seed: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`split`, refused when the training part is too small for ``folds``-fold CV."""
    K = ds.sizes["experiment"]
    train, test = split(ds, test_fraction, seed)
    need = max(folds, 3)
    if train.size < need or train.size - int(np.ceil(train.size / folds)) - 1 < 1:
        raise TooFewExperimentsError(
            f"the combined-load analysis needs at least {need + 1} training experiments for "
            f"{folds}-fold CV, but {data.selection_text(ds)} has {K} done experiments "
            f"({train.size} after holding out {test.size} for testing): run more load cases "
            "or lower --folds / --test-fraction"
        )
    return train, test


def _targets(ds: xr.Dataset) -> dict[str, tuple[np.ndarray, list[int]]]:
    """What the models predict, with its block sizes: the six totals, the nodal force map
    (Fx of every tread node, then Fy, then Fz)."""
    forces = np.asarray(ds["reaction_force"].transpose("experiment", "tread_node",
                                                       "component").values, dtype=float)
    M = forces.shape[1]
    Y_map = np.concatenate([forces[:, :, j] for j in range(3)], axis=1)
    out = {"totals": (totals(ds), [1] * 6), "nodal": (Y_map, [M, M, M])}
    rolled = [n for n in ROLL_PARAMETERS if n in varying_parameters(ds)]
    if rolled:  # a rolling study: its slip ratio and slip angle, from the camera too
        out["slip"] = (np.column_stack([np.asarray(ds[n].values, dtype=float)
                                        for n in ROLL_PARAMETERS]), [1, 1])
    return out


def _scenario_sigmas(vars_: tuple[str, ...], blocks: list[np.ndarray]) -> dict[str, np.ndarray]:
    """Per noise scenario the sigma of every input column (a scenario that adds no noise
    to these inputs is left out, except the noise-free one)."""
    sigmas = {}
    for scenario in SCENARIOS:
        sigma = np.concatenate([np.full(b.shape[1], _sigma(v, scenario))
                                for v, b in zip(vars_, blocks, strict=True)])
        if scenario == "noise-free" or np.any(sigma > 0):
            sigmas[scenario] = sigma
    return sigmas


def _study_input_set(ds: xr.Dataset, name: str, targets: dict, setup: _Setup,
                     results: _Results) -> None:
    """Every model of one input set: per target, training and scenario, choose the count
    by CV, fit, predict the held-out experiments and record the errors."""
    vars_ = INPUT_SETS[name]
    blocks = [field_matrix(ds, v) for v in vars_]
    X = np.concatenate(blocks, axis=1)
    x_blocks = [b.shape[1] for b in blocks]
    sigmas = _scenario_sigmas(vars_, blocks)
    for target, (Y, y_blocks) in targets.items():
        chosen = _choose_counts(X, Y, sigmas, x_blocks, y_blocks, setup)
        for (training, method, scenario), (best, table) in chosen.items():
            key = dict(inputs=name, scenario=scenario, training=training, method=method,
                       target=target)
            k = list(sigmas).index(scenario)
            Xf, Yf, Xt, Yt = _noisy_parts(X, Y, sigmas[scenario], training, k, setup)
            results.cvs.append(table.assign(**key, chosen=table["n_components"] == best))
            model = BlockRegression(method, best, x_blocks, y_blocks).fit(Xf, Yf)
            results.models.append({**key, "n_components": model.n_components_,
                                   "chosen_by": _chosen_by(setup, sigmas[scenario], training,
                                                           best)})
            results.record(key, model.predict(Xt), Yt, Y, setup)


def _choose_counts(X, Y, sigmas: dict, x_blocks, y_blocks, setup: _Setup) -> dict:
    """(training, method, scenario) -> (chosen count, CV table): trained noise-free, and
    again on the same noise in training (issue 25: as measured data have it)."""
    train = setup.train
    cv_args = dict(methods=setup.methods, folds=setup.folds,
                   max_components=setup.max_components, draws=setup.draws, seed=setup.seed,
                   x_blocks=x_blocks, y_blocks=y_blocks,
                   groups=None if setup.groups is None else setup.groups[train])
    chosen = {("noise-free", *k): v for k, v in cross_validate(
        X[train], Y[train], sigmas=sigmas, **cv_args).items()}
    noisy_sigmas = {s: v for s, v in sigmas.items() if np.any(v > 0)}
    if noisy_sigmas:
        chosen |= {("noisy", *k): v for k, v in cross_validate(
            X[train], Y[train], sigmas=noisy_sigmas, train_noise=True, **cv_args).items()}
    return chosen


def _noisy_parts(X, Y, sigma: np.ndarray, training: str, k: int, setup: _Setup):
    """(X, Y) to fit on and (X, Y) to test on: ``draws`` noisy copies of the held-out
    experiments when the scenario adds noise, and of the training ones when the model is
    trained on noise. Seeded by the scenario's position ``k``."""
    train, test, draws = setup.train, setup.test, setup.draws
    Xf, Yf, Xt, Yt = X[train], Y[train], X[test], Y[test]
    if np.any(sigma > 0):
        rng = np.random.default_rng([setup.seed, 2, k])
        Xt = np.concatenate([add_noise(X[test], sigma, rng) for _ in range(draws)])
        Yt = np.concatenate([Y[test]] * draws)
    if training == "noisy":
        rng = np.random.default_rng([setup.seed, 3, k])
        Xf = np.concatenate([add_noise(X[train], sigma, rng) for _ in range(draws)])
        Yf = np.concatenate([Y[train]] * draws)
    return Xf, Yf, Xt, Yt


def _chosen_by(setup: _Setup, sigma: np.ndarray, training: str, best: int) -> str:
    """How a model's count was chosen, for the ``models`` table."""
    return (f"{setup.folds}-fold CV on {setup.train.size} training experiments, "
            + ("noisy held-out inputs" if np.any(sigma > 0) else "noise-free")
            + (", noisy training inputs" if training == "noisy" else "")
            + (" (the cap: the error still fell)" if best == setup.max_components else ""))


def _figures(report: Report, tread: pd.DataFrame, sets: list[str],
             results: _Results) -> list[tuple[str, Path]]:
    """(caption, path) of the noise-free PLSR figures per input set."""
    figures = []
    for name in sets:
        if name in results.preds:
            figures.append((f"Predicted vs true totals, PLSR from {name}, noise-free test set",
                            _pred_figure(report, name, *results.preds[name])))
        if name in results.maps:
            maps = results.maps[name]
            figures.append((f"Nodal RMSE on the unrolled tread, PLSR from {name}, noise-free",
                            plots.node_maps(tread, {f"RMSE F{c} [N]": maps[j]
                                                    for j, c in enumerate("xyz")},
                                            report.out / f"error_map_{name}.png",
                                            f"Held-out nodal RMSE, PLSR from {name}")))
    return figures


def _input_sets(ds: xr.Dataset, spec: str | None) -> list[str]:
    if spec is None:
        return [n for n, vs in INPUT_SETS.items() if all(v in ds for v in vs)]
    items = [s.strip() for s in spec.split(",") if s.strip()]
    for item in items:
        if item not in INPUT_SETS:
            raise ParameterError(f"unknown input set {item!r}; known: {', '.join(INPUT_SETS)}")
        missing = [v for v in INPUT_SETS[item] if v not in ds]
        if missing:
            raise MissingVariableError(
                f"input set {item!r} needs {missing[0]!r}, which group "
                f"{ds.attrs.get('group', '?')!r} does not hold"
            )
    if not items:
        raise ParameterError("no input set given")
    return items


def _pct(rmse: float, span: float) -> float:
    return 100.0 * rmse / span if span > 0 else float("nan")


def _total_errors(P, Yt, Y_all, key, names: tuple[str, ...] = TOTALS) -> pd.DataFrame:
    """RMSE per total (or slip parameter) over the held-out rows (and draws), % of its
    range over all selected experiments: the load range of the design, not that of a few
    test cases."""
    rows = []
    for j, name in enumerate(names):
        rmse = float(np.sqrt(np.mean((P[:, j] - Yt[:, j]) ** 2)))
        span = float(np.ptp(Y_all[:, j]))
        unit = ROLL_UNITS.get(name) or ("N" if name[0] == "F" else "N mm")
        rows.append({**key, "total": name, "unit": unit,
                     "rmse": rmse, "range": span, "rmse_pct_range": _pct(rmse, span)})
    return pd.DataFrame(rows)


def _nodal_errors(P, Yt, Y_all, M, key):
    rows, maps = [], []
    for j, c in enumerate("xyz"):
        cols = slice(j * M, (j + 1) * M)
        err = P[:, cols] - Yt[:, cols]
        rmse = float(np.sqrt(np.mean(err**2)))
        span = float(np.ptp(Y_all[:, cols]))
        rows.append({**key, "component": c, "rmse": rmse, "range": span,
                     "rmse_pct_range": _pct(rmse, span)})
        maps.append(np.sqrt(np.mean(err**2, axis=0)))
    return pd.DataFrame(rows), np.array(maps)


def anchors(totals: pd.DataFrame) -> pd.DataFrame:
    """Fz, Fy, Fx: published anchor, issue goal, measured held-out % of range (noise-free
    displacements + strains, PLSR and PCR; strains alone beside the strain-based anchor)."""
    rows = []
    for comp, (published, goal) in ANCHORS.items():
        row: dict[str, str | float | bool | None] = {
            "total": comp, "published_pct (strains)": published,
            "goal_pct (displacement+strain, noise-free)": goal}
        measured: dict[str, float] = {}  # "<method> <inputs>" -> held-out % of range
        for inputs in ("both", "strain"):
            for method in METHODS:
                sel = totals[(totals["inputs"] == inputs) & (totals["method"] == method)
                             & (totals["scenario"] == "noise-free") & (totals["total"] == comp)]
                if len(sel):
                    measured[f"{method} {inputs}"] = float(sel["rmse_pct_range"].iloc[0])
        row |= measured
        both = [measured[k] for k in ("plsr both", "pcr both") if k in measured]
        row["goal_met"] = (bool(min(both) <= goal) if both else None)
        rows.append(row)
    return pd.DataFrame(rows)


def _pca_table(ds: xr.Dataset, sets: list[str], varying: list[str]) -> pd.DataFrame:
    rows = []
    fields: dict[str, np.ndarray] = {}
    for name in sets:
        for var in INPUT_SETS[name]:
            fields.setdefault(var, field_matrix(ds, var))
    items = []
    for var, X in fields.items():
        n = X.shape[1] // 3
        comps = ("x", "y", "z") if var == "displacement" else ("xx", "yy", "xy")
        for j, c in enumerate(comps):
            items.append((f"{var} {c}", X[:, j * n:(j + 1) * n]))
        items.append((var, X))
    if "both" in sets:
        both = np.concatenate([fields["displacement"], fields["strain"]], axis=1)
        n = fields["displacement"].shape[1]
        items.append(("both (block-scaled)",
                      BlockScaler([n, both.shape[1] - n]).fit_transform(both)))
    for label, X in items:
        lc = latent_count(X)
        lam = lc.eigenvalues / lc.eigenvalues[0] if lc.eigenvalues.size and lc.eigenvalues[0] \
            else lc.eigenvalues
        rows.append({
            "input": label, "n_99": lc.n_99, "n_99_9": lc.n_999, "n_gap": lc.n_gap,
            "gap_ratio": lc.gap_ratio, "load_parameters_varying": len(varying),
            "eigenvalues_rel": " ".join(f"{v:.2e}" for v in lam[:8]),
        })
    return pd.DataFrame(rows)


def _pred_figure(report: Report, name: str, Y_true: np.ndarray, P: np.ndarray) -> Path:
    fig, axes = plots.new_figure(2, 3, 12, 7.5)
    for j, total in enumerate(TOTALS):
        ax = axes[j // 3, j % 3]
        t, p = Y_true[:, j], P[:, j]
        lo, hi = float(min(t.min(), p.min())), float(max(t.max(), p.max()))
        ax.plot([lo, hi], [lo, hi], "k--", lw=1)
        ax.plot(t, p, "o", ms=4)
        unit = "N" if total[0] == "F" else "N mm"
        ax.set(xlabel=f"true {total} [{unit}]", ylabel=f"predicted {total} [{unit}]",
               title=total)
    fig.suptitle(f"Held-out test set, PLSR from {name} (noise-free)")
    return plots.save_figure(fig, report.out / f"pred_vs_true_{name}.png")


def _summary(report, ds, varying, train, test, folds, draws, figures, cap) -> None:
    d = np.asarray(ds["deflection"].values, dtype=float)
    ranges = []
    for p in varying:
        v = np.asarray(ds[p].values, dtype=float)
        ranges.append(f"{p} {v.min():.4g}..{v.max():.4g}")
    sel = (
        f"{data.selection_text(ds)}: {ds.sizes['experiment']} done experiments "
        f"({train.size} training, {test.size} held out), deflection {d.min():g}-{d.max():g} mm. "
        f"Varying load parameters ({len(varying)}): {', '.join(ranges)}."
    )
    tot = report.tables["totals"]
    wide = tot.pivot_table(index=["inputs", "method", "scenario", "training"], columns="total",
                           values="rmse_pct_range", sort=False).reset_index()
    slips = [n for n in ROLL_PARAMETERS if n in wide.columns]  # a rolling group's
    wide = wide[["inputs", "method", "scenario", "training", *TOTALS, *slips]]
    nod = report.tables["nodal"].pivot_table(index=["inputs", "method", "scenario", "training"],
                                             columns="component", values="rmse_pct_range",
                                             sort=False).reset_index()
    links = "\n\n".join(markdown.figure(p, report.out, c) for c, p in figures)
    if cap < len(varying):
        # 6 training experiments in 5 folds leave 3 components for 5 load parameters: the
        # quick combined study's first run (8 done) was underfitted by construction.
        sel += (f" **Warning: the CV can try at most {cap} components ({train.size} "
                f"training experiments in {folds} folds), fewer than the {len(varying)} "
                "varying load parameters: the models are underfitted by construction; run "
                "more experiments or lower --folds / --test-fraction.**")
    sections = [
        ("Selection", sel),
        ("PCA: latent variables per input (rules: 99 % / 99.9 % variance; largest "
         "eigenvalue ratio lambda_k / lambda_k+1)", report.tables["pca"]),
        ("Held-out RMSE of the totals, % of their range over all selected experiments", wide),
        ("Held-out RMSE of the nodal force map per component, % of its nodal range over "
         "all selected experiments", nod),
        ("Beside the published anchors and the issue's goal (noise-free)",
         report.tables["anchors"]),
        ("Models (component counts chosen by CV)", report.tables["models"]),
        ("About", f"Noise N(0, sigma^2) on every input of the held-out experiments "
         f"({draws} draws each, also in each of the {folds} CV folds that choose the count). "
         "Models trained on the noise-free training part (training = noise-free: a model "
         "trained on FE data), and again on the same noise in training (training = noisy: "
         f"{draws} noisy copies of each training experiment, as a model trained on "
         "measurements sees them; its count chosen again by the same CV). Displacement + "
         "strain: each set one block, centred and divided by its total standard "
         "deviation. Moments Mx, My, Mz as stored (about the contact centre, N mm)."),
        ("Figures", links),
    ]
    report.files.append(markdown.write(report.out / "summary.md",
                                       "Combined loads: which forces can the camera recover?",
                                       sections))
