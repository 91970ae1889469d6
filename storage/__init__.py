"""The Zarr v3 dataset of virtual experiments (schema: ``docs/schema.md``).

One store, one group per model mesh; every group opens with
``xarray.open_zarr(store, group=name)``. Clients create groups and reserve slots,
taking turns at the store's lock (metadata has one writer at a time); workers write
whole chunks of their own slot, status last. No FEM and no Dask here.

Client::

    create_group(store, group, mesh, attrs)
    index = reserve(store, group, ids, {"deflection": d, "pressure": p})
    todo = [e for e, s in statuses(store, group, ids).items() if s != DONE]

Worker::

    write_experiment(store, group, experiment_id, result, info)
    write_failure(store, group, experiment_id, reason, info)

Analysis::

    ds = done(open_dataset(store, group))
    ds.sel(deflection=30, pressure=0.2)  # one index over the load case: exact labels
    select(ds, pressure=0.2, deflection=slice(10, 40))  # within a relative 1e-9

Several clients on one store take turns at metadata (``storage.lock``); a worker holds
a claim on the unit of work it does, so that a second cluster waits instead of solving
it again::

    with claim(store, group, "path-3f9a") as go:
        ...  # if go: re-read statuses, solve what is not done

Inverse studies (one group each, client-written; ``storage.solves``)::

    write_solves(store, group, Unknowns(...), [SolveRecord(...), ...], SolvesAttrs(...))
    ds = open_solves(store, group)
"""

from storage.errors import (
    AlreadyDoneError,
    ConcurrentClientError,
    DamagedStoreError,
    GroupNotFoundError,
    MeshMismatchError,
    NotAStoreError,
    NotReservedError,
    ParameterConflictError,
    SchemaError,
    StoreBusyError,
    StoreError,
)
from storage.group import create_group, list_groups, unfinished_groups
from storage.lock import claim, client_lock
from storage.mesh import GroupAttrs, MeshNodes, package_versions
from storage.paths import URL_SCHEMES, StoreLike, open_store
from storage.read import (
    done,
    index_parameters,
    open_dataset,
    parameters,
    select,
    status_counts,
    statuses,
    verify_done,
)
from storage.reserve import reserve
from storage.schema import DONE, FAILED, PENDING, SCHEMA_VERSION
from storage.solves import SolveRecord, SolvesAttrs, Unknowns, open_solves, write_solves
from storage.verify import VerifyReport, verify
from storage.write import write_experiment, write_failure

__all__ = [
    "DONE",
    "FAILED",
    "PENDING",
    "SCHEMA_VERSION",
    "URL_SCHEMES",
    "AlreadyDoneError",
    "ConcurrentClientError",
    "DamagedStoreError",
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
    "StoreBusyError",
    "StoreError",
    "StoreLike",
    "Unknowns",
    "VerifyReport",
    "claim",
    "client_lock",
    "create_group",
    "done",
    "index_parameters",
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
    "unfinished_groups",
    "verify",
    "verify_done",
    "write_experiment",
    "write_failure",
    "write_solves",
]
