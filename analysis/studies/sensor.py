"""`farm analyse sensor`: which forces the camera recovers, as a function of the sensor (issue 27).

Every other analysis reads every inner-surface node exactly. This one measures the
group's experiments with a virtual T2Cam (:mod:`analysis.camera.sensor`): a window about the
contact patch, points on a grid of their own, noisy reference and deformed clouds,
strain by four CSTs from the noisy clouds (thesis §2.2). Around a base sensor it varies
one thing at a time - the window (10°-360°), the position noise, the point spacing,
where the window looks (issue 46) - and for each sensor:

- seeded held-out splits that keep load paths whole (the same for every sensor and
  learner; repeated over seeds, issue 46);
- features of the training experiments from ``draws`` noisy measurements each (what a
  model trained on measurements sees) - for the base sensor also noise-free
  (``training`` column: the contrast of training on FE data) - and of the held-out ones
  from ``draws`` noisy measurements;
- each learner of :mod:`analysis.camera.learners` (PLSR with the count chosen by grouped CV on
  the training part; a Gaussian process on the PLS scores) fitted on the same rows;
- held-out RMSE of Fx, Fy, Fz and Mz (or any target of ``ALL_TARGETS``) as % of each
  target's range over all selected experiments, beside the published anchors (Fz 1.8,
  Fy 3, Fx 4.7 %) and issue 27's goals (Fz 1.5, Fy 2.5, Fx 4, Mz 5 %);
- for the base sensor, the held-out coverage of 90 % split-conformal intervals.

Optionally (issue 46) the base sensor trained on the design's interior and tested at
its edges, and on smaller shares of each split's training paths; every study measures
its reference cloud's effect (:mod:`analysis.camera.sensor.reference`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path

import numpy as np
import pandas as pd
import xarray as xr
from sklearn.base import clone

from analysis.camera import learners
from analysis.camera.features import (
    TARGETS,
    UNITS,
    displacements,
    measured_features,
    targets,
    varying_targets,
)
from analysis.camera.predict.intervals import ConformalIntervals
from analysis.camera.sensor import InnerSurface, SensorSpec, VirtualSensor
from analysis.camera.sensor.reference import ReferenceGap, reference_gap
from analysis.camera.sensor.spec import NOISE_FIELDS
from analysis.errors import ParameterError, TooFewExperimentsError
from analysis.render import markdown, plots
from analysis.splits import edge_split, path_groups, split
from analysis.splits import folds as path_folds
from analysis.studies.combined import check_combined
from analysis.studies.common import Report
from analysis.studies.resume import RowCache, fingerprint

#: published recovery from inner-liner strains (% of range) and issue 27's goals
ANCHORS = {"Fz": 1.8, "Fy": 3.0, "Fx": 4.7, "Mz": float("nan")}
GOALS = {"Fz": 1.5, "Fy": 2.5, "Fx": 4.0, "Mz": 5.0}
WINDOWS = (10.0, 20.0, 40.0, 90.0, 360.0)
NOISES = (0.0, 0.5, 1.0, 2.0)
SPACINGS = (5.0, 10.0, 20.0)
INPUTS = ("displacement", "surface_strain")


@dataclass(frozen=True)
class Setup:
    """What every sensor of one study shares."""

    train: np.ndarray
    test: np.ndarray
    learners: tuple[str, ...]
    inputs: tuple[str, ...]
    draws: int
    folds: int
    max_components: int
    seed: int
    groups: np.ndarray  # (K,) load path of each experiment (analysis.splits.path_groups)
    targets: tuple[str, ...] = TARGETS  # issue 46: any of features.ALL_TARGETS


def variants(base: SensorSpec, windows=WINDOWS, noises=NOISES,
             spacings=SPACINGS, positions=()) -> list[tuple[str, SensorSpec]]:
    """(varied axis, sensor): the base sensor, then one axis changed at a time;
    ``positions``: (centre_deg, centre_mm) pairs, the base's window moved there (issue
    46: where to look)."""
    out = [("base", base)]
    out += [("window", replace(base, window_deg=w)) for w in windows if w != base.window_deg]
    out += [("noise", replace(base, noise_mm=n)) for n in noises if n != base.noise_mm]
    out += [("spacing", replace(base, spacing_mm=s)) for s in spacings
            if s != base.spacing_mm]
    out += [("position", replace(base, centre_deg=float(a), centre_mm=float(m)))
            for a, m in positions if (a, m) != (base.centre_deg, base.centre_mm)]
    return out


def run(
    ds: xr.Dataset,
    out: Path,
    *,
    sensor: SensorSpec,
    windows=WINDOWS,
    noises=NOISES,
    spacings=SPACINGS,
    positions=(),
    learner_names=("plsr", "gp"),
    inputs=INPUTS,
    test_fraction: float = 0.25,
    folds: int = 5,
    draws: int = 3,
    max_components: int = 10,
    seed: int = 0,
    repeats: int = 1,
    edges: float = 0.0,
    target_names=TARGETS,
    sizes=(),
) -> Report:
    """Run the sensor study on one loaded group; tables, figures and summary in ``out``.

    ``repeats`` grouped splits (seeds ``seed`` .. ``seed + repeats - 1``; issue 46: a
    held-out error is a mean and a spread over repeated splits, never one split): every
    figure and table shows the mean over them, ``errors.csv`` the mean with its spread
    (``rmse_pct_std``, ``rmse_pct_min``, ``rmse_pct_max``) and ``errors_by_split.csv``
    every split's rows.

    ``edges`` > 0 (issue 46: check the design's edges): the base sensor once more,
    trained on the interior and tested on the load paths with a varying parameter in
    the outer ``edges`` of its range (:func:`analysis.splits.edge_split`);
    ``errors_edges.csv`` and the summary's "At the design's edges".

    ``target_names``: what the models predict, any of
    :data:`analysis.camera.features.ALL_TARGETS` (issue 46: the six forces and moments,
    the slips and the camber), or ``"all"``: those that vary in the group.

    ``sizes``: fractions in (0, 1) of each split's training groups (issue 46: the error
    against the training set's size): the base sensor trained on that share of them
    (seeded), tested on the same held-out paths; axis ``size``, column
    ``train_fraction``."""
    varying = check_combined(ds)
    if target_names == "all":
        target_names = varying_targets(ds)
    Y = targets(ds, target_names)
    _check(Y.shape[0], folds, draws, repeats, learner_names)
    groups = path_groups(ds)
    setups = [_trainable(Setup(*split(ds, test_fraction, seed + r),  # whole rolls
                               tuple(learner_names), tuple(inputs), draws, folds,
                               max_components, seed + r, groups, tuple(target_names)))
              for r in range(repeats)]
    setup = setups[0]
    # the smaller training sets and the edges' split first: what cannot run fails here
    sized = [(f, r, fewer(one, f)) for f in sizes for r, one in enumerate(setups)]
    at_edges = None
    if edges > 0:
        at_edges = _at_edges(setup, ds, varying, edges)
    surface = InnerSurface.from_dataset(ds)
    sensors = _laid_out(surface, variants(sensor, windows, noises, spacings, positions))
    U = displacements(ds)
    report = Report(Path(out))
    cache = RowCache(out, fingerprint(ds, Y))  # a stopped study resumes from its units
    rows, points = _all_sensors(sensors, U, Y, setups, sized, cache)
    by_split = pd.DataFrame(rows)
    errors = over_splits(by_split)
    report.csv("errors", errors)
    report.csv("errors_by_split", by_split)
    report.csv("sensors", pd.DataFrame(points))
    edge = _edge_errors(ds, VirtualSensor(sensor, surface), U, Y, at_edges, report, edges)
    gap = _reference(ds, surface, U, sensor, seed, inputs, report)
    figures = _figures(report, errors, sensor)
    _summary(report, ds, sensor, errors, setup, varying, figures, repeats, edge, gap)
    return report


def _laid_out(surface: InnerSurface, specs: list[tuple[str, SensorSpec]]
              ) -> list[tuple[str, VirtualSensor]]:
    """Every sensor laid out on ``surface`` first: a window that sees too few points
    fails before any work."""
    return [(axis, VirtualSensor(spec, surface)) for axis, spec in specs]


def _all_sensors(sensors: list[tuple[str, VirtualSensor]], U: np.ndarray, Y: np.ndarray,
                 setups: list[Setup], sized=(), cache: RowCache | None = None
                 ) -> tuple[list[dict], list[dict]]:
    """Error rows of every sensor on every split (and of the base sensor on each
    smaller training set of ``sized``: (fraction, split, setup)), and each sensor's
    points; each sensor on each split kept in ``cache`` as it ends (a stopped study
    resumes: :mod:`analysis.studies.resume`)."""
    def unit(k: int, axis: str, one: Setup) -> list[dict]:
        virtual = sensors[k][1]
        if cache is None:
            return _one_sensor(virtual, U, Y, one, k, axis)
        key = {"axis": axis, "k": k, "sensor": virtual.spec.to_dict(),
               **{f.name: getattr(one, f.name) for f in fields(one)}}
        return cache.rows(key, lambda: _one_sensor(virtual, U, Y, one, k, axis))

    rows, points = [], []
    for k, (axis, virtual) in enumerate(sensors):
        points.append({"axis": axis, **virtual.spec.to_dict(),
                       "points": int(np.prod(virtual.layout.xyz.shape[:2]))})
        for r, one in enumerate(setups):
            rows += [{**row, "split": r, "train_fraction": 1.0} for row in unit(k, axis, one)]
    for f, r, one in sized:
        rows += [{**row, "split": r, "train_fraction": f} for row in unit(0, "size", one)]
    return rows, points


def fewer(setup: Setup, fraction: float) -> Setup:
    """``setup`` trained on ``fraction`` of its training groups (enough for its CV;
    seeded by the split), tested on the same held-out ones."""
    if not 0.0 < fraction < 1.0:
        raise ParameterError(f"a training-set fraction must be in (0, 1), got {fraction!r}")
    labels = np.unique(setup.groups[setup.train])
    keep = round(fraction * labels.size)
    chosen = np.random.default_rng([setup.seed, 46]).permutation(labels)[:keep]
    train = setup.train[np.isin(setup.groups[setup.train], chosen)]
    return _trainable(replace(setup, train=train), f"--sizes {fraction:g} of the "
                      f"{labels.size} training paths trains on",
                      "give a larger fraction or fewer --folds")


def _trainable(setup: Setup, what: str = "a split trains on",
               fix: str = "give fewer --folds or a smaller --test-fraction") -> Setup:
    """``setup``, checked before any work: its training paths fill ``folds`` CV folds,
    and each fold's model (the base sensor's out-of-fold residuals for its intervals)
    keeps at least two paths for a CV of its own; else one error, ``what`` and ``fix``
    saying where the paths went and what to change."""
    groups = setup.groups[setup.train]
    paths = np.unique(groups).size
    if paths < setup.folds:
        raise ParameterError(f"{what} {paths} load paths, fewer than the {setup.folds} CV "
                             f"folds: {fix}, or run more load cases")
    if min(np.unique(groups[tr]).size for tr, _ in path_folds(groups, setup.folds, None)) < 2:
        raise ParameterError(
            f"{what} {paths} load paths: {setup.folds} CV folds (each fold's model choosing "
            f"its own count on two paths or more) need more - {fix}, or run more load cases")
    return setup


def _at_edges(setup: Setup, ds: xr.Dataset, varying: list[str], edges: float) -> Setup:
    """The base setup trained on the design's interior and tested at its edges."""
    inner, outer = edge_split(ds, varying, edges)
    return _trainable(replace(setup, train=inner, test=outer),
                      f"the interior left by --edges {edges:g} trains on",
                      "give a smaller --edges or fewer --folds")


def _reference(ds: xr.Dataset, surface: InnerSurface, U: np.ndarray, sensor: SensorSpec,
               seed: int, inputs, report: Report) -> ReferenceGap | None:
    """The reference cloud's effect on the measured strain (None: no strain read)."""
    if "surface_strain" not in inputs or "surface_strain" not in ds:
        return None
    gap = reference_gap(ds, surface, U, sensor, np.random.default_rng([seed, 46]))
    report.csv("reference", pd.DataFrame([{**asdict(gap), "relative": gap.relative}]))
    return gap


def _edge_errors(ds: xr.Dataset, virtual: VirtualSensor, U: np.ndarray, Y: np.ndarray,
                 at_edges: Setup | None, report: Report, fraction: float
                 ) -> pd.DataFrame | None:
    """The base sensor trained on the interior, tested at the edges (None: not asked)."""
    if at_edges is None:
        return None
    edge = pd.DataFrame(_one_sensor(virtual, U, Y, at_edges, 0, "base"))
    report.csv("errors_edges", edge)
    edge.attrs.update(fraction=fraction, train=at_edges.train.size, test=at_edges.test.size,
                      paths=len(set(path_groups(ds, trees=False)[at_edges.test])))
    return edge


def _check(K: int, folds: int, draws: int, repeats: int, learner_names) -> None:
    """Refuse a study that cannot run, before any work."""
    if 2 * folds > K:
        raise TooFewExperimentsError(f"the sensor study needs at least {2 * folds} done "
                                     f"experiments ({folds} CV folds), the selection has {K}")
    if draws < 1:
        raise ParameterError(f"draws must be at least 1, got {draws}")
    if not (isinstance(repeats, int) and 1 <= repeats <= MAX_REPEATS):
        raise ParameterError(f"repeats must be an integer in [1, {MAX_REPEATS}], got "
                             f"{repeats!r}")
    for name in learner_names:
        learners.learner(name)  # unknown names fail here, before any work


def _one_sensor(virtual: VirtualSensor, U: np.ndarray, Y: np.ndarray, setup: Setup,
                k: int, axis: str) -> list[dict]:
    """Every learner and training of one sensor, on the study's split."""
    clean = virtual.clean(U)
    rng = np.random.default_rng([setup.seed, k])
    noisy = virtual.spec.noisy
    reps = setup.draws if noisy else 1
    Xt, blocks = measured_features(virtual, clean[setup.test], reps, rng,
                                  setup.inputs)
    Yt = np.tile(Y[setup.test], (reps, 1))
    span = np.ptp(Y, axis=0)
    # the noise-free training is the base sensor's contrast (the summary's "trained on
    # noise-free FE data"); the other axes read models trained as they are used, so
    # they skip it (half their fits)
    trainings = ({"noise-free": 0} if not noisy else
                 {"noisy": reps, "noise-free": 0} if axis == "base" else {"noisy": reps})
    rows = []
    for training, n in trainings.items():
        Xf, _ = measured_features(virtual, clean[setup.train], n, rng, setup.inputs)
        # a CV fold keeps an experiment's noisy draws, and a roll's states, together
        groups = np.tile(setup.groups[setup.train], max(n, 1))
        Yf = np.tile(Y[setup.train], (max(n, 1), 1))
        # the intervals are checked where the model is meant for use: the base sensor,
        # trained on measurements (noise-free only for a sensor without noise)
        check = axis == "base" and (training == "noisy" or not noisy)
        for name in setup.learners:
            model = learners.learner(name, max_components=setup.max_components,
                                     folds=setup.folds, x_blocks=blocks,
                                     y_blocks=[1] * len(setup.targets), seed=setup.seed)
            P = model.fit(Xf, Yf, groups).predict(Xt)
            rmse = np.sqrt(np.mean((P - Yt) ** 2, axis=0))
            cover = (_coverage(model, Xf, Yf, groups, setup.folds, P, Yt) if check
                     else np.full(len(setup.targets), np.nan))
            for j, target in enumerate(setup.targets):
                rows.append({"axis": axis, **virtual.spec.to_dict(), "training": training,
                             "learner": name, "n_components": model.n_components_,
                             "target": target, "unit": UNITS[target],
                             "rmse": float(rmse[j]), "range": float(span[j]),
                             "rmse_pct_range": _pct(rmse[j], span[j]),
                             "coverage_90": float(cover[j])})
    return rows


def _coverage(model, Xf: np.ndarray, Yf: np.ndarray, groups: np.ndarray, folds: int,
              P: np.ndarray, Yt: np.ndarray) -> np.ndarray:
    """Held-out coverage (n_targets,) of split-conformal 90 % intervals (issue 46) whose
    half-widths are the training rows' out-of-fold residuals (each row predicted by a
    model fitted without its group: :func:`analysis.splits.folds`), as ``farm fit``
    calibrates its own; ``P`` the fitted ``model``'s predictions of the held-out
    ``Yt``."""
    residuals = np.empty_like(Yf)
    for train, test in path_folds(groups, folds, None):
        # a fold's model chooses its own count by CV over the paths it has: fewer folds
        # where it has fewer paths than the study's folds
        inner = min(folds, np.unique(groups[train]).size)
        fold = clone(model).set_params(folds=inner).fit(Xf[train], Yf[train], groups[train])
        residuals[test] = Yf[test] - fold.predict(Xf[test])
    return ConformalIntervals(alpha=0.1).fit(residuals).coverage(Yt, P)


#: The most repeated splits one study may take (each refits every learner and sensor)
MAX_REPEATS = 100


def over_splits(by_split: pd.DataFrame) -> pd.DataFrame:
    """Per-split error rows (a ``split`` column) -> one row per sensor, training, learner
    and target: ``rmse``, ``range``, ``rmse_pct_range`` and ``n_components`` their means
    over the splits, with ``rmse_pct_std`` (0 for one split), ``rmse_pct_min``,
    ``rmse_pct_max`` and ``splits``; ``coverage_90`` (the base sensor's held-out interval
    coverage) its mean, with ``coverage_90_min`` and ``coverage_90_max``."""
    means = [c for c in ("rmse", "range", "rmse_pct_range", "n_components", "coverage_90")
             if c in by_split]
    keys = [c for c in by_split.columns if c not in (*means, "split")]
    grouped = by_split.groupby(keys, sort=False, dropna=False)
    out = grouped[means].mean()
    pct = grouped["rmse_pct_range"]
    out["rmse_pct_std"] = pct.std(ddof=0)
    out["rmse_pct_min"], out["rmse_pct_max"] = pct.min(), pct.max()
    if "coverage_90" in by_split:  # the held-out coverage's spread over the splits
        out["coverage_90_min"] = grouped["coverage_90"].min()
        out["coverage_90_max"] = grouped["coverage_90"].max()
    out["splits"] = grouped["split"].nunique()
    return out.reset_index()


def spread_table(errors: pd.DataFrame) -> pd.DataFrame:
    """The base sensor's held-out % of range as "mean ± std (min-max)" over the splits,
    one row per target, one column per learner (trained on measurements)."""
    base = measured(errors[errors["axis"] == "base"])
    cells = {(t, lrn): f"{g['rmse_pct_range'].iat[0]:.2f} ± {g['rmse_pct_std'].iat[0]:.2f} "
                       f"({g['rmse_pct_min'].iat[0]:.2f}-{g['rmse_pct_max'].iat[0]:.2f})"
             for (t, lrn), g in base.groupby(["target", "learner"])}
    learners_ = sorted({lrn for _, lrn in cells})
    return pd.DataFrame([{"target": t, **{lrn: cells.get((t, lrn), "") for lrn in learners_}}
                         for t in _targets(errors)])


def coverage_table(errors: pd.DataFrame) -> pd.DataFrame:
    """The base sensor's held-out coverage of its 90 % intervals, one row per target, one
    column per learner: the mean over the splits (min-max where there are several)."""
    rows = errors[(errors["axis"] == "base") & errors["coverage_90"].notna()]

    def cell(g: pd.DataFrame) -> str:
        text = f"{g['coverage_90'].iat[0]:.2f}"
        if "coverage_90_min" in g and g["splits"].iat[0] > 1:
            text += f" ({g['coverage_90_min'].iat[0]:.2f}-{g['coverage_90_max'].iat[0]:.2f})"
        return text

    cells = {key: cell(g) for key, g in rows.groupby(["target", "learner"])}
    names = sorted({lrn for _, lrn in cells})
    return pd.DataFrame([{"target": t, **{n: cells.get((t, n), "") for n in names}}
                         for t in _targets(rows)])


def _targets(errors: pd.DataFrame) -> list[str]:
    """The targets of an error table, in the order the study asked for them."""
    return list(dict.fromkeys(errors["target"]))


def _pct(rmse: float, span: float) -> float:
    return 100.0 * float(rmse) / float(span) if span > 0 else float("nan")


def _figures(report: Report, errors: pd.DataFrame, base: SensorSpec) -> list[Path]:
    """Error vs window and error vs noise, one line per target and learner (noisy
    training where the sensor has noise)."""
    figures = []
    for axis, column, label in (("window", "window_deg", "window (°)"),
                                ("noise", "noise_mm", "position noise σ (mm)"),
                                ("spacing", "spacing_mm", "point spacing (mm)"),
                                ("size", "train_fraction", "share of the training paths")):
        sel = measured(errors[errors["axis"].isin(["base", axis])])
        if sel[column].nunique() < 2:
            continue
        series = {f"{t}, {lrn}": (g[column].to_numpy(float), g["rmse_pct_range"].to_numpy())
                  for (t, lrn), g in sel.sort_values(column).groupby(["target", "learner"])}
        path = report.out / f"error_vs_{axis}.png"
        plots.lines(path, series, xlabel=label, ylabel="held-out RMSE (% of range)",
                    title=f"Held-out error vs {label.split(' (')[0]} (base: {base.name})",
                    logx=axis == "window")
        report.files.append(path)
        figures.append(path)
    return figures


def _noisy(frame: pd.DataFrame) -> pd.Series:
    cols = [c for c in NOISE_FIELDS if c in frame]
    return (frame[cols] > 0).any(axis=1)


def best_table(errors: pd.DataFrame, axis: str = "base") -> pd.DataFrame:
    """Held-out % of range per target (rows) and learner x training (columns) for one
    axis of the study, beside the anchors and goals."""
    sel = errors[errors["axis"] == axis]
    table = sel.pivot_table(index="target", columns=["learner", "training"],
                            values="rmse_pct_range", aggfunc="first")
    table.columns = [f"{lrn}, trained {tr}" for lrn, tr in table.columns]
    table = table.reindex(_targets(sel))
    table["published anchor"] = [ANCHORS.get(t, np.nan) for t in table.index]
    table["issue 27 goal"] = [GOALS.get(t, np.nan) for t in table.index]
    return table.reset_index()


AXIS_COLUMNS = {"window": ["window_deg"], "noise": ["noise_mm"], "spacing": ["spacing_mm"],
                "position": ["centre_deg", "centre_mm"], "size": ["train_fraction"]}


def measured(errors: pd.DataFrame) -> pd.DataFrame:
    """The rows of models trained as they would be used: on noisy measurements where the
    sensor has noise, noise-free where it has none."""
    noisy = _noisy(errors)
    return errors[(errors["training"] == "noisy") | ~noisy]


def axis_table(errors: pd.DataFrame, axis: str) -> pd.DataFrame:
    """Held-out % of range along one axis (base sensor included), trained on
    measurements: one row per axis value, one column per target and learner."""
    column = AXIS_COLUMNS[axis]
    sel = measured(errors[errors["axis"].isin(["base", axis])])
    wide = sel.pivot_table(index=column, columns=["target", "learner"],
                           values="rmse_pct_range", aggfunc="first")
    wide = wide.reindex(columns=[c for t in _targets(sel) for c in wide.columns if c[0] == t])
    wide.columns = [f"{t} {lrn}" for t, lrn in wide.columns]
    return wide.reset_index()


def where_to_look(errors: pd.DataFrame) -> list[str]:
    """Bullets: for each target, the window position (base included) whose model, reading
    that region alone, recovers it best (issue 46: which region carries Mz)."""
    sel = measured(errors[errors["axis"].isin(["base", "position"])])
    if not (errors["axis"] == "position").any():
        return []
    out = []
    for target in _targets(sel):
        rows = sel[sel["target"] == target]
        best = rows.loc[rows["rmse_pct_range"].idxmin()]
        base = rows[rows["axis"] == "base"]["rmse_pct_range"].min()
        out.append(f"- {target}: best seen at {best['centre_deg']:g}°, "
                   f"{best['centre_mm']:g} mm ({best['rmse_pct_range']:.2f} % of range, "
                   f"{best['learner']}; centred: {base:.2f} %).")
    return out


def findings(errors: pd.DataFrame) -> list[str]:
    """Bullets: the base sensor's best learner per target against anchor and goal, and
    what training on noise-free data does to a noisy sensor."""
    base = measured(errors[errors["axis"] == "base"])
    out = []
    for target in _targets(base):
        rows = base[base["target"] == target]
        best = rows.loc[rows["rmse_pct_range"].idxmin()]
        goal, anchor = GOALS.get(target, np.nan), ANCHORS.get(target, np.nan)
        verdict = ("" if np.isnan(goal) else
                   f" {'meets' if best['rmse_pct_range'] <= goal else 'misses'} the goal "
                   f"of {goal:g} %")
        against = "" if np.isnan(anchor) else f", published anchor {anchor:g} %"
        out.append(f"- {target}: {best['rmse_pct_range']:.2f} % of range ({best['learner']})"
                   f"{verdict}{against}.")
    base = errors[(errors["axis"] == "base") & _noisy(errors)]
    if not base.empty:
        pct = base.set_index(["target", "learner", "training"])["rmse_pct_range"].unstack()
        if {"noisy", "noise-free"} <= set(pct.columns):
            worse = int((pct["noise-free"] > pct["noisy"]).sum())
            out.append(f"- Trained on noise-free FE data (count chosen noise-free) and applied "
                       f"to the noisy sensor: {pct['noise-free'].min():.3g}-"
                       f"{pct['noise-free'].max():.3g} % of range, against "
                       f"{pct['noisy'].min():.3g}-{pct['noisy'].max():.3g} % when trained on "
                       f"noisy measurements (worse in {worse} of {len(pct)} target x "
                       "learner pairs).")
    return out


def _edges(edge: pd.DataFrame | None) -> list[str]:
    """The summary's section on the design's edges (none without ``edges``)."""
    if edge is None:
        return []
    a = edge.attrs
    return ["## At the design's edges", "",
            f"Trained on the interior ({a['train']} experiments), tested on the "
            f"{a['test']} experiments of the {a['paths']} load paths with a varying "
            f"parameter in the outer {a['fraction']:g} of its range (`errors_edges.csv`): "
            "what a model does at and just beyond the edges of what it was trained on.", "",
            markdown.table(best_table(edge)), "", "Their 90 % intervals' coverage:", "",
            markdown.table(coverage_table(edge)), ""]


def _summary(report: Report, ds: xr.Dataset, sensor: SensorSpec, errors: pd.DataFrame,
             setup: Setup, varying: list[str], figures: list[Path], repeats: int = 1,
             edge: pd.DataFrame | None = None, gap: ReferenceGap | None = None) -> None:
    paths = len(set(setup.groups.tolist()))
    held = (f"{setup.train.size} for training, {setup.test.size} held out (seed "
            f"{setup.seed})" if repeats == 1 else
            f"{repeats} grouped splits (seeds {setup.seed}-{setup.seed + repeats - 1}; the "
            f"first: {setup.train.size} for training, {setup.test.size} held out), every "
            "figure a mean over them")
    lines = [
        "# Identifiability vs the sensor (issue 27)", "",
        f"Group {ds.attrs.get('group', '?')!r}: {ds.sizes['experiment']} done experiments "
        f"in {paths} load paths (a roll's states are one; a split holds out whole paths), "
        f"varying {', '.join(varying)}; {held}; inputs {', '.join(setup.inputs)}; "
        f"{setup.draws} "
        "noisy measurements per experiment; learners "
        f"{', '.join(setup.learners)} (PLSR count by {setup.folds}-fold grouped CV).", "",
        f"Base sensor `{sensor.name}`: " + ", ".join(
            f"{k} {v}" for k, v in sensor.to_dict().items() if k != "name"), "",
        "## Findings (held-out RMSE, % of each total's range)", "", *findings(errors), "",
        "## Base sensor", "", markdown.table(best_table(errors)), "",
        *(["Over the splits, mean ± standard deviation (min-max), % of range:", "",
           markdown.table(spread_table(errors)), ""] if repeats > 1 else []),
        "Held-out coverage of the 90 % intervals (split-conformal, calibrated on the "
        "training rows' out-of-fold residuals as `farm fit` does; goal 0.85-0.95):", "",
        markdown.table(coverage_table(errors)), "",
        *_edges(edge),
        *(["## The reference cloud", "", gap.sentence() + " (`reference.csv`; "
           "analysis/camera/sensor/reference.py)", ""] if gap is not None else []),
        "Below, models are trained on noisy measurements (noise-free only where the sensor "
        "has no noise); `errors.csv` holds every row (`errors_by_split.csv`: each split's).",
        "",
    ]
    for axis in AXIS_COLUMNS:
        if (errors["axis"] == axis).any():
            lines += [f"## Varying the {axis}", "",
                      markdown.table(axis_table(errors, axis)), ""]
    if (errors["axis"] == "position").any():
        lines += ["Where to look: the same window moved (centre_deg from the contact "
                  "centre, + ahead of the patch; centre_mm from the crown, + towards +y), "
                  "each model reading that region alone:", "", *where_to_look(errors), ""]
    lines += [f"![{p.stem}]({p.name})" for p in figures]
    path = report.out / "summary.md"
    path.write_text("\n".join(lines) + "\n")
    report.files.append(path)
