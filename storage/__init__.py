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

# Lazy (SPEC 1, lazy_loader): ``storage.errors`` is imported by the CLI at start-up, and a
# package's __init__ runs first; eager re-exports here cost ``farm --help`` xarray, zarr and
# pandas (0.5 s). The names and their modules live in __init__.pyi, which type checkers and
# the layering test read; ``EAGER_IMPORT=1`` loads everything at once.
import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
