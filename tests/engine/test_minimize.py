"""The one minimiser's safeguards: descent directions from indefinite tangents, the step cap, the history."""

import numpy as np
import pytest
import scipy.sparse as sp

from tissuefem import newton


def _double_well():
    # E = x0^4/4 - x0^2/2 + x1^2/2: minima at x0 = +-1, a maximum at x0 = 0 (indefinite Hessian near it)
    energy = lambda x: 0.25 * x[0] ** 4 - 0.5 * x[0] ** 2 + 0.5 * x[1] ** 2  # noqa: E731
    residual = lambda x: np.array([x[0] ** 3 - x[0], x[1]])  # noqa: E731
    tangent = lambda x: sp.diags([3 * x[0] ** 2 - 1, 1.0])  # noqa: E731
    return energy, residual, tangent


def test_indefinite_tangent_is_shifted_to_a_descent_direction():
    energy, residual, tangent = _double_well()
    res = newton(np.array([0.1, 0.0]), residual, tangent, energy=energy, line_search="energy")
    assert res.converged
    np.testing.assert_allclose(abs(res.x[0]), 1.0, atol=1e-10)
    assert res.history[0].shift > 0  # the plain Newton step pointed uphill
    e = np.concatenate([[energy(np.array([0.1, 0.0]))], res.energies])
    assert np.all(np.diff(e) <= 1e-14)


def test_plain_newton_goes_uphill_on_the_same_problem():
    energy, residual, tangent = _double_well()
    res = newton(np.array([0.1, 0.0]), residual, tangent, line_search=None, max_iterations=50)
    assert res.converged and abs(res.x[0]) < 1e-10  # converges to the maximum: why the safeguard exists


def test_singular_tangent_does_not_stop_the_energy_solve():
    energy, residual, _ = _double_well()
    res = newton(np.array([0.5, 1.0]), residual, lambda x: sp.csr_matrix((2, 2)), energy=energy,
                       line_search="energy", max_iterations=200, rtol=1e-8)
    assert np.all(np.isfinite(res.x)) and res.status in ("converged", "max-iterations")
    assert res.history[0].shift > 0  # a shifted (regularised) system gave the direction
    assert res.energies[-1] < energy(np.array([0.5, 1.0]))


def test_max_step_caps_every_step_and_counts_cuts():
    energy = lambda x: 0.5 * float(x @ x)  # noqa: E731
    res = newton(np.array([10.0]), lambda x: x.copy(), lambda x: sp.identity(1), energy=energy,
                       line_search="energy", max_step=0.5, max_iterations=100)
    assert res.converged and res.iterations == 20  # 10 / 0.5
    assert all(h.step_norm <= 0.5 + 1e-12 for h in res.history)
    assert res.line_search_cuts == 0
    with pytest.raises(ValueError, match="max_step"):
        newton(np.array([1.0]), lambda x: x, lambda x: sp.identity(1), line_search=None, max_step=0.0)


def test_cuts_are_counted_from_step_lengths():
    # E = sqrt(1 + x^2): Newton overshoots wildly from x = 2, the line search halves
    energy = lambda x: float(np.sqrt(1 + x[0] ** 2))  # noqa: E731
    residual = lambda x: np.array([x[0] / np.sqrt(1 + x[0] ** 2)])  # noqa: E731
    tangent = lambda x: sp.csr_matrix([[(1 + x[0] ** 2) ** -1.5]])  # noqa: E731
    res = newton(np.array([2.0]), residual, tangent, energy=energy, line_search="energy")
    assert res.converged and res.line_search_cuts > 0
    assert res.line_search_cuts == sum(h.cuts for h in res.history)
    assert all(h.step_length == 2.0 ** -h.cuts for h in res.history)


def test_a_budget_stops_before_a_new_assembly_or_solve_but_never_before_the_first_step():
    clock = [0.0]

    def hessian(x):
        clock[0] += 1.0  # each assembly costs a second of fake time
        return sp.identity(1)

    energy = lambda x: float(np.cosh(x[0]))  # noqa: E731  Newton needs several steps from 3
    gradient = lambda x: np.array([np.sinh(x[0])])  # noqa: E731
    res = newton(np.array([3.0]), gradient, lambda x: sp.csr_matrix([[np.cosh(x[0])]]) if hessian(x) is not None else None,
                 energy=energy, clock=lambda: clock[0], budget=0.5, rtol=1e-12)
    assert res.status == "budget" and res.iterations == 1  # the first step runs whatever the budget
    assert energy(res.x) < energy(np.array([3.0]))
    clock[0] = 0.0
    res = newton(np.array([3.0]), gradient, lambda x: sp.csr_matrix([[np.cosh(x[0])]]) if hessian(x) is not None else None,
                 energy=energy, clock=lambda: clock[0], budget=100.0, rtol=1e-12)
    assert res.converged


def test_the_floor_stops_a_solve_at_round_off():
    # a residual that cannot fall below 1e-9 (noise): without the floor it would cut the step forever
    energy = lambda x: 0.5 * float(x @ x)  # noqa: E731
    noisy = lambda x: x + 1e-9  # noqa: E731
    res = newton(np.array([1.0]), noisy, lambda x: sp.identity(1), energy=energy, rtol=1e-15, floor=1e-8)
    assert res.converged and res.residual_norm <= 1e-8


def test_bad_settings_are_refused_by_name():
    args = (np.array([1.0]), lambda x: x, lambda x: sp.identity(1))
    for kw, name in (({"line_search": "wolfe"}, "line_search"), ({"rtol": -1.0}, "rtol"), ({"rtol": np.nan}, "rtol"),
                     ({"max_iterations": -1}, "max_iterations"), ({"max_iterations": 2.5}, "max_iterations")):
        with pytest.raises(ValueError, match=name):
            newton(*args, **{"line_search": None, **kw})
    with pytest.raises(ValueError, match="energy"):
        newton(*args, line_search="energy")
    with pytest.raises(ValueError, match="non-finite"):
        newton(np.array([np.nan]), *args[1:], line_search=None)
