"""Names of the ``analysis`` package, loaded on first use (analysis/__init__.py)."""

from .combined import BlockRegression, BlockScaler, latent_count
from .crosscov import CrossCovariancePCA, direction_importance
from .data import inputs, load, outputs
from .errors import AnalysisError
from .moments import Moments, compute_moments
from .noise import NoiseResult, monte_carlo, nodal_average_std, totals_operator
from .pcr import PCRegression
from .pls import SIMPLSRegression, pctvar_from_scores
from .selection import cross_validate_simpls, select_n_components
from .sensitivity import MorrisScreening, SobolIndices
from .sensitivity_data import OutputRequest, read_outputs
from .surrogate import FieldSurrogate

__all__ = [
    "AnalysisError",
    "BlockRegression",
    "BlockScaler",
    "CrossCovariancePCA",
    "FieldSurrogate",
    "Moments",
    "MorrisScreening",
    "NoiseResult",
    "OutputRequest",
    "PCRegression",
    "SIMPLSRegression",
    "SobolIndices",
    "compute_moments",
    "cross_validate_simpls",
    "direction_importance",
    "inputs",
    "latent_count",
    "load",
    "monte_carlo",
    "nodal_average_std",
    "outputs",
    "pctvar_from_scores",
    "read_outputs",
    "select_n_components",
    "totals_operator",
]
