"""Errors of the store.

Every error says in one line what was wrong, what was given and how to fix it; the CLI
prints ``str(error)``. Each class also derives from the builtin that a caller would
naturally catch (``ValueError`` for bad input, ``FileNotFoundError`` for a missing
store, ``LookupError`` for a missing group or experiment), so generic handlers keep
working. ``LookupError`` rather than ``KeyError``: ``str(KeyError(msg))`` adds quotes.
"""

from __future__ import annotations


class StoreError(Exception):
    """Base class of every error raised by :mod:`storage`."""


class NotAStoreError(StoreError, FileNotFoundError):
    """The path or URL does not hold a Zarr v3 store (missing, or some other directory)."""


class GroupNotFoundError(StoreError, LookupError):
    """The store has no group of that name."""


class SchemaError(StoreError, ValueError):
    """Data or names that do not fit the schema: shapes, dtypes, NaN/inf, unknown names."""


class MeshMismatchError(SchemaError):
    """A group exists for a different mesh (mesh key, node ids or coordinates differ)."""


class ParameterConflictError(SchemaError):
    """An experiment id is already reserved with different load-case parameters."""


class NotReservedError(StoreError, LookupError):
    """An experiment id was never reserved in the group (only the client reserves)."""


class AlreadyDoneError(StoreError, RuntimeError):
    """A failure would overwrite an experiment that is already done."""
