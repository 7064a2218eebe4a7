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
from .linsolve import available, rigid_body_modes
from .stepping import Stepper

__all__ = ["RealtimeSolver", "FRAME_BUDGET", "LINEAR_SOLVERS", "default_linear_solver"]

#: The linear solvers the real-time loop offers (``"constant"``: a quadratic model's; those with ``pardiso`` need
#: the optional ``pypardiso``).
LINEAR_SOLVERS = ("reuse-background", "reuse", "reuse-pardiso", "direct", "superlu", "superlu-colamd", "pardiso",
                  "constant")


def default_linear_solver(model) -> str:
    """The real-time default for ``model``: ``"constant"`` (one factorization per set of held dofs) for a
    quadratic model; else in 2D ``"reuse"`` (CG preconditioned by a kept SuperLU factorization) and in 3D
    ``"reuse-background-cholmod"`` (CG preconditioned by a kept CHOLMOD Cholesky factorization, refreshed on the
    second core: in 3D a factorization costs many frames and CHOLMOD's fills in less than half SuperLU's) where
    the optional ``scikit-sparse`` is installed, else ``"reuse-background"`` (the same with SuperLU);
    ``docs/benchmarks.md``, *Real time in 3D*."""
    if getattr(model, "quadratic", False):
        return "constant"
    X = getattr(model, "X", None)  # not a model: the stepper refuses it by name
    if X is None or X.shape[0] == 2:
        return "reuse"
    return "reuse-background-cholmod" if available("cholmod") else "reuse-background"


class RealtimeSolver(Stepper):
    """A :class:`~tissuefem.engine.stepping.Stepper` with a frame's defaults: ``budget = 1/30`` s, ``rtol =
    1e-6``, ``anytime = True``, the linear solver :func:`default_linear_solver` (by the model's dimension).
    A multigrid preconditioner (``"...cg-amg"``) is given the body's rigid motions (P1)."""

    def __init__(self, model, *, budget: float = FRAME_BUDGET, rtol: float = 1e-6, linear_solver=None,
                 clock=time.perf_counter, anytime: bool = True, **options):
        if linear_solver is None:
            linear_solver = default_linear_solver(model)
        super().__init__(model, budget=budget, rtol=rtol, linear_solver=linear_solver, clock=clock,
                         anytime=anytime, **options)
        if hasattr(self.linear.factorizing, "near_nullspace") and model.n_dofs == model.X.size:
            self.linear.use_rigid_modes(rigid_body_modes(model.X))
