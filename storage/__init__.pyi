"""Names of the ``storage`` package, loaded on first use (storage/__init__.py)."""

from .errors import (
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
from .group import create_group, list_groups, unfinished_groups
from .lock import claim, client_lock
from .mesh import GroupAttrs, MeshNodes, package_versions
from .paths import URL_SCHEMES, StoreLike, open_store
from .read import (
    done,
    held_ids,
    index_parameters,
    open_dataset,
    parameters,
    select,
    status_counts,
    statuses,
    verify_done,
)
from .reserve import reserve
from .rounds import read_rounds, write_rounds
from .schema import DONE, FAILED, PENDING, SCHEMA_VERSION
from .solves import SolveRecord, SolvesAttrs, Unknowns, open_solves, write_solves
from .verify import VerifyReport, verify
from .write import write_experiment, write_failure

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
    "held_ids",
    "index_parameters",
    "list_groups",
    "open_dataset",
    "open_solves",
    "open_store",
    "package_versions",
    "parameters",
    "read_rounds",
    "reserve",
    "select",
    "status_counts",
    "statuses",
    "unfinished_groups",
    "verify",
    "verify_done",
    "write_experiment",
    "write_failure",
    "write_rounds",
    "write_solves",
]
