"""From what a caller gives (a path, a URL, a store) to zarr stores and groups.

One code path: local paths become a :class:`zarr.storage.LocalStore` (whose writes are
atomic, a temporary file renamed into place, which is what keeps a killed writer from
leaving a torn chunk), ``file://`` URLs too, and every other URL goes through fsspec
(:class:`zarr.storage.FsspecStore`), e.g. ``s3://bucket/farm.zarr``. A store object is
used as given (an in-memory store in tests, or :func:`open_store` with credentials).

Metadata is read fresh (never from consolidated metadata) everywhere in this package,
so a client's resize is seen at once; the consolidated copy at the root exists for
readers (``xarray.open_zarr``) and is refreshed by :func:`publish` after every change.

What is accepted (``docs/store.md``, "Store paths and URLs"): a directory that is new,
empty or a Zarr v3 store, and not inside another Zarr hierarchy; ``file://`` URLs of
such directories; URLs of the object stores in :data:`URL_SCHEMES`, which every worker
can reach. Anything else is one :class:`StoreError` line: ``memory://`` (a store in one
process, which workers can never write into), other or malformed schemes, files, FIFOs
and devices, system directories.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import stat
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, Literal, TypeAlias, TypeVar

import zarr
import zarr.errors
from zarr.abc.store import Store
from zarr.errors import ZarrUserWarning
from zarr.storage import FsspecStore, LocalStore

from storage._zarr import consolidate, key_exists
from storage.errors import (
    GroupNotFoundError,
    NotAStoreError,
    SchemaError,
    StoreError,
    access_error,
)
from storage.schema import GROUP_NAME, SCHEMA_VERSION

StoreLike: TypeAlias = str | os.PathLike[str] | Store

#: URL schemes of stores that every Dask worker can reach (with the fsspec backend
#: installed: s3fs, gcsfs, adlfs). ``file://`` is a local path.
URL_SCHEMES = ("s3", "s3a", "gs", "gcs", "az", "abfs", "abfss")
#: Entries of a store's root that are the farm's, not zarr's: the client lock and the
#: workers' claims (:mod:`storage.lock`), the saved solver states of load-path trees
#: (:mod:`storage.saved`). A directory holding only these is empty.
LOCK_NAME = ".farm.lock"
CLAIMS_DIR = ".claims"
STATES_DIR = ".states"
FARM_ENTRIES = (LOCK_NAME, CLAIMS_DIR, STATES_DIR)
# zarr warns about every entry of a group's directory that is no zarr node when it lists
# members (list_groups, consolidating metadata): the farm's own entries are expected.
# Filtered for the whole process (a user's own zarr calls), and again around this
# package's listings (test runners reset the process-wide filters).
_FARM_ENTRY_WARNING = r"Object at \.(farm\.lock|claims|states) is not recognized"
warnings.filterwarnings("ignore", category=ZarrUserWarning, message=_FARM_ENTRY_WARNING)
_URL = re.compile(r"([A-Za-z][A-Za-z0-9+.-]*)://(.*)", re.DOTALL)
_SCHEME_ONLY = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:")  # "s3:" of a URL missing its "//"
_SYSTEM_DIRS = (Path("/dev"), Path("/proc"), Path("/sys"))
_ZARR_MARKERS = ("zarr.json", ".zgroup", ".zarray")

# URL stores without explicit options are made once per (url, read_only) and process:
# fsspec filesystems are costly to create. They keep the environment (endpoint,
# credentials) of their first use.
_URL_STORES: dict[tuple[str, bool], Store] = {}


def _local(text: str, read_only: bool) -> LocalStore:
    """A local directory store; a path that looks like a URL missing its ``//`` is
    refused, not made a folder named ``s3:``."""
    first = text.split("/", 1)[0]
    if "/" in text and _SCHEME_ONLY.fullmatch(first):
        raise StoreError(
            f"store {text[:80]!r} looks like a URL without the '//' after {first!r}: "
            f"write {first}//..., or ./{text[:40]} for a directory"
        )
    return LocalStore(Path(text).expanduser(), read_only=read_only)


def open_store(
    store: StoreLike, *, read_only: bool = False, storage_options: dict[str, Any] | None = None
) -> Store:
    """Resolve ``store`` into a zarr store object (no I/O).

    Parameters
    ----------
    store : str, path-like or zarr store
        A local directory, a ``file://`` URL, a URL of an object store that every worker
        can reach (:data:`URL_SCHEMES`: ``s3://bucket/path``, ...), or a zarr store
        object, returned unchanged.
    read_only : bool
        Open local paths and URLs read-only.
    storage_options : dict, optional
        fsspec options for a URL (endpoint, credentials); without them the filesystem
        takes its defaults from the environment (``AWS_*`` variables for S3).

    Raises
    ------
    StoreError
        An empty path or one with control characters, ``memory://``, a scheme not in
        :data:`URL_SCHEMES`, a malformed URL or one without a bucket, or a URL whose
        fsspec backend is not installed.
    """
    if isinstance(store, Store):
        return store
    if not isinstance(store, str | os.PathLike):
        raise StoreError(
            f"store must be a path, an fsspec URL or a zarr store, got {type(store).__name__}"
        )
    text = _check_text(os.fspath(store))
    if text.startswith("file://"):
        text = text.removeprefix("file://")
    if "://" not in text:
        return _local(text, read_only)
    _check_url(text)
    key = (text, read_only)
    if storage_options is None and key in _URL_STORES:
        return _URL_STORES[key]
    try:
        opened = FsspecStore.from_url(text, storage_options=storage_options, read_only=read_only)
    except (ImportError, ValueError, TypeError, OSError) as e:
        raise StoreError(
            f"cannot open store URL {text!r}: {e}; install the fsspec backend for its "
            "protocol (s3fs for s3://) or check the URL"
        ) from e
    if storage_options is None:
        _URL_STORES[key] = opened
    return opened


def _check_text(text: str) -> str:
    if not text.strip():
        raise StoreError("the store path is empty: give a directory path or an s3:// URL")
    bad = next((c for c in text if ord(c) < 32 or ord(c) == 127), None)
    if bad is not None:
        raise StoreError(
            f"the store path {text[:80]!r} holds the control character {bad!r}: give a "
            "directory path or an s3:// URL"
        )
    return text


def _check_url(text: str) -> None:
    """One line for a URL that no worker could write to, or that is not a URL at all."""
    supported = ", ".join(f"{s}://" for s in URL_SCHEMES)
    m = _URL.fullmatch(text)
    if m is None:
        raise StoreError(
            f"store {text[:80]!r} is not a URL of the form scheme://bucket/path: give a "
            f"directory path or a URL of {supported}"
        )
    scheme, rest = m.group(1).lower(), m.group(2)
    if scheme == "memory":
        raise StoreError(
            f"store {text[:80]!r}: memory:// stores live inside one process, so Dask workers "
            f"can never write experiments into them; give a directory path or a URL of "
            f"{supported}"
        )
    if scheme not in URL_SCHEMES:
        raise StoreError(
            f"store URL scheme {scheme + '://'!r} ({text[:80]!r}) is not supported: give a "
            f"directory path (or file://), or a URL of {supported}"
        )
    bucket = rest.split("/", 1)[0]
    if not bucket or bucket in (".", "..") or not rest.strip("/"):
        raise StoreError(
            f"store URL {text[:80]!r} names no bucket: give {scheme}://bucket/path/farm.zarr"
        )


F = TypeVar("F", bound=Callable[..., Any])


def names_the_store(func: F) -> F:
    """Decorate a store API function whose first argument is the store: an error that
    says the store cannot be reached or written (:func:`storage.errors.access_error`)
    leaves it as one :class:`~storage.errors.StoreAccessError` line naming that store."""

    @functools.wraps(func)
    def wrapper(store: Any, *args: Any, **kwargs: Any) -> Any:
        try:
            return func(store, *args, **kwargs)
        except StoreError:
            raise
        except Exception as e:
            where = describe(store) if isinstance(store, Store) else os.fspath(store)
            access = access_error(e, f"the store at {where}")
            if access is None:
                raise
            raise access from e

    return wrapper  # type: ignore[return-value]


def describe(store: Store) -> str:
    """Where a store lives, for messages."""
    if isinstance(store, LocalStore):
        return str(store.root)
    if isinstance(store, FsspecStore):
        protocol = store.fs.protocol
        protocol = protocol[0] if isinstance(protocol, tuple | list) else protocol
        return f"{protocol}://{store.path}"
    return repr(store)


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISREG, "a file")):
        if test(mode):
            return name
    return "not a directory"


def _enclosing(root: Path) -> Path | None:
    """The nearest directory above ``root`` that is a Zarr group or array, if any."""
    for parent in root.parents:
        if any((parent / m).is_file() for m in _ZARR_MARKERS):
            return parent
    return None


def _foreign(name: str) -> bool:
    """Whether an entry makes a directory without zarr.json "not empty": the farm's own
    entries do not, nor zarr's in-flight writes (``zarr.<hex>.partial`` while another
    client writes the root's zarr.json; a killed writer may leave one too)."""
    return name not in FARM_ENTRIES and not name.endswith(".partial")


def _check_creatable(root: Path) -> None:
    existing = next((p for p in root.absolute().parents if p.exists()), None)
    if existing is not None and not existing.is_dir():
        raise NotAStoreError(
            f"cannot create a store at {root}: {existing} is {_kind(existing.stat().st_mode)}, "
            "not a directory"
        )


def check_local_dir(store: LocalStore, create: bool) -> None:
    """Refuse a local path that is not (or cannot become) a store, in one line.

    Raises :class:`NotAStoreError` for a missing store (unless ``create``), a file, a
    FIFO or device, a directory of other things, or a path inside another Zarr
    hierarchy; :class:`SchemaError` for a Zarr v2 store; :class:`StoreError` for system
    directories and paths the operating system refuses to look at.
    """
    root = Path(store.root)
    try:
        _check_local_dir(root, create)
    except StoreError:
        raise
    except OSError as e:  # a name too long, a permission denied on a parent, ...
        raise NotAStoreError(f"cannot use {root} as a store: {e.strerror or e}") from e


def _check_local_dir(root: Path, create: bool) -> None:
    try:
        real = root.resolve()
    except RuntimeError as e:  # a symlink loop
        raise NotAStoreError(f"cannot use {root} as a store: {e}") from e
    system = next((d for d in _SYSTEM_DIRS if real == d or d in real.parents), None)
    if system is not None and Path("/dev/shm") not in (real, *real.parents):
        raise StoreError(
            f"{root} is under {system}, which holds devices and kernel files, not data: "
            "give a directory on a disk (or an s3:// URL)"
        )
    if root.exists() and not root.is_dir():
        kind = _kind(root.stat().st_mode)
        raise NotAStoreError(f"{root} is {kind}, not a Zarr store: give a directory path")
    outer = _enclosing(real)
    if outer is not None:
        raise NotAStoreError(
            f"{root} is inside the Zarr store or group at {outer}: stores cannot nest; give "
            f"a path outside it (or {outer}'s own root with a group name)"
        )
    if not root.exists():
        if create:
            _check_creatable(root)
            return
        raise NotAStoreError(
            f"no store at {root}: check the path, or create the store with "
            "storage.create_group(...)"
        )
    names = [p.name for p in root.iterdir()]  # one listing: another client may be creating
    if ".zgroup" in names or ".zarray" in names:
        raise SchemaError(f"{root} is a Zarr v2 store; the farm writes Zarr v3: use a new path")
    if "zarr.json" in names:
        return
    other = next(filter(_foreign, names), None)
    if not create or other is not None:
        holds = f", it holds {other!r}" if other is not None else ""
        raise NotAStoreError(
            f"{root} is not a Zarr v3 store (no zarr.json at its root{holds}): give the "
            "store's directory, or an empty or new one to create a store there"
        )


def root_group(store: Store, *, create: bool = False) -> zarr.Group:
    """Open the store's root group for writing, creating the store when ``create``.

    Raises :class:`NotAStoreError` for a missing store (unless ``create``) or a path
    that holds something else, and :class:`SchemaError` for a Zarr v2 store.
    """
    if isinstance(store, LocalStore):
        check_local_dir(store, create)
    elif not create and not key_exists(store, "zarr.json"):
        raise NotAStoreError(
            f"no Zarr v3 store at {describe(store)} (no zarr.json): check the URL, or "
            "create the store with storage.create_group(...)"
        )
    mode: Literal["r", "a", "r+"] = "r" if store.read_only else ("a" if create else "r+")
    try:
        root = zarr.open_group(store=store, mode=mode, use_consolidated=False)
    except (zarr.errors.NodeNotFoundError, FileNotFoundError) as e:
        raise NotAStoreError(f"no Zarr store at {describe(store)}: {e}") from e
    except zarr.errors.ContainsArrayError as e:
        raise NotAStoreError(f"{describe(store)} holds a single array, not a store") from e
    if root.metadata.zarr_format != 3:
        raise SchemaError(
            f"{describe(store)} is a Zarr v{root.metadata.zarr_format} store; the farm writes "
            "Zarr v3: use a new store path"
        )
    return root


def check_group_name(group: str) -> str:
    if not (isinstance(group, str) and GROUP_NAME.fullmatch(group)):
        raise SchemaError(
            f"group name must be 1-128 letters, digits, '_', '.' or '-' (no '/'), got {group!r}"
        )
    return group


def open_group(store: Store, group: str) -> zarr.Group:
    """Open an existing experiment group (fresh metadata) and check its schema version."""
    g = open_existing(store, group, "create it with storage.create_group(...)")
    check_schema(g, group)
    return g


def open_existing(store: Store, group: str, hint: str) -> zarr.Group:
    """Open an existing group of any kind (fresh metadata), read-only if the store is.

    Raises :class:`GroupNotFoundError`, ending in ``hint`` (how to make the group), when
    there is none of that name, and :class:`NotAStoreError` when there is no store.
    """
    check_group_name(group)
    if isinstance(store, LocalStore):  # before zarr, which would make the directory
        check_local_dir(store, create=False)
    try:
        g = zarr.open_group(store=store, path=group, mode="r" if store.read_only else "r+",
                            use_consolidated=False)
    except (zarr.errors.NodeNotFoundError, zarr.errors.ContainsArrayError, OSError) as e:
        # Only now look at the root (costly when its consolidated metadata is large):
        # it raises NotAStoreError when there is no store at all.
        with farm_entries_ignored():
            names = ", ".join(sorted(root_group(store).group_keys())) or "none"
        raise GroupNotFoundError(
            f"no group {group!r} in the store at {describe(store)} (groups: {names}): {hint}"
        ) from e
    return g


def check_schema(g: zarr.Group, group: str) -> None:
    if g.metadata.zarr_format != 3:
        raise SchemaError(f"group {group!r} is Zarr v{g.metadata.zarr_format}; the farm writes v3")
    version = g.attrs.get("schema_version")
    if version != SCHEMA_VERSION:
        raise SchemaError(
            f"group {group!r} is not a tyre-farm experiment group of schema version "
            f"{SCHEMA_VERSION} (schema_version={version!r}): open a group written by "
            "storage.create_group"
        )


@contextlib.contextmanager
def farm_entries_ignored() -> Iterator[None]:
    """Silence zarr's warning about the farm's own entries while listing a store."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=ZarrUserWarning,
                                message=_FARM_ENTRY_WARNING)
        yield


def publish(store: Store) -> None:
    """Refresh the consolidated metadata at the root (client only, after any change).

    xarray opens a store through the root's consolidated metadata, which also gives a
    reader one consistent snapshot of all shapes while the client resizes.
    """
    with farm_entries_ignored():
        consolidate(store)
