"""A virtual T2Cam (thesis §2.2): the in-tyre stereo camera as a model of measurement.

Every other analysis reads every inner-surface node exactly. T2Cam sees a noisy point
cloud of about 200 mm x 280 mm (a 40° arc) about the contact patch, at points of its own,
and computes strain from four constant-strain triangles around each point of the noisy
cloud against a noisy reference cloud of the inflated, unloaded tyre (the 2017 and 2020
T2Cam papers; docs/sensor.md).

- :mod:`.spec`: :class:`SensorSpec` (what the camera is), :data:`PRESETS`,
  :func:`sensor_spec` (the ``--sensor`` text);
- :mod:`.surface`: :class:`InnerSurface`, the FE inner surface as a grid;
- :mod:`.layout`: :class:`Layout`, the camera's points and the bilinear face interpolation
  of FE fields to them (:func:`layout`);
- :mod:`.noise`: the errors of a measured cloud;
- :mod:`.model`: :class:`VirtualSensor`, displacements in, features out;
- :mod:`.resample`: measured clouds onto a layout (``farm predict``).
"""

from analysis.camera.sensor.layout import Layout, layout
from analysis.camera.sensor.model import VirtualSensor
from analysis.camera.sensor.spec import PRESETS, SensorSpec, sensor_spec
from analysis.camera.sensor.surface import InnerSurface

__all__ = ["PRESETS", "InnerSurface", "Layout", "SensorSpec", "VirtualSensor", "layout",
           "sensor_spec"]
