"""Applying a trained force model to measured point clouds (``farm predict``).

- :mod:`~analysis.predict.clouds`: read/write point clouds (CSV/TXT/XYZ, PLY/VTK/VTU...).
- :mod:`~analysis.predict.registration`: rigid transforms, Kabsch/Umeyama fits, ICP,
  transform files.
- :mod:`~analysis.predict.intervals`: split-conformal prediction intervals.
- :mod:`~analysis.predict.persist`: safe model files (skops + manifest + checksum).

Names are imported lazily (as in :mod:`analysis`), so importing one module, e.g.
``analysis.predict.intervals``, does not pull in meshio, SciPy's KD-tree or skops.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from analysis.predict.clouds import read_cloud, write_cloud
    from analysis.predict.intervals import ConformalIntervals
    from analysis.predict.persist import TRUSTED_TYPES, load_model, save_model
    from analysis.predict.registration import Transform, icp, read_transform, rigid_fit

_EXPORTS = {
    "read_cloud": "analysis.predict.clouds",
    "write_cloud": "analysis.predict.clouds",
    "Transform": "analysis.predict.registration",
    "rigid_fit": "analysis.predict.registration",
    "icp": "analysis.predict.registration",
    "read_transform": "analysis.predict.registration",
    "ConformalIntervals": "analysis.predict.intervals",
    "save_model": "analysis.predict.persist",
    "load_model": "analysis.predict.persist",
    "TRUSTED_TYPES": "analysis.predict.persist",
}

__all__ = [  # literal, so that static tools read it; a test keeps it == the table
    "TRUSTED_TYPES", "ConformalIntervals", "Transform", "icp", "load_model", "read_cloud",
    "read_transform", "rigid_fit", "save_model", "write_cloud",
]


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'analysis.predict' has no attribute {name!r}")
