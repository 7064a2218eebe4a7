"""Stepping: every step -- quasistatic, backward Euler, a real-time frame -- minimises one potential,

    E(x) = W(x) [+ other terms] - f . x  [+ 1/(2 dt^2) (x - x~)^T M (x - x~)],   x~ = u^n + dt v^n,

the inertia term only with a time step (:mod:`.terms`). Its gradient is the backward-Euler residual (the
notes' ``q`` of "Time stepping", with the README's errata), without inertia the quasistatic one. A
:class:`Stepper` holds ``u, v`` and takes one step at a time:

1. **input**: the handles' new targets, checked before anything moves (a refusal changes nothing);
2. **warm start**: the lowest-energy valid guess. Dynamic: the constant-acceleration guess
   ``x~ + dt (v^n - v^{n-1})``, the inertial ``x~``, the previous state; quasistatic: one linearised step
   ``K_ff dx_f = -g_f - K_fc dx_c`` (the free dofs follow the handles), or the previous state. A quadratic
   model with its exact factorization takes the first valid one. If none is valid (an element would invert),
   the handles go part of the way (``handle_fraction``). With self-contact the handles' motion is taken as
   given (points dragged through the surface are counted in ``crossed`` and ignored until back out) and each
   guess is cut back to what collision detection allows;
3. **solve**: :func:`.minimize.newton` with the energy line search, until the residual is below
   ``atol + rtol ||g(x0)||`` (never below its round-off level) or the wall-clock ``budget`` is spent; one
   :class:`~.linsolve.LinearSolver` reuses a factorization across iterations *and* steps;
4. **commit**: a converged iterate becomes ``u^{n+1}`` (``v^{n+1} = (u^{n+1} - u^n)/dt``). An unconverged step
   keeps the state, or with ``anytime=True`` (the real-time loop) commits the last accepted iterate (finite,
   no higher in energy than the start);
5. **report**: every :class:`StepReport` says how far its result is from the solution it promises: the relative
   residual, the energy decrease, whether it converged, the smallest ``J = det F`` and the number of inverted
   elements, and what it left undone (:class:`Undone`); :attr:`StepReport.accuracy` puts them on one line.

:func:`solve`: the quasistatic solve of chapters 3 to 6, load steps ramping the loads and the handles.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .linsolve import LinearSolver
from .minimize import NewtonResult, check_budget, check_state, newton
from .model import Model
from .parameters import call_user, check_count, check_indices, check_positive, check_real, check_time_step
from .vectors import norm

__all__ = ["Stepper", "StepReport", "Undone", "StaticResult", "solve", "accuracy_summary"]

#: The residual's round-off level, relative to the body's force scale (see :func:`_roundoff_floors`).
_ROUNDOFF = 1e-13
#: The most Newton iterations a step may take, and the most load steps of :func:`solve`.
MAX_ITERATIONS = 100_000
MAX_LOAD_STEPS = 100_000


@dataclass(frozen=True)
class Undone:
    """What a step (frame) left for the ones after it; false when nothing. ``stopped``: why Newton stopped short of
    its tolerance (a status of :data:`~.minimize.STATUSES`; ``None``: it converged), after ``newton_steps`` at
    ``relative_residual`` (the step's :attr:`StepReport.scaled_residual`); ``handles``: the share of the handles'
    motion not made (``1 - handle_fraction``);
    ``committed``: False when the state was kept (an offline step that failed); ``skipped``: the pieces of work a
    budgeted step did not start because they would not have ended in time (kinds of :data:`.linsolve.WORK`)."""

    stopped: str | None = None
    newton_steps: int = 0
    relative_residual: float = 0.0
    handles: float = 0.0
    committed: bool = True
    skipped: tuple = ()

    def __bool__(self):
        return self.stopped is not None or self.handles > 0.0 or not self.committed

    def __str__(self):
        stopped = [] if self.stopped is None else [f"stopped ({self.stopped}) after {self.newton_steps} Newton steps "
                                                   f"at relative residual {self.relative_residual:.1e}"]
        return "; ".join(stopped + self.left()) or "nothing"

    def left(self) -> list[str]:
        """Besides an unfinished solve, in words: the share of the handles' motion not made, a kept state."""
        handles = [f"handles {self.handles:.0%} short"] if self.handles > 0.0 else []
        return handles + ([] if self.committed else ["state kept"])


@dataclass
class StepReport:
    """What one step (or real-time frame) did: the one report type of every solve of a model.

    Its accuracy, measured at the result ``x`` (the new state if committed): :attr:`converged`, :attr:`scaled_residual`,
    :attr:`energy_decrease`, ``min_J``, ``inverted``, :attr:`undone`; :attr:`accuracy` is all of them on one line.
    """

    newton: NewtonResult
    step: int  # step (frame) number after this one, from 1; unchanged when nothing was committed
    time: float  # simulated time after the step
    elapsed: float  # clock seconds the step used
    budget: float
    handle_fraction: float = 1.0  # how far the handles got towards their targets
    warm_start: str = "previous"  # "accelerating", "inertial", "linearised" or "previous"
    committed: bool = True  # whether the state moved to the result
    crossed: int = 0  # surface points found through the surface when the step started (self-contact)
    min_J: float = math.nan  # the smallest J = det F at x (over elements, or quadrature points)
    inverted: int = 0  # elements with J <= 0 at x (at any of their points)
    residual_scale: float = 0.0  # what the tolerance is relative to (see scaled_residual)
    #: the real-time loop's step too long for a frame (:class:`~.realtime.RealtimeSolver`): ``"running"``, it runs
    #: off the frame and this frame shows the last committed state (its accuracy is that state's, from the step
    #: before); ``"finished"``, this frame committed a step that ran off the frame for ``off_frame_seconds``
    off_frame: str = ""
    off_frame_seconds: float = 0.0

    contact_status = property(lambda self: "crossed" if self.crossed else "clear",
                              doc="``crossed``: the step started with surface points through the surface.")

    #: the Newton solve's results, passed on (``x``: the last accepted iterate, the new state if committed)
    FORWARDED = ("x", "converged", "status", "linear_iterations", "factorizations", "residual_norm",
                 "initial_residual", "relative_residual", "energy", "start_energy", "line_search_cuts",
                 "history", "energies", "residual_norms", "table", "skipped", "unestimated")

    def __getattr__(self, name):
        if name in StepReport.FORWARDED:
            return getattr(self.newton, name)
        raise AttributeError(f"StepReport has no attribute {name!r}")

    @property
    def newton_iterations(self) -> int:
        """The minimiser's Newton steps, plus one for a quasistatic step's linearised start."""
        return self.newton.iterations + (self.warm_start == "linearised")

    iterations = newton_iterations
    frame = property(lambda self: self.step)

    @property
    def scaled_residual(self) -> float:
        """``||g(x)||`` over ``residual_scale``, the residual the tolerance is relative to: the largest of
        ``||g(x0)||``, the load a quasistatic step's linearised start balances, and the round-off level over
        ``rtol``. A step converged if it is ``<= rtol`` (with ``atol = 0``). Not the Newton solve's own ratio
        :attr:`relative_residual` ``||g(x)|| / ||g(x0)||``, which a good start or a body at rest (``g(x0)`` at
        round-off) makes large."""
        return self.residual_norm / self.residual_scale if self.residual_scale > 0 else 0.0

    @property
    def energy_decrease(self) -> float:
        """``E(x0) - E(x)``: how much the solve lowered the step's potential from its warm start (``>= 0`` under the
        energy line search); NaN when an energy is unknown."""
        start, end = self.newton.start_energy, self.newton.energy
        return math.nan if start is None or end is None else float(start) - float(end)

    @property
    def undone(self) -> Undone:
        """What this step left for the next ones (:class:`Undone`; false when nothing)."""
        stopped = None if self.converged else self.status
        return Undone(stopped, self.newton_iterations, self.scaled_residual, 1.0 - self.handle_fraction,
                      self.committed, tuple(self.newton.skipped))

    @property
    def accuracy(self) -> str:
        """The step's accuracy on one line: converged or why it stopped, the relative residual, ``dE = E(x) - E(x0)``,
        min J, the inverted elements, what was left (:meth:`Undone.left`), the work a budget ``skipped`` or started
        ``unestimated`` (the first frame's), a step off the frame (:attr:`off_frame`)."""
        undone = self.undone
        head = "converged" if self.converged else f"{self.status} after {self.newton_iterations} Newton"
        rest = undone.left()
        rest += [f"skipped {', '.join(undone.skipped)}"] if undone.skipped else []
        rest += [f"unestimated {', '.join(self.newton.unestimated)}"] if self.newton.unestimated else []
        if self.off_frame:
            ran = f"ran off the frame ({self.off_frame_seconds:.2f} s: simulated time slower than real time)"
            rest.append("step " + ("running off the frame" if self.off_frame == "running" else ran))
        return " | ".join([head, f"rel. residual {self.scaled_residual:.1e}", f"dE {-self.energy_decrease:.1e}",
                           f"min J {self.min_J:.3f}", f"{self.inverted} inverted", *rest])

    def __repr__(self):
        crossed = f", {self.crossed} points through the surface" if self.crossed else ""
        return (f"StepReport(step {self.step}, {self.status}, {self.newton_iterations} Newton, "
                f"residual {self.residual_norm:.3g} (from {self.initial_residual:.3g}), {1e3 * self.elapsed:.1f} ms"
                f"{crossed})")


def accuracy_summary(reports) -> dict:
    """The accuracy of a run of steps (frames), for a benchmark's columns: ``scaled_residual`` (the median),
    ``converged`` (the share that converged), ``min_J`` (the smallest), ``inverted`` (the most in one step),
    ``undone`` (how many left something undone), ``steps`` and ``undone_reasons`` (what they left, sorted; a
    frame showing the last state while its step runs off the frame: ``"step off the frame"``).
    ``reports``: step reports, or anything with their ``scaled_residual, converged, min_J, inverted, undone``."""
    reports, reasons = list(reports), set()
    for r in reports:
        undone = r.undone
        reasons |= {undone.stopped} - {None}
        reasons |= {"handles short"} if undone.handles > 0.0 else set()
        running = getattr(r, "off_frame", "") == "running"
        reasons |= {"step off the frame"} if running else set() if undone.committed else {"state kept"}
    return {"scaled_residual": float(np.median([r.scaled_residual for r in reports])) if reports else math.nan,
            "converged": float(np.mean([r.converged for r in reports])) if reports else math.nan,
            "min_J": float(min((r.min_J for r in reports), default=math.nan)),
            "inverted": int(max((r.inverted for r in reports), default=0)),
            "undone": sum(bool(r.undone) for r in reports), "steps": len(reports), "undone_reasons": sorted(reasons)}


def jacobian_extremes(model: Model, x) -> tuple[float, int]:
    """``(min_J, inverted)`` at ``x``: the smallest ``J = det F`` and the number of elements with ``J <= 0`` (or
    not finite) at any of their points."""
    with np.errstate(all="ignore"):
        J = model.jacobian(x)
    bad = ~(J > 0.0)
    if J.ndim > 1:
        bad = bad.any(axis=tuple(range(1, J.ndim)))
    return float(np.min(J)) if J.size else math.nan, int(np.count_nonzero(bad))


def _finite_hessian(K):
    """``K`` if every entry is finite, else a ``ValueError`` (a linear solve must never factorize it)."""
    if not np.all(np.isfinite(K.data)):
        raise ValueError("the Hessian is not finite")
    return K


def _roundoff_floors(model: Model) -> tuple[float, float]:
    """``(residual floor, energy floor)``: the levels below which round-off hides the residual and the energy.

    At rest the stress is a difference of terms of the modulus' size (``mu F - mu F^-T``): each element's
    force errs by a few ``eps A_e |A(I)| |grad N|``. The floor, ``_ROUNDOFF`` times the norm of
    ``|A(I)| sqrt(A_e)`` summed at the nodes (``|grad N| ~ 1/h``), is thousands of times that error and far
    below any tolerance asked for; the energy's is ``_ROUNDOFF`` times the sum of ``|A(I)| A_e``.
    """
    d = model.X.shape[0]
    F = np.eye(d).reshape(d, d, 1)
    with np.errstate(all="ignore"):
        A = np.asarray(model._density.tangent(F))
    modulus = float(np.nanmax(np.abs(A))) if np.any(np.isfinite(A)) else 1.0
    areas = model.element_areas()
    t = model.mesh.t  # each element's modulus * sqrt(A_e) to each of its nodes
    nodal = np.bincount(t.ravel(), np.tile(modulus * np.sqrt(areas), t.shape[0]), minlength=model.mesh.nvertices)
    return _ROUNDOFF * math.sqrt(float(d)) * float(np.linalg.norm(nodal)), _ROUNDOFF * modulus * float(areas.sum())


class Stepper:
    """Steps a :class:`~tissuefem.engine.model.Model` forward: quasistatic if it has no inertia, else backward Euler.

    ``linear_solver``: a :class:`~tissuefem.engine.linsolve.LinearSolver` or its method name (``"reuse"``, the default:
    CG preconditioned by a kept factorization; ``"direct"``; ``"constant"`` for a quadratic model; a backend name).
    ``rtol, atol, max_iterations, line_search, max_step``: Newton's settings
    (:func:`~tissuefem.engine.minimize.newton`). ``budget``: wall-clock seconds per step (default: none) measured by
    ``clock`` (any callable returning seconds). ``anytime``: commit the last accepted iterate of an unconverged step
    (the real-time loop) instead of keeping the old state.
    """

    def __init__(self, model: Model, *, linear_solver="reuse", rtol: float = 1e-6, atol: float = 0.0,
                 max_iterations: int = 50, line_search: str = "energy", max_step: float | None = None,
                 budget: float = math.inf, clock=time.perf_counter, anytime: bool = False):
        if not isinstance(model, Model):
            raise ValueError(f"model must be a tissuefem Model, got {type(model).__name__}")
        self.model = model
        self.rtol = check_real("rtol", rtol, 0.0, 1.0, lo_open=True)
        self.atol = check_real("atol", atol, 0.0, None)
        self.max_iterations = check_count("max_iterations", max_iterations, 1, MAX_ITERATIONS)
        if line_search is not None and (not isinstance(line_search, str) or line_search not in ("energy", "finite")):
            raise ValueError(f"line_search must be 'energy', 'finite' or None, got {line_search!r}")
        self.line_search = line_search
        self.max_step = None if max_step is None else check_positive("max_step", max_step)
        self._budget = check_budget(budget)
        if not callable(clock):
            raise ValueError(f"clock must be a callable returning seconds, got {clock!r}")
        # read through a check: a clock that raises or returns no finite number of seconds is refused by name
        self._clock = lambda: check_real("clock (its reading in seconds)", call_user("clock", "clock", clock))
        if not isinstance(anytime, (bool, np.bool_)):
            raise ValueError(f"anytime must be True or False, got {anytime!r}")
        self.anytime = bool(anytime)
        self.linear = linear_solver if isinstance(linear_solver, LinearSolver) else LinearSolver(linear_solver)
        self.floor, self.energy_floor = _roundoff_floors(model)
        self.last_report: StepReport | None = None
        self._running = None  # a step running off the frame: (job, box), see settle
        self.set_state(None)  # at rest: u = v = 0, time 0, no steps

    @property
    def dt(self):
        """The time step (``None`` when quasistatic); may be changed between steps (checked)."""
        inertia = self.model.inertia
        return None if inertia is None else inertia.dt

    @dt.setter
    def dt(self, value):
        inertia = self.model.inertia
        if inertia is None or value is None:
            raise ValueError("dt cannot switch between quasistatic (None) and dynamic steps; build another model")
        dt = check_time_step(value)
        self.settle()
        if dt != inertia.dt:
            inertia.dt = dt
            self.linear.invalidate()  # M / dt^2 changed the Newton matrix

    @property
    def budget(self):
        """Wall-clock seconds per step; may be changed between steps (``> 0``, ``math.inf`` for none)."""
        return self._budget

    @budget.setter
    def budget(self, value):
        self._budget = check_budget(value)

    frames = property(lambda self: self.steps)
    linear_solver_name = property(lambda self: self.linear.name)
    costs = property(lambda self: self.linear.costs, doc="The learned seconds of each piece of a step's work "
                                                         "(:attr:`.linsolve.LinearSolver.costs`).")

    def reset(self, u=None, v=None) -> None:
        """Set the state (default: rest), keeping the time and the step count; checked, nothing changes on a refusal."""
        self.settle()  # first: a step it commits moves the time
        self.set_state(u, v, time_=self.time, steps=self.steps)

    def set_state(self, u, v=None, *, v_previous=None, time_=0.0, steps=0) -> None:
        """Carry a state over (after the model was rebuilt): displacement (``None``: zero), velocities, time and step
        count (all checked before anything changes)."""
        n = self.model.n_dofs
        u = np.zeros(n) if u is None else check_state("u", u, n)
        v = np.zeros(n) if v is None else check_state("v", v, n)
        if self.dt is None and np.any(v):
            raise ValueError("a quasistatic stepper has no velocity: v must be zero or None")
        if v_previous is not None:
            v_previous = check_state("v_previous", v_previous, n)
            if self.dt is None:
                raise ValueError("a quasistatic stepper has no velocity: v_previous must be None")
        t = check_real("time_", time_)
        steps = check_count("steps", steps, 0)
        self.settle()
        self.u, self.v, self.v_previous = u, v, v_previous
        self.time, self.steps = t, steps

    def kinetic_energy(self) -> float:
        inertia = self.model.inertia
        return 0.0 if inertia is None else inertia.kinetic_energy(self.v)

    def momentum(self) -> np.ndarray:
        inertia = self.model.inertia
        return np.zeros(self.model.X.shape[0]) if inertia is None else inertia.momentum(self.v)

    def total_energy(self) -> float:
        """Kinetic plus stored energy minus the work potential of the constant loads."""
        model = self.model
        return self.kinetic_energy() + model.stored_energy(self.u) - float(model.external @ self.u)

    def step(self, targets=None, *, prescribed=None, load: float = 1.0) -> StepReport:
        """Take one step: apply ``targets`` (see :meth:`Model.set_targets`), solve, commit, report. For load
        stepping, ``prescribed``: ``(dofs, values)`` held instead of the handles', ``load``: the loads' factor
        in ``[0, 1]``. All or nothing: whatever is refused or raised before the commit leaves the state, the
        targets and the model as they were."""
        self.settle()
        return self._commit(self._attempt(targets, prescribed, load))

    def settle(self) -> None:
        """Wait for a step running off the frame (:class:`~.realtime.RealtimeSolver`), if any, and commit it (its
        error, if it failed, is raised here: the state stays). Whatever changes the model or the state calls this
        first; a step started later sees the change."""
        if self._running is None:
            return
        (job, box), self._running = self._running, None
        job.join()
        if "error" in box:
            raise box["error"]
        self._commit(box["report"])

    def _commit(self, report: StepReport) -> StepReport:
        """Make ``report``'s result the state if it says so (nothing here can raise); the report."""
        if report.committed:
            if self.dt is not None:
                self.v_previous = self.v
                self.v = (report.x - self.u) / self.dt
            self.u, self.time, self.steps = report.x, report.time, report.step
        self.last_report = report
        return report

    def _attempt(self, targets, prescribed, load, budget=None) -> StepReport:
        """Steps 1 to 3 and 5 of the module docstring, without the commit: the report (``committed``: whether
        :meth:`_commit` makes its result the state); ``budget``: seconds, default the stepper's. All or nothing: an
        error puts back the targets this step was given (a step given none, as one off the frame, leaves the handles'
        targets alone: frames may have moved them while it ran)."""
        model = self.model
        load = check_real("load", load, 0.0, 1.0)
        if prescribed is not None:
            try:
                fixed, values = prescribed
            except (TypeError, ValueError):
                raise ValueError(f"prescribed must be (dofs, values), got {prescribed!r}") from None
            fixed = check_indices("prescribed dofs", fixed, model.n_dofs)
            prescribed = fixed, check_state("prescribed values", values, fixed.size)
        start = self._clock()
        inertia = model.inertia
        saved_targets = [] if targets is None else [(h, h.target) for h in model.handles]
        saved_x_tilde = None if inertia is None else inertia.x_tilde
        try:
            return self._step(targets, prescribed, load, start, self._budget if budget is None else budget)
        except BaseException:
            for h, target in saved_targets:
                h.target = target
            if inertia is not None:
                inertia.x_tilde = saved_x_tilde
            raise

    def _step(self, targets, prescribed, load, start, step_budget) -> StepReport:
        model = self.model
        model.set_targets(targets)
        fixed, values = model.prescribed() if prescribed is None else prescribed  # checked dof indices and floats
        if not np.all(np.isfinite(values)):
            raise ValueError("the prescribed displacements are not finite")
        free = np.ones(model.n_dofs, dtype=bool)
        free[fixed] = False

        inertia = model.inertia
        dt = None if inertia is None else inertia.dt
        loads = model.loads
        for term in loads:
            term.scale = float(load)
        try:
            if inertia is not None:
                inertia.x_tilde = self.u + dt * self.v
            # the budget less what the report's check of J is expected to take after the solve
            budget = max(step_budget - (self.linear.costs.get("report") or 0.0), 1e-9 * step_budget)
            deadline = self.linear.deadline(self._clock, start + budget)
            x0, E0, fraction, which, load_norm, pre, crossed, learned = self._warm_start(fixed, values, free, deadline)
            if fraction < 1.0 and not self.anytime:
                # the targets cannot be reached without leaving the valid (finite-energy) states: an offline
                # step fails at once (the real-time loop goes part of the way and carries the rest over)
                g = model.gradient(self.u)
                r = norm(g[free]) if np.all(np.isfinite(g)) else math.inf
                result, pre = NewtonResult(self.u.copy(), False, "non-finite", 0, r, r, 0.0, E0, E0), 0
            else:
                result = newton(
                    x0, model.gradient, model.hessian, energy=model.energy, free=free, line_search=self.line_search,
                    rtol=self.rtol, atol=self.atol, reference_norm=load_norm, floor=self.floor,
                    max_iterations=self.max_iterations - (which == "linearised"), max_step=self.max_step,
                    linear=self.linear, clock=self._clock, budget=budget, start=start, energy0=E0,
                    energy_floor=self.energy_floor, step_limit=model.step_limit, learned=learned,
                    safe_hessian=(lambda x: model.hessian(x, safe=True)) if model.has_safe_hessian else None)
        finally:
            for term in loads:
                term.scale = 1.0
            model.end_step()
        result.factorizations += pre
        result.skipped[:0] = [k for k in deadline.skipped if k not in result.skipped]
        result.unestimated[:0] = [k for k in deadline.unestimated if k not in result.unestimated]
        commit = result.converged or (self.anytime and np.all(np.isfinite(result.x)))
        min_J, inverted = deadline.timed("report", jacobian_extremes, model, result.x)  # timed with the step
        elapsed = self._clock() - start
        return StepReport(result, self.steps + bool(commit), self.time + (dt if commit and dt is not None else 0.0),
                          elapsed, step_budget, fraction, which, bool(commit), crossed, min_J, inverted,
                          max(result.initial_residual, load_norm, self.floor / self.rtol))

    frame = step

    def run(self, targets_per_step) -> list[StepReport]:
        """One step per entry of ``targets_per_step``; the reports."""
        return [self.step(t) for t in targets_per_step]

    def _warm_start(self, fixed, values, free, deadline):
        """``(x0, E0, handle_fraction, name, load_norm, factorizations, crossed, learned)``: step 2 of the module
        docstring; ``learned``: the seconds of its linearised increment, whose pieces the solver learns on their own.

        With self-contact the reference is the state with only the handles moved (``Model.begin_step``).
        """
        model, u = self.model, self.u
        limit = model.step_limit
        crossed = 0
        previous = u[fixed]
        dynamic = model.inertia is not None
        linearised, load_norm, factorizations, learned = None, 0.0, 0, 0.0
        if not dynamic and np.any(values != previous):
            # an assembly and a solve, if they fit (the solve itself starts no factorization that does not)
            if deadline.fits("assembly", *self.linear.least_work()):
                t0 = self._clock()
                linearised, load_norm, factorizations = self._linearised_increment(fixed, free, values - previous,
                                                                                   deadline)
                learned = self._clock() - t0
            else:
                deadline.skip("assembly")
        x_tilde = model.inertia.x_tilde if dynamic else None
        accelerating = None  # constant acceleration: the best guess along a smooth drag
        if dynamic and self.v_previous is not None:
            accelerating = x_tilde + model.inertia.dt * (self.v - self.v_previous)
        # a quadratic energy with its exact factorization and no step cap: one Newton step from any start reaches
        # the minimiser (and the linearised start is it), so the first valid start is as good as the best
        exact = model.quadratic and self.linear.constant and self.max_step is None
        for halvings in range(12):
            fraction = 0.5**halvings
            held = previous + fraction * (values - previous)
            # in order of preference; the linear prediction scales with the handles' increment
            scaled = None if linearised is None else u + fraction * linearised
            candidates = [(name, x) for name, x in (("accelerating", accelerating), ("inertial", x_tilde),
                                                    ("linearised", scaled), ("previous", u)) if x is not None]
            best = reference = None
            if model.notes_steps:
                reference = u.copy()
                reference[fixed] = held
                crossed = model.begin_step(reference, u)
            for name, base in candidates:
                x = base.copy()
                x[fixed] = held
                if limit is not None and name != "previous":
                    allowed = limit(reference, x - reference)
                    if allowed < 1.0:
                        x = reference + allowed * (x - reference)
                with np.errstate(all="ignore"):
                    E = model.energy(x)
                if np.isfinite(E) and (best is None or E < best[1]):
                    best = (x, E, name)
                    if exact:
                        break
            if best is not None:
                return best[0], best[1], fraction, best[2], load_norm, factorizations, crossed, learned
        x = u.copy()  # the handles cannot move at all without leaving the valid states: stay
        if model.notes_steps:
            crossed = model.begin_step(x, u)
        with np.errstate(all="ignore"):
            E = model.energy(x)
        return x, E, 0.0, "previous", load_norm, factorizations, crossed, learned

    def _linearised_increment(self, fixed, free, du_fixed, deadline):
        """``(dx, load_norm, factorizations)``: the first-order response of every dof to moving the held ones
        by ``du_fixed``, from the previous state: ``K_ff dx_f = -g_f(u) - K_fc dx_c``. ``dx`` is ``None`` when
        it cannot be had (a singular or non-finite tangent, or a solve that does not fit the ``deadline``)."""
        model = self.model
        dx = np.zeros(model.n_dofs)
        dx[fixed] = du_fixed
        try:
            with np.errstate(all="ignore"):
                if model.quadratic and self.linear.constant:
                    # a quadratic energy: g(u) + K dx is g(u + dx) exactly, and the constant K is assembled only
                    # when the kept factorization is to be made
                    rhs = -model.gradient(self.u + dx)[free]
                    A = self.linear.matrix(lambda: _finite_hessian(model.hessian(self.u)), free, deadline=deadline)
                else:
                    K = _finite_hessian(deadline.timed("assembly", model.hessian, self.u))
                    rhs = -model.gradient(self.u)[free] - (K @ dx)[free]
                    A = self.linear.matrix(lambda: K, free)
            load_norm = norm(rhs)
            if not math.isfinite(load_norm):  # a non-finite entry, or a norm that overflows: no prediction
                return None, 0.0, 0
            dx_free, info = self.linear.solve(A, rhs, atol=1e-3 * load_norm, deadline=deadline)
        except (RuntimeError, ValueError, np.linalg.LinAlgError, ZeroDivisionError):
            return None, 0.0, 0
        if dx_free is None or not np.all(np.isfinite(dx_free)):
            return None, load_norm, info.factorizations
        dx[free] = dx_free
        return dx, load_norm, info.factorizations


@dataclass
class StaticResult:
    """A quasistatic solve: the displacement, whether every load step converged, and each step's report."""

    u: np.ndarray
    converged: bool
    steps: list[StepReport] = field(default_factory=list)

    newton_iterations = property(lambda self: sum(r.newton_iterations for r in self.steps))
    status = property(lambda self: self.steps[-1].status if self.steps else "not run")


def solve(model: Model, load_steps: int = 1, u0=None, *, stepper: Stepper | None = None, **options) -> StaticResult:
    """Equilibrium of a quasistatic model: ramp the loads and the handles' displacements over ``load_steps``.

    ``options`` go to :class:`Stepper` (here ``rtol`` defaults to ``1e-10``). If a step fails, the result holds
    the last converged state and ``converged`` is False.
    """
    if not isinstance(model, Model):
        raise ValueError(f"model must be a tissuefem Model, got {type(model).__name__}")
    if model.inertia is not None:
        raise ValueError("solve() finds an equilibrium: give it a model without dt (use a Stepper for dynamics)")
    load_steps = check_count("load_steps", load_steps, 1, MAX_LOAD_STEPS)
    if u0 is not None:
        u0 = check_state("u0", u0, model.n_dofs)
    if stepper is None:
        options.setdefault("rtol", 1e-10)
        stepper = Stepper(model, **options)
    elif not isinstance(stepper, Stepper) or stepper.model is not model:
        raise ValueError("stepper must be a Stepper of this model")
    elif options:
        raise ValueError(f"give either a stepper or its options, not both (options: {sorted(options)})")
    fixed, values = model.prescribed()  # a target that cannot be evaluated is refused before the stepper changes
    stepper.reset(u0)
    start = stepper.u[fixed].copy()
    steps = []
    for s in np.arange(1, load_steps + 1) / load_steps:
        steps.append(stepper.step(prescribed=(fixed, start + s * (values - start)), load=s))
        if not steps[-1].converged:
            break
    return StaticResult(stepper.u.copy(), steps[-1].converged, steps)
