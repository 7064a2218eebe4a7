"""Measuring, one place for each: errors (:func:`relative_l2_error`), rates and fits (:func:`fitted_exponent`,
:func:`power_law_fit`, :func:`observed_rates`), what a cost/error plot says (:func:`pareto_front`,
:func:`best_within_budget`, :func:`cost_at_error`) and timings (:func:`median_time`: read, never asserted).
"""

from __future__ import annotations

import time

import numpy as np
from skfem import Basis

from ..engine.parameters import check_real

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
    """Values ``(2, n)`` of the field ``u`` at points ``(2, n)``, in chunks (scikit-fem's point location takes
    memory ~ points^2)."""
    f = basis.interpolator(u)
    return np.concatenate([f(points[:, i:i + chunk]) for i in range(0, points.shape[1], chunk)], axis=1)


def relative_l2_error(basis, u, reference, u_reference=None, intorder: int = 4) -> float:
    """``||u - u_ref||_L2 / ||u_ref||_L2`` by quadrature of degree ``intorder`` on ``basis``'s mesh: ``u_ref`` is
    the field ``u_reference`` on the basis ``reference`` (another mesh) located at the quadrature points, or
    without ``u_reference`` the values ``reference(x)`` there (``x``: ``(d, n_elements, n_points)``, an exact
    solution). Models (anything with ``basis``) may stand for the bases."""
    basis = getattr(basis, "basis", basis)
    quad = Basis(basis.mesh, basis.elem, intorder=intorder)
    uh = np.asarray(quad.interpolate(u))  # (d, nel, nq)
    x = quad.mapping.F(quad.quadrature[0])  # quadrature points (d, nel, nq)
    if u_reference is None:
        ur = reference(x)
    else:
        ur = evaluate(getattr(reference, "basis", reference), u_reference, x.reshape(len(x), -1)).reshape(x.shape)
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


def _costs_errors(costs, errors, rtol=0.0):
    """``(costs, errors, 1 + rtol)`` checked: two 1D float arrays of one length and a resolution factor."""
    c, e = np.asarray(costs, dtype=float), np.asarray(errors, dtype=float)
    if c.shape != e.shape or c.ndim != 1:
        raise ValueError(f"costs and errors must be 1D arrays of the same length, got {c.shape} and {e.shape}")
    return c, e, 1.0 + check_real("rtol", rtol, 0.0)


def pareto_front(costs, errors, rtol: float = 0.0) -> np.ndarray:
    """Indices of the non-dominated points by increasing cost (dominated: another costs and errs no more, one
    strictly; ties keep the first; non-finite never on it). An error is smaller only by more than ``1 +
    rtol``."""
    c, e, factor = _costs_errors(costs, errors, rtol)
    ok = np.flatnonzero(np.isfinite(c) & np.isfinite(e))
    # by cost, then error: a point is on the front when its error is below every error seen so far
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
    """Index of the most accurate setting costing at most ``budget``, or ``None``; errors within ``1 + rtol``
    of the smallest tie and the cheapest wins (no winner by the last digits); non-finite entries never
    qualify."""
    c, e, factor = _costs_errors(costs, errors, rtol)
    budget = float(budget)
    if not budget > 0:
        raise ValueError(f"budget must be > 0, got {budget!r}")
    ok = np.flatnonzero(np.isfinite(c) & np.isfinite(e) & (c <= budget))
    if ok.size == 0:
        return None
    tied = ok[e[ok] <= e[ok].min() * factor]
    return int(tied[np.lexsort((e[tied], c[tied]))[0]])


def cost_at_error(costs, errors, target):
    """The cost at which a curve reaches the error ``target`` (log-log interpolation), or ``None``."""
    c, e = np.asarray(costs, dtype=float), np.asarray(errors, dtype=float)
    order = np.argsort(c)
    c, e = c[order], e[order]
    for k in range(c.size - 1):
        (c0, c1), (e0, e1) = c[k:k + 2], e[k:k + 2]
        if e0 >= target >= e1 and e0 > e1:
            s = np.log(target / e0) / np.log(e1 / e0)
            return float(np.exp(np.log(c0) + s * np.log(c1 / c0)))
    return None
