"""Dot products and norms of dof vectors that keep to the calling thread.

NumPy hands ``a @ b`` and ``np.linalg.norm(a)`` of long vectors to the BLAS, which splits them over its own threads.
With a factorization (or a step) running on the second core, the BLAS thread waits for a core at every call: each
dot product then takes a scheduler's time slice (milliseconds) instead of microseconds, and a frame that takes
dozens of them (the energies of the warm start and the line search, every CG iteration's) overruns its budget
several times over (measured at 16k triangles: one energy 90 ms against 0.5 ms). :func:`dot` and :func:`norm` sum
in the calling thread (``einsum`` without the BLAS); the real-time path uses them.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["dot", "norm"]


def dot(a, b) -> float:
    """``a . b`` of two 1D arrays, summed in the calling thread."""
    return float(np.einsum("i,i->", a, b))


def norm(a) -> float:
    """The Euclidean norm of a 1D array, summed in the calling thread (``inf`` or NaN as ``np.linalg.norm``)."""
    a = np.asarray(a, dtype=float)
    if a.size == 0:
        return 0.0
    scale = float(np.max(np.abs(a)))
    if not math.isfinite(scale):
        return scale
    if scale == 0.0:
        return 0.0
    s = a / scale if scale > 1e150 or scale < 1e-150 else a
    r = math.sqrt(float(np.einsum("i,i->", s, s)))
    return r * scale if s is not a else r
