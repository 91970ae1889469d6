"""What a group is made for: the mesh's node sets and the attributes of the model.

:class:`MeshNodes` is everything experiments of one mesh share (node ids, reference
coordinates, grid positions); :class:`GroupAttrs` is what the group records about where
its data came from. Both are validated once, when constructed, and hold read-only
arrays in the store's dtypes, so a value that exists can be written as is.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import metadata

import numpy as np

from storage.errors import SchemaError

# Two meshes are the same when their reference coordinates agree to this (mm): gmsh is
# deterministic, but a mesh rebuilt elsewhere may differ in the last bits.
XYZ_TOLERANCE_MM = 1e-6


def package_versions() -> dict[str, str]:
    """Versions of the packages that shape the store's content, for ``package_versions``."""
    versions = {}
    for name in ("tyre-farm", "numpy", "zarr", "xarray", "numcodecs"):
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def _ids(name: str, values: object) -> np.ndarray:
    a = np.asarray(values)
    if a.ndim != 1 or a.size == 0 or a.dtype.kind not in "iu":
        raise SchemaError(
            f"{name} must be a non-empty 1-D array of integer node ids, got "
            f"{a.dtype} array of shape {a.shape}"
        )
    if np.unique(a).size != a.size:
        raise SchemaError(f"{name} has repeated node ids: give each node once")
    return _frozen(a.astype(np.int64))


def _xyz(name: str, values: object, n: int) -> np.ndarray:
    a = np.asarray(values)
    if a.shape != (n, 3) or a.dtype.kind not in "iuf":
        raise SchemaError(
            f"{name} must be a ({n}, 3) array of coordinates in mm (one row per node id), "
            f"got {a.dtype} array of shape {a.shape}"
        )
    if not np.isfinite(a).all():
        raise SchemaError(f"{name} holds NaN or inf: reference coordinates must be finite")
    return _frozen(a.astype(np.float64))


def _grid(name: str, values: object, n: int) -> np.ndarray:
    a = np.asarray(values)
    if a.shape != (n,) or a.dtype.kind not in "iu":
        raise SchemaError(
            f"{name} must be a ({n},) array of integer grid positions, got "
            f"{a.dtype} array of shape {a.shape}"
        )
    if a.size and (a.min() < 0 or a.max() > np.iinfo(np.int32).max):
        raise SchemaError(
            f"{name} must hold grid positions in [0, 2**31), got {a.min()}..{a.max()}"
        )
    return _frozen(a.astype(np.int32))


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class MeshNodes:
    """Node sets of one model mesh, shared by every experiment of its group.

    Parameters
    ----------
    inner_ids : (N,) int
        CalculiX node ids of the inner-surface (cavity) nodes, unique.
    inner_xyz : (N, 3) float
        Their reference coordinates in mm (TYDEX C, origin at the wheel centre).
    inner_row, inner_col : (N,) int
        Their position on the structured surface grid (row: meridian, col: circumference).
    tread_ids : (M,) int
        CalculiX node ids of the outer tread nodes, unique.
    tread_xyz : (M, 3) float
        Their reference coordinates in mm.
    tread_row, tread_col : (M,) int
        Their position on the tread grid.
    """

    inner_ids: np.ndarray
    inner_xyz: np.ndarray
    inner_row: np.ndarray
    inner_col: np.ndarray
    tread_ids: np.ndarray
    tread_xyz: np.ndarray
    tread_row: np.ndarray
    tread_col: np.ndarray

    def __post_init__(self) -> None:
        for side in ("inner", "tread"):
            ids = _ids(f"{side}_ids", getattr(self, f"{side}_ids"))
            n = ids.size
            object.__setattr__(self, f"{side}_ids", ids)
            xyz = _xyz(f"{side}_xyz", getattr(self, f"{side}_xyz"), n)
            object.__setattr__(self, f"{side}_xyz", xyz)
            for g in ("row", "col"):
                name = f"{side}_{g}"
                object.__setattr__(self, name, _grid(name, getattr(self, name), n))

    @property
    def n_inner(self) -> int:
        return int(self.inner_ids.size)

    @property
    def n_tread(self) -> int:
        return int(self.tread_ids.size)

    def arrays(self) -> dict[str, np.ndarray]:
        """The mesh variables of the schema, by store name."""
        return {
            "inner_node": self.inner_ids, "inner_xyz": self.inner_xyz,
            "inner_row": self.inner_row, "inner_col": self.inner_col,
            "tread_node": self.tread_ids, "tread_xyz": self.tread_xyz,
            "tread_row": self.tread_row, "tread_col": self.tread_col,
        }

    def difference(self, stored: Mapping[str, np.ndarray]) -> str | None:
        """Name the first mesh variable that differs from ``stored``; ``None`` if all agree."""
        for name, mine in self.arrays().items():
            theirs = np.asarray(stored[name])
            if theirs.shape != mine.shape:
                return f"{name} has shape {theirs.shape} in the store, {mine.shape} given"
            if name.endswith("_xyz"):
                same = np.allclose(theirs, mine, rtol=0.0, atol=XYZ_TOLERANCE_MM)
            else:
                same = np.array_equal(theirs, mine)
            if not same:
                return f"{name} differs from the store's"
        return None


@dataclass(frozen=True)
class GroupAttrs:
    """What a group records about its origin (group attributes of the schema).

    Parameters
    ----------
    model_spec : str
        JSON text of the model spec (``json.dumps(ModelSpec.to_dict())``).
    mesh_key : str
        The mesh's key: :func:`farm.mesh.version.mesh_key` (the spec's geometry,
        density and sector, the mesher's and gmsh's versions), as the worker's mesh
        carries it (``TyreMesh.mesh_key``); not ``ModelSpec.mesh_key()``, which leaves
        the mesher out.
    solver : str
        Solver and version, e.g. ``"CalculiX 2.20"``.
    package_versions : mapping of str to str
        Versions of the packages that made the data; by default those of this process.
    """

    model_spec: str
    mesh_key: str
    solver: str
    package_versions: Mapping[str, str] = field(default_factory=package_versions)

    def __post_init__(self) -> None:
        try:
            spec = json.loads(self.model_spec)
        except (TypeError, ValueError) as e:
            raise SchemaError(
                "model_spec must be JSON text of the model spec, got "
                f"{str(self.model_spec)[:60]!r}: pass json.dumps(spec.to_dict())"
            ) from e
        if not isinstance(spec, dict):
            raise SchemaError(f"model_spec must be a JSON object, got {type(spec).__name__}")
        for name in ("mesh_key", "solver"):
            value = getattr(self, name)
            if not (isinstance(value, str) and value.strip()):
                raise SchemaError(f"{name} must be a non-empty string, got {value!r}")
        versions = dict(self.package_versions)
        if not all(isinstance(k, str) and isinstance(v, str) for k, v in versions.items()):
            raise SchemaError(
                f"package_versions must map package names to version strings, got {versions!r}"
            )
        object.__setattr__(self, "package_versions", versions)
