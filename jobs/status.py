"""``farm sweep status``: what a store group holds - counts, and failures with reasons."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import storage


@dataclass(frozen=True)
class Failure:
    experiment: str
    deflection: float
    pressure: float
    reason: str


@dataclass(frozen=True)
class GroupStatus:
    group: str
    counts: dict[str, int]
    failures: tuple[Failure, ...]


def group_status(store: storage.StoreLike, group: str) -> GroupStatus:
    """Counts of pending/done/failed experiments and the failures' reasons."""
    counts = storage.status_counts(store, group)
    failures: list[Failure] = []
    if counts.get("failed"):
        ds = storage.open_dataset(store, group)
        failed = np.flatnonzero(ds["status"].values == storage.FAILED)
        sub = ds.isel(experiment=failed)[["deflection", "pressure", "error"]].load()
        failures = [Failure(str(e), float(d), float(p), str(r)) for e, d, p, r in zip(
            sub["experiment"].values, sub["deflection"].values, sub["pressure"].values,
            sub["error"].values, strict=True)]
    return GroupStatus(group, counts, tuple(failures))


def store_status(store: storage.StoreLike, group: str | None = None
                 ) -> list[GroupStatus]:
    """Status of one group, or of every group of the store."""
    groups = [group] if group else storage.list_groups(store)
    return [group_status(store, g) for g in groups]
