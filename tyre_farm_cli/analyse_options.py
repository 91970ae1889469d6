"""The options of ``farm analyse`` (:mod:`tyre_farm_cli.analyse`), one alias each.

Typer reads an option's help and default from its annotation; kept here, a command's
signature is one line per option, and options shared by several analyses (a split, its
folds and seed, the noise draws) are declared once.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tyre_farm_cli.jsondoc import JSON_HELP
from tyre_farm_cli.options import SCHEDULER_HELP, STORAGE_OPTION_HELP, check_scheduler

# ---------------------------------------------------------------- the selection, the output
Store = Annotated[str, typer.Argument(help="Zarr store: directory or fsspec URL.")]
StorageOption = Annotated[list[str] | None,
                         typer.Option("--storage-option", help=STORAGE_OPTION_HELP)]
Group = Annotated[
    str | None,
    typer.Option("--group", "-g", help="Group (mesh) [default: the store's only group]."),
]
Out = Annotated[
    Path | None, typer.Option(help="Output folder [default: ./analysis-out/<command>].")
]
Pressure = Annotated[
    float | None,
    typer.Option(help="Only experiments at this inflation pressure, kPa, as in study files "
                 "and `farm run` (the store keeps MPa) [default: all pressures]."),
]
Deflection = Annotated[
    float | None,
    typer.Option(help="Only experiments at this deflection, mm [default: all deflections]."),
]
Inputs = Annotated[
    str | None,
    typer.Option(
        help="Comma list of input sets or directions (displacement,strain; Uz,exx; Uz+Uy) "
        "[default: the study's own sets]."
    ),
]
Force = Annotated[
    str, typer.Option("--force-component", help="Tread force component for Y: x, y or z.")
]
Reference = Annotated[
    float | None,
    typer.Option(help="Deflection (mm) of the reference experiment [default: the median]."),
]
#: Analyses without a scheduler run on dask's threads, not on an embedded cluster
ANALYSE_SCHEDULER_HELP = SCHEDULER_HELP.replace("else an embedded LocalCluster",
                                                "else dask's local threads")
Scheduler = Annotated[
    str | None,
    typer.Option(help=ANALYSE_SCHEDULER_HELP, callback=check_scheduler),
]
Json = Annotated[bool, typer.Option("--json", help=JSON_HELP)]
Axes = Annotated[
    str, typer.Option("--axes", help="Axes of the forces and moments learned and reported: "
                      "wheel (the store's) or road (x, y in the road plane, z its normal: "
                      "TYDEX, ISO 8855; differs where the road is tilted).")]

# ---------------------------------------------------------------- chapter 5
PcaModes = Annotated[int, typer.Option("--components",
                                       help="Modes written to the eigen-vector tables.")]
PcrModes = Annotated[int, typer.Option("--components", help="Largest number of modes shown.")]
PlsComponents = Annotated[int, typer.Option("--components",
                                            help="Largest number of components shown.")]
PlsCv = Annotated[
    int | None,
    typer.Option("--cv", help="Choose components by k-fold CV with k folds [default: no CV]."),
]
Nipals = Annotated[
    bool, typer.Option(help="Also fit scikit-learn's NIPALS (needs X in memory).")
]
ShuffleSeed = Annotated[
    int | None,
    typer.Option("--seed", help="Shuffle CV folds with this seed [default: no shuffle]."),
]
NoiseComponents = Annotated[
    int | None,
    typer.Option("--components",
                 help="PLS components of each model [default: chosen per input set by "
                 "cross-validation over the experiments, see --cv; reported in models.csv]."),
]
NoiseCv = Annotated[
    int | None,
    typer.Option("--cv", help="Folds of the cross-validation that chooses --components "
                 "[default: leave-one-out up to 10 experiments, else 10]."),
]
NoiseDraws = Annotated[int, typer.Option("--draws", help="Monte Carlo draws per noise level.")]
NoiseLevels = Annotated[
    str | None,
    typer.Option(help="Comma list of multiples of the thesis level (1 mm, 4e-4) "
                 "[default: 0,0.1,...,2]."),
]
NoiseSeed = Annotated[int, typer.Option("--seed", help="Seed of the noise draws.")]
Sampling = Annotated[
    str,
    typer.Option(help="'inputs': N(0, σ²) on every input (thesis); 'subspace': same law, "
                 "faster."),
]
TrainNoise = Annotated[
    bool,
    typer.Option(help="Also refit each model on noisy training inputs (rows 'training: "
                 "noisy'; the thesis trained on noise-free data, rows 'training: clean')."),
]

# ---------------------------------------------------------------- held-out splits
TestFraction = Annotated[
    float, typer.Option(help="Share of the load paths held out for testing (seeded; a roll's "
                        "states together).")
]
SplitSeed = Annotated[int, typer.Option("--seed",
                                        help="Seed of the split, CV folds and noise.")]
CombinedInputs = Annotated[
    str | None,
    typer.Option("--inputs", help="Comma list of input sets: displacement, strain, "
                 "surface_strain, both (displacement + strain) [default: those the group "
                 "has]."),
]
CombinedFolds = Annotated[
    int, typer.Option("--folds", help="Folds of the CV on the training part that chooses "
                      "each component count.")
]
CombinedMaxComponents = Annotated[
    int, typer.Option("--max-components", help="Largest component count the CV tries.")]
CombinedDraws = Annotated[
    int, typer.Option("--draws", help="Noise draws per held-out experiment (test set, CV "
                      "folds).")
]

# ---------------------------------------------------------------- the sensor (issue 27)
SENSOR_HELP = ("Virtual camera: a preset (t2cam-2017, t2cam-2020, ideal-full), optionally "
               "with field=value changes, e.g. 't2cam-2017,window_deg=90' "
               "(docs/sensor.md lists the fields).")
Sensor = Annotated[str, typer.Option("--sensor", help=SENSOR_HELP)]
Windows = Annotated[
    str, typer.Option(help="Windows (degrees about the contact centre) to try, comma list in "
                      "(0, 360].")
]
Noises = Annotated[str, typer.Option(help="Position noise levels σ (mm) to try, comma list.")]
Spacings = Annotated[str, typer.Option(help="Point spacings (mm) to try, comma list.")]
Learners = Annotated[
    str, typer.Option(help="Learners side by side: plsr (CV-chosen count), gp (Gaussian "
                      "process on the PLS scores), krr (kernel ridge on the scores), auto "
                      "(the one of those with the least grouped-CV error).")
]
SensorFolds = Annotated[int, typer.Option("--folds",
                                          help="Folds of the grouped CV on the training part.")]
SensorDraws = Annotated[
    int, typer.Option("--draws", help="Noisy measurements per experiment (training and test).")
]
SensorMaxComponents = Annotated[int, typer.Option("--max-components",
                                                  help="Largest PLS count the CV tries.")]
Repeats = Annotated[
    int, typer.Option(help="Grouped splits (seeds SEED, SEED+1, ...): every figure a mean "
                      "over them, with its spread (issue 46 asks for at least 5).")
]
Positions = Annotated[
    str, typer.Option(help="Where else the base window looks, DEG:MM pairs, comma-separated: "
                      "its centre's angle from the contact centre (+: ahead of the patch) "
                      "and arc length from the crown (+: towards +y), e.g. "
                      "20:0,-20:0,0:150 (issue 46: where to look) [default: none].")
]
Sizes = Annotated[
    str, typer.Option(help="Also train the base sensor on these shares of each split's "
                      "training paths, comma-separated in (0, 1) (issue 46: the error "
                      "against the training set's size) [default: none].")
]
Targets = Annotated[
    str, typer.Option(help="What the models predict, comma-separated: Fx, Fy, Fz, Mx, My, Mz, "
                      "slip_ratio (commanded), free_slip_ratio (from each rolling tree's "
                      "measured free rolling: farm analyse free-rolling), slip_angle, tilt "
                      "(the camber), or all (those that vary in the group; issue 46).")
]
Edges = Annotated[
    float, typer.Option(help="Also train on the interior and test on the load paths with a "
                        "varying parameter in this outer fraction of its range, in [0, 0.5) "
                        "[default: 0, no edge check].")
]

# ---------------------------------------------------------------- regions (issue 46)
Bands = Annotated[int, typer.Option(help="Bands of meridional arc length, bead to bead.")]
Sectors = Annotated[int, typer.Option(help="Sectors of angle about the contact centre.")]
Span = Annotated[float, typer.Option("--span", help="Half-width of the angles mapped, degrees "
                                     "from the contact centre, in (0, 180].")]
RegionFolds = Annotated[int, typer.Option("--folds", help="Grouped CV folds (whole load "
                                          "paths: a rolling tree's states together).")]
RegionRepeats = Annotated[int, typer.Option("--repeats", help="Repeats over shuffled folds: "
                                            "each index a mean with its spread.")]
RegionNoise = Annotated[float, typer.Option("--noise-mm", help="IID noise on each coordinate, "
                                            "mm, drawn for training and test alike.")]
RegionComponents = Annotated[int, typer.Option("--max-components",
                                               help="Largest PLS count the inner CV tries.")]

# ---------------------------------------------------------------- surrogate (issue 28)
SurrogateField = Annotated[
    str, typer.Option("--field", help="Inner-surface field the surrogate predicts beside the "
                      "six totals: displacement or strain.")
]
SurrogateFolds = Annotated[int, typer.Option("--folds", help="Folds of the cross-validation.")]
SurrogateSeed = Annotated[int, typer.Option("--seed",
                                            help="Seed of the folds and kernel restarts.")]
Restarts = Annotated[
    int, typer.Option(help="Restarts of each Gaussian process' kernel optimiser.")
]

# ---------------------------------------------------------------- sensitivity (issue 15)
ModelStudy = Annotated[Path, typer.Argument(help="Model-space study file (.toml) with a "
                                            "[models] sobol or morris design.")]
Method = Annotated[
    str | None,
    typer.Option(help="sobol or morris: must be the study's [models] method "
                 "[default: the study's]."),
]
Deflections = Annotated[
    str | None,
    typer.Option("--deflection", help="Comma list of deflections, mm [default: the study's]."),
]
PressuresKpa = Annotated[
    str | None,
    typer.Option("--pressure-kpa",
                 help="Comma list of inflation pressures, kPa [default: the study's]."),
]
ScoreField = Annotated[
    str | None,
    typer.Option("--field", help="Also the PCA scores of this inner-surface field across the "
                 "models: displacement, strain or surface_strain [default: none]."),
]
ScoreComponents = Annotated[int, typer.Option("--components",
                                              help="PCA scores of --field per load case.")]
NumResamples = Annotated[int, typer.Option(help="Bootstrap resamples of the confidence "
                                           "intervals.")]
ConfLevel = Annotated[float, typer.Option(help="Confidence level of the intervals.")]
BootstrapSeed = Annotated[int, typer.Option("--seed", help="Seed of the bootstrap.")]


# --- farm analyse population (issue 47) --------------------------------------------------
NominalStore = Annotated[str, typer.Argument(
    help="Store of the nominal tyre (its only group, or --group).")]
PopulationStore = Annotated[str, typer.Argument(
    help="Store of the population: every group a tyre (a [models] study, loads = 'own').")]
MismatchedStore = Annotated[str, typer.Argument(
    help="Store of tyres outside the population: every group one, compared one by one.")]
NominalGroup = Annotated[str | None, typer.Option(
    "--group", "-g", help="The nominal store's group [default: its only one].")]
FitLearner = Annotated[str, typer.Option(
    "--learner", help="plsr, gp, krr or auto (as farm fit takes them).")]
PopulationFolds = Annotated[int, typer.Option(
    "--folds", help="Folds of the grouped CV (the population's hold out whole tyres).")]
IntervalKind = Annotated[str, typer.Option(
    "--intervals", help="split (one half-width per target) or adaptive (wider where a "
    "cloud is unlike the training clouds).")]
IntervalKinds = Annotated[str, typer.Option(
    "--intervals", help="split, adaptive or both (calibrated on the same fits, so the two "
    "differ in nothing else).")]
Tpms = Annotated[bool, typer.Option(
    "--tpms", help="Also read the tyre's inflation pressure, as a TPMS does (issue 47): "
    "farm predict then needs --pressure-kpa.")]
TpmsPressure = Annotated[float | None, typer.Option(
    "--pressure-kpa", help="The TPMS reading for a model fitted with --tpms (kPa) "
    "[default: none: a model fitted without --tpms].")]
