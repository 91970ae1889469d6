"""Errors of the store.

Every error says in one line what was wrong, what was given and how to fix it; the CLI
prints ``str(error)``. Each class also derives from the builtin that a caller would
naturally catch (``ValueError`` for bad input, ``FileNotFoundError`` for a missing
store, ``LookupError`` for a missing group or experiment), so generic handlers keep
working. ``LookupError`` rather than ``KeyError``: ``str(KeyError(msg))`` adds quotes.
"""

from __future__ import annotations

import errno
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


class StoreAccessError(StoreError, PermissionError):
    """The store could not be reached or written: credentials, permissions, a missing
    bucket, an unreachable endpoint, a full disk. Not damage: nothing is wrong with the
    bytes already stored."""


_CREDENTIALS = ("set AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY (or AWS_PROFILE) in the "
                "environment of the client and of every worker")
_CLIENT_CODES = {
    "NoSuchBucket": "the bucket does not exist: create it, or check the URL",
    "AccessDenied": f"access denied: check the credentials' rights on the bucket ({_CREDENTIALS})",
    "InvalidAccessKeyId": f"the credentials were rejected ({_CREDENTIALS})",
    "SignatureDoesNotMatch": f"the credentials were rejected ({_CREDENTIALS})",
    "403": f"access denied ({_CREDENTIALS})",
}


def _chain(e: BaseException) -> Iterator[BaseException]:
    seen: set[int] = set()
    x: BaseException | None = e
    while x is not None and id(x) not in seen:
        seen.add(id(x))
        yield x
        x = x.__cause__ or x.__context__


def access_error(e: BaseException, store: str = "the store") -> StoreAccessError | None:
    """The one line for an error that says the store cannot be reached or written (any
    link of ``e``'s chain), or None when ``e`` is something else (issue 26: botocore's
    ``NoCredentialsError`` and ``OSError: [Errno 28]`` reached users as tracebacks)."""
    for x in _chain(e):
        name = type(x).__name__
        if name in ("NoCredentialsError", "PartialCredentialsError",
                    "CredentialRetrievalError"):
            why = f"no credentials for the object store: {_CREDENTIALS}"
        elif name == "ClientError":
            code = str(getattr(x, "response", {}).get("Error", {}).get("Code", ""))
            why = _CLIENT_CODES.get(code, f"the object store refused ({code or x})")
        elif name in ("EndpointConnectionError", "ConnectTimeoutError"):
            why = f"cannot reach the object store ({x}): check endpoint_url and the network"
        elif isinstance(x, OSError) and x.errno == errno.ENOSPC:
            why = ("no space left on the device: free space or give a store elsewhere; what "
                   "was written before stays (`farm sweep verify` checks it)")
        elif isinstance(x, PermissionError):
            why = f"permission denied ({x.filename or x}): give a store you can write"
        else:
            continue
        return StoreAccessError(f"{store}: {why}")
    return None


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
        access = access_error(e, f"the store at {store}")
        if access is not None:
            raise access from e
        detail = " ".join(str(e).split())[:200] or "no detail"
        raise DamagedStoreError(
            f"cannot read {what} of the store at {store} ({type(e).__name__}: {detail}): the "
            f"store is damaged or was changed by hand; {verify_hint(store)}"
        ) from e
