"""From what a caller gives (a path, a URL, a store) to zarr stores and groups.

One code path: local paths become a :class:`zarr.storage.LocalStore` (whose writes are
atomic, a temporary file renamed into place, which is what keeps a killed writer from
leaving a torn chunk), ``file://`` URLs too, and every other URL goes through fsspec
(:class:`zarr.storage.FsspecStore`), e.g. ``s3://bucket/farm.zarr``. A store object is
used as given (an in-memory store in tests, or :func:`open_store` with credentials).

Metadata is read fresh (never from consolidated metadata) everywhere in this package,
so a client's resize is seen at once; the consolidated copy at the root exists for
readers (``xarray.open_zarr``) and is refreshed by :func:`publish` after every change.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, TypeAlias

import zarr
import zarr.errors
from zarr.abc.store import Store
from zarr.storage import FsspecStore, LocalStore

from storage._zarr import consolidate, key_exists
from storage.errors import GroupNotFoundError, NotAStoreError, SchemaError, StoreError
from storage.schema import GROUP_NAME, SCHEMA_VERSION

StoreLike: TypeAlias = str | os.PathLike[str] | Store

# URL stores without explicit options are made once per (url, read_only) and process:
# fsspec filesystems are costly to create. They keep the environment (endpoint,
# credentials) of their first use.
_URL_STORES: dict[tuple[str, bool], Store] = {}


def open_store(
    store: StoreLike, *, read_only: bool = False, storage_options: dict[str, Any] | None = None
) -> Store:
    """Resolve ``store`` into a zarr store object (no I/O).

    Parameters
    ----------
    store : str, path-like or zarr store
        A local directory, a ``file://`` or any fsspec URL (``s3://bucket/path``), or a
        zarr store object, returned unchanged.
    read_only : bool
        Open local paths and URLs read-only.
    storage_options : dict, optional
        fsspec options for a URL (endpoint, credentials); without them the filesystem
        takes its defaults from the environment (``AWS_*`` variables for S3).
    """
    if isinstance(store, Store):
        return store
    if not isinstance(store, str | os.PathLike):
        raise StoreError(
            f"store must be a path, an fsspec URL or a zarr store, got {type(store).__name__}"
        )
    text = os.fspath(store)
    if text.startswith("file://"):
        text = text.removeprefix("file://")
    if "://" not in text:
        return LocalStore(Path(text).expanduser(), read_only=read_only)
    key = (text, read_only)
    if storage_options is None and key in _URL_STORES:
        return _URL_STORES[key]
    try:
        opened = FsspecStore.from_url(text, storage_options=storage_options, read_only=read_only)
    except (ImportError, ValueError) as e:
        raise StoreError(
            f"cannot open store URL {text!r}: {e}; install the fsspec backend for its "
            "protocol (s3fs for s3://) or check the URL"
        ) from e
    if storage_options is None:
        _URL_STORES[key] = opened
    return opened


def describe(store: Store) -> str:
    """Where a store lives, for messages."""
    if isinstance(store, LocalStore):
        return str(store.root)
    if isinstance(store, FsspecStore):
        protocol = store.fs.protocol
        protocol = protocol[0] if isinstance(protocol, tuple | list) else protocol
        return f"{protocol}://{store.path}"
    return repr(store)


def _check_local_dir(store: LocalStore, create: bool) -> None:
    root = Path(store.root)
    if root.is_file():
        raise NotAStoreError(f"{root} is a file, not a Zarr store: give a directory path")
    if not root.exists():
        if create:
            return
        raise NotAStoreError(
            f"no store at {root}: check the path, or create the store with "
            "storage.create_group(...)"
        )
    if (root / ".zgroup").is_file() or (root / ".zarray").is_file():
        raise SchemaError(f"{root} is a Zarr v2 store; the farm writes Zarr v3: use a new path")
    if not (root / "zarr.json").is_file() and (not create or any(root.iterdir())):
        raise NotAStoreError(
            f"{root} is not a Zarr v3 store (no zarr.json at its root): give the store's "
            "directory, or an empty or new one to create a store there"
        )


def root_group(store: Store, *, create: bool = False) -> zarr.Group:
    """Open the store's root group for writing, creating the store when ``create``.

    Raises :class:`NotAStoreError` for a missing store (unless ``create``) or a path
    that holds something else, and :class:`SchemaError` for a Zarr v2 store.
    """
    if isinstance(store, LocalStore):
        _check_local_dir(store, create)
    elif not create and not key_exists(store, "zarr.json"):
        raise NotAStoreError(
            f"no Zarr v3 store at {describe(store)} (no zarr.json): check the URL, or "
            "create the store with storage.create_group(...)"
        )
    mode = "r" if store.read_only else ("a" if create else "r+")
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
        _check_local_dir(store, create=False)
    try:
        g = zarr.open_group(store=store, path=group, mode="r" if store.read_only else "r+",
                            use_consolidated=False)
    except (zarr.errors.NodeNotFoundError, zarr.errors.ContainsArrayError, OSError) as e:
        # Only now look at the root (costly when its consolidated metadata is large):
        # it raises NotAStoreError when there is no store at all.
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


def publish(store: Store) -> None:
    """Refresh the consolidated metadata at the root (client only, after any change).

    xarray opens a store through the root's consolidated metadata, which also gives a
    reader one consistent snapshot of all shapes while the client resizes.
    """
    consolidate(store)
