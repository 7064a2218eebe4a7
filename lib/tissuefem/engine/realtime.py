"""The real-time loop: one step per drawn frame within a wall-clock budget (the notes' interactive simulator).

:meth:`RealtimeSolver.frame` keeps the frame's budget (:data:`.constants.FRAME_BUDGET`) with every linear solver of
:data:`LINEAR_SOLVERS`: before each piece of work (an assembly, a factorization, a back-substitution, a CG iteration) it
reads the clock and starts the piece only if the piece's cost, learned from its last runs (``solver.costs``), says it
ends in time. A factorization that does not fit runs in the background (the second core) while the frame goes on with
the old one as CG's preconditioner, or the frame stops; then it commits the last accepted iterate (*anytime*, see
:mod:`.stepping`) and the residual left carries into the next frame. The first Newton iteration's short pieces always
run, so every frame makes progress. What a frame did not start is its report's ``skipped``. The clock is a parameter, so
tests use a fake one.

**The first step is predicted.** With nothing learned yet, the first step ever is predicted to cost
:data:`FIRST_STEP_COST` seconds per dof: if that fits the budget it runs on the frame, all its work whatever it costs,
and learns the costs (its report's ``unestimated`` says so), else it runs off the frame (below) and learns them there.

**A step too long for a frame runs off it.** When the learned costs say that a step's start (its warm start) and one
Newton iteration (an assembly, the least solve, a line search and the report's check of J), which a frame always runs,
take more than :data:`FIRST_ITERATION_SHARE` of the budget, the frame does not start the step: it hands the step to a
worker thread (numpy and scipy leave the interpreter's lock in the heavy parts) and returns at once with the last
committed state; its report's ``off_frame`` is ``"running"``. The step there has a budget of its own
(:meth:`RealtimeSolver.off_frame_budget`: a few frames) and commits, like a frame, its last accepted iterate if it did
not converge by then (its report's residual says how far it is), so that the next step starts. The frames after it
return at once too, until one finds the step finished and commits it (``off_frame == "finished"``). Simulated time then
advances slower than real time: one step of ``dt`` per so many frames (the report's ``off_frame_seconds`` says how long
the step took). The handles' targets given meanwhile are kept for the next step; whatever changes the model or the state
first waits for the running step (:meth:`~.stepping.Stepper.settle`).
"""

from __future__ import annotations

import math

import numpy as np

from .constants import FRAME_BUDGET
from .linsolve import available, check_launch, start_thread
from .minimize import NewtonResult
from .model import Model
from .parameters import ParameterError
from .stepping import Stepper, StepReport

__all__ = ["RealtimeSolver", "FRAME_BUDGET", "LINEAR_SOLVERS", "FIRST_STEP_COST", "FIRST_ITERATION_SHARE",
           "OFF_FRAME_SLOWDOWN", "OFF_FRAME_FRAMES", "default_linear_solver"]

#: What a first step (nothing learned yet: it factorizes) is predicted to cost, seconds per dof: about twice what it
#: took on the machine of docs/benchmarks.md (3.5 to 7.5 us per dof from 2k to 128k triangles), so that a frame
#: holds the first step of up to 3000 dofs.
FIRST_STEP_COST = FRAME_BUDGET / 3000

#: The share of the budget a step's start and first Newton iteration may be learned to take for the step to run on
#: the frame (they always run there: the rest of the budget is room for their spread; beyond it the step runs off the
#: frame).
FIRST_ITERATION_SHARE = 0.8

#: How many times its cost off the frame a piece of work is expected to take on it. Off the frame a step runs beside
#: nothing (the frames only wait for it); on the frame, beside a factorization on the second core, which on a 2-core
#: machine whose cores share one physical core slows the frame's work down. Costs learned off the frame count this
#: many times when they decide whether the step after one off the frame fits the frame, so that the loop does not
#: come back only to overrun the frame and leave again: at 16k triangles a factor of 2 brought it back, and its
#: frames then took up to 45 ms (docs/benchmarks.md).
OFF_FRAME_SLOWDOWN = 3.0

#: A step that runs off the frame may take this many frames' budgets (or, if more, twice a Newton iteration's learned
#: cost: :meth:`RealtimeSolver.off_frame_budget`). Solved to convergence, such a step of a large model took many
#: frames (measured, 11 Newton iterations and 1.4 s at 32k triangles), and the loop committed one step in 60 frames;
#: with four, a step commits what it reached after a few Newton iterations (at least one), and the residual left
#: carries into the next step, as a frame's does. Simulated time then runs four times slower than real time, or more
#: where one iteration takes longer (docs/benchmarks.md: one step in about twelve frames at 128k triangles).
OFF_FRAME_FRAMES = 4

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
    if isinstance(model, Model) and model.quadratic:
        return "constant"
    if not isinstance(model, Model) or model.X.shape[0] == 2:  # (not a model: the stepper refuses it by name)
        return "reuse"
    return "reuse-background-cholmod" if available("cholmod") else "reuse-background"


class RealtimeSolver(Stepper):
    """A :class:`~tissuefem.engine.stepping.Stepper` with a frame's defaults: ``budget = 1/30`` s, ``anytime = True``,
    the linear solver :func:`default_linear_solver` (by the model's dimension; a multigrid preconditioner,
    ``"...cg-amg"``, is given the body's rigid motions). ``launch(work)``: how a step too long for a frame starts off
    it, returning a job with ``is_alive`` and ``join`` (a test passes one it controls; default: the linear solver's
    ``launch``, else :func:`.linsolve.start_thread`); ``off_frame=False``: every step on the frame, however long (each
    frame then does at least its first Newton iteration)."""

    def __init__(self, model, *, budget: float = FRAME_BUDGET, linear_solver=None, anytime: bool = True, launch=None,
                 off_frame: bool = True, **options):
        launch = check_launch(launch)  # refused before anything is built
        if linear_solver is None:
            linear_solver = default_linear_solver(model)
        super().__init__(model, budget=budget, linear_solver=linear_solver, anytime=anytime, **options)
        if model.n_dofs == model.X.size:  # dofs node by node: a multigrid preconditioner keeps the rigid motions
            self.linear.use_rigid_modes(model.X)
        if not isinstance(off_frame, bool):
            raise ParameterError("off_frame", f"off_frame must be True or False, got {off_frame!r}")
        self.launch, self.off_frame = launch, off_frame
        self.off_costs = {}  # the pieces' costs learned by steps off the frame (see too_long)

    running = property(lambda self: self._running is not None, doc="Whether a step runs off the frame (not committed).")

    def too_long(self) -> bool:
        """Whether the next step goes off the frame: with nothing learned yet, when its predicted cost
        (:data:`FIRST_STEP_COST` per dof) exceeds the budget; else when the costs learned on the frame (``costs``),
        or, after a step off the frame, those learned off it (``off_costs``) :data:`OFF_FRAME_SLOWDOWN` times, say
        the step's start and one Newton iteration (:meth:`_iteration_cost`) take more than
        :data:`FIRST_ITERATION_SHARE` of it."""
        if not (self.off_frame and math.isfinite(self.budget)):
            return False
        share, last = FIRST_ITERATION_SHARE * self.budget, self.last_report
        if self.off_costs and (not self.costs or (last is not None and last.off_frame)):
            return OFF_FRAME_SLOWDOWN * self._iteration_cost(self.off_costs) > share
        if self.costs:
            return self._iteration_cost(self.costs) > share
        return self.model.n_dofs * FIRST_STEP_COST > self.budget

    def off_frame_budget(self) -> float:
        """The budget of a step that runs off the frame, seconds: :data:`OFF_FRAME_FRAMES` frames' budgets, or twice
        what its start and first Newton iteration (which always runs) are learned to cost, if that is more."""
        return max(OFF_FRAME_FRAMES * self.budget, 2.0 * self._iteration_cost(self.off_costs or self.costs))

    def _iteration_cost(self, costs) -> float:
        """A step's learned seconds up to its first Newton iteration's end: its start (the warm start's energies and
        the first gradient), an assembly (unless a kept constant factorization makes it unnecessary), the least
        solve, a line search and the report's check of J; a CG iteration costing at least its preconditioner's
        back-substitution."""
        fixed, _ = self.model.prescribed()
        free = np.ones(self.model.n_dofs, dtype=bool)
        free[fixed] = False
        kinds = ("start", *(("assembly",) if self.linear.assembles(free) else ()), *self.linear.least_work(),
                 "line-search", "report")
        costs = dict(costs)
        costs.setdefault("cg-iteration", costs.get("back-substitution"))
        return sum(costs.get(kind) or 0.0 for kind in kinds)

    def step(self, targets=None, *, prescribed=None, load: float = 1.0) -> StepReport:
        """One frame (see the module docstring): a step within the budget, or one started, still running or
        committed off the frame. ``prescribed`` and ``load`` (load stepping) always step on the frame."""
        start = self._clock()
        if self._running is None and (prescribed is not None or load != 1.0 or not self.too_long()):
            if not self.costs:  # the first step on the frame after steps off it: their costs, slowed down
                self.costs.update({kind: OFF_FRAME_SLOWDOWN * cost for kind, cost in self.off_costs.items()})
            return super().step(targets, prescribed=prescribed, load=load)
        self.model.set_targets(targets)  # checked, all or nothing; the step off the frame (the next one) reads them
        if self._running is not None:
            if self._running[0].is_alive():
                return self._running_report(start)
            self.settle()
            seconds, report = self.last_report.elapsed, self.last_report
            report.elapsed, report.off_frame, report.off_frame_seconds = self._clock() - start, "finished", seconds
            return report
        box, budget = {}, self.off_frame_budget()

        def work():  # the whole step, on a budget of its own; committed by a later frame (settle)
            if not self.off_costs:  # the frame's costs to start from (they are higher, if anything)
                self.off_costs.update(self.linear.costs)
            costs, self.linear.costs = self.linear.costs, self.off_costs  # its pieces learn the costs off the frame
            try:
                box["report"] = self._attempt(None, None, 1.0, budget=budget)
            except BaseException as err:  # handed to the frame that settles
                box["error"] = err
            finally:
                self.linear.costs = costs
        self._running = ((self.launch or self.linear.launch or start_thread)(work), box)
        return self._running_report(start)

    frame = step

    def _running_report(self, start) -> StepReport:
        """The report of a frame that shows the last committed state while a step runs off the frame."""
        last = self.last_report
        residual, energy = (last.residual_norm, last.energy) if last is not None else (math.nan, None)
        result = NewtonResult(self.u, False, "budget", 0, residual, residual, 0.0, energy, energy)
        measured = (last.min_J, last.inverted, last.residual_scale) if last is not None else (math.nan, 0, 0.0)
        return StepReport(result, self.steps, self.time, self._clock() - start, self._budget, 1.0, "previous",
                          False, 0, *measured, off_frame="running")
