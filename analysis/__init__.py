"""Chapter-5 analyses over the store: cross-covariance PCA, PCR, PLSR, noise sweeps.

Reads the store only (never imports :mod:`farm`). Public API, imported lazily so that
``import analysis`` stays cheap for the ``farm`` command::

    from analysis import load, CrossCovariancePCA, PCRegression, SIMPLSRegression
    from analysis import monte_carlo, AnalysisError

See ``docs/analysis.md``.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "load": "analysis.data",
    "inputs": "analysis.data",
    "outputs": "analysis.data",
    "compute_moments": "analysis.moments",
    "Moments": "analysis.moments",
    "CrossCovariancePCA": "analysis.crosscov",
    "direction_importance": "analysis.crosscov",
    "PCRegression": "analysis.pcr",
    "SIMPLSRegression": "analysis.pls",
    "pctvar_from_scores": "analysis.pls",
    "select_n_components": "analysis.selection",
    "cross_validate_simpls": "analysis.selection",
    "monte_carlo": "analysis.noise",
    "totals_operator": "analysis.noise",
    "nodal_average_std": "analysis.noise",
    "NoiseResult": "analysis.noise",
    "SobolIndices": "analysis.sensitivity",
    "MorrisScreening": "analysis.sensitivity",
    "read_outputs": "analysis.sensitivity_data",
    "OutputRequest": "analysis.sensitivity_data",
    "BlockScaler": "analysis.combined",
    "BlockRegression": "analysis.combined",
    "latent_count": "analysis.combined",
    "AnalysisError": "analysis.errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'analysis' has no attribute {name!r}")
