"""The camera's room: a virtual T2Cam and the force models that read tyre forces from its
point clouds (issues 27 and 47; ``docs/sensor.md``).

The rest of :mod:`analysis` reads every inner-surface node of the store exactly; the
in-tyre camera sees a noisy cloud of points of its own in a window about the contact
patch. Everything that follows from that lives here:

- :mod:`.sensor`: the camera as a model of measurement (its spec and presets, the FE
  inner surface, the camera's points, the errors of a cloud, :class:`VirtualSensor`,
  measured clouds onto the camera's points);
- :mod:`.features`: what a force model learns from and predicts (the targets, the
  displacements the camera measures, features of noisy measurements);
- :mod:`.learners`: the learners, compared side by side (PLSR with grouped CV, a
  Gaussian process on its scores);
- :mod:`.predictor`: a force model (:class:`ForceModel`): trained on a store with
  conformal intervals checked held out, saved and loaded, applied to measured clouds;
- :mod:`.predict`: measured clouds and model files (reading and writing clouds,
  registration, the intervals, the training clouds' domain, skops files and their
  checks);
- :mod:`.mismatch`: a force model trained on one tyre model applied to another's clouds;
- :mod:`.regions`: where each target lives on the surface (each region's held-out R2).

``farm fit|measure|predict|mismatch`` are its commands; ``farm analyse sensor``
(:mod:`analysis.studies.sensor`) is a study that uses it. Public API, imported lazily::

    from analysis.camera import sensor_spec, VirtualSensor, InnerSurface, fit, ForceModel
    from analysis.camera import read_cloud, write_cloud, displacements, targets
    from analysis.camera import predictor  # predictor.save, predictor.load

Lazy (SPEC 1, lazy_loader, as :mod:`analysis`): importing the package pulls in neither
scikit-learn, SciPy, xarray, meshio nor skops. The names and their modules live in
``__init__.pyi``, which type checkers and the layering test read.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
