"""Errors (and the warnings) of the analysis layer.

Each error is one line that says what was asked, what the store holds and how to fix
it; the ``farm analyse`` CLI prints ``str(error)``. Errors caused by bad input also
subclass :class:`ValueError`, so scikit-learn's own checks (which expect ``ValueError``)
keep working on the estimators.

Errors of the store itself (missing store or group, bad schema) are :mod:`storage`'s:
analysis reads through :mod:`storage` and lets them through unchanged, so there is one
:class:`StoreError` class, re-exported here for callers that only import analysis.
"""

from __future__ import annotations

from storage.errors import StoreError

__all__ = [
    "AmbiguousGroupError",
    "AnalysisError",
    "CloudError",
    "CommonMeshError",
    "ComponentsError",
    "DegenerateDesignWarning",
    "DesignError",
    "EmptySelectionError",
    "IncompleteDesignError",
    "MissingVariableError",
    "ModelFileError",
    "NoVarianceError",
    "NonFiniteError",
    "ParameterError",
    "RegistrationError",
    "SchedulerError",
    "SelectionError",
    "StoreError",
    "TooFewExperimentsError",
    "UndefinedVarianceWarning",
]


class AnalysisError(Exception):
    """Base class of every error raised by :mod:`analysis`."""


class AmbiguousGroupError(AnalysisError, StoreError, LookupError):
    """The store has several groups (or none) and the analysis was not told which to use.

    Both an :class:`AnalysisError` and a :class:`storage.StoreError`: it is about the
    store's layout, found by the analysis.
    """


class SelectionError(AnalysisError, ValueError):
    """The selected experiments cannot support the analysis asked for."""


class EmptySelectionError(SelectionError):
    """No done experiment matches the selection (status, pressure, deflection)."""


class TooFewExperimentsError(SelectionError):
    """The selection holds fewer done experiments than the analysis needs."""


class NoVarianceError(SelectionError):
    """The outputs do not vary over the selection: variance explained is undefined."""


class IncompleteDesignError(SelectionError):
    """Rows of a sensitivity design lack a done experiment (Sobol and Morris cannot drop rows)."""


class CommonMeshError(SelectionError):
    """Field outputs over a design need the same inner-surface mesh in every group."""


class MissingVariableError(AnalysisError, ValueError):
    """The group lacks a variable or coordinate the analysis needs."""


class NonFiniteError(AnalysisError, ValueError):
    """Inputs or outputs contain NaN or inf values."""


class ComponentsError(AnalysisError, ValueError):
    """More components were asked for than the data can support.

    ``available``: how many the data do support, where the raiser knows (else None); a
    caller asking for "all" falls back to it.
    """

    def __init__(self, message: str, available: int | None = None) -> None:
        super().__init__(message)
        self.available = available


class ParameterError(AnalysisError, ValueError):
    """A parameter of an estimator or analysis is out of its valid range."""


class DesignError(ParameterError):
    """A sensitivity design matrix lacks the structure SALib's analysis relies on."""


class CloudError(AnalysisError, ValueError):
    """A point-cloud file cannot be read (missing, empty, not numbers, too large...) or a
    cloud is unusable (wrong shape, NaN/inf)."""


class RegistrationError(AnalysisError, ValueError):
    """Clouds cannot be registered (too few or degenerate points), or a transform (or its
    file) is not a rigid/similarity transform."""


class ModelFileError(AnalysisError, ValueError):
    """A saved model cannot be written or loaded safely: missing or corrupt manifest,
    checksum mismatch, unknown format version, not a skops file, or untrusted types."""


class SchedulerError(AnalysisError, ConnectionError):
    """The Dask scheduler given with ``--scheduler`` cannot be reached."""


class UndefinedVarianceWarning(UserWarning):
    """A fraction of variance explained is 0/0 (data without variance): reported as NaN."""


class DegenerateDesignWarning(UserWarning):
    """A parameter is (nearly) never changed by its own swap in a Sobol' design: its
    indices would be 0 by construction, not by the model, and are reported as NaN."""
