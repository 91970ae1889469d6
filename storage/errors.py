"""Errors of the store.

Every error says in one line what was wrong, what was given and how to fix it; the CLI
prints ``str(error)``. Each class also derives from the builtin that a caller would
naturally catch (``ValueError`` for bad input, ``FileNotFoundError`` for a missing
store, ``LookupError`` for a missing group or experiment), so generic handlers keep
working. ``LookupError`` rather than ``KeyError``: ``str(KeyError(msg))`` adds quotes.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager


class StoreError(Exception):
    """Base class of every error raised by :mod:`storage`."""


class NotAStoreError(StoreError, FileNotFoundError):
    """The path or URL does not hold a Zarr v3 store (missing, or some other directory)."""


class GroupNotFoundError(StoreError, LookupError):
    """The store has no group of that name."""


class SchemaError(StoreError, ValueError):
    """Data or names that do not fit the schema: shapes, dtypes, NaN/inf, unknown names."""


class MeshMismatchError(SchemaError):
    """A group exists for a different mesh (mesh key, node ids or coordinates) or model."""


class ParameterConflictError(SchemaError):
    """An experiment id is already reserved with different load-case parameters."""


class NotReservedError(StoreError, LookupError):
    """An experiment id was never reserved in the group (only the client reserves)."""


class AlreadyDoneError(StoreError, RuntimeError):
    """A failure would overwrite an experiment that is already done."""


class StoreBusyError(StoreError, TimeoutError):
    """Another client held the store's lock for longer than the caller would wait."""


class ConcurrentClientError(StoreError, RuntimeError):
    """Another client changed the same metadata at the same moment (no lock prevented it)."""


class DamagedStoreError(StoreError, ValueError):
    """The store's bytes are damaged: metadata or chunks that do not decode, missing
    arrays, or experiments whose data do not match their checksum."""


def verify_hint(store: str = "STORE") -> str:
    """How to find and mark what is damaged (the end of every damage message)."""
    return f"run `farm sweep verify {store} --repair`"


@contextmanager
def reading(what: str, store: str = "STORE") -> Iterator[None]:
    """Turn whatever a damaged store makes zarr, json or the file system raise while
    reading ``what`` (a key or a description) into one :class:`DamagedStoreError` line.

    Errors of this package pass through unchanged: they already say what is wrong.
    """
    try:
        yield
    except StoreError:
        raise
    except Exception as e:  # zarr, json, codec and I/O errors have no common base class
        detail = " ".join(str(e).split())[:200] or "no detail"
        raise DamagedStoreError(
            f"cannot read {what} of the store at {store} ({type(e).__name__}: {detail}): the "
            f"store is damaged or was changed by hand; {verify_hint(store)}"
        ) from e
