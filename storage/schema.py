"""The store's schema in one table: every variable's dims, dtype, units and writer.

This module is the code form of ``docs/schema.md``; the rest of the package reads its
names, shapes and units from here, never from literals of its own.

Who writes what (docs/architecture.md, "The store"; docs/schema.md):

- ``"mesh"`` variables are written once, by :func:`storage.create_group`.
- ``"client"`` variables (experiment ids, load-case parameters) are written only by the
  submitting client, in :func:`storage.reserve`, so they may use large chunks along
  ``experiment`` (cheap to read: an id lookup is one read per 1024 experiments).
- ``"worker"`` variables are written by workers, one experiment per chunk along
  ``experiment`` so that concurrent workers never touch the same object; among them
  ``checksum`` (:mod:`storage.checksum`), over the variables of :data:`CHECKED_NAMES`
  and the :data:`COMBINED_VARIABLES` a group has.

Combined loads (issue 13, docs/combined-loads.md): a group whose client reserves one of
:data:`COMBINED_PARAMETERS` also gets the worker variables :data:`COMBINED_VARIABLES`
(created by :func:`storage.reserve`, under the client lock). Every other group, and
every group written before them, has neither: its bytes, checksums and verification are
those of before.

Contact patch and inflation growth (issue 24): :data:`PATCH_VARIABLES`, one float64 per
experiment (NaN: not recorded), are worker variables of every group created since; groups
created before lack them and stay readable, writable and verifiable as they were (a
worker writes only the arrays a group has, and a checksum covers these only where the
group has them and the slot records them, :func:`checked_names`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

SCHEMA_VERSION = 1

PENDING, DONE, FAILED = 0, 1, 2
STATUS_NAMES = {PENDING: "pending", DONE: "done", FAILED: "failed"}

#: Chunk length along ``experiment`` of the client-written variables.
CLIENT_CHUNK = 1024
#: Failure reasons longer than this are cut in the middle (head and tail kept).
MAX_ERROR_CHARS = 2000
#: Fill of the int32 bookkeeping variables of an experiment that recorded nothing.
NOT_RECORDED = -1

COMPONENTS = ("x", "y", "z")
STRAIN_COMPONENTS = ("xx", "yy", "xy")

# Experiment ids are sha256 hex digests in the farm; anything of this shape is accepted
# so that tests and hand-made stores can use readable ids.
EXPERIMENT_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.:-]{0,127}")
GROUP_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,127}")
PARAMETER_NAME = re.compile(r"[a-z][a-z0-9_]{0,63}")

Writer = Literal["mesh", "client", "worker"]


@dataclass(frozen=True)
class Variable:
    """One stored array: its dims, numpy dtype (``"str"`` for UTF-8 text) and units."""

    name: str
    dims: tuple[str, ...]
    dtype: str
    units: str
    long_name: str
    writer: Writer

    @property
    def fill(self) -> Any:
        """Value of a slot nobody wrote (zarr's ``fill_value``)."""
        if self.dtype == "str":
            return ""
        if self.name == "status":
            return PENDING
        if np.dtype(self.dtype).kind == "f":
            return np.nan
        return NOT_RECORDED if self.writer == "worker" else 0

    @property
    def compressed(self) -> bool:
        """Whether chunks are zstd-compressed (zarr's default) or stored raw.

        Worker chunks are raw: dense float64 fields barely compress, one-value chunks
        grow when framed, and decoding halves read throughput (measured: 82 against
        137 MB/s for 10,000 displacement chunks). ``reaction_force`` is mostly zeros
        (tread nodes off the contact patch) and stays compressed, as do the combined
        ``contact_status`` and ``tread_slip`` (open nodes: 0).
        """
        return self.writer != "worker" or self.name in ("reaction_force", "contact_status",
                                                        "tread_slip")

    @property
    def attrs(self) -> dict[str, Any]:
        attrs: dict[str, Any] = {"units": self.units, "long_name": self.long_name}
        if self.name == "status":
            attrs["flag_values"] = list(STATUS_NAMES)
            attrs["flag_meanings"] = " ".join(STATUS_NAMES.values())
        if self.writer == "client" and self.name != "experiment":
            attrs["role"] = "parameter"
        return attrs


def _v(name: str, dims: str, dtype: str, units: str, long_name: str, writer: Writer) -> Variable:
    return Variable(name, tuple(dims.split()), dtype, units, long_name, writer)


MESH_VARIABLES = (
    _v("component", "component", "str", "-", "vector component (TYDEX C axes)", "mesh"),
    _v("strain_component", "strain_component", "str", "-",
       "strain component in the local surface frame", "mesh"),
    _v("inner_node", "inner_node", "int64", "-", "CalculiX node id, inner surface", "mesh"),
    _v("tread_node", "tread_node", "int64", "-", "CalculiX node id, outer tread", "mesh"),
    _v("inner_xyz", "inner_node component", "float64", "mm",
       "reference coordinates of inner-surface nodes", "mesh"),
    _v("tread_xyz", "tread_node component", "float64", "mm",
       "reference coordinates of outer tread nodes", "mesh"),
    _v("inner_row", "inner_node", "int32", "1", "surface grid row (meridian)", "mesh"),
    _v("inner_col", "inner_node", "int32", "1", "surface grid column (circumference)", "mesh"),
    _v("tread_row", "tread_node", "int32", "1", "tread grid row (meridian)", "mesh"),
    _v("tread_col", "tread_node", "int32", "1", "tread grid column (circumference)", "mesh"),
)

EXPERIMENT = _v("experiment", "experiment", "str", "-", "experiment id", "client")

#: Load-case parameters every group has; ``reserve`` requires them.
REQUIRED_PARAMETERS = {
    "deflection": ("mm", "road travel from first touch"),
    "pressure": ("MPa", "inflation pressure"),
}
#: Units of further parameters the farm knows; others need ``units=`` in ``reserve``.
KNOWN_PARAMETER_UNITS = {
    **{k: u for k, (u, _) in REQUIRED_PARAMETERS.items()},
    "lateral_force": "N",
    "longitudinal_force": "N",
    "friction": "1",
    "shift_x": "mm",
    "shift_y": "mm",
    "tilt": "deg",
    "slip_ratio": "1",
    "slip_angle": "deg",
    "travel": "mm",
    "roll_from": "mm",
}
#: The combined-load parameters (farm.specs.RoadMotion's fields, store units above):
#: reserving any of them makes a group a combined one (:data:`COMBINED_VARIABLES`).
#: A vertical experiment among combined ones has them all 0.
COMBINED_PARAMETERS = ("friction", "shift_x", "shift_y", "tilt")
COMBINED_LONG_NAMES = {
    "friction": "Coulomb friction coefficient mu between tread and road",
    "shift_x": "road slide along x (longitudinal) after the deflection",
    "shift_y": "road slide along its lateral axis after the deflection",
    "tilt": "road rotation about x (camber), +y side up",
    # rolling (issue 30): a combined group whose experiments roll instead of sliding
    "slip_ratio": "longitudinal slip kappa (SAE) of the roll: > 0 drives, < 0 brakes",
    "slip_angle": "slip angle of the roll: between the wheel plane and its travel",
    # issue 45: every state along a roll is an experiment of its own
    "travel": "road travel of the roll from rest at this state",
    # issue 45: rolling trees, whose branches turn to their slips after a straight trunk
    "roll_from": "road travel rolled straight at kappa 0 before the slips applied",
}

RESULT_VARIABLES = (
    _v("displacement", "experiment inner_node component", "float64", "mm",
       "displacement of inner-surface nodes from the reference state", "worker"),
    _v("strain", "experiment inner_node strain_component", "float64", "1",
       "solver strain at inner-surface nodes, local surface frame", "worker"),
    _v("surface_strain", "experiment inner_node strain_component", "float64", "1",
       "Green-Lagrange strain from inner-surface triangles, local surface frame", "worker"),
    _v("reaction_force", "experiment tread_node component", "float64", "N",
       "force of the road on each tread node", "worker"),
    _v("total_force", "experiment component", "float64", "N",
       "force of the road summed over the tread", "worker"),
    _v("moment", "experiment component", "float64", "N mm",
       "moment of the tread forces about the contact centre", "worker"),
)

#: Worker variables of combined-load groups only (farm Measurement.combined_arrays,
#: whose COMBINED_UNITS these units are). A vertical experiment of such a group stores
#: them as not recorded (-1 status, NaN floats).
COMBINED_VARIABLES = (
    _v("contact_status", "experiment tread_node", "int8", "1",
       "contact state of each tread node: 0 open, 1 stick, 2 slip", "worker"),
    _v("tread_slip", "experiment tread_node component", "float64", "mm",
       "tangential displacement of each tread node relative to the road", "worker"),
    _v("road_reaction", "experiment component", "float64", "N",
       "sum of the road's reactions (a check of total_force)", "worker"),
    _v("road_moment", "experiment component", "float64", "N mm",
       "moment of the road's reactions about the contact centre (a check of moment)",
       "worker"),
)

INFO_VARIABLES = (
    _v("solve_seconds", "experiment", "float64", "s", "solver wall time of the load path",
       "worker"),
    _v("increments", "experiment", "int32", "1", "converged solver increments", "worker"),
    _v("ccx_runs", "experiment", "int32", "1", "ccx runs spent on the load path", "worker"),
    _v("contact_nodes", "experiment", "int32", "1", "tread nodes carrying road force",
       "worker"),
)

#: Worker variables of the contact patch and the inflation growth (issue 24,
#: farm.measure.patch), NaN where not recorded (a failure, a group's arrays opened by a
#: worker that predates them; ``inflation_growth`` of a model without inflation). Groups
#: created before them lack them: optional, as ``checksum`` is.
PATCH_VARIABLES = (
    _v("patch_area", "experiment", "float64", "mm2",
       "contact patch area: tributary area of the tread nodes carrying road force",
       "worker"),
    _v("patch_length", "experiment", "float64", "mm",
       "contact patch length: extent of the loaded tread nodes along x", "worker"),
    _v("patch_width", "experiment", "float64", "mm",
       "contact patch width: extent of the loaded tread nodes along y", "worker"),
    _v("peak_pressure", "experiment", "float64", "MPa",
       "largest nodal contact pressure (normal force over tributary area); mesh-dependent: "
       "it does not converge with refinement, compare it only on one mesh", "worker"),
    _v("mean_pressure", "experiment", "float64", "MPa",
       "road-normal force of the patch over its area", "worker"),
    _v("nodal_force_mean", "experiment", "float64", "N",
       "mean road-normal force of the loaded tread nodes", "worker"),
    _v("nodal_force_std", "experiment", "float64", "N",
       "standard deviation of the road-normal force of the loaded tread nodes", "worker"),
    _v("inflation_growth", "experiment", "float64", "mm",
       "radial growth of the tread under inflation (the path's inflated reference)",
       "worker"),
    # issue 30: newer than the rest; groups made before them lack them (optional too)
    _v("loaded_radius", "experiment", "float64", "mm",
       "distance from the wheel centre down to the road under it (the contact centre)",
       "worker"),
    _v("rolling_radius", "experiment", "float64", "mm",
       "effective rolling radius r_e the roll turned the rim with (NaN: no roll)",
       "worker"),
)

ERROR = _v("error", "experiment", "str", "-", "failure reason (empty unless failed)", "worker")
CHECKSUM = _v("checksum", "experiment", "str", "-",
              "digest of the id, load case, status and data of a done or failed experiment",
              "worker")
STATUS = _v("status", "experiment", "int8", "-", "0 pending, 1 done, 2 failed", "worker")

#: Everything a worker writes, in write order: ``status`` last. ``checksum`` and
#: :data:`PATCH_VARIABLES` are absent from groups written before they existed (those
#: stay readable and writable: :data:`OPTIONAL_NAMES`).
WORKER_VARIABLES = (*RESULT_VARIABLES, *INFO_VARIABLES, *PATCH_VARIABLES, ERROR, CHECKSUM,
                    STATUS)

FIXED_VARIABLES = {v.name: v for v in (*MESH_VARIABLES, EXPERIMENT, *WORKER_VARIABLES,
                                         *COMBINED_VARIABLES)}
RESULT_NAMES = tuple(v.name for v in RESULT_VARIABLES)
INFO_NAMES = tuple(v.name for v in INFO_VARIABLES)
COMBINED_NAMES = tuple(v.name for v in COMBINED_VARIABLES)
PATCH_NAMES = tuple(v.name for v in PATCH_VARIABLES)
#: Worker variables of every new group that older groups may lack.
OPTIONAL_NAMES = (CHECKSUM.name, *PATCH_NAMES)
#: The worker variables a checksum covers in every group (with the status), in this
#: order; then those of :func:`checked_names`.
CHECKED_NAMES = (*RESULT_NAMES, *INFO_NAMES, ERROR.name)


def checked_names(present) -> tuple[str, ...]:
    """The variables a checksum covers in a group holding the arrays ``present``:
    :data:`CHECKED_NAMES`, then the combined ones and the patch ones the group has (none
    in groups made before them, so their checksums are those of before)."""
    present = set(present)
    return (*CHECKED_NAMES, *(n for n in (*COMBINED_NAMES, *PATCH_NAMES) if n in present))


def parameter(name: str, units: str) -> Variable:
    """The variable of a load-case parameter: float64 along ``experiment``."""
    long_name = REQUIRED_PARAMETERS.get(name, ("", COMBINED_LONG_NAMES.get(
        name, f"load-case parameter {name}")))[1]
    return Variable(name, ("experiment",), "float64", units, long_name, "client")


def result_shape(name: str, n_inner: int, n_tread: int) -> tuple[int, ...]:
    """Shape of one experiment's slice of a result variable (without ``experiment``)."""
    sizes = {"inner_node": n_inner, "tread_node": n_tread, "component": 3,
             "strain_component": 3}
    return tuple(sizes[d] for d in FIXED_VARIABLES[name].dims[1:])


def truncate_error(reason: str) -> str:
    """Cut a failure reason to :data:`MAX_ERROR_CHARS`, keeping its head and its tail.

    Solver failures put the outcome first and the solver's last words at the end; both
    matter, the middle of a long log does not.
    """
    if len(reason) <= MAX_ERROR_CHARS:
        return reason
    marker = f" [... cut, {len(reason)} characters in all ...] "
    keep = MAX_ERROR_CHARS - len(marker)
    head = keep * 2 // 3
    return reason[:head] + marker + reason[len(reason) - (keep - head):]
