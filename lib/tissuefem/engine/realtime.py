"""The real-time loop: one step per drawn frame within a wall-clock budget (the notes' interactive simulator).

:meth:`RealtimeSolver.frame` reads the user's input and stops its Newton solve when the frame's budget
(:data:`~tissuefem.engine.constants.FRAME_BUDGET`) is spent -- the clock is read before each tangent assembly and
each linear solve, so a frame overruns by at most one solve -- and commits the last accepted iterate whether or not
it converged (*anytime*: finite and no higher in energy than the frame's start; the residual left carries into the
next frame). Every frame takes at least one Newton step. A factorization is kept across Newton iterations *and*
frames as CG's preconditioner (``"reuse"``); a quadratic model runs ``"constant"``: one factorization per set of
held dofs, then one back-substitution a frame. The clock is a parameter, so tests use a fake one.
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
