"""Newton's method with a convergence history, Dirichlet condensation and safeguards.

The notes' iteration: solve ``dq/du (u^k) du = -q(u^k)`` and set
``u^{k+1} = u^k + du``. This module does it for any residual/tangent pair
(1D or 2D), holds Dirichlet degrees of freedom fixed by condensation (only
the free rows and columns of the tangent are solved), and never lets a
numerical failure escape as an exception or a NaN state: a failure is a
``status`` on the result, and the result keeps the last good iterate.

Optional safeguards (``line_search``):

* ``None``: plain Newton, exactly the notes' iteration.
* ``"finite"``: halve the step until the residual is finite (keeps the log
  model out of ``J <= 0`` when it can).
* ``"energy"``: backtracking (Armijo) line search on a total energy whose
  gradient is the residual: every accepted iterate lowers the energy.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.sparse as sp


@dataclass
class NewtonIteration:
    """One row of the convergence history."""

    iteration: int
    residual_norm: float  # ||q(u^k)|| over the free dofs, before the step
    step_norm: float  # ||du|| actually taken (after any line-search scaling)
    step_length: float  # line-search factor alpha (1 = full Newton step)
    energy: float | None = None  # total energy after the step, when known
    shift: float = 0.0  # diagonal shift tau added to the tangent to get a descent direction (0: plain Newton)

    @property
    def cuts(self) -> int:
        """How many times the line search halved the step (``alpha = 2**-cuts``)."""
        return int(round(-np.log2(self.step_length))) if self.step_length > 0 else 0


@dataclass
class NewtonResult:
    """What a Newton solve returns: the iterate, whether it converged, and why it stopped."""

    x: np.ndarray
    converged: bool
    status: str  # "converged", "max_iter", "non-finite", "singular", "line-search-failed"
    iterations: int
    residual_norm: float
    history: list[NewtonIteration] = field(default_factory=list)

    @property
    def line_search_cuts(self) -> int:
        """Total number of step halvings over the solve."""
        return sum(h.cuts for h in self.history)

    @property
    def energies(self) -> np.ndarray:
        """Total energy after each accepted step (NaN where unknown)."""
        return np.array([np.nan if h.energy is None else h.energy for h in self.history])

    def residual_norms(self) -> np.ndarray:
        """Residual norms ``||q(u^k)||`` for k = 0, 1, ..., including the final one."""
        return np.array([h.residual_norm for h in self.history] + [self.residual_norm])

    def table(self) -> str:
        """The history as a plain-text table (iteration, residual, step, alpha, ratio)."""
        norms = self.residual_norms()
        lines = [f"{'k':>3} {'|q(u^k)|':>12} {'|du|':>11} {'alpha':>6} {'|q_k+1|/|q_k|^2':>16}"]
        for h in self.history:
            k = h.iteration
            ratio = ""
            # the final norm is only a new residual when the last step was accepted
            accepted = k + 1 < len(self.history) or self.status in ("converged", "max_iter")
            if accepted and k + 1 < len(norms) and norms[k] > 0:
                ratio = f"{norms[k + 1] / norms[k] ** 2:16.3e}"
            lines.append(f"{k:>3} {h.residual_norm:12.4e} {h.step_norm:11.3e} {h.step_length:6.3f} {ratio}")
        lines.append(f"{len(self.history):>3} {self.residual_norm:12.4e}   ({self.status})")
        return "\n".join(lines)


def _default_linear_solve(A, b):
    # SuperLU with the symmetric minimum-degree ordering in symmetric mode (see tissuefem.linsolve)
    from .linsolve import SuperLU

    return SuperLU().factorize(A).solve(b)


def _direction(K, rhs, solve, descent: bool):
    """Solve ``K dx = rhs``; with ``descent``, shift ``K`` until ``rhs . dx > 0``. Returns ``(dx, shift)``."""
    def attempt(A):
        try:
            dx = np.asarray(solve(A, rhs), dtype=float)
        except (RuntimeError, ValueError, np.linalg.LinAlgError, ZeroDivisionError):
            return None
        if not np.all(np.isfinite(dx)) or (descent and not rhs @ dx > 0):
            return None
        return dx

    if K is not None and K.shape[0] and np.all(np.isfinite(K.data)):
        dx = attempt(K)
        if dx is not None or not descent:
            return dx, 0.0
        scale = float(np.max(np.abs(K.diagonal()), initial=0.0)) or 1.0
        eye = sp.identity(K.shape[0], format="csr")
        for tau in scale * 10.0 ** np.arange(-6.0, 3.0):
            dx = attempt((K + tau * eye).tocsr())
            if dx is not None:
                return dx, float(tau)
    elif not descent:
        return None, 0.0
    else:
        scale = 1.0
    # steepest descent, scaled like a very strongly shifted Newton step
    return rhs / (1e3 * scale), float("inf")


def newton_solve(
    x0,
    residual: Callable[[np.ndarray], np.ndarray],
    tangent: Callable[[np.ndarray], sp.spmatrix],
    *,
    fixed=None,
    energy: Callable[[np.ndarray], float] | None = None,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_iter: int = 30,
    line_search: str | None = None,
    linear_solve: Callable | None = None,
    max_halvings: int = 30,
    reference_norm: float = 0.0,
    max_step: float | None = None,
) -> NewtonResult:
    """Solve ``residual(x) = 0`` on the free dofs by Newton's method.

    Parameters
    ----------
    x0 : array (n,)
        Initial guess; entries at ``fixed`` are the prescribed (Dirichlet) values
        and are never changed.
    residual, tangent : callables
        ``residual(x) -> (n,)`` and ``tangent(x) -> (n, n)`` sparse, its Jacobian.
    fixed : index array, optional
        Dofs held at their ``x0`` value (condensation).
    energy : callable, optional
        Total energy whose gradient is ``residual``; needed for ``line_search="energy"``.
    rtol, atol : float
        Converged when ``||q_free|| <= atol + rtol * max(||q_free(x0)||, reference_norm)``.
    reference_norm : float
        The size of the load this solve balances, when ``x0`` is already a good
        guess (a predictor or a warm start): without it a tiny initial residual
        would make the relative tolerance demand more than round-off allows.
    """
    x = np.array(x0, dtype=float, copy=True)
    n = x.size
    if x.ndim != 1:
        raise ValueError(f"x0 must be a 1D array, got shape {np.shape(x0)}")
    if not np.all(np.isfinite(x)):
        raise ValueError("x0 contains non-finite values")
    if line_search not in (None, "finite", "energy"):
        raise ValueError(f"line_search must be None, 'finite' or 'energy', got {line_search!r}")
    if max_step is not None and not (np.isfinite(max_step) and max_step > 0):
        raise ValueError(f"max_step must be finite and > 0, got {max_step!r}")
    if line_search == "energy" and energy is None:
        raise ValueError("line_search='energy' needs the energy callable")
    free = np.ones(n, dtype=bool)
    if fixed is not None:
        free[np.asarray(fixed, dtype=int)] = False
    solve = linear_solve or _default_linear_solve

    history: list[NewtonIteration] = []
    r = np.asarray(residual(x), dtype=float)
    rnorm = float(np.linalg.norm(r[free]))
    if not np.isfinite(rnorm):
        return NewtonResult(x, False, "non-finite", 0, rnorm, history)
    target = atol + rtol * max(rnorm, float(reference_norm))
    e_cur = float(energy(x)) if energy is not None else None
    e_scale = abs(e_cur) if e_cur is not None else 0.0  # grows with the largest |E| and |slope| seen

    for k in range(max_iter):
        if rnorm <= target:
            return NewtonResult(x, True, "converged", k, rnorm, history)
        try:
            K = sp.csr_matrix(tangent(x))[free][:, free]
        except (RuntimeError, ValueError, np.linalg.LinAlgError):
            K = None
        dx_free, shift = _direction(K, -r[free], solve, descent=line_search == "energy")
        if dx_free is None:
            return NewtonResult(x, False, "singular", k, rnorm, history)
        if max_step is not None:
            biggest = float(np.max(np.abs(dx_free), initial=0.0))
            if biggest > max_step:
                dx_free = dx_free * (max_step / biggest)
        dx = np.zeros(n)
        dx[free] = dx_free

        alpha = 1.0
        slope = float(r[free] @ dx_free)  # directional derivative of the energy
        if e_cur is not None:
            e_scale = max(e_scale, abs(e_cur), abs(slope))
        for _ in range(max_halvings + 1):
            x_new = x + alpha * dx
            r_new = np.asarray(residual(x_new), dtype=float)
            rn_new = float(np.linalg.norm(r_new[free]))
            if line_search is None:
                break
            if line_search == "finite":
                if np.isfinite(rn_new):
                    break
            else:
                e_new = float(energy(x_new))
                if np.isfinite(e_new) and np.isfinite(rn_new):
                    # Armijo sufficient decrease ...
                    if e_new <= e_cur + 1e-4 * alpha * min(slope, 0.0):
                        break
                    # ... or, once energy differences are down at round-off (relative to the
                    # energy scale of this solve), a step that still lowers the residual.
                    if e_new - e_cur <= 1e-11 * e_scale and rn_new < rnorm:
                        break
            alpha *= 0.5
        else:
            return NewtonResult(x, False, "line-search-failed", k, rnorm, history)

        if not np.isfinite(rn_new):
            history.append(NewtonIteration(k, rnorm, float(np.linalg.norm(alpha * dx)), alpha, None, shift))
            return NewtonResult(x, False, "non-finite", k + 1, rnorm, history)
        if line_search == "energy":
            e_cur = e_new
        elif energy is not None:
            e_cur = float(energy(x_new))
        history.append(NewtonIteration(k, rnorm, float(np.linalg.norm(alpha * dx)), alpha, e_cur, shift))
        x, r, rnorm = x_new, r_new, rn_new

    status = "converged" if rnorm <= target else "max_iter"
    return NewtonResult(x, status == "converged", status, max_iter, rnorm, history)
