"""What every study shares: input specs, the matrices of one selection, the report record."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import dask.array as da
import numpy as np
import pandas as pd
import xarray as xr

from analysis import data
from analysis.errors import ComponentsError, MissingVariableError
from analysis.moments import Moments, compute_moments
from analysis.pls import SIMPLSRegression

#: the thesis' two "methods" (§5.4-5.6): displacement-based and strain-based models
DEFAULT_MODEL_INPUTS = ("displacement", "strain")
#: why every study needs two experiments
CENTRING = "centring a single experiment leaves no variance to analyse"


@dataclass
class Report:
    """Files written by a study and its tables (also returned for programmatic use)."""

    out: Path
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    files: list[Path] = field(default_factory=list)

    def csv(self, name: str, frame: pd.DataFrame) -> None:
        """Keep ``frame`` as table ``name`` and write ``<out>/<name>.csv``."""
        self.tables[name] = frame
        path = self.out / f"{name}.csv"
        path.parent.mkdir(parents=True, exist_ok=True)
        frame.to_csv(path, index=False)
        self.files.append(path)


def model_inputs(ds: xr.Dataset, spec: str | None) -> list[str]:
    """Input sets of a model study: comma list of sets, directions or ``a+b`` combinations.

    Default: the displacement- and strain-based methods, those the group has.
    """
    if spec is None:
        names = [s for s in DEFAULT_MODEL_INPUTS if _has(ds, s)]
        if not names:
            raise MissingVariableError("group has neither 'displacement' nor 'strain'")
        return names
    items = [s.strip() for s in spec.split(",") if s.strip()]
    for item in items:
        directions = data.expand_inputs(item.split("+"))
        families = {data.family(d) for d in directions}
        if len(families) > 1:
            raise MissingVariableError(
                f"input set {item!r} mixes units ({', '.join(sorted(families))}); "
                "use one set per unit family, e.g. --inputs displacement,strain"
            )
    return items


def _has(ds: xr.Dataset, input_set: str) -> bool:
    return data.family(data.INPUT_SETS[input_set][0]) in ds


def directions_of(input_set: str) -> tuple[str, ...]:
    """Directions of one input set (``"strain"``, ``"Uz"``, ``"Uz+Uy"``)."""
    return data.expand_inputs(input_set.split("+"))


@dataclass
class Selection:
    """The response and node tables of one selection, shared by the input sets."""

    ds: xr.Dataset
    Y: da.Array  # (K, M)
    tread: pd.DataFrame
    reference: int  # position of the reference experiment

    @classmethod
    def of(
        cls,
        ds: xr.Dataset,
        component: str = "z",
        reference_deflection=None,
        *,
        study: str = "this analysis",
        needed: int = 2,
        why: str = CENTRING,
    ) -> Selection:
        """The selection's response, checked before anything is written.

        Raises
        ------
        TooFewExperimentsError
            Fewer than ``needed`` experiments (``study`` and ``why`` go into the message).
        NoVarianceError
            The tread forces are the same in every experiment.
        """
        data.require_experiments(ds, needed, study, why)
        Y = data.outputs(ds, component)
        if Y.nbytes < 2**28:  # small: read once, not once per input set
            Y = da.from_array(Y.compute(), chunks=Y.chunks)
        data.require_variance(Y, ds, component)
        return cls(ds, Y, data.tread_index(ds), data.reference_index(ds, reference_deflection))

    def X(self, input_set: str) -> da.Array:
        return data.inputs(self.ds, directions_of(input_set))

    def moments(self, input_set: str) -> Moments:
        return compute_moments(self.X(input_set), self.Y)

    def x_ref(self, input_set: str) -> np.ndarray:
        return np.asarray(self.X(input_set)[self.reference].compute())

    @property
    def y_ref(self) -> np.ndarray:
        return np.asarray(self.Y[self.reference].compute())

    def describe(self) -> str:
        """One paragraph: group, experiments, load cases, reference experiment."""
        ds, k = self.ds, self.ds.sizes["experiment"]
        d = np.asarray(ds["deflection"].values, dtype=float)
        p = (
            np.asarray(ds["pressure"].values, dtype=float)
            if "pressure" in ds
            else np.full(k, np.nan)
        )
        pressures = ", ".join(f"{v:g}" for v in np.unique(p))
        return (
            f"Group `{ds.attrs.get('group', '?')}`: {k} done experiments, "
            f"{ds.sizes['inner_node']} inner nodes, {ds.sizes['tread_node']} tread nodes; "
            f"deflection {d.min():g}-{d.max():g} mm, pressure {pressures} MPa. "
            f"Reference experiment: deflection {d[self.reference]:g} mm, "
            f"pressure {p[self.reference]:g} MPa."
        )


def fit_simpls(moments: Moments, n_components: int | None, *, cap: int = 10) -> SIMPLSRegression:
    """SIMPLS with ``n_components``, or with as many as the data support (``None``).

    The data support min(K-1, N) components unless X̄ᵀȲ is exhausted earlier (a single
    response, nearly collinear experiments); ``None`` takes that many, at most ``cap``.
    With the thesis' 7 experiments that is 6: the model then reproduces the training
    experiments exactly, like the noise-free rows of Table 5.1.
    """
    limit = min(moments.n_samples - 1, moments.x_mean.shape[0], cap)
    asked = limit if n_components is None else n_components
    try:
        return SIMPLSRegression(asked).fit_moments(moments)
    except ComponentsError as exc:
        if n_components is not None or exc.available is None or exc.available < 1:
            raise
        return SIMPLSRegression(exc.available).fit_moments(moments)
