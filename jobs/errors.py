"""Errors of the job layer: bad study files and failed sweeps."""

from __future__ import annotations


class JobError(Exception):
    """Base class of every error raised by :mod:`jobs`."""


class StudyError(JobError, ValueError):
    """A study file is unreadable or invalid; nothing was submitted, nothing stored."""


class ClusterError(JobError, RuntimeError):
    """The Dask scheduler cannot be reached or has no workers."""
