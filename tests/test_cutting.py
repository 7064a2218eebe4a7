"""Cutting through elements, as the engine and a running simulation use it (issue: surgery as a surgeon cuts).

The construction itself (pieces, nodes, slivers, crossing cuts) is tested in
``test_element_cuts.py``; here: the mechanics of a cut, against closed forms
and across meshes, and the cut as a :class:`~tissuefem.Simulation` operation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tissuefem import Handle, Model, solve
from tissuefem.engine import meshes
from tissuefem.engine.materials import LinearElastic
from tissuefem.surgery.element_cuts import cut_through, excise_through, material_areas, picture

E, NU = 1000.0, 0.3
LAM, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))


def _nearest(p, x, y):
    return np.array([int(np.argmin(np.hypot(p[0] - x, p[1] - y)))])


def _lip_opening(cut, x, at):
    """Opening (normal jump, absolute) of the wound at abscissa ``at`` of a horizontal cut, at positions ``x``."""
    ends = cut.wound.positions(x)
    ref = cut.wound.reference
    lo, hi = np.minimum(ref[:, 0, 0], ref[:, 1, 0]), np.maximum(ref[:, 0, 0], ref[:, 1, 0])
    ys = {1: [], -1: []}
    for i in np.flatnonzero((lo <= at) & (hi >= at) & cut.wound.opened):
        s = (at - ref[i, 0, 0]) / (ref[i, 1, 0] - ref[i, 0, 0])
        ys[int(cut.wound.side[i])].append(ends[i, 0, 1] + s * (ends[i, 1, 1] - ends[i, 0, 1]))
    return abs(float(np.mean(ys[1]) - np.mean(ys[-1])))


def griffith_opening(n, a=1.0, width=10.0, stress=1.0, nudge=0.37):
    """Crack opening at the centre of a crack of length ``2a`` cut through the elements of an ``n x n`` mesh
    of a ``width``-square plate pulled by ``stress`` on its top and bottom (linear elasticity, plane strain)."""
    mesh = meshes.rectangle(width, width, n, n)
    y0 = 0.5 * width + nudge * width / n  # off the grid lines: the crack crosses elements on every mesh
    c = 0.5 * width
    cut = cut_through(mesh, [[c - a, y0], [c + a, y0]])
    p = cut.mesh.p
    # two points hold the plate (no rigid motion), far from the crack
    model = Model(cut.mesh, LinearElastic(LAM, MU), weights=cut.weights,
                  handles=[Handle(_nearest(p, 0.0, c)), Handle(_nearest(p, width, c))],
                  tractions={"top": (0.0, stress), "bottom": (0.0, -stress)})
    result = solve(model)
    assert result.converged
    return _lip_opening(cut, p + result.u.reshape(-1, 2).T, c)


def test_a_crack_cut_through_elements_opens_as_griffiths_crack():
    # plane strain, crack 2a in a plate of width W: centre opening 4 sigma a (1 - nu^2) / E, times Feddersen's
    # finite-width factor sqrt(sec(pi a / W)) (Tada, Paris & Irwin, The Stress Analysis of Cracks Handbook)
    exact = 4.0 * 1.0 * 1.0 * (1 - NU**2) / E * math.sqrt(1.0 / math.cos(math.pi / 10.0))
    ratios = np.array([griffith_opening(n) for n in (40, 80, 160)]) / exact
    # measured: 0.861, 0.927, 0.961 (3.2k, 12.8k, 51k triangles): the error halves with h (the crack tip is
    # resolved to one element, as in the virtual node algorithm) and extrapolates to the closed form
    errors = 1.0 - ratios
    assert np.all(errors > 0) and np.all(np.diff(errors) < 0)
    assert 1.6 < errors[0] / errors[1] < 2.4 and 1.6 < errors[1] / errors[2] < 2.4
    assert errors[2] < 0.05
    richardson = ratios[2] + (ratios[2] - ratios[1])  # first order: e(h) ~ C h
    assert richardson == pytest.approx(1.0, abs=0.02)
