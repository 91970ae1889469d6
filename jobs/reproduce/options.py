"""What to reproduce, where, on which cluster; the test-sized coarse meshes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

# Test-sized meshes of ``--coarse`` (minutes, not for conclusions), as [model.mesh] TOML
COARSE_MESH = {"full": "tread = 4\nsidewall = 2\nbead = 1\ncircumferential = 16",
               "reduced": "tread = 4\nsidewall = 2\nbead = 1\ncircumferential = 8"}


@dataclass(frozen=True)
class Options:
    """What to reproduce, where, on which cluster."""

    out: Path
    store: str
    quick: bool = True
    coarse: bool = False
    materials: str = "table-3.1"
    scheduler: str | None = None
    workers: int | None = None
    cluster: Any = None  # a jobs.cluster.ClusterSpec (e.g. SLURM) instead of the two above

    def cluster_spec(self) -> Any:
        """Where the stages run: ``cluster``, else the embedded/``scheduler`` cluster."""
        from jobs.cluster import DaskCluster

        return self.cluster or DaskCluster(self.scheduler, self.workers)

    def mesh_tag(self) -> str:
        return "coarse" if self.coarse else "default"

    def group(self, kind: str) -> str:
        """The store group of the ``kind`` model's sweeps (one group per model)."""
        return f"{kind}-{self.materials}-{self.mesh_tag()}"
