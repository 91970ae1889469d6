"""Everything that reads the store to answer a question about the tyre, in rooms by the
question each answers (``docs/architecture.md``, "The rooms of analysis/"):

- *What do the inner surface's fields say about the forces?* The chapter-5 analyses, as
  modules of this package: :mod:`.data` (a group's selection as matrices), :mod:`.moments`,
  :mod:`.crosscov` (cross-covariance PCA), :mod:`.pcr`, :mod:`.pls` (SIMPLS/NIPALS PLSR),
  :mod:`.selection` (component counts by CV), :mod:`.noise` (Monte Carlo noise sweeps),
  :mod:`.combined` (combined loads: block scaling, latent counts), with :mod:`.splits`
  (held-out sets that keep a load path whole), :mod:`.axes` (forces in the road's axes),
  :mod:`.free_rolling` (each rolling tree's offset from free rolling), :mod:`.relaxation`
  (a slip's steady force from led rolls), :mod:`.cluster` (a Dask cluster for the
  reductions) and :mod:`.errors`.
- *Which model choices matter, and what would an experiment give without running it?*
  :mod:`.sensitivity` and :mod:`.sensitivity_data` (Sobol' indices, Morris screening over
  a model design); :mod:`.surrogate` (a Gaussian-process surrogate of the experiments),
  :mod:`.adaptive` (an adaptive study's next batch), :mod:`.surrogate_guess` (the
  surrogate-first start of the inverse loops).
- *Can the in-tyre camera read the forces?* :mod:`analysis.camera`: the virtual T2Cam,
  the learners, force models with their intervals, prediction from measured clouds,
  mismatch.
- :mod:`analysis.studies`: one module per ``farm analyse`` command;
  :mod:`analysis.report`: the reproduction's report, chapter by chapter;
  :mod:`analysis.render`: the tables, figures and Markdown both share.

Reads the store only (of :mod:`farm`, only the pure-numpy :mod:`farm.measure.surface` and
:mod:`farm.measure.axes`; never :mod:`jobs`). Public API, imported lazily so that
``import analysis`` stays cheap for the ``farm`` command::

    from analysis import load, CrossCovariancePCA, PCRegression, SIMPLSRegression
    from analysis import monte_carlo, AnalysisError

See ``docs/analysis.md``.

Lazy (SPEC 1, lazy_loader) so that ``farm --help`` does not pay for scikit-learn, SciPy
and dask (about 0.9 s more: the CLI imports :mod:`analysis.errors`, hence this package, at
start-up). The names and their modules live in ``__init__.pyi``, which type checkers and
the layering test read; ``EAGER_IMPORT=1`` loads everything at once.
"""

import lazy_loader as _lazy

__getattr__, __dir__, __all__ = _lazy.attach_stub(__name__, __file__)
