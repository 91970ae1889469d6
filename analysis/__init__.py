"""Chapter-5 analyses over the store: cross-covariance PCA, PCR, PLSR, noise sweeps.

Reads the store only (never imports :mod:`farm`). Public API, imported lazily so that
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
