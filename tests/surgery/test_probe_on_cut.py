"""A probe on a mesh cut through elements presses the material only.

A cut through elements copies each triangle it separates; a copy keeps the triangle's three edges but holds only its
piece, so the mesh's boundary facets are partly or wholly phantom, and a virtual node (a copy's vertex without
material at its place) sits beyond the lip, on the other piece. A probe weights its nodes by their share of the
material's surface (``terms.surface_lengths``): the phantom parts count nothing and a virtual node carries no
probe force, however the tool presses (before, a quarter of the weight near a crack sat on virtual nodes, which the
tool pushed through the other piece).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tissuefem import Handle, Model, StableNeoHookean, rectangle
from tissuefem.engine.effects import factory
from tissuefem.engine.terms import boundary_lengths, surface_lengths
from tissuefem.surgery import element_cuts, topology
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation

E = 1000.0


def _simulation(triangles=200):
    scene = Scene.from_dict({
        "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": triangles},
        "material": {"model": "stable-neo-hookean", "youngs_modulus": E, "poisson_ratio": 0.3},
        "effects": {"handles": [{"name": "fixed", "region": "bottom"}]}})
    return Simulation(scene, clock=lambda: 0.0)


def _surface_length(edit) -> float:
    ends = edit.contact_surface().segment_positions(np.asarray(edit.mesh.p, dtype=float))
    return float(np.hypot(*(ends[:, 1] - ends[:, 0]).T).sum())


def test_a_plain_mesh_and_an_edge_cut_weight_the_boundary_as_before():
    mesh = rectangle(2.0, 1.0, 8, 4)
    model = Model(mesh, StableNeoHookean(1.0, 1.0), handles=[Handle("bottom")])
    np.testing.assert_array_equal(model.boundary_lengths, boundary_lengths(mesh))
    edit = topology.incise(mesh, [[1.0, 1.5], [1.0, 0.4]])
    moved, _ = model.remapped(edit)
    np.testing.assert_allclose(moved.boundary_lengths, boundary_lengths(edit.mesh))
    np.testing.assert_allclose(surface_lengths(edit), boundary_lengths(edit.mesh))


def test_a_cut_through_elements_weights_only_the_material_of_its_facets():
    mesh = rectangle(2.0, 1.0, 10, 5)
    edit = element_cuts.cut_through(mesh, [[1.03, 1.5], [1.03, 0.4]])
    virtual = ~edit.material
    assert virtual.any()
    weights = surface_lengths(edit)
    assert np.all(weights[virtual] == 0.0)
    assert np.all(weights >= 0.0)
    np.testing.assert_allclose(weights.sum(), _surface_length(edit))  # the material's surface, no phantom part
    assert boundary_lengths(edit.mesh).sum() > weights.sum() + 0.1  # the mesh's boundary has phantom facets
    model, _ = Model(mesh, StableNeoHookean(1.0, 1.0), handles=[Handle("bottom")]).remapped(edit)
    np.testing.assert_array_equal(model.boundary_lengths, weights)  # what a probe added after the cut uses


def test_a_probe_pressing_by_the_cut_pushes_no_virtual_node():
    sim = _simulation()
    edit = sim.cut([[1.03, 1.5], [1.03, 0.4]])
    virtual = ~edit.material
    probe = sim.add_probe([1.03, 1.12], 0.15)
    for y in np.linspace(1.12, 0.95, 4)[1:]:
        sim.move_probe(probe, [1.03, y])
        assert sim.frame().converged
    force = np.hypot(*sim.model.probes[0].forces(sim.u))
    assert force.sum() > 1.0  # the tool presses
    assert np.all(force[virtual] == 0.0)
    assert np.all(np.isfinite(sim.u))


def test_a_probe_placed_before_the_cut_is_carried_onto_the_material():
    sim = _simulation()
    probe = sim.add_probe([1.03, 1.2], 0.15)
    edit = sim.cut([[1.03, 1.5], [1.03, 0.4]])
    np.testing.assert_array_equal(sim.model.probes[0].length, surface_lengths(edit))
    sim.move_probe(probe, [1.03, 1.0])
    sim.frame()
    assert np.all(sim.model.probes[0].forces(sim.u)[:, ~edit.material] == 0.0)


@settings(max_examples=15, deadline=None, derandomize=True)
@given(x=st.floats(0.3, 1.7), depth=st.floats(0.3, 0.8), slant=st.floats(-0.3, 0.3), centre=st.floats(-0.3, 0.3))
def test_on_any_cut_no_virtual_node_carries_weight_or_force(x, depth, slant, centre):
    mesh = rectangle(2.0, 1.0, 10, 5)
    stroke = [[x, 1.5], [x + slant, 1.0 - depth]]
    try:
        edit = element_cuts.cut_through(mesh, stroke)
    except ValueError:  # along the boundary only, or changing nothing: not this property's business
        return
    weights = surface_lengths(edit)
    np.testing.assert_allclose(weights.sum(), _surface_length(edit), rtol=1e-12)
    model, _ = Model(mesh, StableNeoHookean(100.0, 100.0), handles=[Handle("bottom")]).remapped(edit)
    probe_x = x + centre
    model.add_term(factory("probes", [dict(center=[probe_x, 1.05], radius=0.1, stiffness=1e4)])(model)[0])
    force = model.probes[0].forces(np.zeros(model.n_dofs))  # the disc reaches 0.05 into the top edge
    if edit.material is not None:
        assert np.all(weights[~edit.material] == 0.0)
        assert np.all(force[:, ~edit.material] == 0.0)


@pytest.mark.parametrize("method", ["elements", "edges"])
def test_the_weights_survive_an_excision(method):
    sim = _simulation(triangles=120)
    edit = sim.excise([[0.87, 1.2], [1.13, 1.2], [1.13, 0.55], [0.87, 0.55]], method=method)
    weights = sim.model.boundary_lengths
    if edit.material is not None:
        assert np.all(weights[~edit.material] == 0.0)
    np.testing.assert_allclose(weights.sum(), _surface_length(edit) if edit.contact_surface() is not None
                               else boundary_lengths(sim.mesh).sum())
