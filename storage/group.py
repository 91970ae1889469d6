"""Client side: create the group of a mesh (node sets written once); list groups.

Creating writes metadata, so it runs under the store's client lock (one metadata
writer at a time, :mod:`storage.lock`): of two clients racing to create one group, the
second finds it complete and checks it holds its own mesh and model. A group is marked
complete by its ``schema_version`` attribute, written last, so a client killed
half-way leaves a group that the next call rebuilds.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import zarr

import storage.identity as identity
from storage._zarr import array, read
from storage.errors import MeshMismatchError, SchemaError
from storage.lock import client_lock
from storage.mesh import GroupAttrs, MeshNodes
from storage.paths import (
    StoreLike,
    check_group_name,
    farm_entries_ignored,
    names_the_store,
    open_group,
    open_store,
)
from storage.paths import publish as _publish
from storage.paths import root_group as _root_group
from storage.schema import (
    CLIENT_CHUNK,
    COMPONENTS,
    EXPERIMENT,
    FIXED_VARIABLES,
    KNOWN_PARAMETER_UNITS,
    MESH_VARIABLES,
    REQUIRED_PARAMETERS,
    SCHEMA_VERSION,
    STRAIN_COMPONENTS,
    WORKER_VARIABLES,
    Variable,
    parameter,
)


def create_array(g: zarr.Group, var: Variable, shape: tuple[int, ...]) -> zarr.Array:
    """Create one variable of the schema in ``g`` (dims, dtype, fill, units, chunks)."""
    # Worker variables: one experiment per chunk, node dims whole, so that a worker's
    # write is whole chunks of its own. Client variables: large chunks, one writer.
    if var.dims[0] != "experiment":
        chunks = shape
    elif var.writer == "worker":
        chunks = (1, *shape[1:])
    else:
        chunks = (CLIENT_CHUNK,)
    return g.create_array(
        var.name,
        shape=shape,
        chunks=tuple(max(c, 1) for c in chunks),
        dtype=str if var.dtype == "str" else var.dtype,
        fill_value=var.fill,
        dimension_names=var.dims,
        attributes=var.attrs,
        compressors=_codecs(var),
    )


def _codecs(var: Variable) -> Any:
    """A worker variable's chunks (one experiment each) end in their CRC32C (issue 50): a
    changed byte fails that chunk's read, so verify knows which chunk was damaged, and a
    lost checksum no longer makes an experiment's intact data suspect
    (:mod:`storage.verify`: such a slot is signed again, not solved again). Client
    variables hold many experiments per chunk (one flipped byte would make every load
    case of the chunk unreadable); their slots are guarded by the checksums' labels.
    Compressed as zarr's "auto" would (zstd level 0), where the variable is."""
    from zarr.codecs import Crc32cCodec, ZstdCodec

    if var.writer != "worker":
        return "auto" if var.compressed else None
    return (ZstdCodec(level=0), Crc32cCodec()) if var.compressed else (Crc32cCodec(),)


def crc_guarded(a: zarr.Array) -> bool:
    """Whether ``a``'s chunks carry a CRC32C (arrays made since issue 50)."""
    codecs = getattr(a.metadata, "codecs", ())  # zarr v2 metadata has none
    return any(type(c).__name__ == "Crc32cCodec" for c in codecs)


OUR_NAMES = frozenset(FIXED_VARIABLES) | frozenset(KNOWN_PARAMETER_UNITS)
"""Every array name a group of ours can hold: a group holding others is not ours."""


@names_the_store
def create_group(store: StoreLike, group: str, mesh: MeshNodes, attrs: GroupAttrs) -> None:
    """Create the group of one model mesh, with its node sets and no experiments.

    Idempotent: calling it again with the same mesh (same ``mesh_key``, node ids, grid
    positions and coordinates) changes nothing. Client only.

    Parameters
    ----------
    store : path, URL or zarr store
        Created when it does not exist yet (a new or empty directory).
    group : str
        Group name, e.g. derived from the mesh key.
    mesh : MeshNodes
        Node ids (N inner, M tread), reference coordinates (N, 3), (M, 3) and grid rows.
    attrs : GroupAttrs
        Model spec, mesh key, solver and package versions.

    Raises
    ------
    MeshMismatchError
        The group exists for a different mesh, or for another model (``model_spec``).
    StoreBusyError
        Another client held the store's lock for too long.
    """
    if not isinstance(mesh, MeshNodes) or not isinstance(attrs, GroupAttrs):
        raise SchemaError(
            f"create_group takes a MeshNodes and a GroupAttrs, got {type(mesh).__name__} and "
            f"{type(attrs).__name__}"
        )
    check_group_name(group)
    zs = open_store(store)
    with client_lock(zs, create=True):  # completeness and mesh are judged under the lock
        root = _root_group(zs, create=True)
        if group in root and _is_complete(root, group):
            _check_same_mesh(open_group(zs, group), group, mesh, attrs)
        else:
            _check_not_renamed(root, group)
            _build(root, group, mesh, attrs)
        _publish(zs)


def _check_not_renamed(root: zarr.Group, group: str) -> None:
    """Refuse to build ``group`` anew when another folder of the store was made as it
    (issue 50: a renamed group folder made resume solve every experiment again into a
    new group): rename the folder back instead."""
    wanted = identity.name_digest(group)
    try:
        others = [(name, g.attrs.get(identity.IDENTITY)) for name, g in root.groups()]
    except Exception:  # a damaged neighbour: verify names it; it is no reason to refuse
        return
    for name, stored in others:
        if (name != group and isinstance(stored, dict)
                and stored.get("version") == identity.VERSION and stored.get("group") == wanted):
            raise SchemaError(
                f"group {group!r} is not in the store, but its folder {name!r} was made as "
                f"{group!r} (renamed by hand?): rename {name!r} back to {group!r} and run "
                "the command again, so that nothing is solved twice")


def _is_complete(root: zarr.Group, group: str) -> bool:
    node = root[group]
    if not isinstance(node, zarr.Group):
        raise SchemaError(f"{group!r} is an array in this store, not a group: choose another name")
    if "schema_version" in node.attrs:
        return True
    foreign = sorted(set(node.keys()) - OUR_NAMES)
    if foreign:
        raise SchemaError(
            f"group {group!r} exists but is not a tyre-farm group (it holds {foreign[0]!r}): "
            "choose another group name"
        )
    return False  # a half-made group of ours: a client died creating it; rebuild it


def _build(root: zarr.Group, group: str, mesh: MeshNodes, attrs: GroupAttrs) -> None:
    g = root.create_group(group, overwrite=True)
    values: dict[str, Any] = {
        "component": np.array(COMPONENTS, dtype=object),
        "strain_component": np.array(STRAIN_COMPONENTS, dtype=object),
        **mesh.arrays(),
    }
    for var in MESH_VARIABLES:
        create_array(g, var, values[var.name].shape)[...] = values[var.name]
    sizes = {"experiment": 0, "inner_node": mesh.n_inner, "tread_node": mesh.n_tread,
             "component": 3, "strain_component": 3}
    experiment_vars = [EXPERIMENT, *(parameter(n, u) for n, (u, _) in REQUIRED_PARAMETERS.items()),
                       *WORKER_VARIABLES]
    for var in experiment_vars:
        create_array(g, var, tuple(sizes[d] for d in var.dims))
    made = {"model_spec": attrs.model_spec, "mesh_key": attrs.mesh_key}
    # what verify compares the group with later: digested as stored (dtypes included)
    stored = {name: read(array(g, name)) for name in identity.MESH_ARRAYS}
    # Last: the attribute that marks the group complete.
    g.update_attributes({
        "schema_version": SCHEMA_VERSION,
        **made,
        "solver": attrs.solver,
        "package_versions": json.dumps(dict(attrs.package_versions), sort_keys=True),
        identity.IDENTITY: identity.digests(group, made, stored),
    })


def _check_same_mesh(g: zarr.Group, group: str, mesh: MeshNodes, attrs: GroupAttrs) -> None:
    stored_key = g.attrs.get("mesh_key")
    if stored_key != attrs.mesh_key:
        raise MeshMismatchError(
            f"group {group!r} holds mesh {stored_key!r}, not {attrs.mesh_key!r}: use one group "
            "per mesh (a new group name for this mesh)"
        )
    stored = {name: read(array(g, name)) for name in mesh.arrays()}
    diff = mesh.difference(stored)
    if diff:
        raise MeshMismatchError(
            f"group {group!r} has mesh key {attrs.mesh_key!r} but another mesh: {diff}; "
            "the mesh key must change when the mesh does"
        )
    # One group, one model: materials or boundary conditions mixed in one group would
    # mix populations in every analysis of it.
    held = _spec(g.attrs.get("model_spec"))
    mine = _spec(attrs.model_spec)
    if held != mine:
        names = sorted(k for k in set(held) | set(mine) if held.get(k) != mine.get(k))
        raise MeshMismatchError(
            f"group {group!r} holds experiments of another model on this mesh (model_spec "
            f"differs in {', '.join(map(repr, names)) or 'its values'}): use one group per "
            "model (another group name)"
        )


def _spec(text: object) -> dict:
    try:
        spec = json.loads(text) if isinstance(text, str) else None
    except ValueError:
        spec = None
    return spec if isinstance(spec, dict) else {"model_spec": text}


def unfinished_groups(store: StoreLike) -> list[str]:
    """Groups of ours whose creation never finished (no ``schema_version``: a client
    stopped mid-way, e.g. on a full disk), sorted. Invisible to :func:`list_groups`;
    ``farm sweep verify`` and ``status`` name them (issue 26), and submitting the study
    again rebuilds them (:func:`create_group`)."""
    zs = open_store(store, read_only=True)
    root = _root_group(zs)
    with farm_entries_ignored():
        return sorted(name for name, g in root.groups()
                      if "schema_version" not in g.attrs and set(g.keys()) <= OUR_NAMES)


def list_groups(store: StoreLike) -> list[str]:
    """Names of the experiment groups in a store, sorted."""
    zs = open_store(store, read_only=True)
    root = _root_group(zs)
    with farm_entries_ignored():
        return sorted(name for name, g in root.groups() if "schema_version" in g.attrs)
