"""Masks that keep only the informative inner nodes (thesis §5.3, §6.2).

§6.2 recommends reformulating the objectives "to only consider the regions which are
most informative". The cross-covariance PCA of `farm analyse pca` (thesis §5.3) writes
``eigen_vectors.csv``: the eigen-deformations/strains W per direction (Ux, ..., exy),
inner node and mode. A node is kept when, in any direction of the method's family,
its |W| of the chosen mode is among the ``keep`` largest fraction of that direction.
The PCA must come from a store of the same mesh (same inner node ids).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from jobs.errors import StudyError
from jobs.inverse.study import MaskSpec

FAMILIES = {"displacement": ("Ux", "Uy", "Uz"), "strain": ("exx", "eyy", "exy")}
COLUMNS = {"direction", "inner_node", "mode", "value"}


def read_components(path: str) -> pd.DataFrame:
    """The eigen-vector table of `farm analyse pca` (raises StudyError)."""
    try:
        table = pd.read_csv(path)
    except (OSError, ValueError) as e:
        raise StudyError(f"mask.eigen_vectors: cannot read {path}: {e}") from e
    missing = sorted(COLUMNS - set(table.columns))
    if missing:
        raise StudyError(f"mask.eigen_vectors: {path} has no column {missing[0]!r}; give the "
                         "eigen_vectors.csv that `farm analyse pca --out DIR` writes")
    return table


def importance_mask(table: pd.DataFrame, inner_nodes: np.ndarray, method: str, keep: float,
                    mode: int = 1) -> np.ndarray:
    """Boolean mask over ``inner_nodes`` (n_inner,) for ``method``'s directions.

    ``combined`` uses both families. Raises :class:`StudyError` when the table lacks a
    direction or the mode, or was computed on another mesh.
    """
    families = FAMILIES if method == "combined" else {method: FAMILIES[method]}
    keep_mask = np.zeros(inner_nodes.size, bool)
    for directions in families.values():
        for d in directions:
            rows = table[(table["direction"] == d) & (table["mode"] == mode)]
            if rows.empty:
                raise StudyError(f"mask.eigen_vectors: no mode {mode} of direction {d!r}; "
                                 f"run `farm analyse pca` with the {d} direction")
            values = pd.Series(rows["value"].to_numpy(), index=rows["inner_node"].to_numpy())
            if not np.isin(inner_nodes, values.index).all():
                raise StudyError("mask.eigen_vectors: its inner nodes are not this model's; "
                                 "run the PCA on a store of the same mesh")
            weight = np.abs(values.loc[inner_nodes].to_numpy())
            n_keep = max(1, round(keep * inner_nodes.size))
            keep_mask[np.argsort(weight)[::-1][:n_keep]] = True
    return keep_mask


def masks_for(spec: MaskSpec | None, inner_nodes: np.ndarray, methods) -> dict[str, np.ndarray]:
    """One mask per method of the study (empty when the study has no mask)."""
    if spec is None:
        return {}
    table = read_components(spec.eigen_vectors)
    return {m: importance_mask(table, inner_nodes, m, spec.keep, spec.mode) for m in methods}
