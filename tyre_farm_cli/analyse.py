"""``farm analyse pca|pcr|plsr|noise|combined|sensor|surrogate STORE``: one command per analysis.

The ``farm`` CLI (:mod:`tyre_farm_cli`) mounts :data:`app` as ``farm analyse`` and turns
:class:`~analysis.errors.AnalysisError` and :class:`storage.StoreError` into one line on
stderr; the commands here raise those errors and never exit themselves. Options are
checked before the analysis runs: ``--out`` must be a folder that can be written,
``--scheduler`` an address, and ``--reference-deflection`` one of the deflections the
selection holds (the nearest one was once used silently: 999 mm meant 30 mm).
"""

from __future__ import annotations

import importlib
import math
from pathlib import Path
from typing import Any

import numpy as np
import typer

from analysis.errors import ParameterError
from jobs.errors import ClusterError, StudyError
from jobs.validate import messages
from jobs.wording import plural
from tyre_farm_cli.analyse_options import (
    Axes,
    Bands,
    BootstrapSeed,
    CombinedDraws,
    CombinedFolds,
    CombinedInputs,
    CombinedMaxComponents,
    ConfLevel,
    Deflection,
    Deflections,
    Edges,
    FitLearner,
    Force,
    Group,
    Inputs,
    IntervalKinds,
    Json,
    Learners,
    Method,
    MismatchedStore,
    ModelStudy,
    Nipals,
    NoiseComponents,
    NoiseCv,
    NoiseDraws,
    NoiseLevels,
    Noises,
    NoiseSeed,
    NominalGroup,
    NominalStore,
    NumResamples,
    Out,
    PcaModes,
    PcrModes,
    PlsComponents,
    PlsCv,
    PopulationFolds,
    PopulationStore,
    Positions,
    Pressure,
    PressuresKpa,
    Reference,
    RegionComponents,
    RegionFolds,
    RegionNoise,
    RegionRepeats,
    Repeats,
    Restarts,
    Sampling,
    Scheduler,
    ScoreComponents,
    ScoreField,
    Sectors,
    Sensor,
    SensorDraws,
    SensorFolds,
    SensorMaxComponents,
    ShuffleSeed,
    Sizes,
    Spacings,
    Span,
    SplitSeed,
    StorageOption,
    Store,
    SurrogateField,
    SurrogateFolds,
    SurrogateSeed,
    Targets,
    TestFraction,
    Tpms,
    TrainNoise,
    Windows,
)
from tyre_farm_cli.checks import output_folder
from tyre_farm_cli.errors import usage
from tyre_farm_cli.jsondoc import dump, records
from tyre_farm_cli.options import APP_SETTINGS, open_target, with_tls

REFERENCE_TOLERANCE_MM = 1e-6  # stored deflections are rounded to 1e-9 mm
MAX_DRAWS = 10_000  # Monte Carlo draws per noise level
MAX_NOISE_LEVEL = 100.0  # multiples of the thesis' noise level


def _study(name: str):
    """Import a study module on first use: `farm --help` must not pay for scikit-learn."""
    return importlib.import_module(f"analysis.studies.{name}")


def dask_scheduler(address: str | None):
    """Where the reductions run: ``--scheduler``, else the scheduler the environment
    names (the order of :func:`jobs.cluster.resolve_scheduler`, as for sweeps), else
    dask's local threads."""
    from analysis.cluster import CONNECT_TIMEOUT, scheduler
    from jobs.cluster import resolve_scheduler
    from jobs.handshake import check_scheduler

    address = resolve_scheduler(address)
    if address:  # Client's timeout does not cover Dask's handshake (issue 26)
        import dask

        from analysis.errors import SchedulerError

        try:
            check_scheduler(address, dask.utils.parse_timedelta(CONNECT_TIMEOUT))
        except OSError as e:
            raise SchedulerError(f"cannot reach the Dask scheduler at {address}: {e}") from e
        except ClusterError as e:
            raise SchedulerError(str(e)) from e
    return scheduler(address)


app = typer.Typer(
    name="analyse",
    help="PCA / PCR / PLSR / noise studies over a store (thesis chapter 5).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    **APP_SETTINGS,
)


_NO_REFERENCE = object()  # the analysis takes no reference deflection


def _analyse(name: str, command: str, *, store: str, options: list[str] | None,
             group: str | None, pressure: float | None, deflection: float | None = None,
             out: Path | None, scheduler: str | None, as_json: bool, axes: str | None = None,
             reference: object = _NO_REFERENCE, **kwargs) -> None:
    """The scaffold of every store analysis: the output folder checked, the selection
    loaded on the scheduler (turned to ``axes``), ``reference`` checked against it when
    the analysis takes one, the study run, what it wrote reported."""
    from analysis.render import provenance
    from tyre_farm_cli.invocation import command as invocation

    folder = _out(out, command)
    run = provenance.Run(invocation())  # the command, commit and load, beside the results
    with dask_scheduler(scheduler):
        ds = load_selection(store, options, group, pressure, deflection)
        if axes is not None:
            ds = in_axes(ds, axes)
        if reference is not _NO_REFERENCE:
            kwargs["reference_deflection"] = _reference(ds, reference)  # type: ignore[arg-type]
        report = _study(name).run(ds, folder, **kwargs)
    report.files.extend(p for p in provenance.record(run, report.out) if p not in report.files)
    _done(report, as_json)


def load_selection(store: str, options: list[str] | None, group: str | None, pressure: float | None,
          deflection: float | None):
    """The selection of ``store`` (opened with its ``--storage-option`` pairs);
    ``pressure`` in kPa (the CLI's unit), converted to the store's MPa."""
    from analysis import data

    mpa = None if pressure is None else pressure / 1000.0
    return data.load(open_target(store, options), group, pressure=mpa, deflection=deflection)


def load_tyres(store: str, options: list[str] | None, groups: list[str | None],
               pressure: float | None = None, *, skip_empty: bool = False) -> list:
    """The selections of ``groups`` of ``store``, one per tyre. ``skip_empty`` (every
    group asked for, as ``--group all`` does): a group with no done experiment yet (a
    population sweep still running) is left out with a note on stderr, not an error;
    none left is one."""
    from analysis.errors import EmptySelectionError

    out, left = [], []
    for g in groups:
        try:
            out.append(load_selection(store, options, g, pressure, None))
        except EmptySelectionError:
            if not skip_empty:
                raise
            left.append(str(g))
    if left:
        typer.echo(f"note: {plural(len(left), 'group')} of {store} with no done experiment "
                   f"left out: {', '.join(left)}", err=True)
    if not out:
        raise EmptySelectionError(f"no group of {store} holds a done experiment: run or "
                                  "resume its sweep first")
    return out


def _out(out: Path | None, command: str) -> Path:
    folder = out if out is not None else Path("analysis-out") / command
    with usage():
        try:
            return output_folder(folder, "--out")
        except StudyError as e:  # the analyses' own error type, for callers of the app
            raise ParameterError(str(e)) from e


def _reference(ds, deflection: float | None) -> float | None:
    """``--reference-deflection`` if the selection holds it (within
    :data:`REFERENCE_TOLERANCE_MM`), else one line listing the deflections it holds
    (a usage error: a value the user typed)."""
    if deflection is None:
        return None
    with usage():
        return _stored_reference(ds, deflection)


def _stored_reference(ds, deflection: float) -> float:
    stored = np.unique(np.asarray(ds["deflection"].values, dtype=float))
    if math.isfinite(deflection) and np.any(np.abs(stored - deflection) <= REFERENCE_TOLERANCE_MM):
        return deflection
    shown = ", ".join(f"{d:g}" for d in stored[:12]) + (", ..." if len(stored) > 12 else "")
    raise ParameterError(
        f"--reference-deflection {deflection:g} mm is not a deflection of the selected "
        f"experiments; give one of: {shown} mm"
    )


def _done(report, as_json: bool = False) -> None:
    """The files an analysis wrote; with ``as_json`` also every table it wrote, by name."""
    summary = report.out / "summary.md"
    if as_json:
        dump({"out": report.out, "summary": summary, "files": report.files,
              "tables": {name: records(frame) for name, frame in report.tables.items()}})
        return
    typer.echo(f"wrote {plural(len(report.files), 'file')} to {report.out} (see {summary})")


@app.command()
@with_tls
def pca(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
        deflection: Deflection = None, inputs: Inputs = None, components: PcaModes = 3,
        force_component: Force = "z", scheduler: Scheduler = None,
        storage_option: StorageOption = None, as_json: Json = False) -> None:
    """Cross-covariance PCA per direction: singular values, eigen-maps, importance (§5.3)."""
    _analyse("crosscov", "pca", store=store, options=storage_option, group=group,
             pressure=pressure, deflection=deflection, out=out, scheduler=scheduler,
             as_json=as_json, inputs=inputs, n_modes=components,
             component=force_component)


@app.command()
@with_tls
def pcr(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
        deflection: Deflection = None, inputs: Inputs = None, components: PcrModes = 5,
        reference_deflection: Reference = None, force_component: Force = "z",
        scheduler: Scheduler = None, storage_option: StorageOption = None,
        as_json: Json = False) -> None:
    """Principal component regression with 1..N modes (§5.4, Figs. 5.5-5.7)."""
    _analyse("pcr", "pcr", store=store, options=storage_option, group=group,
             pressure=pressure, deflection=deflection, out=out, scheduler=scheduler,
             as_json=as_json, reference=reference_deflection, inputs=inputs,
             max_modes=components, component=force_component)


@app.command()
@with_tls
def plsr(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
         deflection: Deflection = None, inputs: Inputs = None, components: PlsComponents = 5,
         cv: PlsCv = None, nipals: Nipals = True, seed: ShuffleSeed = None,
         reference_deflection: Reference = None, force_component: Force = "z",
         scheduler: Scheduler = None, storage_option: StorageOption = None,
         as_json: Json = False) -> None:
    """PLS regression, SIMPLS beside scikit-learn's NIPALS, PCTVAR (§5.5, Figs. 5.8-5.10)."""
    _analyse("plsr", "plsr", store=store, options=storage_option, group=group,
             pressure=pressure, deflection=deflection, out=out, scheduler=scheduler,
             as_json=as_json, reference=reference_deflection, inputs=inputs,
             max_modes=components, cv=cv, nipals=nipals, seed=seed, component=force_component)


@app.command()
@with_tls
def noise(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
          deflection: Deflection = None, inputs: Inputs = None,
          components: NoiseComponents = None, cv: NoiseCv = None, draws: NoiseDraws = 100,
          noise_levels: NoiseLevels = None, seed: NoiseSeed = 0,
          sampling: Sampling = "inputs", train_noise: TrainNoise = True,
          reference_deflection: Reference = None, force_component: Force = "z",
          scheduler: Scheduler = None, storage_option: StorageOption = None,
          as_json: Json = False) -> None:
    """Monte Carlo measurement noise on PLSR: node maps, Table 5.1, sweep (§5.6)."""
    with usage():
        levels = _levels(noise_levels)
        _draws(draws)
    _analyse("noise", "noise", store=store, options=storage_option, group=group,
             pressure=pressure, deflection=deflection, out=out, scheduler=scheduler,
             as_json=as_json, reference=reference_deflection, inputs=inputs,
             n_components=components, multipliers=levels, draws=draws, seed=seed,
             component=force_component, sampling=sampling, cv=cv, train_noise=train_noise)


def _levels(text: str | None):
    if text is None:
        return _study("noise").DEFAULT_MULTIPLIERS
    return _numbers(text, "--noise-levels", low=0.0, high=MAX_NOISE_LEVEL,
                    what=f"multiples of the thesis' noise in [0, {MAX_NOISE_LEVEL:g}]")


def _draws(draws: int) -> int:
    if not 2 <= draws <= MAX_DRAWS:
        raise ParameterError(f"--draws must be in [2, {MAX_DRAWS}], got {draws}")
    return draws


# ------------------------------------------------------------------ combined loads (issue 13)


@app.command()
@with_tls
def combined(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
             inputs: CombinedInputs = None, test_fraction: TestFraction = 0.25,
             folds: CombinedFolds = 5, seed: SplitSeed = 0,
             max_components: CombinedMaxComponents = 15, draws: CombinedDraws = 10,
             axes: Axes = "wheel", scheduler: Scheduler = None,
             storage_option: StorageOption = None, as_json: Json = False) -> None:
    """Combined loads: PCA latent counts, PLSR/PCR of the 3-D force map and totals,
    held-out errors under T2Cam noise, beside the published anchors (issue 13)."""
    with usage():
        _split(test_fraction, folds)
        if max_components < 1:
            raise ParameterError(f"--max-components must be at least 1, got {max_components}")
        _draws_at_least_one(draws)
        _axes(axes)
    _analyse("combined", "combined", store=store, options=storage_option, group=group,
             pressure=pressure, out=out, scheduler=scheduler, as_json=as_json, axes=axes,
             inputs=inputs, test_fraction=test_fraction,
             folds=folds, seed=seed, max_components=max_components, draws=draws)


def _split(test_fraction: float, folds: int) -> None:
    """A held-out split's share and the CV's folds (as the user typed them)."""
    if not 0.0 < test_fraction < 1.0:  # NaN fails too
        raise ParameterError(f"--test-fraction must be in (0, 1), got {test_fraction}")
    if folds < 2:
        raise ParameterError(f"--folds must be at least 2, got {folds}")


def _axes(axes: str) -> str:
    if axes not in ("wheel", "road"):  # analysis.axes.AXES, not imported before it is used
        raise ParameterError(f"--axes must be wheel or road, got {axes!r}")
    return axes


def in_axes(ds, axes: str):
    """:func:`analysis.axes.in_axes` (imported when an analysis runs)."""
    from analysis.axes import in_axes as turned

    return turned(ds, axes)


def _draws_at_least_one(draws: int) -> int:
    if not 1 <= draws <= MAX_DRAWS:
        raise ParameterError(f"--draws must be in [1, {MAX_DRAWS}], got {draws}")
    return draws


# ------------------------------------------------------------------ the sensor (issue 27)


@app.command()
@with_tls
def sensor(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
           sensor_: Sensor = "t2cam-2017", windows: Windows = "10,20,40,90,360",
           noises: Noises = "0,0.5,1,2", spacings: Spacings = "5,10,20", positions: Positions = "",
           learners: Learners = "plsr,gp", test_fraction: TestFraction = 0.25,
           folds: SensorFolds = 5, draws: SensorDraws = 3, seed: SplitSeed = 0,
           max_components: SensorMaxComponents = 10, repeats: Repeats = 1,
           edges: Edges = 0.0, targets: Targets = "Fx,Fy,Fz,Mz", sizes: Sizes = "",
           axes_: Axes = "wheel",
           scheduler: Scheduler = None, storage_option: StorageOption = None,
           as_json: Json = False) -> None:
    """Identifiability vs the sensor: held-out Fx, Fy, Fz, Mz errors (--targets: any
    force, moment, slip or the camber) over window, noise and point spacing of a virtual
    T2Cam, PLSR beside a Gaussian process (issue 27)."""
    from analysis.camera.sensor import sensor_spec

    with usage():
        spec = sensor_spec(sensor_)
        grid = _sensor_grid(windows, noises, spacings) | {
            "positions": _positions(positions),
            "sizes": _numbers(sizes, "--sizes", low=1e-9, high=1 - 1e-9,
                              what="shares in (0, 1)") if sizes.strip() else ()}
        names = _learners(learners)
        _split(test_fraction, folds)
        _draws_at_least_one(draws)
        _axes(axes_)
        _repeats_and_edges(repeats, edges)
        wanted = _targets(targets)
    _analyse("sensor", "sensor", store=store, options=storage_option, group=group,
             pressure=pressure, out=out, scheduler=scheduler, as_json=as_json, axes=axes_,
             sensor=spec, learner_names=names,
             test_fraction=test_fraction, folds=folds, draws=draws,
             max_components=max_components, seed=seed, repeats=repeats, edges=edges,
             target_names=wanted, **grid)


def _targets(text: str) -> tuple[str, ...] | str:
    from analysis.camera.features import ALL_TARGETS

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if names == ("all",):
        return "all"
    unknown = [n for n in names if n not in ALL_TARGETS]
    if unknown or not names:
        raise ParameterError(f"--targets {text!r}: give some of {', '.join(ALL_TARGETS)}, "
                             "comma-separated, or all")
    return names


def _sensor_grid(windows: str, noises: str, spacings: str
                 ) -> dict[str, Any]:  # windows, noises, spacings: tuples
    return dict(windows=_numbers(windows, "--windows", low=1e-9, high=360.0,
                                 what="angles in (0, 360] degrees"),
                noises=_numbers(noises, "--noises", low=0.0),
                spacings=_numbers(spacings, "--spacings", low=0.5,
                                  what="spacings of at least 0.5 mm"))


def _positions(text: str) -> tuple[tuple[float, float], ...]:
    """``--positions DEG:MM,...`` as (centre_deg, centre_mm) pairs."""
    out = []
    for part in (p.strip() for p in text.split(",") if p.strip()):
        try:
            deg, mm = (float(v) for v in part.split(":"))
        except ValueError:
            raise ParameterError(f"--positions: {part!r} is not DEG:MM (e.g. 20:0 for 20° "
                                 "ahead of the patch on the crown)") from None
        if not (-180.0 <= deg <= 180.0 and math.isfinite(mm)):
            raise ParameterError(f"--positions: {part!r} needs an angle in [-180, 180] "
                                 "degrees and a finite arc length in mm")
        out.append((deg, mm))
    return tuple(out)


def _learners(text: str) -> tuple[str, ...]:
    from analysis.camera.learners import learner

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    for name in names:
        learner(name)  # an unknown name: one line naming the known ones
    return names


def _repeats_and_edges(repeats: int, edges: float) -> None:
    if not 1 <= repeats <= 100:
        raise ParameterError(f"--repeats must be in [1, 100], got {repeats}")
    if not 0.0 <= edges < 0.5:  # NaN fails too
        raise ParameterError(f"--edges must be in [0, 0.5), got {edges}")


# -------------------------------------------------------------- free rolling (issue 46)

@app.command("free-rolling")
@with_tls
def free_rolling(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
                 scheduler: Scheduler = None, storage_option: StorageOption = None,
                 as_json: Json = False) -> None:
    """Each rolling tree's free rolling, measured from its states: the commanded slip
    at which it rolls freely and its free-rolling radius (the slip target
    free_slip_ratio is measured from it; issue 46)."""
    _analyse("free_rolling", "free-rolling", store=store, options=storage_option,
             group=group, pressure=pressure, out=out, scheduler=scheduler, as_json=as_json)


# ---------------------------------------------------------------- regions (issue 46)

@app.command("regions")
@with_tls
def regions(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
            targets: Targets = "all", bands: Bands = 6, sectors: Sectors = 8,
            span: Span = 60.0, folds: RegionFolds = 5, repeats: RegionRepeats = 3,
            noise_mm: RegionNoise = 0.0, max_components: RegionComponents = 5,
            seed: SplitSeed = 0, scheduler: Scheduler = None,
            storage_option: StorageOption = None, as_json: Json = False) -> None:
    """Where each target lives on the inner surface: for a grid of regions (bands of
    meridian by sectors round the contact centre), the held-out share of each target's
    variance that the region's displacement field explains (issue 46: where to look)."""
    with usage():
        wanted = _targets(targets)
        _region_grid(bands, sectors, span, folds, repeats, noise_mm, max_components)
    _analyse("regions", "regions", store=store, options=storage_option, group=group,
             pressure=pressure, out=out, scheduler=scheduler, as_json=as_json,
             targets=None if wanted == "all" else wanted, bands=bands, sectors=sectors,
             span_deg=span, folds=folds, repeats=repeats, noise_mm=noise_mm,
             max_components=max_components, seed=seed)


def _region_grid(bands: int, sectors: int, span: float, folds: int, repeats: int,
                 noise_mm: float, max_components: int) -> None:
    checks = (("--bands", bands, 1 <= bands <= 100, "in [1, 100]"),
              ("--sectors", sectors, 1 <= sectors <= 360, "in [1, 360]"),
              ("--span", span, 0.0 < span <= 180.0, "in (0, 180] degrees"),
              ("--folds", folds, 2 <= folds <= 100, "in [2, 100]"),
              ("--repeats", repeats, 1 <= repeats <= 100, "in [1, 100]"),
              ("--noise-mm", noise_mm, 0.0 <= noise_mm < 1e3, "finite and >= 0"),
              ("--max-components", max_components, 1 <= max_components <= 50, "in [1, 50]"))
    for name, value, ok, what in checks:
        if not ok:  # NaN fails too
            raise ParameterError(f"{name} must be {what}, got {value}")


# ----------------------------------------------------------------- population (issue 47)

@app.command("population")
def population(nominal: NominalStore, tyres: PopulationStore, mismatched: MismatchedStore,
               group: NominalGroup = None, out: Out = None, sensor_: Sensor = "t2cam-2017",
               learner: FitLearner = "plsr", repeats: Repeats = 5, draws: SensorDraws = 3,
               folds: PopulationFolds = 4, test_fraction: TestFraction = 0.25,
               seed: SplitSeed = 0, intervals: IntervalKinds = "both", tpms: Tpms = False,
               storage_option: StorageOption = None, as_json: Json = False) -> None:
    """Nominal-only against population force models over repeated splits: error, its
    growth and interval coverage on nominal and mismatched tyres, and the part of each
    error no camera model can remove (issue 47)."""
    from analysis.camera.learners import learner as check_learner
    from analysis.camera.sensor import sensor_spec
    from analysis.data import list_groups

    with usage():
        spec = sensor_spec(sensor_)
        check_learner(learner)
        _split(test_fraction, folds)
        _draws_at_least_one(draws)
        if intervals not in ("split", "adaptive", "both"):
            raise ParameterError(f"--intervals must be split, adaptive or both, got "
                                 f"{intervals!r}")
        if not 2 <= repeats <= 100:
            raise ParameterError(f"--repeats must be in [2, 100] (a spread needs two "
                                 f"splits), got {repeats}")
    folder = _out(out, "population")
    base = load_selection(nominal, storage_option, group, None, None)
    pop = load_tyres(tyres, storage_option, list(list_groups(open_target(tyres, storage_option))),
                     skip_empty=True)
    study = _study("population")
    others = {study.tyre_label(ds, base): ds for ds in (
        load_selection(mismatched, storage_option, g, None, None)
        for g in list_groups(open_target(mismatched, storage_option)))}
    _done(study.run(base, pop, others, spec, folder, learner=learner, repeats=repeats,
                    draws=draws, folds=folds, test_fraction=test_fraction, seed=seed,
                    intervals=("split", "adaptive") if intervals == "both" else (intervals,),
                    tpms=tpms), as_json)


# ------------------------------------------------------------------ surrogate (issue 28)

@app.command()
@with_tls
def surrogate(store: Store, group: Group = None, out: Out = None, pressure: Pressure = None,
              field: SurrogateField = "displacement", folds: SurrogateFolds = 5,
              seed: SurrogateSeed = 0, restarts: Restarts = 3, scheduler: Scheduler = None,
              storage_option: StorageOption = None, as_json: Json = False) -> None:
    """A surrogate of the experiments: Gaussian processes from the varied load parameters
    to the field and the six totals, its held-out errors and uncertainty, and the fitted
    model in OUT/surrogate (issue 28)."""
    fields = _study("surrogate").FIELDS
    with usage():
        if folds < 2:
            raise ParameterError(f"--folds must be at least 2, got {folds}")
        if restarts < 0:
            raise ParameterError(f"--restarts must be at least 0, got {restarts}")
        if field not in fields:
            raise ParameterError(f"--field must be {' or '.join(fields)}, got {field!r}")
    _analyse("surrogate", "surrogate", store=store, options=storage_option, group=group,
             pressure=pressure, out=out, scheduler=scheduler, as_json=as_json,
             field=field, folds=folds, seed=seed, restarts=restarts)


# ------------------------------------------------------------------ sensitivity (issue 15)

SENSITIVITY_FIELDS = ("displacement", "strain", "surface_strain")


@app.command()
@with_tls
def sensitivity(study: ModelStudy, out: Out = None, method: Method = None,
                deflection: Deflections = None, pressure_kpa: PressuresKpa = None,
                field: ScoreField = None, components: ScoreComponents = 3,
                num_resamples: NumResamples = 1000, conf_level: ConfLevel = 0.95,
                seed: BootstrapSeed = 0, storage_option: StorageOption = None,
                as_json: Json = False) -> None:
    """Sobol' indices or Morris screening of a model design over the store (thesis §6.2):
    Fz, contact nodes and area per load case, and PCA scores of an inner-surface field."""
    from analysis.sensitivity_data import OutputRequest

    with usage():
        deflections, pressures = _sensitivity_checks(deflection, pressure_kpa, field, method,
                                                     num_resamples, conf_level, components,
                                                     seed)
    folder = _out(out, "sensitivity")
    spec, design = _model_design(study, method)
    store = open_target(spec.location, storage_option) if storage_option else spec.store
    if deflections is None:
        deflections = spec.deflections
        if not deflections:
            raise ParameterError(f"study {study} samples its deflections: give --deflection")
    pressures_mpa = (tuple(p / 1000.0 for p in pressures) if pressures is not None
                     else spec.pressures or None)
    request = OutputRequest(deflections=tuple(deflections), pressures=pressures_mpa,
                            field=field, components=components)
    _done(_study("sensitivity").run(
        store, design.matrix, design.names, design.bounds, design.groups, request, folder,
        method=design.method, num_levels=spec.models.num_levels,
        num_resamples=num_resamples, conf_level=conf_level, seed=seed, source=str(study)),
        as_json)


def _sensitivity_checks(deflection, pressure_kpa, field, method, num_resamples, conf_level,
                        components, seed):
    """The sensitivity command's values as typed: (deflections, pressures in kPa)."""
    deflections = _numbers(deflection, "--deflection", low=math.ulp(0.0),
                           what="positive numbers of mm")
    pressures = _numbers(pressure_kpa, "--pressure-kpa", low=0.0,  # 0: not inflated
                         what="numbers of kPa >= 0")
    if field is not None and field not in SENSITIVITY_FIELDS:
        raise ParameterError(f"--field must be one of {', '.join(SENSITIVITY_FIELDS)}, "
                             f"got {messages.shown(field)}")
    if method is not None and method not in ("sobol", "morris"):
        raise ParameterError(f"--method must be sobol or morris, got {messages.shown(method)}")
    if not 2 <= num_resamples <= MAX_DRAWS:
        raise ParameterError(f"--num-resamples must be in [2, {MAX_DRAWS}], got {num_resamples}")
    if not 0 < conf_level < 1:
        raise ParameterError(f"--conf-level must be in (0, 1), got {conf_level:g}")
    if not 1 <= components <= 20:
        raise ParameterError(f"--components must be in [1, 20], got {components}")
    if seed < 0:
        raise ParameterError(f"--seed must be >= 0, got {seed}")
    return deflections, pressures


def _numbers(text: str | None, option: str, *, low: float, high: float = math.inf,
             what: str | None = None) -> tuple[float, ...] | None:
    """The comma list of finite numbers in [``low``, ``high``] that ``option`` was given
    (None if it was not); ``what`` says what they must be (default: ">= low")."""
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError as exc:
        raise ParameterError(
            f"{option} must be numbers separated by commas, got {messages.shown(text)}"
        ) from exc
    if not values or not all(math.isfinite(v) and low <= v <= high for v in values):
        raise ParameterError(f"{option} must be {what or f'numbers >= {low:g}'}, got "
                             f"{messages.shown(text)}")
    return values


def _model_design(path: Path, method: str | None):
    """The study and its design, which must be a Sobol' or Morris one (and ``method``)."""
    from jobs.design import model_design
    from jobs.study import load_study

    spec = load_study(path)
    design = model_design(spec)
    if design is None:
        raise ParameterError(
            f"study {path} has no [models] table: a sensitivity analysis needs a design "
            "over model fields (docs/model-space.md)")
    if design.method not in ("sobol", "morris"):
        raise ParameterError(
            f"study {path} has a {design.method} design: Sobol' indices need method = "
            "'sobol' and Morris screening method = 'morris' in [models]")
    if method is not None and method != design.method:
        with usage():
            raise ParameterError(
                f"--method {method} needs a {method} design, but study {path} has a "
                f"{design.method} design: drop --method or change [models] method")
    return spec, design
