"""The one minimiser: Newton's method with an energy line search, safeguards, and an optional time budget.

Every solve in tissuefem is a call of :func:`newton`, the notes' iteration ``dq/du (u^k) du = -q(u^k)``,
``u^{k+1} = u^k + du``, with safeguards for when ``q`` is the gradient of an energy ``E``:

* **line search** ``"energy"``: Armijo backtracking on ``E`` (at round-off, a step that lowers the residual is
  accepted); ``"finite"`` halves until the residual is finite; ``None`` is the notes' plain iteration.
* **descent**: under the energy line search a direction that is not downhill (``q . du >= 0``) makes the linear
  solver refactorize, then the tangent is shifted by ``tau I`` with growing ``tau``, at last steepest descent.
* **step cap** ``max_step`` and **admissible steps** ``step_limit`` (self-contact) before the line search; a **time
  budget** measured by ``clock``: no piece of work (an assembly, a solve, a factorization) starts unless its cost,
  learned by the linear solver (:class:`~.linsolve.Deadline`), says it ends in time; only the first iteration's
  short pieces always run.

A numerical failure never escapes as an exception or a NaN state: it is the result's ``status``, its ``x`` the last
accepted iterate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse as sp

from .linsolve import Deadline, LinearSolver, SuperLU
from .parameters import (ParameterError, check_count, check_indices, check_positive, check_real, check_real_array,
                         check_real_number)
from .vectors import dot, norm

__all__ = ["newton", "NewtonResult", "NewtonIteration", "STATUSES"]

#: Why a solve stopped.
STATUSES = ("converged", "budget", "max-iterations", "line-search-failed", "non-finite", "singular", "blocked")

#: Armijo's sufficient-decrease constant.
_ARMIJO = 1e-4
#: Energy differences below this fraction of the solve's energy scale are round-off.
_ENERGY_ROUNDOFF = 1e-11
#: The most halvings of one step in the line search.
_MAX_HALVINGS = 30


@dataclass
class NewtonIteration:
    """One row of the convergence history."""

    iteration: int
    residual_norm: float  # ||q(u^k)|| over the free dofs, before the step
    step_norm: float  # ||du|| actually taken (after the line search and the cap)
    step_length: float  # line-search factor alpha (1 = the full Newton step)
    energy: float | None = None  # energy after the step, when known
    shift: float = 0.0  # tau added to the tangent's diagonal to get a descent direction (0: none)
    linear_iterations: int = 0  # conjugate-gradient iterations of this step's linear solve

    @property
    def cuts(self) -> int:
        """How many times the line search halved the step (``alpha = 2**-cuts``)."""
        return int(round(-math.log2(self.step_length))) if self.step_length > 0 else 0


@dataclass
class NewtonResult:
    """What :func:`newton` did: the last accepted iterate, why it stopped, and the history."""

    x: np.ndarray
    converged: bool
    status: str  # one of STATUSES
    iterations: int
    residual_norm: float  # ||q|| over the free dofs at x
    initial_residual: float  # ... at x0
    target: float  # the residual it had to reach
    energy: float | None = None  # E(x), when an energy was given
    start_energy: float | None = None  # E(x0)
    linear_iterations: int = 0
    factorizations: int = 0
    history: list[NewtonIteration] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)  # work not started for the budget (kinds of linsolve.WORK)
    unestimated: list[str] = field(default_factory=list)  # work started under a budget with no cost estimate yet

    @property
    def line_search_cuts(self) -> int:
        """Total number of step halvings over the solve."""
        return sum(h.cuts for h in self.history)

    @property
    def energies(self) -> np.ndarray:
        """Energy after each accepted step (NaN where unknown)."""
        return np.array([np.nan if h.energy is None else h.energy for h in self.history])

    def residual_norms(self) -> np.ndarray:
        """Residual norms ``||q(u^k)||`` for k = 0, 1, ..., the final one included."""
        return np.array([h.residual_norm for h in self.history] + [self.residual_norm])

    @property
    def relative_residual(self) -> float:
        return self.residual_norm / self.initial_residual if self.initial_residual > 0 else 0.0

    def table(self) -> str:
        """The history as a plain-text table: iteration, residual, step, alpha, and the quadratic ratio."""
        norms = self.residual_norms()
        lines = [f"{'k':>3} {'|q(u^k)|':>12} {'|du|':>11} {'alpha':>6} {'|q_k+1|/|q_k|^2':>16}"]
        for h in self.history:
            k = h.iteration
            ratio = f"{norms[k + 1] / norms[k] ** 2:16.3e}" if k + 1 < len(norms) and norms[k] > 0 else ""
            lines.append(f"{k:>3} {h.residual_norm:12.4e} {h.step_norm:11.3e} {h.step_length:6.3f} {ratio}")
        lines.append(f"{len(self.history):>3} {self.residual_norm:12.4e}   ({self.status})")
        return "\n".join(lines)


def _free_mask(n, free) -> np.ndarray:
    """``free`` (a boolean mask of shape ``(n,)``, dof indices, or None: all) as a new boolean mask."""
    if free is None:
        return np.ones(n, dtype=bool)
    try:
        is_mask = np.asarray(free).dtype == bool
    except (TypeError, ValueError):  # ragged lists: refused by check_indices
        is_mask = False
    if not is_mask:
        mask = np.zeros(n, dtype=bool)
        mask[check_indices("free", free, n, "dof indices")] = True
        return mask
    if np.shape(free) != (n,):
        raise ParameterError("free", f"free must be a boolean mask of shape ({n},) or dof indices, got shape "
                                     f"{np.shape(free)}")
    return np.array(free, dtype=bool)


def check_state(name, value, n=None) -> np.ndarray:
    """A private copy of ``value`` as a finite real vector (of ``n`` entries if given), else a ``ParameterError``
    naming ``name`` (complex numbers, strings and objects too)."""
    a = np.array(check_real_array(name, value), dtype=float)
    if a.ndim != 1 or (n is not None and a.size != n):
        size = "" if n is None else f" of {n} entries"
        raise ParameterError(name, f"{name} must be a 1D array{size}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ParameterError(name, f"{name} contains non-finite values")
    return a


def check_budget(budget) -> float:
    """A time budget: seconds ``> 0``, or ``math.inf`` for none (never a bool, a string or a complex number)."""
    if isinstance(budget, (float, np.floating)) and budget == math.inf:
        return math.inf
    return check_positive("budget", budget)


def _checked(x0, callables, line_search, linear, optional_reals, max_step, max_iterations, budget, tolerances):
    """:func:`newton`'s arguments checked: ``(x, max_step, max_iterations, budget)``, ``x`` a copy.
    ``optional_reals`` may be None, NaN or infinite (they are results)."""
    x = check_state("x0", x0)
    for name, f in callables.items():
        if not (callable(f) or (f is None and name in ("energy", "clock", "safe_hessian"))):
            raise ParameterError(name, f"{name} must be a callable, got {f!r}")
    if line_search is not None and (not isinstance(line_search, str) or line_search not in ("finite", "energy")):
        raise ParameterError("line_search", f"line_search must be None, 'finite' or 'energy', got {line_search!r}")
    if line_search == "energy" and callables["energy"] is None:
        raise ParameterError("energy", "line_search='energy' needs the energy callable")
    if max_step is not None:
        max_step = check_positive("max_step", max_step)
    for name, value in tolerances.items():
        check_real(name, value, 0.0, None)
    max_iterations = check_count("max_iterations", max_iterations, 0)
    budget = check_budget(budget)
    for name, value in optional_reals.items():
        if value is not None:
            check_real_number(name, value)
    if linear is not None and not all(callable(getattr(linear, m, None)) for m in ("matrix", "solve")):
        raise ParameterError("linear", f"linear must be a LinearSolver (with matrix and solve methods) or None, got "
                                       f"{linear!r}")
    return x, max_step, max_iterations, budget


def _shifted_direction(A, rhs, shifts=None):
    """A descent direction from ``(A + tau I) dx = rhs`` with growing ``tau``; steepest descent at last."""
    finite = A is not None and np.all(np.isfinite(A.data))
    diag = A.diagonal() if finite else np.ones(rhs.size)
    scale = float(np.max(np.abs(diag), initial=0.0)) or 1.0
    factorizations = 0
    if finite:
        eye = sp.identity(A.shape[0], format="csr")
        direct = SuperLU()
        for tau in (scale * 10.0 ** np.arange(-6.0, 3.0) if shifts is None else shifts):
            try:
                dx = direct.factorize((A + tau * eye).tocsr()).solve(rhs)
            except (RuntimeError, ValueError):
                continue
            factorizations += 1
            if np.all(np.isfinite(dx)) and dot(rhs, dx) > 0:
                return dx, float(tau), factorizations
    if shifts is not None:
        return None, math.inf, factorizations
    return rhs / (1e3 * scale), math.inf, factorizations


def _scaled_steepest_descent(A, rhs):
    """``rhs`` over the tangent's diagonal (its magnitude; a downhill direction that factorizes nothing), or None
    without a finite tangent."""
    if A is None or not np.all(np.isfinite(A.data)):
        return None
    d = np.abs(A.diagonal())
    d[~(d > 0)] = float(np.max(d, initial=0.0)) or 1.0
    return rhs / d


def _direction(dx_free, A, rhs, x, mask, hessian, safe_hessian, linear, line_search, stats, deadline):
    """``(dx_free, shift)``: the linear solve's Newton step ``dx_free`` if usable (and downhill under the energy line
    search), else the safe Hessian's, a shifted tangent's, steepest descent; ``(None, 0)``: no usable step and no
    energy to descend. When a factorization (of the safeguards) does not fit the budget: a scaled steepest descent,
    or ``None``."""
    if dx_free is not None and np.all(np.isfinite(dx_free)) and (line_search != "energy" or dot(rhs, dx_free) > 0):
        return dx_free, 0.0
    if line_search != "energy":
        return None, 0.0
    if not deadline.fits("factorization"):
        deadline.skip("factorization")
        dx_free = _scaled_steepest_descent(A, rhs)
        return None if dx_free is None else (dx_free, math.inf)
    if safe_hessian is not None:
        A = linear.condense(safe_hessian(x), mask)
        dx_free, shift, fac = _shifted_direction(A, rhs, shifts=(0.0,))
        stats["factorizations"] += fac
        if shift == 0.0:
            return dx_free, shift
    if A is None:  # a kept factorization that no longer fits: look at the tangent itself
        A = linear.matrix(lambda: hessian(x), mask, force=True)
    dx_free, shift, fac = _shifted_direction(A, rhs)
    stats["factorizations"] += fac
    return dx_free, shift


def _bounded_step(x, dx_free, mask, max_step, step_limit):
    """The full step ``dx`` (zero on prescribed dofs) after the cap ``max_step`` and the admissible fraction
    ``step_limit``, and its free part; ``(None, None)`` when no part of it is admissible (blocked)."""
    if max_step is not None:
        biggest = float(np.max(np.abs(dx_free), initial=0.0))
        if biggest > max_step:
            dx_free = dx_free * (max_step / biggest)
    dx = np.zeros(x.size)
    dx[mask] = dx_free
    if step_limit is not None:
        fraction = float(step_limit(x, dx))
        if not fraction > 0.0:
            return None, None
        if fraction < 1.0:
            dx *= fraction
            dx_free = dx[mask]
    return dx, dx_free


def _line_search(x, dx, E, slope, rnorm, mask, gradient, energy, line_search, tolerance):
    """Halve ``alpha`` from 1 until the step is accepted (``line_search`` None: at once; ``"finite"``: a finite
    residual; ``"energy"``: Armijo's decrease of ``E``, or within ``tolerance`` of ``E`` a residual below ``rnorm``):
    ``(alpha, x_new, g_new or None, E_new or None)``, or None."""
    alpha = 1.0
    for _ in range(_MAX_HALVINGS + 1):
        x_new = x + alpha * dx
        if line_search is None:
            return alpha, x_new, None, None
        if line_search == "finite":
            g_new = np.asarray(gradient(x_new), dtype=float)
            if np.all(np.isfinite(g_new[mask])):
                return alpha, x_new, g_new, None
        else:
            E_new = float(energy(x_new))
            if np.isfinite(E_new):
                if E_new <= E + _ARMIJO * alpha * min(slope, 0.0):
                    return alpha, x_new, None, E_new
                if E_new - E <= tolerance:
                    g_new = np.asarray(gradient(x_new), dtype=float)
                    if norm(g_new[mask]) < rnorm:
                        return alpha, x_new, g_new, E_new
        alpha *= 0.5
    return None


def newton(x0, gradient: Callable[[np.ndarray], np.ndarray], hessian: Callable[[np.ndarray], sp.spmatrix], *,
           energy: Callable[[np.ndarray], float] | None = None, free=None, line_search: str | None = "energy",
           rtol: float = 1e-10, atol: float = 0.0, reference_norm: float = 0.0, floor: float = 0.0,
           max_iterations: int = 30, max_step: float | None = None, linear: LinearSolver | None = None,
           safe_hessian: Callable[[np.ndarray], sp.spmatrix] | None = None, clock: Callable[[], float] | None = None,
           budget: float = math.inf, start: float | None = None, energy0: float | None = None,
           energy_floor: float = 0.0, step_limit: Callable[[np.ndarray, np.ndarray], float] | None = None,
           learned: float = 0.0) -> NewtonResult:
    """Minimise ``energy`` (or zero ``gradient``, ``q``) over the ``free`` dofs (a mask or indices; the others keep
    their ``x0`` values); ``hessian(x)``: the sparse Jacobian of ``q``; ``energy0 = E(x0)`` if known. Converged when
    ``||q_free|| <= max(atol + rtol max(||q_free(x0)||, reference_norm), floor)``: ``reference_norm`` the size of the
    balanced load (for a good ``x0``), ``floor`` the round-off level; energy changes below ``energy_floor`` are not
    trusted. ``max_step`` caps one dof's change per iteration; ``linear``: the linear-solve policy (default: a fresh
    direct factorization); ``safe_hessian(x)``: a positive semi-definite Hessian tried before the shift; ``budget``
    seconds by ``clock`` from ``start`` (default: now): a piece of work starts only if ``linear.costs`` says it ends
    in time (the first iteration's assembly and its cheapest solve always run; what was not started is the result's
    ``skipped``); the time from ``start`` to the first iteration, less ``learned`` seconds (pieces learned on their
    own), is learned as the ``"start"`` piece; ``step_limit(x, dx)``: the admissible fraction of ``dx``."""
    x, max_step, max_iterations, budget = _checked(
        x0, {"gradient": gradient, "hessian": hessian, "energy": energy, "clock": clock, "safe_hessian": safe_hessian},
        line_search, linear, {"start": start, "energy0": energy0, "learned": learned}, max_step, max_iterations, budget,
        {"rtol": rtol, "atol": atol, "floor": floor, "reference_norm": reference_norm, "energy_floor": energy_floor})
    mask = _free_mask(x.size, free)
    linear = LinearSolver("direct") if linear is None else linear
    timed = clock is not None and budget < math.inf
    if timed and start is None:
        start = clock()
    # the budget: a piece of work starts only if its learned cost says it ends in time (see linsolve.Deadline)
    ours = isinstance(linear, LinearSolver)  # another object with matrix and solve is called as before
    deadline = Deadline(clock, start + budget if timed else math.inf, linear.costs if ours else None)
    history: list[NewtonIteration] = []
    g = np.asarray(gradient(x), dtype=float)
    rnorm = r0 = norm(g[mask])
    E = None if energy is None else float(energy(x)) if energy0 is None else float(energy0)
    E_start, e_scale = E, abs(E) if E is not None else 0.0
    if clock is not None and start is not None:  # all before the first iteration (a stepper's warm start too)
        deadline.record("start", max(clock() - start - float(learned), 0.0))
    target = max(atol + rtol * max(r0, float(reference_norm)), float(floor))
    stats = {"linear": 0, "factorizations": 0}

    def result(status, k):
        return NewtonResult(x, status == "converged", status, k, rnorm, r0, target, E, E_start,
                            stats["linear"], stats["factorizations"], history, list(deadline.skipped),
                            list(deadline.unestimated))
    if not np.isfinite(rnorm):
        return result("non-finite", 0)
    for k in range(max_iterations):
        if rnorm <= target:
            return result("converged", k)
        deadline.first = k == 0
        # the tangent's free block (unless the policy keeps a factorization), if it and the least solve fit
        least, assembles = (linear.least_work(), linear.assembles(mask)) if ours else ((), True)
        needed = (("assembly",) if assembles else ()) + tuple(least) + ("line-search",)
        if needed and not deadline.fits(*needed):
            deadline.skip(max(needed, key=lambda kind: deadline.costs.get(kind) or 0.0))  # the costliest
            return result("budget", k)
        rhs = -g[mask]
        timing = {"deadline": deadline} if ours else {}
        A = linear.matrix(lambda: hessian(x), mask, **timing)
        # inexact Newton: an iterative solve may stop at eta ||q||, eta = min(1e-3, ||q|| / ||q0||) (quadratic
        # convergence stays), never below a third of the target; the solve starts only what fits
        eta = min(1e-3, rnorm / r0) if r0 > 0 else 1e-3
        dx_free, info = linear.solve(A, rhs, atol=max(eta * rnorm, 0.3 * target), **timing)
        stats["linear"] += info.iterations
        stats["factorizations"] += info.factorizations
        if getattr(info, "skipped", ""):
            return result("budget", k)
        found = _direction(dx_free, A, rhs, x, mask, hessian, safe_hessian, linear, line_search, stats, deadline)
        if found is None:
            return result("budget", k)
        dx_free, shift = found
        if dx_free is None:
            return result("singular", k)
        dx, dx_free = _bounded_step(x, dx_free, mask, max_step, step_limit)
        if dx is None:
            return result("blocked", k)
        slope = -dot(rhs, dx_free)  # dE/dalpha at alpha = 0
        if E is not None:
            e_scale = max(e_scale, abs(E), abs(slope))
        t0 = deadline.clock()
        step = _line_search(x, dx, E, slope, rnorm, mask, gradient, energy, line_search,
                            max(_ENERGY_ROUNDOFF * e_scale, energy_floor))
        if step is None:
            return result("line-search-failed", k)
        alpha, x_new, g_new, E_new = step
        g_new = np.asarray(gradient(x_new), dtype=float) if g_new is None else g_new
        deadline.record("line-search", deadline.clock() - t0)  # its energies and the new gradient
        rn_new, step_norm = norm(g_new[mask]), norm(alpha * dx)
        if not np.isfinite(rn_new):
            history.append(NewtonIteration(k, rnorm, step_norm, alpha, None, shift, info.iterations))
            return result("non-finite", k + 1)
        if line_search == "energy":
            E = min(E_new, E)
        elif energy is not None:
            E = float(energy(x_new))
        history.append(NewtonIteration(k, rnorm, step_norm, alpha, E, shift, info.iterations))
        x, g, rnorm = x_new, g_new, rn_new
    return result("converged" if rnorm <= target else "max-iterations", max_iterations)
