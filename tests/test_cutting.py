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


# --- the cut as a Simulation operation ------------------------------------------------------------------------------

from tissuefem import Scene, Simulation  # noqa: E402  (grouped with the tests that use them)


def _pulled_sheet(triangles, diagonal_pull=0.02):
    scene = Scene(domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": triangles},
                  material={"model": "stable-neo-hookean", "youngs_modulus": E, "poisson_ratio": NU},
                  effects={"handles": [{"name": "fixed", "region": "left"},
                                       {"name": "pull", "region": "right", "target": [diagonal_pull, 0.0]}]},
                  solver={"budget": 1e9, "rtol": 1e-9, "max_iterations": 100})
    sim = Simulation(scene)
    sim.frame()
    return sim


def _mouth(sim, edit):
    """Opening of the crack at its mouth (the top edge): the distance between its two lips there."""
    ends = edit.wound.positions(sim.positions()) if hasattr(edit, "wound") else None
    if ends is None:  # the edge-snapped cut: copies of the nodes on the top edge
        x = sim.positions()
        top = np.flatnonzero(np.isclose(sim.model.X[1], 1.0))
        copies = top[top >= edit.n_old_nodes]
        return float(np.max(np.hypot(*(x[:, copies] - x[:, edit.parent[copies]]))))
    first = np.flatnonzero(edit.wound.stroke[:, 0] == edit.wound.stroke[:, 0].min())
    a = first[edit.wound.side[first] > 0][0]
    b = first[edit.wound.side[first] < 0][0]
    return float(np.hypot(*(ends[a, 0] - ends[b, 0])))


def test_the_opening_of_an_oblique_crack_does_not_depend_on_the_mesh():
    stroke = [[0.93, 1.05], [1.17, 0.45]]  # from above the top edge, slanted, ending inside
    through, snapped = [], []
    for triangles in (1200, 2600):
        sim = _pulled_sheet(triangles)
        edit = sim.cut(stroke)
        assert sim.frame().converged
        through.append(_mouth(sim, edit))
        sim = _pulled_sheet(triangles)
        edit = sim.cut(stroke, method="edges")
        assert sim.frame().converged
        snapped.append(_mouth(sim, edit))
    # cut through elements, the crack is the drawn one on both meshes; snapped to edges, its path, length
    # and slant change with the mesh, and so does the opening
    assert through[1] == pytest.approx(through[0], rel=0.06)
    assert abs(snapped[1] - snapped[0]) > 2 * abs(through[1] - through[0])


def test_an_excision_through_elements_removes_exactly_the_outline():
    sim = _pulled_sheet(800)
    area = float(sim.model.element_areas().sum())
    mass, polygon = sim.total_mass(), np.array([[0.61, 0.23], [1.37, 0.31], [1.22, 0.78], [0.7, 0.71]])
    sim.excise(polygon)
    shoelace = 0.5 * abs(np.dot(polygon[:, 0], np.roll(polygon[:, 1], -1)) - np.dot(polygon[:, 1],
                                                                                    np.roll(polygon[:, 0], -1)))
    # to 1e-5: where the outline passes within a few percent of an element of a vertex, the sliver it
    # would leave is snapped onto the element's edges (min_weight), moving the rim by less than that
    assert float(sim.model.element_areas().sum()) == pytest.approx(area - shoelace, rel=1e-5)
    assert sim.total_mass() / mass == pytest.approx(float(sim.model.element_areas().sum()) / area, rel=1e-12)
    assert sim.frame().converged
    sim2 = _pulled_sheet(800)
    sim2.excise(polygon, method="edges")  # the triangles whose centroids fall inside: not the outline
    assert abs(float(sim2.model.element_areas().sum()) - (area - shoelace)) > 1e-3


def test_crossing_cuts_through_elements_keep_the_mass_and_a_valid_state():
    scene = Scene(domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 900},
                  material={"model": "stable-neo-hookean", "youngs_modulus": E, "poisson_ratio": NU},
                  effects={"handles": [{"name": "fixed", "region": "left"}], "inertia": {},
                           "gravity": {"acceleration": [0.0, -9.81]}},
                  solver={"budget": 1e9})
    sim = Simulation(scene)
    sim.run(3)
    mass, momentum = sim.total_mass(), sim.momentum()
    sim.cut([[0.8, 1.2], [1.3, -0.2]])
    sim.cut([[0.5, 0.2], [1.7, 0.7]])  # crosses the first
    sim.cut([[0.3, 0.9], [0.6, 0.5], [0.9, 0.7]])  # bends, through vertices or not
    assert sim.total_mass() == pytest.approx(mass, rel=1e-12)
    np.testing.assert_allclose(sim.momentum(), momentum, rtol=1e-11, atol=1e-13)
    weights = sim._weights
    assert weights is not None and np.all(weights > 0) and np.all(weights <= 1)
    used = np.zeros(sim.mesh.nvertices, dtype=bool)
    used[sim.mesh.t.ravel()] = True
    assert used.all()  # no unreferenced node
    reports = sim.run(5)
    assert all(r.status in ("converged", "budget") for r in reports) and np.all(np.isfinite(sim.u))
    assert sim.pieces() == 2  # the first cut runs through the body; the others end inside it


def test_a_scene_file_names_how_its_incisions_meet_the_mesh(tmp_path):
    text = """
name = "crack"
[domain]
shape = "rectangle"
width = 2.0
height = 1.0
triangles = 600
[material]
model = "stable-neo-hookean"
youngs_modulus = 1000.0
poisson_ratio = 0.3
[[effects.handles]]
region = "left"
[[effects.handles]]
region = "right"
target = [0.05, 0.0]
[[effects.incisions]]
path = [[1.03, 1.2], [1.11, 0.5]]
[[effects.incisions]]
path = [[0.5, -0.2], [0.5, 0.4]]
method = "edges"
"""
    path = tmp_path / "crack.toml"
    path.write_text(text)
    scene = Scene.load(path)
    assert [e["method"] for e in scene.effects["incisions"]] == ["elements", "edges"]
    sim = Simulation(scene)
    assert not sim.picture.plain and sim.frame().converged
    path.write_text(text.replace('method = "edges"', 'method = "sideways"'))
    with pytest.raises(ValueError, match=r"effects.incisions\[1\].method"):
        Scene.load(path)
