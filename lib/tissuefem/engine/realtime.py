"""The real-time loop: one step per drawn frame within a wall-clock budget (the notes' interactive simulator).

:meth:`RealtimeSolver.frame` stops its Newton solve when the frame's budget (:data:`.constants.FRAME_BUDGET`)
is spent -- the clock is read before each assembly and linear solve, so a frame overruns by at most one solve
-- and commits the last accepted iterate (*anytime*, see :mod:`.stepping`); the residual left carries into the
next frame. The clock is a parameter, so tests use a fake one.
"""

from __future__ import annotations

import time

from .constants import FRAME_BUDGET
from .stepping import Stepper

__all__ = ["RealtimeSolver", "FRAME_BUDGET"]


class RealtimeSolver(Stepper):
    """A :class:`~tissuefem.engine.stepping.Stepper` with a frame's defaults: ``budget = 1/30`` s, ``rtol =
    1e-6``, ``anytime = True``, the linear solver ``"constant"`` (one factorization per set of held dofs) for
    a quadratic model, else ``"reuse"`` (a kept factorization as CG's preconditioner)."""

    def __init__(self, model, *, budget: float = FRAME_BUDGET, rtol: float = 1e-6, linear_solver=None,
                 clock=time.perf_counter, anytime: bool = True, **options):
        if linear_solver is None:
            linear_solver = "constant" if getattr(model, "quadratic", False) else "reuse"
        super().__init__(model, budget=budget, rtol=rtol, linear_solver=linear_solver, clock=clock,
                         anytime=anytime, **options)
