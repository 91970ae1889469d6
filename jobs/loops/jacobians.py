"""Finite-difference Jacobians, and a store that lets the loops of a study share them.

All loops of an inverse study share one problem (the same reference and forward model;
thesis §4.2), and per-solve noise only shifts a loop's target, never its residuals'
derivatives. So a Jacobian computed at a point serves every loop whose residuals have
the same shape (``key``: method, mask, regularisation, step) near that point. "Near"
is a relative radius: the forward model is not linear (on the coarse reduced mesh the
Jacobian at the true forces differs from the one at 90 % of them by 12 %;
docs/inverse.md, "Jacobian reuse"), so a Jacobian computed elsewhere is a starting
model that the secant updates of :mod:`jobs.loops.secant` then correct.

:class:`JacobianStore` is thread-safe: loops run in client threads, and a loop that
asks for a Jacobian another loop is computing near the same point waits for it
instead of solving the same n columns again.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field

import numpy as np

TINY = 1e-12


def fd_points(x: np.ndarray, step: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, list]:
    """Signed steps (backwards where forwards would leave ``upper``) and the n points."""
    h = np.where(x + step > upper, -step, step)
    return h, [x + h[j] * np.eye(x.size)[j] for j in range(x.size)]


def fd_jacobian(base: np.ndarray, columns: list[np.ndarray], h: np.ndarray) -> np.ndarray:
    """Forward-difference Jacobian, shape (m, n), from r(x) (m,) and r(x + h_j e_j)."""
    return np.column_stack([(c - base) / h[j] for j, c in enumerate(columns)])


@dataclass
class _Entry:
    x: np.ndarray
    jacobian: np.ndarray | None = None
    ready: threading.Event = field(default_factory=threading.Event)


class JacobianStore:
    """Full finite-difference Jacobians by residual shape and point, shared by loops.

    ``hits`` counts Jacobians served to a loop that did not compute them, ``computed``
    those computed (both read by tests and benchmarks).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._entries: dict[Hashable, list[_Entry]] = {}
        self.hits = 0
        self.computed = 0

    def get_or_compute(self, key: Hashable, x: np.ndarray, radius: float,
                       compute: Callable[[], np.ndarray]) -> tuple[np.ndarray, np.ndarray, bool]:
        """A Jacobian for ``x``: ``(J, where it was computed, computed here?)``.

        The nearest stored one within ``radius`` x ||x|| is returned (waiting for one in
        progress); otherwise ``compute()`` runs and its result is stored. If it raises
        (a spent budget, a shutdown), nothing is stored and loops waiting on it compute
        their own.
        """
        x = np.array(x, dtype=float)
        while True:
            with self._lock:
                entry = self._nearest(key, x, radius)
                if entry is None:
                    entry = _Entry(x)
                    self._entries.setdefault(key, []).append(entry)
                    break
            entry.ready.wait()
            if entry.jacobian is not None:
                with self._lock:
                    self.hits += 1
                return entry.jacobian.copy(), entry.x, False
        try:
            entry.jacobian = np.asarray(compute(), dtype=float)
        finally:
            if entry.jacobian is None:
                with self._lock:
                    self._entries[key].remove(entry)
            entry.ready.set()
        with self._lock:
            self.computed += 1
        return entry.jacobian.copy(), entry.x, True

    def _nearest(self, key: Hashable, x: np.ndarray, radius: float) -> _Entry | None:
        best, best_d = None, np.inf
        limit = radius * max(float(np.linalg.norm(x)), TINY)
        for e in self._entries.get(key, []):
            d = float(np.linalg.norm(e.x - x))
            # a finished entry beats a pending one at the same distance: no waiting
            if d <= limit and (d < best_d or (d == best_d and e.ready.is_set())):
                best, best_d = e, d
        return best
