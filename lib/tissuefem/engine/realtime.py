"""The real-time loop: one step per drawn frame within a wall-clock budget (the notes' interactive simulator).

:meth:`RealtimeSolver.frame` keeps the frame's budget (:data:`.constants.FRAME_BUDGET`) with every linear solver
of :data:`LINEAR_SOLVERS`: before each piece of work (an assembly, a factorization, a back-substitution, a CG
iteration) it reads the clock and starts the piece only if the piece's cost, learned from its last runs
(``solver.costs``), says it ends in time. A factorization that does not fit runs in the background (the second
core) while the frame goes on with the old one as CG's preconditioner, or the frame stops; then it commits the last
accepted iterate (*anytime*, see :mod:`.stepping`) and the residual left carries into the next frame. Only the first
frame ever, with no cost learned yet, runs its work whatever it costs (its report's ``unestimated`` says so); the
first Newton iteration's short pieces always run, so every frame makes progress. What a frame did not start is its
report's ``skipped``. The clock is a parameter, so tests use a fake one.
"""

from __future__ import annotations

import time

from .constants import FRAME_BUDGET
from .stepping import Stepper

__all__ = ["RealtimeSolver", "FRAME_BUDGET", "LINEAR_SOLVERS"]

#: The linear solvers the real-time loop offers (``"constant"``: a quadratic model's; those with ``pardiso`` need
#: the optional ``pypardiso``).
LINEAR_SOLVERS = ("reuse-background", "reuse", "reuse-pardiso", "direct", "superlu", "superlu-colamd", "pardiso",
                  "constant")


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
