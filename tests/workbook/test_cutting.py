"""Cutting through elements, as the engine and a running simulation use it (issue: surgery as a surgeon cuts).

The construction itself (pieces, nodes, slivers, crossing cuts) is tested in
``test_element_cuts.py``; here: the mechanics of a cut, against closed forms
and across meshes, and the cut as a :class:`~tissuefem.Simulation` operation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tissuefem.workbook.cracks import griffith_closed_form, griffith_opening
from tissuefem.workbook.procedures import crack_opening

E, NU = 1000.0, 0.3
LAM, MU = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))


def test_a_crack_cut_through_elements_opens_as_griffiths_crack():
    # plane strain, crack 2a = 2 in a plate of width W = 10 pulled by sigma = 1: the centre opening
    # 4 sigma a (1 - nu^2) / E times Feddersen's finite-width factor sqrt(sec(pi a / W)), written out here
    exact = 4.0 * 1.0 * 1.0 * (1 - NU**2) / E * math.sqrt(1.0 / math.cos(math.pi / 10.0))
    assert griffith_closed_form(1.0, 10.0, 1.0, E, NU) == pytest.approx(exact, rel=1e-14)
    ratios = np.array([griffith_opening(n, E=E, nu=NU)[1] for n in (40, 80, 160)]) / exact
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


def test_the_opening_of_an_oblique_crack_does_not_depend_on_the_mesh():
    stroke = [[0.93, 1.05], [1.17, 0.45]]  # from above the top edge, slanted, ending inside
    through, snapped = [], []
    for triangles in (1200, 2600):
        sim = _pulled_sheet(triangles)
        edit = sim.cut(stroke)
        assert sim.frame().converged
        through.append(crack_opening(sim, edit))
        sim = _pulled_sheet(triangles)
        edit = sim.cut(stroke, method="edges")
        assert sim.frame().converged
        snapped.append(crack_opening(sim, edit))
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
    weights = sim.model.weights
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
    sim = Simulation(scene, clock=lambda: 0.0)  # a fake clock: no budget miss under load
    assert not sim.picture.plain and sim.frame().converged
    path.write_text(text.replace('method = "edges"', 'method = "sideways"'))
    with pytest.raises(ValueError, match=r"effects.incisions\[1\].method"):
        Scene.load(path)
