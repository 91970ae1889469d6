"""Names of the ``analysis.camera`` package, loaded on first use (analysis/camera/__init__.py)."""

from .features import TARGETS, displacements, targets
from .learners import LEARNERS, learner
from .predict.clouds import read_cloud, write_cloud
from .predict.intervals import ConformalIntervals
from .predictor import ForceModel, fit
from .sensor import PRESETS, InnerSurface, SensorSpec, VirtualSensor, sensor_spec

__all__ = [
    "LEARNERS",
    "PRESETS",
    "TARGETS",
    "ConformalIntervals",
    "ForceModel",
    "InnerSurface",
    "SensorSpec",
    "VirtualSensor",
    "displacements",
    "fit",
    "learner",
    "read_cloud",
    "sensor_spec",
    "targets",
    "write_cloud",
]
