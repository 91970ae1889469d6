"""Applying a trained force model to measured point clouds (``farm predict``), and the
model files it is read from.

- :mod:`~analysis.camera.predict.clouds`: read/write point clouds (CSV/TXT/XYZ,
  PLY/VTK/VTU...).
- :mod:`~analysis.camera.predict.registration`: rigid transforms, Kabsch/Umeyama fits,
  ICP, transform files.
- :mod:`~analysis.camera.predict.intervals`: split-conformal prediction intervals.
- :mod:`~analysis.camera.predict.domain`: is a measured cloud like the training clouds?
  (the reference cloud's checks, the training clouds' feature domain).
- :mod:`~analysis.camera.predict.persist`: safe model files (skops + manifest +
  checksum; files of types that moved since load too). The surrogate study
  (:mod:`analysis.studies.surrogate`) saves its models with it as well.
- :mod:`~analysis.camera.predict.validate`: a force model file checked as a whole when
  it is read.

Names are imported lazily (as in :mod:`analysis`), so importing one module, e.g.
``analysis.camera.predict.intervals``, does not pull in meshio, SciPy's KD-tree or skops.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from analysis.camera.predict.clouds import read_cloud, write_cloud
    from analysis.camera.predict.intervals import ConformalIntervals
    from analysis.camera.predict.persist import TRUSTED_TYPES, load_model, save_model
    from analysis.camera.predict.registration import Transform, icp, read_transform, rigid_fit

_EXPORTS = {
    "read_cloud": "analysis.camera.predict.clouds",
    "write_cloud": "analysis.camera.predict.clouds",
    "Transform": "analysis.camera.predict.registration",
    "rigid_fit": "analysis.camera.predict.registration",
    "icp": "analysis.camera.predict.registration",
    "read_transform": "analysis.camera.predict.registration",
    "ConformalIntervals": "analysis.camera.predict.intervals",
    "save_model": "analysis.camera.predict.persist",
    "load_model": "analysis.camera.predict.persist",
    "TRUSTED_TYPES": "analysis.camera.predict.persist",
}

__all__ = [  # literal, so that static tools read it; a test keeps it == the table
    "TRUSTED_TYPES", "ConformalIntervals", "Transform", "icp", "load_model", "read_cloud",
    "read_transform", "rigid_fit", "save_model", "write_cloud",
]


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'analysis.camera.predict' has no attribute {name!r}")
