"""The study's group in the store: created from the model's mesh, checked for its model."""

from __future__ import annotations

import json

import numpy as np

import storage
from farm.mesh import TyreMesh, mesh_for
from jobs.errors import StudyError
from jobs.study import Study


def mesh_nodes(mesh: TyreMesh) -> storage.MeshNodes:
    """The node sets the store keeps for a mesh: ids, coordinates and grid positions."""
    rows, cols = np.indices(mesh.inner_grid.shape)
    first, stop = mesh.tread_rows
    tread = mesh.outer_grid[first:stop]
    t_rows, t_cols = np.indices(tread.shape)
    return storage.MeshNodes(
        inner_ids=mesh.inner_nodes, inner_xyz=mesh.xyz(mesh.inner_nodes),
        inner_row=rows.ravel(), inner_col=cols.ravel(),
        tread_ids=tread.ravel(), tread_xyz=mesh.xyz(tread.ravel()),
        tread_row=t_rows.ravel(), tread_col=t_cols.ravel(),
    )


def model_json(study: Study) -> str:
    return json.dumps(study.model.to_dict(), sort_keys=True)


def ensure_group(study: Study, solver: str) -> None:
    """Create the study's group (idempotent) after checking it holds this very model.

    A group holds the experiments of one model: mixing materials or boundary
    conditions in one group would mix populations in every analysis of it.
    """
    group = study.group_name
    if group in _groups(study.store):
        held = storage.open_dataset(study.store, group).attrs.get("model_spec")
        if held is not None and json.loads(held) != study.model.to_dict():
            raise StudyError(
                f"group {group!r} of {study.location} holds another model; give the study "
                "another [study] group name (or drop it to get one per model)")
    mesh = mesh_for(study.model)
    attrs = storage.GroupAttrs(model_spec=model_json(study), mesh_key=mesh.mesh_key,
                               solver=solver, package_versions=storage.package_versions())
    storage.create_group(study.store, group, mesh_nodes(mesh), attrs)


def _groups(store: storage.StoreLike) -> list[str]:
    try:
        return storage.list_groups(store)
    except storage.NotAStoreError:
        return []
