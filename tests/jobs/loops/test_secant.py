"""Jacobian reuse: Broyden updates between full Jacobians, and a store shared by loops.

Analytic residuals only (no solver): a linear least-squares problem, where the first
full Jacobian is exact and no second one is ever needed; Rosenbrock's residuals, where
the secant model must be refreshed; a noisy (non-zero residual) problem whose answer
must be the full-Jacobian method's; two loops sharing a store.
"""

import threading

import numpy as np
import pytest

from jobs.loops import optimizers
from jobs.loops.jacobians import JacobianStore
from jobs.loops.secant import _Model, secant_least_squares


class Counted:
    """A batch function over a residual, recording every batch size."""

    def __init__(self, residual):
        self.residual, self.batches = residual, []

    def __call__(self, points):
        self.batches.append(len(points))
        return [np.asarray(self.residual(np.asarray(p, float)), float) for p in points]

    @property
    def used(self) -> int:
        return sum(self.batches)


def linear(n=6, m=15, seed=2):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(m, n))
    x_true = rng.uniform(5, 50, n)
    return a, x_true, (lambda x: a @ x - a @ x_true)


def rosenbrock(x):
    return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])


def test_broyden_update_is_exact_along_the_step_and_keeps_an_exact_linear_jacobian():
    a, _, _ = linear()
    rng = np.random.default_rng(0)
    model = _Model(a + rng.normal(scale=0.1, size=a.shape), np.zeros(a.shape[1]))
    s = rng.normal(size=a.shape[1])
    model.update(s, a @ s)
    np.testing.assert_allclose(model.jacobian @ s, a @ s)  # the secant condition
    exact = _Model(a.copy(), np.zeros(a.shape[1]))
    exact.update(s, a @ s)
    np.testing.assert_allclose(exact.jacobian, a, atol=1e-12)


def test_linear_problem_needs_one_jacobian_and_is_exact():
    _, x_true, residual = linear()
    f = Counted(residual)
    out = secant_least_squares(f, 0.9 * x_true, max_evaluations=100, fd_step=0.1,
                               ftol=1e-10, xtol=1e-10, radius=0.5)
    np.testing.assert_allclose(out.x, x_true, rtol=1e-8)
    assert out.status == "converged"
    assert f.batches[0] == 1 + x_true.size  # x0 and its columns in one round
    assert f.batches.count(x_true.size) == 0 and set(f.batches[1:]) == {1}


def test_rosenbrock_refreshes_the_secant_model_when_it_fails_and_converges():
    f = Counted(rosenbrock)
    out = secant_least_squares(f, np.array([-1.2, 1.0]), max_evaluations=500, fd_step=1e-7,
                               ftol=1e-12, xtol=1e-12)
    np.testing.assert_allclose(out.x, [1.0, 1.0], atol=1e-6)
    refreshes = f.batches[1:].count(2)  # a later batch of n = 2 is a full Jacobian
    assert refreshes >= 1  # the curved valley defeats the secant model at least once
    assert f.used < 100


def test_patience_answers_poor_steps_by_damping_before_a_new_jacobian():
    """Rosenbrock's curved valley: with patience, fewer refreshes, the same minimum."""
    runs = {}
    for patience in (0, 3):
        f = Counted(rosenbrock)
        out = secant_least_squares(f, np.array([-1.2, 1.0]), max_evaluations=500,
                                   fd_step=1e-7, ftol=1e-12, xtol=1e-12, patience=patience)
        np.testing.assert_allclose(out.x, [1.0, 1.0], atol=1e-6)
        runs[patience] = f.batches[1:].count(2)  # later batches of n = 2: full Jacobians
    assert runs[3] < runs[0]


def test_a_nonzero_residual_ends_where_the_full_jacobian_method_ends():
    """Noisy target: the stationary point of a secant J is not the problem's, so the
    last steps must be taken on a full Jacobian."""
    rng = np.random.default_rng(5)
    a, x_true, _ = linear(n=5, m=20)
    target = a @ x_true + rng.normal(scale=2.0, size=20)

    def residual(x):  # mildly nonlinear, like the tyre (J changes ~10 % over the path)
        return a @ x + 0.002 * (a @ x) ** 2 - target

    full = optimizers.least_squares(Counted(residual), 0.9 * x_true, max_evaluations=500,
                                    fd_step=1e-4, ftol=1e-10, xtol=1e-10, gtol=1e-15)
    for patience in (0, 2):  # damping before a refresh changes the path, not the end
        f = Counted(residual)
        out = secant_least_squares(f, 0.9 * x_true, max_evaluations=500, fd_step=1e-4,
                                   ftol=1e-10, xtol=1e-10, patience=patience)
        np.testing.assert_allclose(out.x, full.x, rtol=1e-5)
        assert out.objective == pytest.approx(full.objective, rel=1e-8)


@pytest.mark.parametrize("budget", [7, 9, 13])
def test_the_budget_is_exact(budget):
    _, x_true, residual = linear()
    f = Counted(residual)
    out = secant_least_squares(f, 0.5 * x_true, max_evaluations=budget, fd_step=0.1,
                               ftol=1e-14, xtol=1e-14)
    assert f.used <= budget
    assert out.status in ("max_evaluations", "converged")
    if out.status == "max_evaluations":
        assert f.used > budget - (1 + x_true.size)  # stopped only when the next round overran


def test_a_stop_condition_ends_the_loop():
    _, x_true, residual = linear()
    start = np.linalg.norm(residual(0.5 * x_true))
    out = secant_least_squares(Counted(residual), 0.5 * x_true, max_evaluations=500,
                               fd_step=0.1, stop=lambda x, f: f < 0.5 * start)
    assert out.status == "stopped" and out.objective < 0.5 * start


def sharing(store, key, anchors, residual, step=0.1, radius=0.2):
    """A ``shared`` callback over ``store``: Jacobians at the nearest anchor only."""
    def at(a):
        h = np.full(a.size, step)
        base = residual(a)
        return np.column_stack([(residual(a + h[j] * np.eye(a.size)[j]) - base) / h[j]
                                for j in range(a.size)])

    def shared(x):
        near = [a for a in anchors if np.linalg.norm(a - x) <= radius * np.linalg.norm(x)]
        if not near:
            return None
        a = min(near, key=lambda a: np.linalg.norm(a - x))
        return store.get_or_compute(key, a, 0.0, lambda: at(a))[:2]

    return shared


def test_two_loops_share_one_jacobian_through_the_store():
    _, x_true, residual = linear()
    store = JacobianStore()
    anchors = [0.9 * x_true]
    alone, first, second = Counted(residual), Counted(residual), Counted(residual)
    kwargs = {"max_evaluations": 100, "fd_step": 0.1, "ftol": 1e-10, "xtol": 1e-10,
              "radius": 0.2}
    secant_least_squares(alone, 0.9 * x_true, **kwargs)
    secant_least_squares(first, 0.9 * x_true, shared=sharing(store, "k", anchors, residual),
                         **kwargs)
    out = secant_least_squares(second, 0.95 * x_true,
                               shared=sharing(store, "k", anchors, residual), **kwargs)
    np.testing.assert_allclose(out.x, x_true, rtol=1e-8)
    # the shared Jacobian costs a loop's budget nothing: each evaluates its steps only
    assert first.used == alone.used - x_true.size
    assert second.used == first.used
    assert (store.computed, store.hits) == (1, 1)
    other = Counted(residual)  # another key (another method): nothing shared
    secant_least_squares(other, 0.9 * x_true, shared=sharing(store, "o", anchors, residual),
                         **kwargs)
    assert store.computed == 2


def test_a_loop_far_from_every_anchor_computes_its_own():
    _, x_true, residual = linear()
    store = JacobianStore()
    far = Counted(residual)
    secant_least_squares(far, 0.5 * x_true, max_evaluations=100, fd_step=0.1, radius=0.05,
                         shared=sharing(store, "k", [0.9 * x_true], residual, radius=0.05))
    assert far.batches[0] == 1 + x_true.size  # x0 and its own columns
    assert store.computed <= 1  # at most near the end, close to the anchor


def test_loops_in_threads_wait_for_a_jacobian_in_progress():
    store = JacobianStore()
    started, release = threading.Event(), threading.Event()
    calls = []

    def slow():
        calls.append(1)
        started.set()
        release.wait(5)
        return np.eye(2)

    got = []
    t1 = threading.Thread(target=lambda: got.append(store.get_or_compute("k", [1, 1], 0.1, slow)))
    t1.start()
    started.wait(5)
    t2 = threading.Thread(target=lambda: got.append(store.get_or_compute("k", [1, 1.01], 0.1,
                                                                          slow)))
    t2.start()
    release.set()
    t1.join(5)
    t2.join(5)
    assert len(calls) == 1 and len(got) == 2
    assert sorted(g[2] for g in got) == [False, True]


def test_a_failed_computation_is_not_stored():
    store = JacobianStore()

    def fails():
        raise RuntimeError("budget")

    with pytest.raises(RuntimeError):
        store.get_or_compute("k", [1.0], 0.5, fails)
    jac, _, computed = store.get_or_compute("k", [1.0], 0.5, lambda: np.ones((1, 1)))
    assert computed and jac[0, 0] == 1


class Based(Counted):
    """A batch function that records the base each batch was given (warm starts)."""

    def __init__(self, residual):
        super().__init__(residual)
        self.evaluated, self.bases = [], []

    def __call__(self, points, base=None):
        if base is not None:  # a base is always a point evaluated alone before
            assert any(np.array_equal(base, p) for p in self.evaluated)
        self.bases.append(None if base is None else np.array(base))
        if len(points) == 1:
            self.evaluated.append(np.array(points[0]))
        return super().__call__(points)


@pytest.mark.parametrize("optimiser", ["secant", "trf"])
def test_warm_starts_give_every_batch_after_the_first_its_evaluated_base(optimiser):
    _, x_true, residual = linear()
    f = Based(rosenbrock if optimiser == "secant" else residual)
    x0 = np.array([-1.2, 1.0]) if optimiser == "secant" else 0.9 * x_true
    if optimiser == "secant":
        out = secant_least_squares(f, x0, max_evaluations=500, fd_step=1e-7, ftol=1e-12,
                                   xtol=1e-12, warm_starts=True)
    else:
        out = optimizers.least_squares(f, x0, max_evaluations=100, fd_step=0.1,
                                       warm_starts=True)
    assert out.status == "converged"
    assert f.batches[0] == 1 and f.bases[0] is None  # x0 alone, from rest
    assert f.batches[1] == x0.size and np.array_equal(f.bases[1], x0)  # then its columns
    assert all(b is not None for b in f.bases[1:])


def test_without_warm_starts_the_batch_function_gets_no_base():
    _, x_true, residual = linear()
    f = Counted(residual)  # takes no base argument: calling it with one would fail
    optimizers.least_squares(f, 0.9 * x_true, max_evaluations=100, fd_step=0.1)
    secant_least_squares(f, 0.9 * x_true, max_evaluations=100, fd_step=0.1)
