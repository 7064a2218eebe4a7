"""Exercises of chapter 7 (time stepping and the real-time budget), graded for the library and the student."""

import numpy as np
import pytest
import scipy.sparse as sp

from grading import assert_close, implementations
from tissuefem.workbook import answers


class Clock:
    """A fake clock: each Newton step (each call of the step function) costs one second."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


# --- 7.1 the backward-Euler residual -------------------------------------------------------------

@pytest.mark.parametrize("answer", implementations("ch07", "backward_euler_residual", answers.backward_euler_residual))
@pytest.mark.parametrize("dense", [True, False], ids=["dense-M", "sparse-M"])
def test_ex7_1_backward_euler_residual(answer, dense):
    rng = np.random.default_rng(71)
    n, dt = 6, 0.05
    B = rng.normal(size=(n, n))
    M = B @ B.T + n * np.eye(n)
    u, u_n, v_n, f_int, f_ext = (rng.normal(size=n) for _ in range(5))
    got = answer(M if dense else sp.csr_matrix(M), u, u_n, v_n, dt, f_int, f_ext)
    # written from the semi-discrete equations: M (v^{n+1} - v^n)/dt = f_ext - f_int, times dt^2
    v_new = (u - u_n) / dt
    expected = dt**2 * (M @ ((v_new - v_n) / dt) + f_int - f_ext)
    assert_close(got, expected, "the backward-Euler residual times dt^2", rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("answer", implementations("ch07", "backward_euler_residual", answers.backward_euler_residual))
def test_ex7_1_residual_is_zero_at_rest_and_for_free_flight(answer):
    n, dt = 4, 0.1
    M = np.diag([1.0, 2.0, 3.0, 4.0])
    v = np.array([1.0, -1.0, 0.5, 0.0])
    u_n = np.zeros(n)
    # no forces: the body moves on at constant velocity, u^{n+1} = u^n + dt v^n
    assert_close(answer(M, u_n + dt * v, u_n, v, dt, np.zeros(n), np.zeros(n)), np.zeros(n), "free flight")


# --- 7.2 one budgeted frame ----------------------------------------------------------------------

def _quadratic(n=5, seed=72):
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(n, n))
    A = B @ B.T + n * np.eye(n)
    b = rng.normal(size=n)
    return A, b, (lambda x: 0.5 * x @ A @ x - b @ x), (lambda x: A @ x - b)


def _tilted_well():
    """A non-convex energy in 2D where full Newton steps can overshoot: E = (x^2 - 1)^2 + (y - x)^2 / 2 + x / 4."""
    def energy(z):
        x, y = z
        return (x * x - 1.0) ** 2 + 0.5 * (y - x) ** 2 + 0.25 * x

    def gradient(z):
        x, y = z
        return np.array([4 * x * (x * x - 1.0) - (y - x) + 0.25, y - x])

    def hessian(z):
        x, _ = z
        return np.array([[12 * x * x - 4.0 + 1.0, -1.0], [-1.0, 1.0]])

    return energy, gradient, hessian


@pytest.mark.parametrize("answer", implementations("ch07", "budgeted_newton", answers.budgeted_newton))
def test_ex7_2_converges_on_a_quadratic_with_time_to_spare(answer):
    A, b, energy, gradient = _quadratic()
    clock = Clock()

    def step(x, g):
        clock.now += 1.0
        return np.linalg.solve(A, -g)

    x, iterations, converged = answer(np.zeros(5), energy, gradient, step, clock, 100.0, 1e-10)
    assert converged and iterations == 1
    assert_close(x, np.linalg.solve(A, b), "the minimiser", rtol=1e-9)


@pytest.mark.parametrize("answer", implementations("ch07", "budgeted_newton", answers.budgeted_newton))
@pytest.mark.parametrize("budget, max_steps", [(1e-9, 1), (0.5, 1), (2.5, 3), (3.0, 3)])
def test_ex7_2_stops_when_the_budget_is_spent(answer, budget, max_steps):
    energy, gradient, hessian = _tilted_well()
    clock = Clock()
    calls = []

    def step(x, g):
        clock.now += 1.0
        calls.append(x.copy())
        H = hessian(x)
        dx = np.linalg.solve(H, -g)
        return dx if g @ dx < 0 else -g  # fall back to steepest descent where H is indefinite

    x0 = np.array([0.1, 2.0])
    x, iterations, converged = answer(x0, energy, gradient, step, clock, budget, 1e-12)
    assert len(calls) <= max_steps  # the first step always, later ones only within the budget
    assert len(calls) >= 1 and iterations >= 1
    assert not converged
    assert np.all(np.isfinite(x)) and energy(x) <= energy(x0)


@pytest.mark.parametrize("answer", implementations("ch07", "budgeted_newton", answers.budgeted_newton))
def test_ex7_2_never_returns_a_higher_energy_and_converges_with_a_big_budget(answer):
    energy, gradient, hessian = _tilted_well()
    clock = Clock()

    def step(x, g):
        clock.now += 1.0
        dx = np.linalg.solve(hessian(x), -g)
        return dx if g @ dx < 0 else -g

    for x0 in ([0.1, 2.0], [-0.3, -3.0], [2.5, 0.0]):
        x0 = np.array(x0)
        x, iterations, converged = answer(x0, energy, gradient, step, clock, 1e6, 1e-10)
        assert converged and energy(x) <= energy(x0)
        assert np.linalg.norm(gradient(x)) <= 1e-10 * np.linalg.norm(gradient(x0))
