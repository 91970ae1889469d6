"""Schema-conformant synthetic stores with a known latent structure (for tests, benchmarks).

Writes one group that follows ``docs/schema.md`` (variables, dims, dtypes, units,
status flags, one chunk per experiment along ``experiment``) with xarray's ``to_zarr``.

Why here and not in ``analysis/``, and why not through ``storage.write_experiment``
(issue 25): the store has one writer in the product, ``storage/``. This is test data:
it makes groups ``storage`` deliberately cannot (no strain arrays, the shape of older
stores that the analysis must still name a missing variable in), and the out-of-core
benchmark's 10,000-experiment group in dask blocks, where one ``write_experiment`` per
experiment would time the writer instead of the analysis. Tests and benchmarks import
it as ``tests.synthetic`` (the project root is on their path).
The physics is a caricature of the thesis' chapter 5 dataset, not a tyre model:

- the single latent variable is the deflection d (the thesis' 10..40 mm at 200 kPa);
- the contact patch grows like a Hertz-ish ellipse, half-length sqrt(2 R d), so nodal
  forces switch on as d grows and depend on d *nonlinearly*; total Fz ~ d^1.15 (about
  4.6 kN at 30 mm, like the thesis' 4.5 kN);
- inner-surface fields are Gaussian bumps around the contact whose width also grows
  with d: Uz the strongest displacement, exx the strongest strain, as in Figs. 5.1-5.4.

``signal="uz_only"`` keeps the d-dependence in Uz alone (all other inputs are zero plus
noise), so Uz must rank first. ``noise`` adds independent Gaussian noise to every input,
relative to each family's scale (30 mm for displacements, 2e-3 for strains).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Literal

import dask.array as da
import numpy as np
import xarray as xr

R_INNER, R_TREAD, HALF_WIDTH = 300.0, 350.0, 100.0  # mm
SCALE = {"displacement": 30.0, "strain": 2e-3}  # noise reference per family
STRAIN_VARS = ("strain", "surface_strain")


@dataclass(frozen=True)
class Geometry:
    """Structured inner and tread grids (rows: meridian from -y; cols: angle towards +x)."""

    inner_s: np.ndarray  # (N,) meridian coordinate in [-1, 1]
    inner_theta: np.ndarray  # (N,) angle from the contact centre, rad
    inner_rc: tuple[np.ndarray, np.ndarray]
    tread_s: np.ndarray
    tread_theta: np.ndarray
    tread_rc: tuple[np.ndarray, np.ndarray]

    @property
    def inner_xyz(self) -> np.ndarray:
        return _xyz(R_INNER, self.inner_s, self.inner_theta)

    @property
    def tread_xyz(self) -> np.ndarray:
        return _xyz(R_TREAD, self.tread_s, self.tread_theta)


def _xyz(radius, s, theta):
    return np.column_stack([radius * np.sin(theta), HALF_WIDTH * s, -radius * np.cos(theta)])


def _grid(rows: int, cols: int, half_angle: float):
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    s = np.linspace(-1.0, 1.0, rows)[r.ravel()]
    theta = np.linspace(-half_angle, half_angle, cols)[c.ravel()]
    return s, theta, (r.ravel().astype(np.int32), c.ravel().astype(np.int32))


def geometry(rows: int, cols: int, tread_rows: int, tread_cols: int) -> Geometry:
    """Inner grid over ±60° of circumference, tread grid over ±35° (covers the patch)."""
    s, th, rc = _grid(rows, cols, np.radians(60.0))
    ts, tth, trc = _grid(tread_rows, tread_cols, np.radians(35.0))
    return Geometry(s, th, rc, ts, tth, trc)


def tread_forces(geo: Geometry, d: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Road force on tread nodes, (K, M, 3) in N: an elliptic patch growing with d."""
    xyz = geo.tread_xyz
    a = np.sqrt(2.0 * R_TREAD * d)[:, None]  # patch half-length, mm
    b = (HALF_WIDTH * (1.0 - np.exp(-d / 12.0)))[:, None]  # half-width, mm
    shape = np.sqrt(np.clip(1.0 - (xyz[:, 0] / a) ** 2 - (xyz[:, 1] / b) ** 2, 0.0, None))
    fz_total = 110.0 * d**1.15 * (p / 0.2) ** 0.3
    norm = np.where(shape.sum(1) > 0, shape.sum(1), 1.0)
    fz = shape * (fz_total / norm)[:, None]
    fx = -0.02 * fz * xyz[:, 0] / a
    fy = 0.02 * fz * xyz[:, 1] / b
    return np.stack([fx, fy, fz], axis=-1)


def inner_fields(geo: Geometry, d: np.ndarray, p: np.ndarray, signal: str) -> dict[str, np.ndarray]:
    """Displacement (K, N, 3) in mm and strains (K, N, 3) for each experiment."""
    th0 = 1.2 * np.sqrt(2.0 * R_TREAD * d)[:, None] / R_INNER  # bump half-width, rad
    u = geo.inner_theta / th0
    bump = np.exp(-(u**2))
    g = np.cos(0.5 * np.pi * geo.inner_s) ** 2  # 1 on the crown, 0 at the beads
    soft = ((0.2 / p) ** 0.3)[:, None]
    amp, e = d[:, None] * soft, (d[:, None] / 30.0) ** 1.3 * soft
    uz = amp * bump * (0.3 + 0.7 * g)
    if signal == "uz_only":
        zero = np.zeros_like(uz)
        disp, strain = np.stack([zero, zero, uz], -1), np.zeros((*uz.shape, 3))
        return {"displacement": disp, "strain": strain, "surface_strain": strain.copy()}
    ux = 0.15 * amp * u * bump * g
    uy = 0.25 * amp * geo.inner_s * bump * (1.0 - g)
    exx = 2e-3 * e * (1.0 - 2.0 * u**2) * bump * g
    eyy = 1.2e-3 * e * bump * (2.0 * g - 1.0)
    exy = 6e-4 * e * u * geo.inner_s * bump
    strain = np.stack([exx, eyy, exy], -1)
    # CST strains (T2Cam) smooth the field over the triangles: a damped copy here.
    return {
        "displacement": np.stack([ux, uy, uz], -1),
        "strain": strain,
        "surface_strain": 0.9 * strain * (d[:, None, None] / 30.0) ** 0.05,
    }


def make_store(
    path,
    *,
    n_experiments: int = 7,
    rows: int = 12,
    cols: int = 24,
    tread_rows: int = 8,
    tread_cols: int = 20,
    signal: Literal["deflection", "uz_only"] = "deflection",
    noise: float = 0.0,
    group: str = "synthetic",
    pressures=(0.2,),
    deflection_range=(10.0, 40.0),
    n_failed: int = 0,
    n_pending: int = 0,
    include_strain: bool = True,
    seed: int = 0,
    block: int = 256,
) -> str:
    """Write one synthetic group into the Zarr store at ``path``; returns the group name.

    Parameters
    ----------
    n_experiments : int
        Done experiments per pressure, deflections evenly spaced over
        ``deflection_range`` (mm); K = n_experiments * len(pressures).
    rows, cols : int
        Inner grid (N = rows * cols nodes); ``tread_rows * tread_cols`` = M tread nodes.
    signal : {"deflection", "uz_only"}
        Latent structure, see the module docstring.
    noise : float
        Input noise, relative to 30 mm (displacements) and 2e-3 (strains).
    pressures : sequence of float
        Inflation pressures (MPa).
    n_failed, n_pending : int
        Extra experiments with status 2 / 0 whose float variables hold NaN.
    include_strain : bool
        Write ``strain`` and ``surface_strain`` (skip them for large benchmark stores).
    block : int
        Experiments generated per dask task (the Zarr chunks stay one per experiment).
    """
    geo = geometry(rows, cols, tread_rows, tread_cols)
    d, p, status = _load_cases(n_experiments, pressures, deflection_range, n_failed, n_pending)
    done = status == 1
    forces = np.full((len(d), len(geo.tread_s), 3), np.nan)
    forces[done] = tread_forces(geo, d[done], p[done])
    ds = _skeleton(geo, d, p, status, forces, group, seed)
    names = ("displacement", *STRAIN_VARS) if include_strain else ("displacement",)
    for k, name in enumerate(names):
        arr = _lazy_field(geo, d, p, status, name, signal, noise, seed + 7919 * k, block)
        ds[name] = (("experiment", "inner_node", _comp_dim(name)), arr, {"units": _units(name)})
    enc = {v: {"chunks": (1, *ds[v].shape[1:])} for v in ds.data_vars if "experiment" in ds[v].dims}
    ds.to_zarr(path, group=group, mode="w", encoding=enc, consolidated=False)
    return group


def _comp_dim(name: str) -> str:
    return "component" if name == "displacement" else "strain_component"


def _units(name: str) -> str:
    return "mm" if name == "displacement" else "1"


def _load_cases(n, pressures, drange, n_failed, n_pending):
    d = np.tile(np.linspace(*drange, n), len(pressures))
    p = np.repeat(np.asarray(pressures, dtype=float), n)
    status = np.ones(len(d), dtype=np.int8)
    extra = n_failed + n_pending
    d = np.concatenate([d, np.linspace(drange[0], drange[1], max(extra, 1))[:extra]])
    p = np.concatenate([p, np.full(extra, float(pressures[0]))])
    status = np.concatenate([status, np.full(n_failed, 2, np.int8), np.zeros(n_pending, np.int8)])
    return d, p, status


def _lazy_field(geo, d, p, status, name, signal, noise, seed, block) -> da.Array:
    """(K, N, 3) dask array, generated ``block`` experiments per task."""
    idx = da.arange(len(d), chunks=block)

    def gen(ix):
        out = np.full((len(ix), len(geo.inner_s), 3), np.nan)
        ok = status[ix] == 1
        if ok.any():
            field = inner_fields(geo, d[ix][ok], p[ix][ok], signal)[name]
            rng = np.random.default_rng([seed, int(ix[0]) if len(ix) else 0])
            scale = SCALE["displacement" if name == "displacement" else "strain"]
            out[ok] = field + noise * scale * rng.standard_normal(field.shape)
        return out

    chunks = (idx.chunks[0], (len(geo.inner_s),), (3,))
    return da.map_blocks(gen, idx, new_axis=[1, 2], chunks=chunks, dtype=float)


def _skeleton(geo, d, p, status, forces, group, seed) -> xr.Dataset:
    """Coordinates, node variables and the small per-experiment variables."""
    K = len(d)
    ids = [hashlib.sha256(f"{group}/{seed}/{k}".encode()).hexdigest() for k in range(K)]
    z_contact = -(R_TREAD - d)  # road plane: the contact centre is (0, 0, z_contact)
    arm = geo.tread_xyz[None, :, :] - np.stack([0 * d, 0 * d, z_contact], -1)[:, None, :]
    moment = np.cross(arm, forces).sum(axis=1)
    exp = "experiment"
    ds = xr.Dataset(
        {
            "inner_xyz": (("inner_node", "component"), geo.inner_xyz, {"units": "mm"}),
            "tread_xyz": (("tread_node", "component"), geo.tread_xyz, {"units": "mm"}),
            "inner_row": ("inner_node", geo.inner_rc[0], {"units": "1"}),
            "inner_col": ("inner_node", geo.inner_rc[1], {"units": "1"}),
            "tread_row": ("tread_node", geo.tread_rc[0], {"units": "1"}),
            "tread_col": ("tread_node", geo.tread_rc[1], {"units": "1"}),
            "reaction_force": ((exp, "tread_node", "component"), forces, {"units": "N"}),
            "total_force": ((exp, "component"), forces.sum(axis=1), {"units": "N"}),
            "moment": ((exp, "component"), moment, {"units": "N mm"}),
            # role "parameter": what storage.select filters on (storage/schema.py)
            "deflection": (exp, d, {"units": "mm", "role": "parameter"}),
            "pressure": (exp, p, {"units": "MPa", "role": "parameter"}),
            "status": (
                exp,
                status,
                {"units": "-", "flag_values": [0, 1, 2], "flag_meanings": "pending done failed"},
            ),
            "error": (
                exp,
                np.array(["" if s != 2 else "synthetic failure" for s in status], dtype=object),
                {"units": "-"},
            ),
            "solve_seconds": (exp, np.where(status == 1, 1.0 + d / 10.0, np.nan), {"units": "s"}),
            "increments": (exp, np.where(status == 1, 10, 0).astype(np.int32), {"units": "1"}),
            "ccx_runs": (exp, np.where(status == 0, 0, 1).astype(np.int32), {"units": "1"}),
            "contact_nodes": (
                exp,
                (np.nan_to_num(forces[..., 2]) > 0).sum(1).astype(np.int32),
                {"units": "1"},
            ),
        },
        coords={
            exp: np.array(ids, dtype=object),
            "inner_node": np.arange(1, len(geo.inner_s) + 1, dtype=np.int64),
            "tread_node": np.arange(100001, 100001 + len(geo.tread_s), dtype=np.int64),
            "component": np.array(["x", "y", "z"], dtype=object),
            "strain_component": np.array(["xx", "yy", "xy"], dtype=object),
        },
        attrs={
            "schema_version": 1,
            "model_spec": json.dumps({"synthetic": True, "seed": seed}),
            "mesh_key": f"synthetic-{len(geo.inner_s)}-{len(geo.tread_s)}",
            "solver": "synthetic (tests.synthetic)",
            "package_versions": json.dumps({"numpy": np.__version__, "xarray": xr.__version__}),
        },
    )
    return ds


# ----------------------------------------------------------------- combined loads (issue 13)

#: load parameters of a combined-load group beside deflection and pressure
#: (docs/combined-loads.md, ``farm.specs.RoadMotion``)
COMBINED_PARAMETERS = ("friction", "shift_x", "shift_y", "tilt")
_COMBINED_UNITS = {"friction": "1", "shift_x": "mm", "shift_y": "mm", "tilt": "deg"}


def combined_cases(n: int, seed: int = 0, *, vary=("deflection", "shift_x", "shift_y", "tilt")):
    """Random load cases (uniform, seeded): dict of (n,) arrays for every load parameter.

    Parameters not in ``vary`` stay at their nominal value (deflection 25 mm, pressure
    0.2 MPa, friction 0.8, no shift, no tilt); those in it are drawn from deflection
    15..35 mm, pressure 0.18..0.22 MPa, friction 0.5..1, shifts ±5 mm, tilt ±4°.
    """
    rng = np.random.default_rng(seed)
    ranges = {
        "deflection": (15.0, 35.0, 25.0),
        "pressure": (0.18, 0.22, 0.2),
        "friction": (0.5, 1.0, 0.8),
        "shift_x": (-5.0, 5.0, 0.0),
        "shift_y": (-5.0, 5.0, 0.0),
        "tilt": (-4.0, 4.0, 0.0),
    }
    return {
        k: (rng.uniform(lo, hi, n) if k in vary else np.full(n, nominal))
        for k, (lo, hi, nominal) in ranges.items()
    }


def combined_forces(geo: Geometry, c: dict, coupling: float = 0.1) -> np.ndarray:
    """Road force on tread nodes under a combined load, (K, M, 3) in N.

    A caricature, not tyre physics: the vertical map of :func:`tread_forces` (nonlinear
    in d) plus a tilt term loading the lowered side; longitudinal and lateral maps on
    the patch of d = 25 mm, proportional to friction x shift (the lateral one with a
    camber thrust) and coupled to d by ``coupling`` per 10 mm (a bilinear term no linear
    model can follow). Totals are therefore linear-ish in the latent parameters.
    """
    base = tread_forces(geo, c["deflection"], c["pressure"])[..., 2]
    # the tangential maps ride on the patch of d = 25 mm, scaled by a weak d-coupling
    ref = tread_forces(geo, np.array([25.0]), np.array([0.2]))[..., 2]
    ref = ref * (1.0 + coupling * (c["deflection"][:, None] - 25.0) / 10.0)
    s = geo.tread_s[None, :]
    xn = geo.tread_xyz[None, :, 0] / 100.0
    mu, t = c["friction"][:, None], c["tilt"][:, None]
    fz = base + ref * 0.05 * t * s
    fx = ref * 0.1 * mu * (c["shift_x"][:, None] / 5.0) * (1.0 + 0.3 * xn)
    fy = ref * (0.1 * mu * c["shift_y"][:, None] / 5.0 + 0.03 * t / 4.0) * (1.0 + 0.3 * s)
    return np.stack([fx, fy, fz], axis=-1)


def combined_fields(geo: Geometry, c: dict) -> dict[str, np.ndarray]:
    """Inner fields (K, N, 3) under a combined load: a sum of fixed spatial patterns.

    Each pattern's amplitude is linear in one load parameter (d, f x shift_x,
    f x shift_y, tilt), so with ``friction`` fixed the displacement field has exactly 4
    latent variables (deflection, shift_x, shift_y, tilt) and so does every strain field.
    """
    th0 = 1.2 * np.sqrt(2.0 * R_TREAD * 25.0) / R_INNER  # the bump of d = 25 mm, fixed
    u = geo.inner_theta / th0
    bump, s = np.exp(-(u**2)), geo.inner_s
    g = np.cos(0.5 * np.pi * s) ** 2
    soft = ((0.2 / c["pressure"]) ** 0.3)[:, None]
    d = c["deflection"][:, None] * soft
    e = c["deflection"][:, None] / 30.0 * soft
    mu = c["friction"][:, None]
    sx, sy = mu * c["shift_x"][:, None] / 5.0, mu * c["shift_y"][:, None] / 5.0
    t = c["tilt"][:, None] / 4.0
    ux = 0.15 * d * u * bump * g + 2.5 * sx * bump * g
    uy = 0.25 * d * s * bump * (1.0 - g) + 2.5 * sy * bump
    uz = d * bump * (0.3 + 0.7 * g) + 3.0 * t * s * bump
    exx = 2e-3 * e * (1.0 - 2.0 * u**2) * bump * g + 3e-4 * sx * u * bump * g + 2e-4 * t * s * bump
    eyy = 1.2e-3 * e * bump * (2.0 * g - 1.0) + 3e-4 * sy * s * bump + 3e-4 * t * s * bump * g
    exy = 6e-4 * e * u * s * bump + 4e-4 * sx * bump * g + 3e-4 * sy * u * bump
    strain = np.stack([exx, eyy, exy], -1)
    return {
        "displacement": np.stack([ux, uy, uz], -1),
        "strain": strain,
        "surface_strain": 0.9 * strain,
    }


def make_combined_store(
    path,
    *,
    n_experiments: int = 60,
    rows: int = 12,
    cols: int = 24,
    tread_rows: int = 8,
    tread_cols: int = 20,
    vary=("deflection", "shift_x", "shift_y", "tilt"),
    noise: float = 0.0,
    coupling: float = 0.1,
    group: str = "combined",
    seed: int = 0,
    rolling: bool = False,
) -> str:
    """Write a synthetic combined-load group (issue 13) into ``path``; returns its name.

    ``rolling`` (issue 30) adds the parameters ``slip_ratio`` (0.002 x shift_x) and
    ``slip_angle`` (0.5 x tilt, deg) of a rolling group: linear in what shapes the fields.

    Same schema as :func:`make_store` plus the load parameters ``friction`` (1),
    ``shift_x``, ``shift_y`` (mm) and ``tilt`` (deg) along ``experiment`` and all three
    force components filled. Load cases are drawn by :func:`combined_cases` (``vary``
    names the parameters that vary; 4 by default, so the latent count is known); fields by
    :func:`combined_fields`, forces by :func:`combined_forces` (``coupling``: its
    bilinear d-coupling, 0 = forces linear in the fields). ``noise`` adds Gaussian
    noise to the inputs relative to 30 mm / 2e-3, as in :func:`make_store`.
    """
    geo = geometry(rows, cols, tread_rows, tread_cols)
    c = combined_cases(n_experiments, seed, vary=vary)
    status = np.ones(n_experiments, dtype=np.int8)
    forces = combined_forces(geo, c, coupling)
    ds = _skeleton(geo, c["deflection"], c["pressure"], status, forces, group, seed)
    for name in COMBINED_PARAMETERS:
        ds[name] = ("experiment", c[name], {"units": _COMBINED_UNITS[name], "role": "parameter"})
    if rolling:
        ds["slip_ratio"] = ("experiment", 0.002 * c["shift_x"], {"units": "1", "role": "parameter"})
        ds["slip_angle"] = ("experiment", 0.5 * c["tilt"], {"units": "deg", "role": "parameter"})
    rng = np.random.default_rng([seed, 13])
    for name, field in combined_fields(geo, c).items():
        scale = SCALE["displacement" if name == "displacement" else "strain"]
        field = field + noise * scale * rng.standard_normal(field.shape)
        ds[name] = (("experiment", "inner_node", _comp_dim(name)), field, {"units": _units(name)})
    enc = {v: {"chunks": (1, *ds[v].shape[1:])} for v in ds.data_vars if "experiment" in ds[v].dims}
    ds.to_zarr(path, group=group, mode="w", encoding=enc, consolidated=False)
    return group


def stiffer_tyre(path, stiffness: float, *, seed: int, n_experiments: int = 30, **geometry):
    """A synthetic combined group (:func:`make_combined_store`, group named by the file)
    loaded into memory, its forces and moments times ``stiffness``: a tyre that needs that
    much more force for the same deformation (issue 47). Its stiffness leaves no trace in
    its fields, so no camera model can tell it from the nominal one."""
    from analysis import data

    make_combined_store(path, n_experiments=n_experiments, seed=seed, group=path.stem,
                        **geometry)
    ds = data.load(str(path)).load()
    for var in ("total_force", "moment"):
        ds[var] = ds[var] * stiffness
    return ds
