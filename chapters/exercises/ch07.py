"""Chapter 7 exercises: time stepping and the real-time budget.

Fill in each function, then run ``python -m tissuefem grade ch07``.
You may use numpy, scipy and scikit-fem; do not import the answer from tissuefem.

Conventions: dof vectors are 1D numpy arrays; ``M`` is a (sparse or dense)
mass matrix, so ``M @ x`` works for both.
"""

import numpy as np


def backward_euler_residual(M, u, u_n, v_n, dt, f_int, f_ext):
    """Exercise 7.1. The backward-Euler residual, multiplied by ``dt**2``.

    The semi-discrete equations are ``M a = f_ext - f_int(u)``. Backward Euler
    sets ``v^{n+1} = (u^{n+1} - u^n) / dt`` and ``a^{n+1} = (v^{n+1} - v^n) / dt``
    and evaluates the forces at the new time. Write the residual that is zero
    at ``u = u^{n+1}``, multiplied through by ``dt**2`` (so it is the gradient
    of the incremental potential). ``f_int`` is the internal force *at u*
    (already evaluated), ``f_ext`` the external force. Mind the notes' slips
    (README, erratum 10). Return an array shaped like ``u``.
    """
    raise NotImplementedError("Exercise 7.1: the backward-Euler residual")


def budgeted_newton(x0, energy, gradient, newton_step, clock, budget, rtol):
    """Exercise 7.2. One budgeted frame: Newton with a line search that stops when the budget is spent.

    - ``energy(x) -> float`` and ``gradient(x) -> array`` (its gradient);
    - ``newton_step(x, g) -> dx`` solves the Newton system at ``x`` (with
      ``g = gradient(x)``); it is a descent direction: ``g @ dx < 0``;
    - ``clock() -> float`` seconds; ``budget`` seconds for the whole frame,
      counted from your first reading of the clock;
    - converged when ``||gradient(x)|| <= rtol * ||gradient(x0)||``.

    Rules: always take the first Newton step; before each later step, stop if
    the budget is spent. Accept a step only if it does not raise the energy
    (halve it until it does: a backtracking line search). Return
    ``(x, iterations, converged)``: the last accepted iterate (never one with
    a higher energy than ``x0``), the number of accepted steps, and a bool.
    """
    raise NotImplementedError("Exercise 7.2: one budgeted Newton frame")
