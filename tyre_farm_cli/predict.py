"""``farm fit``, ``farm measure``, ``farm predict``, ``farm mismatch``: forces from point clouds
(issue 27).

- ``fit`` trains a force model on a store as a virtual T2Cam measures it and saves it with
  its manifest (:mod:`analysis.camera.predictor`, :mod:`analysis.camera.predict.persist`);
- ``measure`` writes what the virtual camera sees of stored experiments as point-cloud
  files (a reference cloud, one cloud per experiment, and the true forces): example
  input for ``predict``, and the other side of ``mismatch``;
- ``predict`` reads measured clouds (CSV or any point format meshio reads), registers
  them (a given transform, or ICP of the reference cloud onto the model's surface), and
  prints Fx, Fy, Fz, Mz with conformal prediction intervals;
- ``mismatch`` applies a model to another store's clouds: the error growth when the
  tyre is not the one trained on.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from analysis.errors import ParameterError
from jobs.validate.messages import fail
from jobs.validate.scalars import integer
from tyre_farm_cli.analyse import (
    Group,
    Json,
    Pressure,
    Sensor,
    StorageOption,
    Store,
    load_selection,
    load_tyres,
)
from tyre_farm_cli.analyse_options import IntervalKind, Tpms, TpmsPressure
from tyre_farm_cli.checks import model_folder, output_folder
from tyre_farm_cli.errors import usage
from tyre_farm_cli.invocation import command as invocation
from tyre_farm_cli.options import open_target

OUTSIDE_EXIT = 3
"""``farm predict``'s exit status when a cloud lies outside the model's domain (issue 47):
the table is printed, but a script must not take its forces."""
MAX_DRAWS = 1000  # noisy measurements per experiment: each one is a feature row in memory

ModelDir = Annotated[Path, typer.Argument(help="Model folder written by `farm fit`.")]


Groups = Annotated[str | None, typer.Option(
    "--group", "-g", help="Group, or several separated by commas, or 'all': a population "
    "of tyres (issue 47), each tyre held out whole, the first the reference surface "
    "[default: the store's only group].")]


def fit(
    store: Store,
    out: Annotated[Path, typer.Option("--out", help="Model folder to write.")],
    group: Groups = None,
    pressure: Pressure = None,
    sensor: Sensor = "t2cam-2017",
    learner: Annotated[str, typer.Option(help="plsr, gp (Gaussian process on the PLS "
                                         "scores), krr (kernel ridge on the scores) or "
                                         "auto (the one with the least grouped-CV "
                                         "error).")] = "plsr",
    draws: Annotated[int, typer.Option(help="Noisy measurements per experiment.")] = 3,
    alpha: Annotated[float, typer.Option(help="1 - nominal coverage of the intervals.")] = 0.1,
    test_fraction: Annotated[float, typer.Option(help="Share held out to check the model "
                                                 "and its intervals.")] = 0.25,
    folds: Annotated[int, typer.Option(help="Folds of the grouped CV (count, intervals).")] = 5,
    seed: Annotated[int, typer.Option(help="Seed of split, folds and noise.")] = 0,
    intervals: IntervalKind = "split",
    tpms: Tpms = False,
    storage_option: StorageOption = None,
    as_json: Json = False,
) -> None:
    """Train a force model on a store as a virtual T2Cam sees it; save it with a manifest."""
    from analysis.camera import predictor
    from analysis.camera.features import model_inputs
    from analysis.camera.population import Tyres
    from analysis.render import provenance

    run = provenance.Run(invocation())
    spec = _fit_checks(sensor, learner, out, draws, folds, alpha, test_fraction, intervals)
    tyres = Tyres.of(load_tyres(store, storage_option, _groups(store, storage_option, group),
                                pressure, skip_empty=group is not None and group.strip() == "all"))
    model, check = predictor.fit(tyres.datasets, spec, learner=learner, draws=draws,
                                 alpha=alpha, test_fraction=test_fraction, folds=folds,
                                 seed=seed, intervals=intervals,
                                 inputs=model_inputs(tpms))
    ids = [str(i) for i in tyres.ids()[model.info["train"]]]
    path = predictor.save(model, out, store=str(store), group=",".join(tyres.names()),
                          ids=ids, check=check, provenance=run.rows())
    _print_fit(path, model, check, ids, as_json)


def _print_fit(path, model, check, ids: list[str], as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps({"model": str(path), "check": check.to_dict("records")},
                              indent=1))
        return
    info = model.info
    tpms = ", reads a TPMS" if model.tpms else ""
    typer.echo(f"model: {path} ({info['learner']}, sensor {model.sensor.name}{tpms}, "
               f"{len(ids)} training experiments x {info['draws']} noisy "
               f"measurements{_tyres_text(info)})")
    typer.echo(check.to_string(index=False, float_format=lambda v: f"{v:.4g}"))


def _tyres_text(info: dict) -> str:
    """", 8 tyres, 2 held out" for a population's model; "" for one tyre's."""
    if "tyres" not in info:
        return ""
    return f", {len(info['tyres'])} tyres, {len(info['heldout_tyres'])} held out"


def _groups(store: str, options: list[str] | None, group: str | None) -> list[str | None]:
    """``--group`` as a list: None (the store's only group), the names given, or every
    group of the store for ``all``."""
    if group is None:
        return [None]
    if group.strip() == "all":
        from analysis.data import list_groups

        return list(list_groups(open_target(store, options)))
    names = [g.strip() for g in group.split(",")]
    if not all(names) or len(set(names)) != len(names):
        raise ParameterError(f"--group must be group names separated by commas, each once, "
                             f"or 'all'; got {group!r}")
    return list(names)


def _fit_checks(sensor: str, learner: str, out: Path, draws: int, folds: int, alpha: float,
                test_fraction: float, intervals: str = "split"):
    """``farm fit``'s arguments checked before the store is read: the sensor's spec."""
    from analysis.camera.learners import learner as check_learner
    from analysis.camera.sensor import sensor_spec

    with usage():
        spec = sensor_spec(sensor)
        check_learner(learner)
        model_folder(out, "--out")
        integer(draws, "--draws", low=1, high=MAX_DRAWS)
        integer(folds, "--folds", low=2)  # grouped CV needs a train and a test fold
        if intervals not in ("split", "adaptive"):
            raise fail("--intervals", f"must be split or adaptive, got {intervals!r}")
        for value, name in ((alpha, "--alpha"), (test_fraction, "--test-fraction")):
            if not 0.0 < value < 1.0:
                raise fail(name, f"must be in (0, 1), got {value:g}")
    return spec


def measure(
    store: Store,
    out: Annotated[Path, typer.Option("--out", help="Folder for the cloud files.")],
    group: Group = None,
    pressure: Pressure = None,
    sensor: Sensor = "t2cam-2017",
    limit: Annotated[int | None, typer.Option(help="At most this many experiments.")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the noise.")] = 0,
    storage_option: StorageOption = None,
) -> None:
    """Write the virtual camera's clouds of stored experiments: reference.csv, one CSV per
    experiment (named by its id) and truth.csv with the true Fx, Fy, Fz, Mz."""
    import pandas as pd

    from analysis.camera.features import TARGETS, displacements, targets
    from analysis.camera.predict.clouds import write_cloud
    from analysis.camera.sensor import InnerSurface, VirtualSensor, sensor_spec

    with usage():
        spec = sensor_spec(sensor)
        output_folder(out, "--out")
        if limit is not None and limit < 1:
            raise typer.BadParameter(f"--limit must be at least 1, got {limit}")
    ds = load_selection(store, storage_option, group, pressure, None)
    if limit is not None:
        ds = ds.isel(experiment=slice(0, limit))
    virtual = VirtualSensor(spec, InnerSurface.from_dataset(ds))
    rng = np.random.default_rng(seed) if spec.noisy else None
    refs, clouds = virtual.measure(virtual.clean(displacements(ds)), rng)
    out.mkdir(parents=True, exist_ok=True)
    write_cloud(out / "reference.csv", refs[0].reshape(-1, 3))
    ids = [str(i) for i in np.asarray(ds["experiment"].values)]
    for k, name in enumerate(ids):
        write_cloud(out / f"{name}.csv", clouds[k].reshape(-1, 3))
    truth = pd.DataFrame(targets(ds), columns=list(TARGETS)).assign(experiment=ids)
    truth.to_csv(out / "truth.csv", index=False)
    typer.echo(f"{len(ids)} clouds of {clouds[0].reshape(-1, 3).shape[0]} points, "
               f"reference.csv and truth.csv in {out}")


def predict(
    model: ModelDir,
    reference: Annotated[Path, typer.Argument(help="Reference cloud: the inflated, "
                                              "unloaded tyre (same points as the clouds).")],
    clouds: Annotated[list[Path], typer.Argument(help="Measured clouds (CSV, PLY, VTK...).")],
    transform: Annotated[Path | None, typer.Option(
        help="Camera-to-model transform: a 4x4 matrix (text) or JSON [default: none].")] = None,
    align: Annotated[bool, typer.Option(
        help="Register the reference cloud onto the model's surface by ICP (else the "
        "clouds are taken as already in the model's frame).")] = False,
    out: Annotated[Path | None, typer.Option(
        help="Also write the predictions as CSV [default: print only].")] = None,
    pressure_kpa: TpmsPressure = None,
    as_json: Json = False,
) -> None:
    """Fx, Fy, Fz, Mz of measured point clouds, with conformal prediction intervals.

    Exit status 3 (the table printed) when a cloud lies outside what the model was
    trained on (issue 47, docs/sensor.md)."""
    from analysis.camera import predictor
    from analysis.camera.predict.clouds import read_cloud

    fitted, manifest = predictor.load(model)
    with usage():
        if transform is not None and align:
            raise typer.BadParameter("give --transform or --align, not both")
        fitted.check_pressure(pressure_kpa)
    ref = read_cloud(reference)
    measured = [read_cloud(p) for p in clouds]
    ref, measured, rms = _registered(fitted, reference, ref, clouds, measured, transform, align)
    table = fitted.predict_clouds(ref, measured, pressure_kpa)
    table.insert(0, "cloud", [str(p) for p in clouds])
    if out is not None:
        table.to_csv(out, index=False)
    outside = int(table["domain"].str.startswith("outside").sum())
    _print_predictions(model, fitted, manifest, table, rms, outside, as_json)
    if outside:
        raise typer.Exit(OUTSIDE_EXIT)


def _print_predictions(model: Path, fitted, manifest: dict, table, rms: float | None,
                       outside: int, as_json: bool) -> None:
    """The predictions on stdout: one JSON document, or a header and the table; then, on
    stderr, how many clouds lie outside the model's domain."""
    if as_json:
        typer.echo(json.dumps({"model": str(model), "alpha": fitted.intervals.alpha,
                               "registration_rms_mm": rms, "outside": outside,
                               "predictions": _finite(table).to_dict("records")},
                              indent=1))
    else:
        level = 100 * (1 - fitted.intervals.alpha)
        typer.echo(f"model {model} (sensor {manifest['sensor'].get('name')}); intervals: "
                   f"{level:g} % conformal" + ("" if rms is None else
                                               f"; ICP residual {rms:.3g} mm"))
        typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.5g}"))
    if outside:
        typer.echo(f"{outside} of {len(table)} clouds are unlike every cloud the model was "
                   "trained and checked on (column domain): their forces are not predictions "
                   "and their intervals are unbounded", err=True)


def _registered(fitted, reference: Path, ref: np.ndarray, paths: list[Path],
                measured: list[np.ndarray], transform: Path | None, align: bool):
    """The clouds in the model's frame: moved by ``transform``, or by ICP of the
    reference onto the model's sensor points (``align``, whose residual is returned),
    or as given."""
    from analysis.camera.predict.registration import icp, read_transform
    from analysis.errors import CloudError

    for path, cloud in zip(paths, measured, strict=True):
        if cloud.shape != ref.shape:
            raise CloudError(f"{path} has {cloud.shape[0]} points, the reference "
                             f"{reference} {ref.shape[0]}: a cloud must list the "
                             "reference's points in the same order")
    rms = None
    if transform is not None:
        move = read_transform(transform)
    elif align:
        seen = np.isfinite(ref).all(axis=1)
        move, rms = icp(ref[seen], fitted.virtual.layout.xyz.reshape(-1, 3))
    else:
        return ref, measured, rms
    return move.apply(ref), [move.apply(c) for c in measured], rms


def mismatch(
    model: ModelDir,
    store: Store,
    group: Group = None,
    pressure: Pressure = None,
    draws: Annotated[int, typer.Option(help="Noisy clouds per experiment.")] = 1,
    seed: Annotated[int, typer.Option(help="Seed of the noise.")] = 0,
    storage_option: StorageOption = None,
    as_json: Json = False,
) -> None:
    """Apply a model to the clouds of another store (another model of the tyre): the error
    growth beside the model's own held-out error."""
    from analysis.camera import predictor
    from analysis.camera.mismatch import mismatch as run
    from analysis.render import provenance

    started = provenance.Run(invocation())
    with usage():
        integer(draws, "--draws", low=1, high=MAX_DRAWS)
    fitted, manifest = predictor.load(model)
    ds = load_selection(store, storage_option, group, pressure, None)
    table, _, _ = run(fitted, ds, draws=draws, seed=seed)
    rows = started.rows()
    origin = {"provenance": rows,  # this run's, and the model's training's
              "trained_by": (manifest.get("extra") or {}).get("provenance")}
    if as_json:
        typer.echo(json.dumps({"model": str(model), "trained_on": manifest.get("group"),
                               "applied_to": ds.attrs.get("group"),
                               "errors": table.to_dict("records"), **origin}, indent=1))
        return
    typer.echo(f"trained on {manifest.get('store')} group {manifest.get('group')!r}; "
               f"applied to {store} group {ds.attrs.get('group')!r}")
    typer.echo(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    typer.echo(provenance.line(rows))


def _finite(table):
    """JSON has no infinity: an unbounded interval's end is written as null."""
    numbers = table.select_dtypes("number").columns
    return table.astype({c: object for c in numbers}).where(
        ~table.isin([np.inf, -np.inf]), None)
