"""The real-time loop: the notes' frame loop, one step per drawn frame within a wall-clock budget.

The notes' loop for an interactive simulator reads the user's boundary input,
advances ``t``, solves, renders, and must do it every 1/30 s. A
:class:`RealtimeSolver` is a :class:`~tissuefem.engine.stepping.Stepper` set up
for that loop: each :meth:`~RealtimeSolver.frame` is one step whose Newton solve
stops when the frame's budget (:data:`~tissuefem.engine.constants.FRAME_BUDGET`
by default) is spent -- the clock is read before each tangent assembly and
before each linear solve, so a frame overruns by at most the one solve that
was running -- and whose last accepted iterate is committed whether or not it
converged (*anytime*: it is finite and no higher in energy than the frame's
start, and the residual left over carries into the next frame). Every frame
takes at least one Newton step, so even a budget too small for anything makes
progress.

Speed comes from the fast assembly into a fixed pattern, warm starts, and a
factorization kept across Newton iterations *and* frames as the preconditioner
of conjugate gradients (:class:`~tissuefem.engine.linsolve.LinearSolver`
``"reuse"``), refreshed when CG slows down. A model whose Hessian is constant
(linear elasticity, springs) is best run with ``linear_solver="constant"``: one
factorization per set of held dofs, then one back-substitution a frame.

The clock is a parameter (any callable returning seconds), so tests drive the
loop with a fake clock and are deterministic.
"""

from __future__ import annotations

import time

from .constants import FRAME_BUDGET
from .stepping import Stepper

__all__ = ["RealtimeSolver", "FRAME_BUDGET"]


class RealtimeSolver(Stepper):
    """A :class:`~tissuefem.engine.stepping.Stepper` with a per-frame budget and anytime commits.

    Takes the arguments of :class:`~tissuefem.engine.stepping.Stepper`; the defaults differ:
    ``budget = 1/30`` s, ``rtol = 1e-6``, ``anytime = True``, and the linear solver is
    ``"constant"`` when the model is quadratic, else ``"reuse"``.
    """

    def __init__(self, model, *, budget: float = FRAME_BUDGET, rtol: float = 1e-6, linear_solver=None,
                 clock=time.perf_counter, anytime: bool = True, **options):
        if linear_solver is None:
            linear_solver = "constant" if getattr(model, "quadratic", False) else "reuse"
        super().__init__(model, budget=budget, rtol=rtol, linear_solver=linear_solver, clock=clock,
                         anytime=anytime, **options)
