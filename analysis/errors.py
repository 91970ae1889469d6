"""Errors of the analysis layer.

Each error is one line that says what was asked, what the store holds and how to fix
it; the ``farm analyse`` CLI prints ``str(error)``. Errors caused by bad input also
subclass :class:`ValueError`, so scikit-learn's own checks (which expect ``ValueError``)
keep working on the estimators.
"""

from __future__ import annotations


class AnalysisError(Exception):
    """Base class of every error raised by :mod:`analysis`."""


class StoreError(AnalysisError, ValueError):
    """The store or group cannot be opened, or the group to use is ambiguous."""


class EmptySelectionError(AnalysisError, ValueError):
    """No done experiment matches the selection (status, pressure, deflection)."""


class MissingVariableError(AnalysisError, ValueError):
    """The group lacks a variable or coordinate the analysis needs."""


class NonFiniteError(AnalysisError, ValueError):
    """Inputs or outputs contain NaN or inf values."""


class ComponentsError(AnalysisError, ValueError):
    """More components were asked for than the data can support."""


class ParameterError(AnalysisError, ValueError):
    """A parameter of an estimator or analysis is out of its valid range."""
