"""Measuring: errors, rates, fits, timings and the Pareto reading -- the one place for each.

* :func:`relative_l2_error` -- ``||u - u_ref||_L2 / ||u_ref||_L2`` of a finite element field against a
  reference on another (finer) mesh, by quadrature and point location;
* :func:`fitted_exponent` / :func:`power_law_fit` -- the slope (and constant) of a log-log fit: a
  convergence rate (error against h), a cost growth (time against triangles), the CFL slope;
* :func:`observed_rates` -- rates between successive meshes;
* :func:`pareto_front` and :func:`best_within_budget` -- what a cost/error plot says;
* :func:`median_time` -- a median wall time after a warm-up (benchmarks only: never assert on it).
"""

from __future__ import annotations

import time

import numpy as np
from skfem import Basis

__all__ = ["relative_l2_error", "fitted_exponent", "power_law_fit", "observed_rates", "pareto_front",
           "best_within_budget", "cost_at_error", "median_time", "evaluate"]


def median_time(fn, repeats: int) -> float:
    """Median wall time of ``fn()`` in milliseconds over ``repeats`` calls, after one warm-up call."""
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * float(np.median(times))


def evaluate(basis, u, points, chunk: int = 400) -> np.ndarray:
    """Values ``(2, n)`` of the finite element field ``u`` at arbitrary points ``(2, n)``.

    Fed in chunks: scikit-fem's point location compares every point of a call with every candidate element
    of the call (memory grows like points^2).
    """
    f = basis.interpolator(u)
    return np.concatenate([f(points[:, i:i + chunk]) for i in range(0, points.shape[1], chunk)], axis=1)


def relative_l2_error(basis, u, reference_basis, u_reference, intorder: int = 4) -> float:
    """``||u - u_ref||_L2 / ||u_ref||_L2`` over the body, by quadrature on ``basis``'s mesh.

    ``u_ref`` (on another, finer mesh) is evaluated at the quadrature points by point location; ``intorder``
    is the quadrature degree (4 is ample for P1 and P2). The bases may be models (anything with a ``basis``).
    """
    basis = getattr(basis, "basis", basis)
    reference_basis = getattr(reference_basis, "basis", reference_basis)
    quad = Basis(basis.mesh, basis.elem, intorder=intorder)
    uh = np.asarray(quad.interpolate(u))  # (2, nel, nq)
    x = quad.mapping.F(quad.quadrature[0])  # quadrature points (2, nel, nq)
    ur = evaluate(reference_basis, u_reference, x.reshape(2, -1)).reshape(uh.shape)
    err = np.sum(np.sum((uh - ur) ** 2, axis=0) * quad.dx)
    norm = np.sum(np.sum(ur**2, axis=0) * quad.dx)
    return float(np.sqrt(err / norm))


def power_law_fit(x, y) -> tuple[float, float]:
    """Least-squares ``y = C x^p`` on a log-log scale; returns ``(p, C)``."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.shape != y.shape or x.size < 2:
        raise ValueError(f"x and y must have the same shape and at least 2 points, got {x.shape} and {y.shape}")
    if not (np.all(x > 0) and np.all(y > 0) and np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("x and y must be finite and > 0 for a log-log fit")
    p, log_c = np.polyfit(np.log(x), np.log(y), 1)
    return float(p), float(np.exp(log_c))


def fitted_exponent(x, y) -> float:
    """Least-squares slope of ``log y`` against ``log x`` (``y ~ C x^p``: returns ``p``)."""
    return power_law_fit(x, y)[0]


def _check_rtol(rtol) -> float:
    rtol = float(rtol)
    if not (np.isfinite(rtol) and rtol >= 0):
        raise ValueError(f"rtol must be finite and >= 0, got {rtol!r}")
    return rtol


def _costs_errors(costs, errors, rtol=0.0):
    """``(costs, errors, 1 + rtol)`` checked: two 1D float arrays of one length and a resolution factor."""
    c, e = np.asarray(costs, dtype=float), np.asarray(errors, dtype=float)
    if c.shape != e.shape or c.ndim != 1:
        raise ValueError(f"costs and errors must be 1D arrays of the same length, got {c.shape} and {e.shape}")
    return c, e, 1.0 + _check_rtol(rtol)


def pareto_front(costs, errors, rtol: float = 0.0) -> np.ndarray:
    """Indices of the non-dominated points, in order of increasing cost.

    Point ``i`` is dominated when some ``j`` has ``cost_j <= cost_i`` and ``error_j <= error_i`` with at
    least one strict. Ties keep the first; non-finite entries are never on the front. ``rtol`` is the
    errors' resolution: an error counts as smaller only if it is smaller by more than the factor ``1 + rtol``
    (with ``0.01``, a slower setting only 0.5 % more accurate, below what the reference can tell, is not on
    the front).
    """
    c, e, factor = _costs_errors(costs, errors, rtol)
    ok = np.flatnonzero(np.isfinite(c) & np.isfinite(e))
    # sort by cost, then error: walking in that order, a point is on the front when its error is below
    # every error seen so far (by more than the resolution)
    order = ok[np.lexsort((e[ok], c[ok]))]
    front, best = [], np.inf
    for i in order:
        if e[i] * factor < best:
            front.append(i)
            best = e[i]
    return np.asarray(front, dtype=np.intp)


def observed_rates(h, errors) -> np.ndarray:
    """Observed convergence rates between successive meshes: ``log(e_i / e_(i+1)) / log(h_i / h_(i+1))``."""
    h, e = np.asarray(h, dtype=float), np.asarray(errors, dtype=float)
    if h.shape != e.shape or h.ndim != 1 or h.size < 2:
        raise ValueError(f"h and errors must be 1D arrays of the same length >= 2, got {h.shape} and {e.shape}")
    if not (np.all(h > 0) and np.all(e > 0) and np.all(np.isfinite(h)) and np.all(np.isfinite(e))):
        raise ValueError("h and errors must be finite and > 0")
    if np.any(h[1:] == h[:-1]):
        raise ValueError("successive mesh sizes h must differ")
    return np.log(e[:-1] / e[1:]) / np.log(h[:-1] / h[1:])


def best_within_budget(costs, errors, budget, rtol: float = 0.0):
    """Index of the most accurate setting whose cost is at most ``budget`` (the cheaper on a tie), or ``None``.

    What an engineer reads off a Pareto plot: draw the budget line, take the lowest point to its left.
    Non-finite entries never qualify. ``rtol`` is the errors' resolution: every setting within the factor
    ``1 + rtol`` of the smallest error under the budget ties with it, and the cheapest of them is chosen, so a
    winner is never decided by a difference in the last digits.
    """
    c, e = _costs_errors(costs, errors)[:2]
    budget = float(budget)
    if not budget > 0:
        raise ValueError(f"budget must be > 0, got {budget!r}")
    factor = 1.0 + _check_rtol(rtol)
    ok = np.flatnonzero(np.isfinite(c) & np.isfinite(e) & (c <= budget))
    if ok.size == 0:
        return None
    tied = ok[e[ok] <= e[ok].min() * factor]
    return int(tied[np.lexsort((e[tied], c[tied]))[0]])


def cost_at_error(costs, errors, target):
    """The cost at which a curve (one knob's settings, by increasing cost) reaches the error ``target``.

    Interpolated linearly on log-log axes between the two settings around ``target`` (the curves of a
    convergence study are nearly straight there); ``None`` when the curve does not reach it.
    """
    c, e = np.asarray(costs, dtype=float), np.asarray(errors, dtype=float)
    order = np.argsort(c)
    c, e = c[order], e[order]
    for k in range(c.size - 1):
        (c0, c1), (e0, e1) = c[k:k + 2], e[k:k + 2]
        if e0 >= target >= e1 and e0 > e1:
            s = np.log(target / e0) / np.log(e1 / e0)
            return float(np.exp(np.log(c0) + s * np.log(c1 / c0)))
    return None
