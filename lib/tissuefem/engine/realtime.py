"""The real-time-budget solver: the notes' frame loop as a library object.

The notes' loop for an interactive simulator is: read the user's boundary
input, advance ``t``, solve, render, and do it every 1/30 s. A
:class:`RealtimeSolver` does one pass of it per call of :meth:`~RealtimeSolver.frame`:

1. **input**: the handles' new targets (validated *before* anything changes:
   a non-finite target raises ``ValueError`` and the state is untouched);
2. **warm start**: the lowest-energy of three guesses, the inertial
   prediction ``x~ = u^n + dt v^n``, the constant-acceleration prediction
   ``x~ + dt (v^n - v^{n-1})`` and the previous state ``u^n``, with the
   handles moved to their targets. If that start is not a valid state (a handle
   jerked so far that an element would invert under a model that cannot
   take it), the handles go only part of the way (halving the increment);
   the report's ``handle_fraction`` says how far, and the rest carries into
   the next frame, which aims at the full target again. A quasistatic frame
   has no inertial guess; instead its free dofs follow the handles by one
   linearised step from the previous state (``A_ff dx_f = -g_f - A_fc dx_c``,
   solved with the frame's linear solver): moving the held dofs alone would
   squash the elements beside them, invalid on a fine mesh or with P2 edge
   midpoints (on chapter 9's block with P2 at 4k triangles the handle
   then arrives in every frame instead of lagging, and frames are several
   times cheaper);
3. **solve**: Newton on the incremental potential of backward Euler,

       E(x) = 1/2 (x - x~)^T M (x - x~) + dt^2 [W(x) - f^T x],

   (or on ``W(x) - f^T x`` when ``dt`` is ``None``: a quasistatic frame),
   with an energy line search, until the residual is below
   ``atol + rtol ||grad E(x_0)||`` (free dofs; never below ``1e-12`` times the
   gradient over all dofs, reactions included: round-off) or the frame's **wall-clock budget** is
   spent. The clock is read before each tangent assembly and before each
   linear solve; once the budget is spent no new one starts, so a frame
   overruns by at most the one linear solve (or assembly) that was running
   when the budget ran out. Every frame takes at least one Newton step, so
   even a budget too small for anything makes progress;
4. **commit**: the accepted iterate becomes ``u^{n+1}`` (and
   ``v^{n+1} = (u^{n+1} - u^n)/dt``), converged or not. Every accepted
   iterate passed the line search, so the state is finite and its energy is
   not above the frame's start (*anytime*); the residual left over is in the
   report, and the next frame's warm start begins from there.

Speed comes from the fast P1 path (:class:`~tissuefem.assembly.P1Assembler`:
the matrix ``M + dt^2 K`` is assembled into a fixed pattern and condensed by
a precomputed gather, no sparse slicing per iteration), warm starts, and the
reuse of one factorization across Newton iterations *and frames* as the
preconditioner of conjugate gradients
(:class:`~tissuefem.linsolve.ReusedFactorization`), refreshed when CG slows.

The clock is a parameter (any callable returning seconds), so tests drive the
solver with a fake clock and are deterministic.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from . import linsolve
from .dynamics import external_with_gravity, mass_matrix

__all__ = ["RealtimeSolver", "ConstantTangentSolver", "FrameReport", "FRAME_BUDGET", "budgeted_newton", "BudgetedNewtonResult"]

#: the notes' frame time: 1/30 s
FRAME_BUDGET = 1.0 / 30.0


@dataclass
class FrameReport:
    """What one frame did."""

    frame: int  # frame number, from 1
    time: float  # simulated time after the frame
    converged: bool
    status: str  # "converged", "budget", "max-iterations", "line-search-failed"
    newton_iterations: int
    linear_iterations: int  # conjugate-gradient iterations (0 for direct solves)
    factorizations: int
    residual_norm: float  # ||grad E|| over the free dofs at the returned state
    initial_residual: float  # ... at the frame's warm start
    energy: float  # E at the returned state (the incremental potential, or W - f.u when quasistatic)
    start_energy: float  # E at the warm start: energy <= start_energy always
    elapsed: float  # clock seconds the frame used
    budget: float
    handle_fraction: float = 1.0  # how far the handles got towards their targets this frame
    line_search_cuts: int = 0
    warm_start: str = "inertial"  # "accelerating", "inertial" (u + dt v), "linearised" (quasistatic) or "previous" (u)
    residual_history: list[float] = field(default_factory=list)

    @property
    def relative_residual(self) -> float:
        return self.residual_norm / self.initial_residual if self.initial_residual > 0 else 0.0

    @property
    def over_budget(self) -> float:
        """Seconds past the budget (0 if within)."""
        return max(0.0, self.elapsed - self.budget)


def _check_positive(name, value, allow_inf=False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if math.isnan(v) or v <= 0 or (math.isinf(v) and not allow_inf):
        raise ValueError(f"{name} must be {'> 0' if allow_inf else 'finite and > 0'}, got {value!r}")
    return v


class _Condensed:
    """Gather map from the assembler's CSR data to the free-free block, for one set of prescribed dofs."""

    def __init__(self, assembler, free):
        n = assembler.n_dofs
        numbered = sp.csr_matrix(
            (np.arange(1, assembler.nnz + 1, dtype=float), assembler.indices, assembler.indptr), shape=(n, n)
        )
        block = numbered[free][:, free]
        self.gather = block.data.astype(np.intp) - 1
        self.indices, self.indptr, self.shape = block.indices, block.indptr, block.shape

    def __call__(self, data) -> sp.csr_matrix:
        A = sp.csr_matrix((data[self.gather], self.indices, self.indptr), shape=self.shape, copy=False)
        A.has_sorted_indices = True
        return A


@dataclass
class BudgetedNewtonResult:
    """What :func:`budgeted_newton` did."""

    x: np.ndarray
    energy: float
    converged: bool
    status: str  # "converged", "budget", "max-iterations", "line-search-failed"
    iterations: int
    residual_norm: float
    initial_residual: float
    cuts: int = 0
    history: list[float] = field(default_factory=list)


def budgeted_newton(x0, energy, gradient, direction, *, clock, budget, rtol=1e-6, atol=0.0, free=None,
                    max_iterations=50, start=None, tolerance=None, energy0=None) -> BudgetedNewtonResult:
    """Newton with an energy line search that stops when a wall-clock budget is spent (one frame's solve).

    ``direction(x, g)`` returns the Newton step (a descent direction, zero on
    fixed dofs), or ``None`` to stop at once (the budget ran out while it
    assembled). The clock is read before each step; the first step is always
    taken, later ones only while ``clock() - start < budget``. Every accepted
    iterate passed an Armijo test on ``energy``, so whenever the loop stops,
    ``x`` is finite and ``energy(x) <= energy(x0)``.

    Converged when ``||g|| <= atol + rtol ||g(x0)||`` over the ``free`` dofs
    (or ``tolerance(||g(x0)||, g(x0))`` when given).
    """
    start = clock() if start is None else start
    free = slice(None) if free is None else free
    x = np.array(x0, dtype=float, copy=True)
    E = float(energy(x)) if energy0 is None else float(energy0)
    g = gradient(x)
    rnorm = float(np.linalg.norm(g[free]))
    r0 = rnorm
    target = tolerance(r0, g) if tolerance is not None else atol + rtol * r0
    history, cuts, k = [rnorm], 0, 0
    e_scale = abs(E)
    while True:
        if rnorm <= target:
            status = "converged"
            break
        if k >= max_iterations:
            status = "max-iterations"
            break
        if k >= 1 and clock() - start >= budget:
            status = "budget"
            break
        dx = direction(x, g)
        if dx is None:
            status = "budget"
            break
        dx = np.asarray(dx, dtype=float)
        slope = float(g @ dx)  # directional derivative of the energy (negative: descent)
        if not (np.all(np.isfinite(dx)) and slope < 0):
            status = "line-search-failed"
            break
        e_scale = max(e_scale, abs(E), abs(slope))
        alpha, accepted = 1.0, False
        for _ in range(31):
            x_new = x + alpha * dx
            E_new = float(energy(x_new))
            if np.isfinite(E_new):
                if E_new <= E + 1e-4 * alpha * slope:
                    accepted = True
                elif E_new - E <= 1e-11 * e_scale:
                    # energy differences at round-off: accept if the residual still drops
                    accepted = bool(np.linalg.norm(gradient(x_new)[free]) < rnorm)
                if accepted:
                    break
            alpha *= 0.5
            cuts += 1
        if not accepted:
            status = "line-search-failed"
            break
        g_new = gradient(x_new)
        rn_new = float(np.linalg.norm(g_new[free]))
        if not np.isfinite(rn_new):
            status = "line-search-failed"
            break
        x, E, g, rnorm = x_new, min(E_new, E), g_new, rn_new
        k += 1
        history.append(rnorm)
    return BudgetedNewtonResult(x, E, status == "converged", status, k, rnorm, r0, cuts, history)


class RealtimeSolver:
    """A frame loop with a wall-clock budget per frame, around a :class:`~tissuefem.quasistatic.QuasistaticProblem`.

    Parameters
    ----------
    problem
        The body: mesh, material, handles (their targets are the user input),
        tractions and body force.
    dt
        Time step of backward Euler (default 1/30 s), or ``None`` for
        quasistatic frames (no inertia, no mass matrix built).
    density, mass, gravity
        As for :class:`~tissuefem.dynamics.BackwardEuler` (``mass`` is
        ``"lumped"`` or ``"consistent"``).
    budget
        Wall-clock seconds per frame (default 1/30); ``math.inf`` for no budget.
    rtol, atol
        A frame has converged when ``||grad E|| <= atol + rtol ||grad E(x_0)||``
        on the free dofs (``E`` is scaled by ``dt^2`` as above).
    linear_solver
        ``"reuse"`` (default: CG preconditioned by a kept SuperLU
        factorization), ``"reuse-<name>"`` (the same with another backend,
        e.g. ``"reuse-pardiso"``), ``"direct"`` (a fresh SuperLU factorization every
        Newton iteration), a backend name of :func:`tissuefem.linsolve.make`
        (a fresh factorization of that backend every iteration), or a backend
        object (a :class:`~tissuefem.linsolve.ReusedFactorization`, or one with
        ``factorize``).
    clock
        A callable returning seconds (default :func:`time.perf_counter`).
    max_iterations
        Newton iterations per frame at most (even with budget to spare).
    """

    def __init__(self, problem, *, dt=1.0 / 30.0, density: float = 1.0, mass: str = "lumped", gravity=None,
                 budget: float = FRAME_BUDGET, rtol: float = 1e-6, atol: float = 1e-12,
                 linear_solver="reuse", clock=time.perf_counter, max_iterations: int = 50):
        self.problem = problem
        self._dt = None if dt is None else _check_positive("dt", dt)
        self._budget = _check_positive("budget", budget, allow_inf=True)
        self.rtol = _check_positive("rtol", rtol)
        if not (np.isfinite(atol) and atol >= 0):
            raise ValueError(f"atol must be finite and >= 0, got {atol!r}")
        self.atol = float(atol)
        if isinstance(max_iterations, bool) or not isinstance(max_iterations, (int, np.integer)) or max_iterations < 1:
            raise ValueError(f"max_iterations must be a positive integer, got {max_iterations!r}")
        self.max_iterations = int(max_iterations)
        #: the inexact-Newton forcing term's cap: CG stops at this fraction of the current residual (or less).
        #: Measured on the standard drag at 8k triangles (Newton steps / CG iterations per frame):
        #: 0.1 -> 3.33 / 11.0, 0.01 -> 3.00 / 11.2, 0.001 -> 2.20 / 10.6, 1e-4 -> 2.07 / 12.0.
        self.forcing = 1e-3
        if not callable(clock):
            raise ValueError(f"clock must be a callable returning seconds, got {clock!r}")
        self.clock = clock
        if mass not in ("lumped", "consistent"):
            raise ValueError(f"mass must be 'lumped' or 'consistent', got {mass!r}")
        self.linear = self._make_linear(linear_solver)

        self.external = problem.external.copy()
        self.M = None
        if self.dt is not None:
            self.density = _check_positive("density", density)
            self.M = mass_matrix(problem.basis, self.density, lumped=(mass == "lumped"))
            self.external = external_with_gravity(problem, self.density, gravity)
        elif gravity is not None:
            raise ValueError("gravity needs a density and dt; for a quasistatic frame give the problem a body_force")

        self.assembler = problem.assembler  # None for P2 or the forms path: then the generic (slower) path
        if self.assembler is not None and self.M is not None:
            # the mass matrix's entries at the assembler's pattern positions (P1: same pattern)
            M = self.M.tocsr()
            rows = np.repeat(np.arange(self.assembler.n_dofs), np.diff(self.assembler.indptr))
            self._M_data = np.asarray(M[rows, self.assembler.indices]).ravel()
        self._condensed = {}

        n = problem.basis.N
        self.u = np.zeros(n)
        self.v = np.zeros(n)
        self.time = 0.0
        self._v_previous = None
        self.frames = 0
        self.last_report: FrameReport | None = None

    # ------------------------------------------------------------------ settings that may change between frames
    @property
    def dt(self):
        """The time step (``None`` for quasistatic frames). May be changed between frames: a value that is
        not finite and > 0 raises ``ValueError`` and the old one is kept."""
        return self._dt

    @dt.setter
    def dt(self, value):
        if self._dt is None or value is None:
            raise ValueError("dt cannot switch between quasistatic (None) and dynamic frames; make a new solver")
        self._dt = _check_positive("dt", value)

    @property
    def budget(self):
        """Wall-clock seconds per frame; may be changed between frames (``> 0``, ``math.inf`` for none)."""
        return self._budget

    @budget.setter
    def budget(self, value):
        self._budget = _check_positive("budget", value, allow_inf=True)

    # ------------------------------------------------------------------ set-up helpers
    @staticmethod
    def _make_linear(linear_solver):
        if isinstance(linear_solver, str):
            if linear_solver == "reuse":
                return linsolve.ReusedFactorization(linsolve.SuperLU())
            if linear_solver == "direct":
                return linsolve.SuperLU()
            if linear_solver.startswith("reuse-"):  # e.g. "reuse-pardiso": CG with a kept PARDISO factorization
                return linsolve.ReusedFactorization(linsolve.make(linear_solver[len("reuse-"):]))
            return linsolve.make(linear_solver)
        if isinstance(linear_solver, linsolve.ReusedFactorization) or callable(getattr(linear_solver, "factorize", None)):
            return linear_solver
        raise ValueError(
            f"linear_solver must be 'reuse', 'direct', a backend name or a backend object, got {linear_solver!r}"
        )

    @property
    def linear_solver_name(self) -> str:
        return getattr(self.linear, "name", type(self.linear).__name__)

    # ------------------------------------------------------------------ the objective
    def energy(self, x, x_tilde) -> float:
        W = self.problem.strain_energy(x) - float(self.external @ x)
        if self.dt is None:
            return W
        d = x - x_tilde
        return 0.5 * float(d @ (self.M @ d)) + self.dt**2 * W

    def gradient(self, x, x_tilde) -> np.ndarray:
        g = self.problem.internal_force(x) - self.external
        if self.dt is None:
            return g
        return self.M @ (x - x_tilde) + self.dt**2 * g

    def _hessian_free(self, x, free, fixed_key, K=None):
        """The free-free block of the Newton matrix at ``x`` (``K``: the stiffness at ``x`` if already assembled)."""
        if self.assembler is not None:
            data = (self.assembler.tangent(x) if K is None else K).data
            if self.dt is not None:
                data = self.dt**2 * data + self._M_data
            cond = self._condensed.get(fixed_key)
            if cond is None:
                if len(self._condensed) >= 8:  # each grab makes a new held set: keep the cache small
                    self._condensed.clear()
                cond = self._condensed[fixed_key] = _Condensed(self.assembler, free)
            return cond(data)
        K = self.problem.tangent(x) if K is None else K
        if self.dt is not None:
            K = self.M + self.dt**2 * K
        return sp.csr_matrix(K)[free][:, free]

    # ------------------------------------------------------------------ input
    def _validated_targets(self, targets):
        """``[(handle, target), ...]`` after checking every target (nothing is moved yet)."""
        handles = self.problem.handles
        if targets is None:
            return []
        if isinstance(targets, dict):
            items = list(targets.items())
        else:
            try:
                seq = list(targets)
            except TypeError:
                raise ValueError(f"targets must be a dict, a sequence (one per handle) or None, got {targets!r}") from None
            if len(seq) != len(handles):
                raise ValueError(f"targets has {len(seq)} entries but the problem has {len(handles)} handles")
            items = list(enumerate(seq))
        out = []
        for key, target in items:
            if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or not 0 <= key < len(handles):
                raise ValueError(f"targets: {key!r} is not a handle index (0..{len(handles) - 1})")
            if target is None:
                continue
            if not callable(target):
                t = np.asarray(target, dtype=float)
                if t.shape != (2,):
                    raise ValueError(f"targets[{key}] must be a translation (dx, dy) or a callable, got shape {t.shape}")
                if not np.all(np.isfinite(t)):
                    raise ValueError(f"targets[{key}] must be finite, got {t}")
                target = t
            out.append((handles[key], target))
        return out

    # ------------------------------------------------------------------ the frame
    def frame(self, targets=None) -> FrameReport:
        """Run one frame: apply ``targets``, solve within the budget, commit, report.

        ``targets``: ``None`` (handles stay where they are aiming), a sequence
        with one entry per handle (``None`` to leave one alone, a translation
        ``(dx, dy)``, or a map ``X -> x``), or a dict ``{handle index: target}``.
        """
        moves = self._validated_targets(targets)
        old_targets = [h.target for h in self.problem.handles]
        try:
            for handle, target in moves:
                handle.move(target)
            fixed, values = self.problem.prescribed()
        except ValueError:
            for h, t in zip(self.problem.handles, old_targets):
                h.target = t
            raise
        return self._solve_frame(fixed, values)

    def _solve_frame(self, fixed, values) -> FrameReport:
        start = self.clock()
        n = self.u.size
        free = np.setdiff1d(np.arange(n), fixed, assume_unique=True)
        fixed_key = fixed.tobytes()
        if getattr(self, "_fixed_key", None) != fixed_key:
            self._fixed_key = fixed_key
            if isinstance(self.linear, linsolve.ReusedFactorization):
                self.linear.invalidate()

        x_tilde = self.u + self.dt * self.v if self.dt is not None else self.u.copy()
        # warm start: the lower-energy of the inertial prediction and the previous state, handles moved;
        # if neither is valid, move the handles only part of the way
        previous = self.u[fixed]
        linearised, prediction_factorizations = None, 0
        if self.dt is None and np.any(values != previous):
            linearised, prediction_factorizations = self._linearised_increment(fixed, free, fixed_key,
                                                                               values - previous)
        x0, E0, fraction, which = None, math.inf, 1.0, "inertial"
        for halvings in range(12):
            fraction = 0.5**halvings
            prescribed = previous + fraction * (values - previous)
            if self.dt is None:
                candidates = [("previous", self.u)]
                if linearised is not None:
                    # the linear prediction scales with the handles' increment
                    candidates.insert(0, ("linearised", self.u + fraction * linearised))
            else:
                candidates = [("inertial", x_tilde), ("previous", self.u)]
                if self._v_previous is not None:
                    # constant acceleration: u + dt v + dt (v - v_previous), the best guess along a smooth drag
                    candidates.insert(0, ("accelerating", x_tilde + self.dt * (self.v - self._v_previous)))
            for name, base in candidates:
                x = base.copy()
                x[fixed] = prescribed
                with np.errstate(all="ignore"):
                    E = self.energy(x, x_tilde)
                if np.isfinite(E) and E < E0:
                    x0, E0, which = x, E, name
            if x0 is not None:
                break
        if x0 is None:  # the handles cannot move at all this frame without leaving the valid states
            fraction = 0.0
            x0 = self.u.copy()
            E0 = self.energy(x0, x_tilde)
            which = "previous"

        stats = {"cg": 0, "factorizations": prediction_factorizations, "r0": None}

        def direction(x, g):
            # the second budget check: after assembling the tangent, before the linear solve
            A = self._hessian_free(x, free, fixed_key)
            if stats["r0"] is not None and self.clock() - start >= self.budget:
                return None
            rnorm = float(np.linalg.norm(g[free]))
            if stats["r0"] is None:
                stats["r0"] = rnorm
            dx_free, its, fac = self._direction(A, -g[free], rnorm, stats["r0"], target[0])
            stats["cg"] += its
            stats["factorizations"] += fac
            dx = np.zeros(n)
            dx[free] = dx_free
            return dx

        target = [0.0]

        def tolerance(r0, g):
            # rtol relative to the frame's first residual, but never below round-off: the forces of the
            # whole body (reactions at the handles included) set that scale
            target[0] = self.atol + max(self.rtol * r0, 1e-12 * float(np.linalg.norm(g)))
            return target[0]

        with np.errstate(all="ignore"):
            result = budgeted_newton(
                x0,
                lambda x: self.energy(x, x_tilde),
                lambda x: self.gradient(x, x_tilde),
                direction,
                clock=self.clock,
                budget=self.budget,
                start=start,
                tolerance=tolerance,
                free=free,
                max_iterations=self.max_iterations,
                energy0=E0,
            )
        x = result.x
        status, k, cuts, rnorm, r0 = result.status, result.iterations, result.cuts, result.residual_norm, result.initial_residual
        cg_its, factorizations, history = stats["cg"], stats["factorizations"], result.history

        return self._commit(
            x, x_tilde, start, status=status, newton_iterations=k, linear_iterations=cg_its,
            factorizations=factorizations, residual_norm=rnorm, initial_residual=r0, start_energy=E0,
            handle_fraction=fraction, line_search_cuts=cuts, warm_start=which, residual_history=history,
        )

    def _linearised_increment(self, fixed, free, fixed_key, du_fixed):
        """``(dx, factorizations)``: the increment of every dof that moves the held ones by ``du_fixed`` to
        first order (quasistatic frames), and how many factorizations it took.

        From the previous state ``u`` (an equilibrium, or close to one):
        ``K_ff dx_f = -g_f(u) - K_fc dx_c``, with ``K`` assembled once. ``dx`` is
        ``None`` when it cannot be had (a singular or non-finite tangent): the
        plain guesses remain.
        """
        dx = np.zeros(self.u.size)
        dx[fixed] = du_fixed
        fac = 0
        try:
            with np.errstate(all="ignore"):
                K = self.problem.tangent(self.u)
                rhs = -self.gradient(self.u, self.u)[free] - (K @ dx)[free]
                A = self._hessian_free(self.u, free, fixed_key, K)
                if not (np.all(np.isfinite(A.data)) and np.all(np.isfinite(rhs))):
                    return None, 0
                if isinstance(self.linear, linsolve.ReusedFactorization):
                    dx_free, info = self.linear.solve(A, rhs, atol=0.0, rtol=1e-3)
                    fac = int(info.factorized)
                else:
                    factor = self.linear.factorize(A)
                    dx_free = factor.solve(rhs)
                    fac = 0 if hasattr(factor, "iterations") else 1
        except (RuntimeError, ValueError, np.linalg.LinAlgError, ZeroDivisionError):
            return None, fac
        if not np.all(np.isfinite(dx_free)):
            return None, fac
        dx[free] = dx_free
        return dx, fac

    def _commit(self, x, x_tilde, start, **report) -> FrameReport:
        """Make ``x`` the new state (velocity, time, frame count) and return the frame's report."""
        elapsed = self.clock() - start
        # commit: the accepted iterate is the new state, converged or not (it is finite and E <= E0)
        if self.dt is not None:
            self._v_previous = self.v
            self.v = (x - self.u) / self.dt
            self.time += self.dt
        self.u = x
        self.frames += 1
        report = FrameReport(
            frame=self.frames,
            time=self.time,
            converged=report["status"] == "converged",
            energy=float(self.energy(x, x_tilde)),
            elapsed=elapsed,
            budget=self.budget,
            **report,
        )
        self.last_report = report
        return report

    def _direction(self, A, rhs, rnorm, r0, target):
        """A descent direction for ``E`` from the linear system ``A dx = rhs``: ``(dx, cg_its, factorizations)``."""
        # inexact Newton: solve only as accurately as this iteration needs (a forcing term shrinking with the
        # residual, capped at self.forcing) and never tighter than a third of the frame's target
        eta = min(self.forcing, rnorm / r0) if r0 > 0 else self.forcing
        atol = max(eta * rnorm, 0.3 * target)
        its, fac = 0, 0
        dx = None
        if np.all(np.isfinite(A.data)):
            try:
                if isinstance(self.linear, linsolve.ReusedFactorization):
                    dx, info = self.linear.solve(A, rhs, atol=atol, rtol=0.0)
                    its, fac = info.iterations, int(info.factorized)
                    if not (np.all(np.isfinite(dx)) and rhs @ dx > 0) and not info.factorized:
                        dx, info = self.linear.solve(A, rhs, refactorize=True)
                        fac += 1
                else:
                    factor = self.linear.factorize(A)
                    dx = np.asarray(factor.solve(rhs), dtype=float)
                    # an iterative backend (PreconditionedCG) counts CG iterations and factorizes nothing
                    its = int(getattr(factor, "iterations", 0))
                    fac = 0 if hasattr(factor, "iterations") else 1
            except (RuntimeError, ValueError, np.linalg.LinAlgError, ZeroDivisionError):
                dx = None
        if dx is not None and np.all(np.isfinite(dx)) and rhs @ dx > 0:
            return dx, its, fac
        # not a descent direction (an indefinite tangent) or a failed solve: shift the diagonal
        diag = A.diagonal() if np.all(np.isfinite(A.data)) else np.ones(A.shape[0])
        scale = float(np.max(np.abs(diag), initial=0.0)) or 1.0
        eye = sp.identity(A.shape[0], format="csr")
        direct = linsolve.SuperLU()
        if np.all(np.isfinite(A.data)):
            for tau in scale * 10.0 ** np.arange(-6.0, 3.0):
                try:
                    dx = direct.factorize((A + tau * eye).tocsr()).solve(rhs)
                except RuntimeError:
                    continue
                fac += 1
                if np.all(np.isfinite(dx)) and rhs @ dx > 0:
                    return dx, its, fac
        return rhs / (1e3 * scale), its, fac  # steepest descent, as a last resort

    # ------------------------------------------------------------------ conveniences
    def run(self, targets_per_frame) -> list[FrameReport]:
        """Run one frame per entry of ``targets_per_frame`` (an iterable of ``targets``); return the reports."""
        return [self.frame(t) for t in targets_per_frame]

    def kinetic_energy(self) -> float:
        return 0.0 if self.M is None else 0.5 * float(self.v @ (self.M @ self.v))

    def total_energy(self) -> float:
        """Kinetic plus stored minus the work potential of the constant loads (gravity included)."""
        return self.kinetic_energy() + self.problem.strain_energy(self.u) - float(self.external @ self.u)

    def reset(self, u=None, v=None) -> None:
        """Set the state (default: rest), checking shapes and finiteness."""
        n = self.problem.basis.N
        for name, arr in (("u", u), ("v", v)):
            if arr is not None:
                a = np.asarray(arr, dtype=float)
                if a.shape != (n,):
                    raise ValueError(f"{name} must have shape ({n},), got {a.shape}")
                if not np.all(np.isfinite(a)):
                    raise ValueError(f"{name} contains non-finite values")
        if self.dt is None and v is not None and np.any(np.asarray(v, dtype=float)):
            raise ValueError("a quasistatic solver has no velocity: v must be zero or None")
        self.u = np.zeros(n) if u is None else np.array(u, dtype=float)
        self.v = np.zeros(n) if v is None else np.array(v, dtype=float)


class ConstantTangentSolver(RealtimeSolver):
    """The frame loop for a model whose Hessian is constant (small-strain linear elasticity, springs).

    Then ``E`` is quadratic and one Newton step from any start is exact:
    ``x = x0 - A_ff^{-1} grad E(x0)`` on the free dofs, with
    ``A = M + dt^2 K`` (or ``K`` when quasistatic). ``A_ff`` is factorised once
    per set of held dofs and kept, so a frame costs one gradient evaluation and
    one back-substitution. ``factorizations`` counts how often it factorised.

    Takes the same arguments as :class:`RealtimeSolver`; ``linear_solver`` must
    be a direct backend name (default ``"superlu"``) since the factorisation is
    the point.
    """

    def __init__(self, problem, *, linear_solver="superlu", **options):
        if not getattr(problem, "quadratic", False):
            raise ValueError("ConstantTangentSolver needs a problem whose energy is quadratic (problem.quadratic)")
        if linear_solver in ("reuse", "direct"):
            linear_solver = "superlu"
        super().__init__(problem, linear_solver=linear_solver, **options)
        if not callable(getattr(self.linear, "factorize", None)):
            raise ValueError(f"linear_solver must be a direct backend for a constant tangent, got {linear_solver!r}")
        self._factor, self._factor_key = None, None
        self.factorizations = 0

    def _solve_frame(self, fixed, values) -> FrameReport:
        start = self.clock()
        n = self.u.size
        free = np.setdiff1d(np.arange(n), fixed, assume_unique=True)
        key = (fixed.tobytes(), self.dt)  # A = M + dt^2 K changes with dt
        fac = 0
        if self._factor_key != key:
            A = self._hessian_free(np.zeros(n), free, key[0])
            try:
                self._factor = self.linear.factorize(A.tocsr())
            except RuntimeError as err:  # nothing committed: the state is unchanged
                raise ValueError(f"the constant tangent is singular ({err}): is a piece held by nothing?") from None
            self._factor_key = key
            self.factorizations += 1
            fac = 1
        x_tilde = self.u + self.dt * self.v if self.dt is not None else self.u.copy()
        x = (x_tilde if self.dt is not None else self.u).copy()
        x[fixed] = values
        E0 = self.energy(x, x_tilde)
        g = self.gradient(x, x_tilde)
        r0 = float(np.linalg.norm(g[free]))
        if free.size:
            x[free] -= self._factor.solve(g[free])
        if not np.all(np.isfinite(x)):  # keep the state: commit nothing
            raise ValueError("the linear solve returned non-finite values; the state is unchanged")
        g = self.gradient(x, x_tilde)
        rnorm = float(np.linalg.norm(g[free]))
        converged = rnorm <= self.atol + max(self.rtol * r0, 1e-12 * float(np.linalg.norm(g)))
        return self._commit(
            x, x_tilde, start, status="converged" if converged else "max-iterations", newton_iterations=1,
            linear_iterations=0, factorizations=fac, residual_norm=rnorm, initial_residual=r0, start_energy=E0,
            handle_fraction=1.0, line_search_cuts=0, warm_start="inertial" if self.dt is not None else "previous",
            residual_history=[r0, rnorm],
        )
