"""Chapter-5 analyses over the store: cross-covariance PCA, PCR, PLSR, noise sweeps.

Reads the store only (never imports :mod:`farm`). Public API, imported lazily so that
``import analysis`` stays cheap for the ``farm`` command::

    from analysis import load, CrossCovariancePCA, PCRegression, SIMPLSRegression
    from analysis import monte_carlo, AnalysisError

See ``docs/analysis.md``.

The lazy table keeps ``farm --help`` from paying for scikit-learn, SciPy and dask (about
0.9 s more: the CLI imports :mod:`analysis.errors`, hence this package, at start-up). The
``TYPE_CHECKING`` block names the same imports for type checkers, linters and the layering
test, which would not see through ``importlib``; tests/analysis/test_analysis_exports.py
keeps the two equal.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from analysis.combined import BlockRegression, BlockScaler, latent_count
    from analysis.crosscov import CrossCovariancePCA, direction_importance
    from analysis.data import inputs, load, outputs
    from analysis.errors import AnalysisError
    from analysis.moments import Moments, compute_moments
    from analysis.noise import NoiseResult, monte_carlo, nodal_average_std, totals_operator
    from analysis.pcr import PCRegression
    from analysis.pls import SIMPLSRegression, pctvar_from_scores
    from analysis.selection import cross_validate_simpls, select_n_components
    from analysis.sensitivity import MorrisScreening, SobolIndices
    from analysis.sensitivity_data import OutputRequest, read_outputs

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

__all__ = [  # literal, so that static tools read it; the test keeps it == the table
    "AnalysisError", "BlockRegression", "BlockScaler", "CrossCovariancePCA", "Moments",
    "MorrisScreening", "NoiseResult", "OutputRequest", "PCRegression", "SIMPLSRegression",
    "SobolIndices", "compute_moments", "cross_validate_simpls", "direction_importance", "inputs",
    "latent_count", "load", "monte_carlo", "nodal_average_std", "outputs", "pctvar_from_scores",
    "read_outputs", "select_n_components", "totals_operator",
]


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'analysis' has no attribute {name!r}")
