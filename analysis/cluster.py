"""Run the heavy reductions on a Dask cluster when one is given (``--scheduler``).

Inside :func:`scheduler`, every ``dask.compute`` of :mod:`analysis` (the chunk-wise
moments over the store) runs on the cluster's workers, which read the store directly;
the small dense algebra afterwards stays on the client. Without an address, dask's
local threaded scheduler is used.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from analysis.errors import SchedulerError

CONNECT_TIMEOUT = "10s"  # how long to try reaching the scheduler before giving up


@contextmanager
def scheduler(address: str | None) -> Iterator[object | None]:
    """Context in which dask computations go to the scheduler at ``address``."""
    if not address:
        yield None
        return
    from distributed import Client

    try:
        client = Client(address, timeout=CONNECT_TIMEOUT)
    except OSError as exc:
        raise SchedulerError(f"cannot reach the Dask scheduler at {address}: {exc}") from exc
    with client:
        yield client
