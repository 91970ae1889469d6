"""Errors of the physics layer.

Every error says what happened, what was given and how to fix it; the CLI prints
``str(error)`` as one line. Solver failures carry their classified outcome so that the
job layer can record them as data instead of crashing a sweep.
"""

from __future__ import annotations

import reprlib
from typing import Any

_SHORT = reprlib.Repr()
_SHORT.maxstring = _SHORT.maxother = 60
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxdict = 2, 6, 4


def shown(value: Any) -> str:
    """``repr(value)`` cut short: an error line names a 1 MiB list, it does not print it."""
    return _SHORT.repr(value)


class FarmError(Exception):
    """Base class of every error raised by :mod:`farm`."""


class SpecError(FarmError, ValueError):
    """A model spec, load case or solver setting is invalid (bad input, nothing run)."""


class MeshError(FarmError, RuntimeError):
    """gmsh failed, or produced a mesh that breaks an invariant (Jacobian, faces, sets)."""


class ResultsError(FarmError, ValueError):
    """A CalculiX result file is missing, truncated or not what the deck asked for."""


class CcxNotFoundError(FarmError, FileNotFoundError):
    """The ``ccx`` executable is not installed or not on ``PATH``."""


class SolverError(FarmError, RuntimeError):
    """A ``ccx`` run did not converge or did not finish.

    Attributes
    ----------
    outcome : str
        The classified outcome (see :class:`farm.ccx.outcome.Outcome`), e.g.
        ``"too_many_cutbacks"`` or ``"timeout"``.
    command : list of str
        The command that ran.
    returncode : int or None
        Exit status, ``None`` when the process was killed on timeout.
    tail : str
        The last lines of the solver's output.
    hint : str
        How to fix it.
    reached : float or None
        Step time of the last converged increment (from the ``.sta`` file; 0 when none
        converged, None when unknown): where along its load path the run stopped.
    where : str
        What the load path was doing at ``reached`` (e.g. "in the slide, 40 % of it"),
        when the caller knows its path's time layout (:meth:`located`).
    partial : object or None
        What its load path reached before it stopped (issue 45: a roll that fails keeps
        the travel it did), as the layer that raised it knows it (:meth:`with_partial`):
        the rolled states, then the camera's path solution, then the measurements, in
        the path's order. None where nothing was reached or kept.
    """

    def __init__(
        self,
        outcome: str,
        command: list[str],
        returncode: int | None,
        tail: str,
        hint: str = "",
        reached: float | None = None,
        where: str = "",
        partial: object | None = None,
    ) -> None:
        self.outcome = outcome
        self.command = list(command)
        self.returncode = returncode
        self.tail = tail
        self.hint, self.reached, self.where = hint, reached, where
        self.partial = partial
        last = " | ".join(line.strip() for line in tail.strip().splitlines()[-3:] if line.strip())
        msg = f"ccx failed ({outcome}, exit code {returncode}) running {' '.join(command)}"
        if last:
            msg += f": {last}"
        if reached is not None:
            msg += (f"; last converged increment at step time {reached:.4g}" if reached > 0
                    else "; no increment converged")
            msg += f" ({where})" if where else ""
        if hint:
            msg += f". {hint}"
        super().__init__(msg)

    def located(self, where: str) -> SolverError:
        """The same failure, saying what the load path was doing when it stopped."""
        return SolverError(self.outcome, self.command, self.returncode, self.tail, self.hint,
                           self.reached, where, self.partial)

    def noting(self, note: str) -> SolverError:
        """The same failure with ``note`` added to its hint (what the caller keeps)."""
        hint = f"{self.hint}. {note}" if self.hint else note
        return SolverError(self.outcome, self.command, self.returncode, self.tail, hint,
                           self.reached, self.where, self.partial)

    def with_partial(self, reached: object | None) -> SolverError:
        """The same failure holding ``reached``: what the path reached, as the caller's
        layer sees it (:attr:`partial`; None: nothing)."""
        return SolverError(self.outcome, self.command, self.returncode, self.tail, self.hint,
                           self.reached, self.where, reached)

    def __reduce__(self):  # keep the fields when the error crosses a process boundary
        # (not ``partial``: the states stay with the worker that stores them)
        return (type(self), (self.outcome, self.command, self.returncode, self.tail,
                             self.hint, self.reached, self.where))
