"""One training set from one tyre or a population of tyres (issue 47).

A force model trained on one tyre model is confidently wrong on another: 10 % stiffer
rubber grew its errors 1.5-2.7x and its 90 % intervals covered 69-86 % (docs/sensor.md).
A real tyre is never the model, so the model should have seen tyres that differ the way
real ones do. A population study (``[models] loads = "own"``, docs/model-space.md)
writes one store group per tyre drawn from a stated distribution; :class:`Tyres` makes
them one training set:

- every tyre is measured by its own virtual camera on its own inner surface, and each
  cloud is resampled onto the model's sensor points over the *reference* tyre's surface
  (the first group), exactly as ``farm predict`` resamples a measured cloud
  (:func:`analysis.camera.sensor.resample.to_layout`): the model learns what a camera on
  a tyre it was not built on sees;
- a population's groups of experiments are its **tyres**: held-out checks and the CV
  folds of the intervals hold out whole tyres, so that the error and the conformal
  half-widths are those of a tyre the model never saw (with one tyre, the groups are
  its load paths, as before: :func:`analysis.splits.path_groups`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import xarray as xr

from analysis.camera.features import (
    TPMS,
    camera_inputs,
    displacements,
    measured_features,
    pressures,
    targets,
    with_tpms,
)
from analysis.camera.sensor import InnerSurface, VirtualSensor
from analysis.camera.sensor.model import INPUTS
from analysis.camera.sensor.resample import to_layout
from analysis.errors import ParameterError
from analysis.splits import path_groups

__all__ = ["Tyres", "resampled_features", "tyre_features"]


def resampled_features(virtual: VirtualSensor, ref_points: np.ndarray, points: np.ndarray,
                       inputs: Sequence[str] = INPUTS) -> np.ndarray:
    """Features (1, F) of one cloud against its reference cloud, both (M, 3) in the
    frame of ``virtual``'s surface, resampled on its points (points not seen, NaN,
    left out)."""
    seen = np.isfinite(ref_points).all(axis=1) & np.isfinite(points).all(axis=1)
    ref, cloud = to_layout(virtual.surface, virtual.layout, ref_points[seen], points[seen])
    X, _ = virtual.features(ref[None], cloud[None], inputs)
    return X


def _same_surface(a: InnerSurface, b: InnerSurface) -> bool:
    return a is b or (a.xyz.shape == b.xyz.shape and np.array_equal(a.xyz, b.xyz)
                      and np.array_equal(a.node_index, b.node_index))


def tyre_features(virtual: VirtualSensor, ds: xr.Dataset, draws: int,
                  rng: np.random.Generator, inputs: Sequence[str] = INPUTS,
                  rows: np.ndarray | None = None) -> list[np.ndarray]:
    """Features of ``draws`` noisy measurements of experiments of ``ds`` as ``virtual``'s
    model sees them, one (K, F) array per draw (one array: a noise-free sensor or 0
    draws).

    On ``virtual``'s own surface the camera's points are the model's
    (:func:`~analysis.camera.features.measured_features`); on another tyre the camera
    measures that tyre's inner surface and each cloud is resampled onto the model's
    points (:func:`resampled_features`). Where ``inputs`` hold
    :data:`~analysis.camera.features.TPMS`, each row ends with its experiment's pressure.
    """
    U = displacements(ds) if rows is None else displacements(ds)[rows]
    kpa = None if TPMS not in inputs else (pressures(ds) if rows is None
                                           else pressures(ds)[rows])
    camera = camera_inputs(inputs)
    surface = InnerSurface.from_dataset(ds)
    noisy = virtual.spec.noisy and draws > 0
    if _same_surface(surface, virtual.surface):
        X, _ = measured_features(virtual, virtual.clean(U), draws, rng, camera)
        return [with_tpms(x, kpa, inputs) for x in X.reshape(draws if noisy else 1,
                                                             U.shape[0], -1)]
    other = VirtualSensor(virtual.spec, surface)
    clean = other.clean(U)
    out = []
    for _ in range(draws if noisy else 1):
        refs, clouds = other.measure(clean, rng if noisy else None)
        out.append(with_tpms(np.concatenate(
            [resampled_features(virtual, refs[k].reshape(-1, 3), clouds[k].reshape(-1, 3),
                                camera) for k in range(clean.shape[0])]), kpa, inputs))
    return out


@dataclass(frozen=True, eq=False)
class Tyres:
    """Store groups as one training set, in the order given; the first is the reference
    tyre (the model's surface).

    Attributes
    ----------
    datasets : tuple of xarray.Dataset
        One group each (:func:`analysis.data.load`).
    """

    datasets: tuple[xr.Dataset, ...]

    @classmethod
    def of(cls, ds: xr.Dataset | Sequence[xr.Dataset]) -> Tyres:
        """One dataset, or several (a population)."""
        parts = (ds,) if isinstance(ds, xr.Dataset) else tuple(ds)
        if not parts:
            raise ParameterError("a training set needs at least one store group")
        return cls(parts)

    @property
    def population(self) -> bool:
        """Whether more than one tyre is given."""
        return len(self.datasets) > 1

    @cached_property
    def sizes(self) -> np.ndarray:
        """Experiments per tyre, (T,)."""
        return np.array([d.sizes["experiment"] for d in self.datasets])

    @cached_property
    def tyre(self) -> np.ndarray:
        """Tyre index of every experiment, (K,)."""
        return np.repeat(np.arange(len(self.datasets)), self.sizes)

    def targets(self) -> np.ndarray:
        """(K, 4) true Fx, Fy, Fz, Mz, tyre by tyre."""
        return np.concatenate([targets(d) for d in self.datasets])

    def groups(self) -> np.ndarray:
        """(K,) labels that a split and a fold keep whole: the tyre in a population, the
        load path (:func:`~analysis.splits.path_groups`) for one tyre."""
        return self.tyre.copy() if self.population else path_groups(self.datasets[0])

    def paths(self) -> np.ndarray:
        """(K,) load-path labels, distinct across tyres: what a learner's own CV (its
        component count) keeps whole. Holding out tyres there too would leave too few in
        each outer fold's training part; the outer folds (the intervals) and the
        held-out check hold out tyres (:meth:`groups`)."""
        labels = [path_groups(d) for d in self.datasets]
        offsets = np.cumsum([0] + [int(x.max()) + 1 if x.size else 0 for x in labels[:-1]])
        return np.concatenate([x + o for x, o in zip(labels, offsets, strict=True)])

    def ids(self) -> np.ndarray:
        """(K,) experiment ids, tyre by tyre."""
        return np.concatenate([np.asarray(d["experiment"].values) for d in self.datasets])

    def names(self) -> list[str]:
        """The groups' names (their ``group`` attribute)."""
        return [str(d.attrs.get("group", f"tyre {t}")) for t, d in enumerate(self.datasets)]

    def held_out(self, test: np.ndarray) -> dict[str, list[str]]:
        """A population's ``tyres`` and ``heldout_tyres`` (the tyres of the positions
        ``test``), by name, for a model's info; nothing for one tyre."""
        if not self.population:
            return {}
        names = self.names()
        return {"tyres": names, "heldout_tyres": [names[t] for t in np.unique(self.tyre[test])]}

    def surface(self) -> InnerSurface:
        """The reference tyre's inner surface: what the model's sensor points lie on."""
        return InnerSurface.from_dataset(self.datasets[0])

    def features(self, virtual: VirtualSensor, rows: np.ndarray, draws: int,
                 rng: np.random.Generator, inputs: Sequence[str] = INPUTS) -> np.ndarray:
        """Features of ``draws`` noisy measurements of the experiments ``rows`` (sorted
        positions), stacked draw by draw, each draw's rows in ``rows``' order (as
        :func:`~analysis.camera.features.measured_features` stacks them)."""
        per_tyre = []
        for t, ds in enumerate(self.datasets):
            start = int(self.sizes[:t].sum())
            mine = rows[(rows >= start) & (rows < start + self.sizes[t])] - start
            if mine.size:
                per_tyre.append(tyre_features(virtual, ds, draws, rng, inputs, mine))
        return np.concatenate([np.concatenate([p[d] for p in per_tyre])
                               for d in range(len(per_tyre[0]))])
