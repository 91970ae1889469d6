"""One xarray index over all load-case parameters of a group, so that
``ds.sel(deflection=30, pressure=0.2)`` selects experiments (issue 25).

Why not ``xarray.indexes.PandasMultiIndex``: it takes over the dimension coordinate,
so the experiment ids (``ds["experiment"]``) become tuples of parameters, and a scalar
selection drops levels and renames the ``experiment`` dimension (``sel(deflection=30)``
would return a dataset along ``pressure``). And two single indexes (``set_xindex`` per
parameter) cannot be queried together: xarray refuses ``sel`` over two indexes of one
dimension. This index lives beside the ids' index, covers every parameter, and always
answers with positions along ``experiment``: a selection is a set of experiments, the
dimension and the ids stay.

Labels match exactly (the parameters are stored rounded, see :func:`LoadCaseIndex.sel`);
``storage.select`` compares within a tolerance.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from xarray.core.indexing import IndexSelResult

_TOLERANCE_HINT = "for a tolerance use storage.select(ds, name=value), which matches within 1e-9"


def kpa_hint(name: Hashable, label: float, values: np.ndarray) -> str:
    """A hint when ``label`` is a pressure in kPa: the store keeps MPa (issue 48), while
    every command and study file takes kPa, so ``sel(pressure=200)`` is the natural slip."""
    if name != "pressure" or not np.any(np.isclose(values, label / 1000.0, rtol=1e-9, atol=0)):
        return ""
    return f"; the store keeps pressure in MPa: pressure={label / 1000.0:g} is {label:g} kPa"


class LoadCaseIndex(xr.Index):
    """Index of the load-case coordinates (1-D, along one dimension) of a dataset."""

    def __init__(self, values: Mapping[Hashable, np.ndarray], dim: Hashable):
        self._dim = dim
        self._values = {n: _frozen(v) for n, v in values.items()}

    @property
    def names(self) -> tuple[Hashable, ...]:
        """The coordinates this index covers, in the order it was built."""
        return tuple(self._values)

    @classmethod
    def from_variables(cls, variables: Mapping[Any, xr.Variable], *,
                       options: Mapping[str, Any]) -> LoadCaseIndex:
        dims = {v.dims for v in variables.values()}
        if len(dims) != 1 or len(next(iter(dims))) != 1:
            raise ValueError(f"a load-case index needs 1-D coordinates along one dimension, "
                             f"got {sorted(map(str, variables))} with dimensions {dims}")
        (dim,) = dims.pop()
        return cls({n: np.asarray(v.values) for n, v in variables.items()}, dim)

    @classmethod
    def concat(cls, indexes: Sequence[LoadCaseIndex], dim: Hashable,
               positions: Iterable[Iterable[int]] | None = None) -> LoadCaseIndex:
        names = [tuple(i._values) for i in indexes]
        if len(set(names)) != 1:
            raise ValueError(f"cannot concatenate load-case indexes over different "
                             f"parameters: {sorted(set(names))}")
        values = {n: np.concatenate([i._values[n] for i in indexes]) for n in names[0]}
        if positions is not None:  # as PandasIndex.concat: put each piece where it goes
            order = np.argsort(np.concatenate([np.asarray(p) for p in positions]))
            values = {n: v[order] for n, v in values.items()}
        return cls(values, dim)

    def create_variables(self, variables: Mapping[Any, xr.Variable] | None = None
                         ) -> dict[Hashable, xr.Variable]:
        # from this index's own values: after isel, xarray passes the old variables
        old = variables or {}
        return {n: xr.Variable((self._dim,), v, attrs=_attrs(old.get(n)),
                               encoding=_encoding(old.get(n)))
                for n, v in self._values.items()}

    def to_pandas_index(self) -> pd.MultiIndex:
        return pd.MultiIndex.from_arrays(list(self._values.values()), names=list(self._values))

    def isel(self, indexers: Mapping[Any, Any]) -> LoadCaseIndex | None:
        key = indexers[self._dim]
        if isinstance(key, xr.Variable):
            if key.ndim != 1:
                return None
            key = key.values
        if np.ndim(key) == 0 and not isinstance(key, slice):
            return None  # one experiment: the parameters become scalars, nothing to index
        return type(self)({n: v[key] for n, v in self._values.items()}, self._dim)

    def sel(self, labels: dict[Any, Any], method: Any = None,
            tolerance: Any = None) -> IndexSelResult:
        """Positions of the experiments whose parameters equal every label given.

        A label is a number (exact match), a list of numbers (any of them; each must
        occur) or a ``slice(lo, hi)`` (inclusive). Always positions, never a scalar: the
        ``experiment`` dimension stays even when one experiment matches. Exact is
        enough for the numbers of a study file: the farm stores parameters rounded to 9
        decimals (``jobs.validate.limits.DECIMALS``), so ``0.2`` is stored as the double 0.2.
        """
        if method is not None or tolerance is not None:
            raise ValueError(f"the load-case index matches labels exactly; {_TOLERANCE_HINT}")
        keep = np.ones(self._size(), dtype=bool)
        for name, label in labels.items():
            keep &= self._match(name, label)
        return IndexSelResult({self._dim: np.flatnonzero(keep)})

    def _match(self, name: Hashable, label: Any) -> np.ndarray:
        values = self._values[name]
        if isinstance(label, slice):
            if label.step is not None:
                raise ValueError(f"sel {name}=slice(...) takes no step, got {label!r}")
            lo = -np.inf if label.start is None else float(label.start)
            hi = np.inf if label.stop is None else float(label.stop)
            return (values >= lo) & (values <= hi)
        wanted = np.asarray(getattr(label, "values", label), dtype=np.float64).ravel()
        missing = wanted[~np.isin(wanted, values)]
        if missing.size:
            raise KeyError(f"no experiment has {name}={missing[0]:.12g} (labels match "
                           f"exactly; {_TOLERANCE_HINT}){kpa_hint(name, missing[0], values)}")
        return np.isin(values, wanted)

    def _size(self) -> int:
        return len(next(iter(self._values.values())))

    def equals(self, other: xr.Index, *, exclude: frozenset[Hashable] | None = None) -> bool:
        if not isinstance(other, LoadCaseIndex) or other._dim != self._dim:
            return False
        return list(other._values) == list(self._values) and all(
            np.array_equal(v, other._values[n], equal_nan=v.dtype.kind == "f")
            for n, v in self._values.items())

    def join(self, other: LoadCaseIndex, how: str = "inner") -> LoadCaseIndex:
        # load cases repeat: they cannot say which experiment of one object is which of
        # the other's; the ids (``experiment``) can
        raise NotImplementedError(
            f"cannot align datasets with different experiments on their load-case index "
            f"({', '.join(map(str, self._values))}): drop it first, "
            f"ds.drop_indexes(storage.parameters(ds)), and they align by experiment id")

    def roll(self, shifts: Mapping[Any, int]) -> LoadCaseIndex:
        shift = shifts.get(self._dim, 0)
        return type(self)({n: np.roll(v, shift) for n, v in self._values.items()}, self._dim)

    def rename(self, name_dict: Mapping[Any, Hashable],
               dims_dict: Mapping[Any, Hashable]) -> LoadCaseIndex:
        return type(self)({name_dict.get(n, n): v for n, v in self._values.items()},
                          dims_dict.get(self._dim, self._dim))

    def __repr__(self) -> str:
        return f"LoadCaseIndex({', '.join(map(str, self._values))} along {self._dim!r})"

    def _repr_inline_(self, max_width: int) -> str:
        return f"LoadCaseIndex({', '.join(map(str, self._values))})"[:max_width]


def _frozen(values: np.ndarray) -> np.ndarray:
    """A read-only copy: writing into a coordinate's array would leave the index stale."""
    out = np.array(values, copy=True)
    out.flags.writeable = False
    return out


def _attrs(var: xr.Variable | None) -> dict:
    return dict(var.attrs) if var is not None else {}


def _encoding(var: xr.Variable | None) -> dict:
    return dict(var.encoding) if var is not None else {}
