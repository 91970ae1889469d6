"""The Zarr v3 dataset of virtual experiments (schema: ``docs/schema.md``).

One store, one group per model mesh; every group opens with
``xarray.open_zarr(store, group=name)``. The client creates groups and reserves slots
(metadata has one writer); workers write whole chunks of their own slot, status last.
No FEM and no Dask here.

Client::

    create_group(store, group, mesh, attrs)
    index = reserve(store, group, ids, {"deflection": d, "pressure": p})
    todo = [e for e, s in statuses(store, group, ids).items() if s != DONE]

Worker::

    write_experiment(store, group, experiment_id, result, info)
    write_failure(store, group, experiment_id, reason, info)

Analysis::

    ds = done(open_dataset(store, group))
    select(ds, pressure=0.2, deflection=slice(10, 40))

Inverse studies (one group each, client-written; ``storage.solves``)::

    write_solves(store, group, Unknowns(...), [SolveRecord(...), ...], SolvesAttrs(...))
    ds = open_solves(store, group)
"""

from storage.errors import (
    AlreadyDoneError,
    GroupNotFoundError,
    MeshMismatchError,
    NotAStoreError,
    NotReservedError,
    ParameterConflictError,
    SchemaError,
    StoreError,
)
from storage.group import create_group, list_groups
from storage.mesh import GroupAttrs, MeshNodes, package_versions
from storage.paths import StoreLike, open_store
from storage.read import done, open_dataset, parameters, select, status_counts, statuses
from storage.reserve import reserve
from storage.schema import DONE, FAILED, PENDING, SCHEMA_VERSION
from storage.solves import SolveRecord, SolvesAttrs, Unknowns, open_solves, write_solves
from storage.write import write_experiment, write_failure

__all__ = [
    "DONE",
    "FAILED",
    "PENDING",
    "SCHEMA_VERSION",
    "AlreadyDoneError",
    "GroupAttrs",
    "GroupNotFoundError",
    "MeshMismatchError",
    "MeshNodes",
    "NotAStoreError",
    "NotReservedError",
    "ParameterConflictError",
    "SchemaError",
    "SolveRecord",
    "SolvesAttrs",
    "StoreError",
    "StoreLike",
    "Unknowns",
    "create_group",
    "done",
    "list_groups",
    "open_dataset",
    "open_solves",
    "open_store",
    "package_versions",
    "parameters",
    "reserve",
    "select",
    "status_counts",
    "statuses",
    "write_experiment",
    "write_failure",
    "write_solves",
]
