"""Chapter 10's study: a crack cut through the elements against Griffith's closed form.

A crack ``2a`` pulled open by ``sigma`` opens by ``4 sigma a (1 - nu^2) / E`` at its centre (plane strain,
Griffith 1921), times about ``sqrt(sec(pi a / W))`` in a plate of width ``W`` (Feddersen's factor, in Tada,
Paris and Irwin, *The Stress Analysis of Cracks Handbook*).
"""

from __future__ import annotations

import math

import numpy as np

from ..engine.constants import TISSUE_E, TISSUE_NU
from ..engine.materials import LinearElastic
from ..engine.meshes import rectangle
from ..engine.model import Handle, Model
from ..engine.stepping import solve
from ..surgery.element_cuts import cut_through

__all__ = ["griffith_closed_form", "griffith_opening", "lip_opening"]


def griffith_closed_form(a=1.0, width=10.0, stress=1.0, E=TISSUE_E, nu=TISSUE_NU) -> float:
    """Centre opening of a crack ``2a`` across a plate of ``width``: ``4 sigma a (1 - nu^2) / E sqrt(sec(pi a/W))``."""
    return 4.0 * stress * a * (1.0 - nu**2) / E * math.sqrt(1.0 / math.cos(math.pi * a / width))


def lip_opening(wound, x, at) -> float:
    """Opening (the jump of the vertical position) of a horizontal wound at abscissa ``at``, at positions ``x``."""
    ends = wound.positions(x)
    ref = wound.reference
    lo, hi = np.minimum(ref[:, 0, 0], ref[:, 1, 0]), np.maximum(ref[:, 0, 0], ref[:, 1, 0])
    lips = {1: [], -1: []}
    for i in np.flatnonzero((lo <= at) & (hi >= at) & wound.opened):
        s = (at - ref[i, 0, 0]) / (ref[i, 1, 0] - ref[i, 0, 0])
        lips[int(wound.side[i])].append(ends[i, 0, 1] + s * (ends[i, 1, 1] - ends[i, 0, 1]))
    return abs(float(np.mean(lips[1]) - np.mean(lips[-1])))


def griffith_opening(n, a=1.0, width=10.0, stress=1.0, E=TISSUE_E, nu=TISSUE_NU, nudge=0.37):
    """``(elements, opening)``: the crack cut through the elements of an ``n x n`` mesh of the square plate
    pulled by ``stress`` at top and bottom (linear, plane strain), held at its sides' middles."""
    mesh = rectangle(width, width, n, n)
    c = 0.5 * width
    y0 = c + nudge * width / n  # off the grid lines: the crack crosses elements on every mesh
    cut = cut_through(mesh, [[c - a, y0], [c + a, y0]])
    p = cut.mesh.p
    nearest = [np.array([int(np.argmin(np.hypot(p[0] - x, p[1] - c)))]) for x in (0.0, width)]
    model = Model(cut.mesh, LinearElastic.from_young(E, nu), weights=cut.weights, handles=[Handle(q) for q in nearest],
                  tractions={"top": (0.0, stress), "bottom": (0.0, -stress)})
    result = solve(model)
    if not result.converged:
        raise RuntimeError(f"griffith_opening: the plate's equilibrium did not converge on {n} x {n}")
    return cut.mesh.nelements, lip_opening(cut.wound, p + result.u.reshape(-1, 2).T, c)
