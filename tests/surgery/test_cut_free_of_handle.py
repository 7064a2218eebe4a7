"""A piece cut free of a handle is free: a copy of a held node with no material at its place (a virtual node of a
cut through elements) holds nothing, whether the cut runs through elements or an excision takes the held edge."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tissuefem import Handle, Model, NeoHookean, rectangle
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery import element_cuts, topology
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation


def sheet(dynamic=True, triangles=160):
    """A 2 x 1 sheet whose left edge is fixed, under gravity (160 triangles: 13 x 6 cells)."""
    effects = {"handles": [{"name": "fixed", "region": "left"}], "gravity": {"acceleration": [0.0, -9.81]}}
    if dynamic:
        effects["inertia"] = {}
    scene = Scene(domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": triangles},
                  material={"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
                  effects=effects, solver={"budget": 1e9})
    return Simulation(scene, clock=lambda: 0.0)


def pieces(sim):
    """The piece of every node."""
    return topology.connected_components(sim.mesh.t, sim.mesh.nvertices)[1]


def held_nodes(sim):
    nodes = [h.nodes for h in sim.model.handles]
    return np.unique(np.concatenate(nodes)) if nodes else np.zeros(0, dtype=np.int64)


def drops(sim, frames):
    """How far the centroid of every piece's nodes drops in ``frames`` frames."""
    labels = pieces(sim)
    before = sim.positions()[1]
    sim.run(frames)
    after = sim.positions()[1]
    return np.array([(before - after)[labels == k].mean() for k in range(labels.max() + 1)]), labels


def nodes_with_material(mesh, regions):
    """The nodes with material at their place, read off what is drawn: a node of a whole element's triangle, or a
    corner of a cut element's material polygon (a drawn point that sits on one node alone)."""
    n = mesh.nvertices
    pic = element_cuts.picture(mesh, regions)
    on = np.zeros(n, dtype=bool)
    on[pic.triangles[pic.triangles < n]] = True  # whole elements draw the nodes themselves
    corner = np.abs(pic.coefficients - 1.0) <= 1e-9  # (3, k): drawn point k is that node's place
    polygon_points = np.unique(pic.triangles[pic.triangles >= n])
    a, k = np.nonzero(corner[:, polygon_points])
    on[pic.nodes[a, polygon_points[k]]] = True
    return on


def expected_held(parent, material_on, held_before):
    """The copies of the nodes held before that have material at their place."""
    return np.flatnonzero(np.isin(parent, held_before) & material_on)


# --- a vertical stroke through the first column of elements ------------------------------------------------------

@pytest.mark.parametrize("x", [0.05, 0.01])
def test_a_piece_cut_off_the_clamped_edge_through_elements_falls(x):
    sim = sheet()
    sim.cut([[x, -0.1], [x, 1.1]])
    drop, labels = drops(sim, 30)
    assert drop.size == 2
    strip = labels[held_nodes(sim)[0]]
    assert np.all(np.isin(labels[held_nodes(sim)], strip))  # only the strip at the clamp is held
    assert abs(drop[strip]) < 0.01
    assert drop[1 - strip] > 4.5  # as after a cut along mesh edges: about 5 units in 30 frames


def test_the_same_piece_cut_along_mesh_edges_falls_the_same_way():
    edges, through = sheet(), sheet()
    edges.cut([[0.1, -0.1], [0.1, 1.1]], method="edges")
    through.cut([[0.05, -0.1], [0.05, 1.1]])
    (d_edges, l_edges), (d_through, l_through) = drops(edges, 30), drops(through, 30)
    free_edges = d_edges[1 - l_edges[held_nodes(edges)[0]]]
    free_through = d_through[1 - l_through[held_nodes(through)[0]]]
    assert free_through == pytest.approx(free_edges, rel=0.02)  # free fall under backward Euler, both


@pytest.mark.parametrize("x", [0.05, 0.01])
def test_a_quasistatic_scene_lifts_the_piece_out(x):
    sim = sheet(dynamic=False)
    mass = sim.total_mass()
    sim.cut([[x, -0.1], [x, 1.1]])
    assert sim.removed_pieces == 1 and sim.pieces() == 1
    assert sim.total_mass() < 0.05 * mass  # only the strip at the clamp is left
    for _ in range(2):
        assert sim.frame().converged
    assert np.abs(sim.u).max() < 0.1


# --- a V whose tip lies on the clamped edge -----------------------------------------------------------------------

V = [[1.0, 1.0], [0.0, 0.5], [1.0, 0.0]]


def test_a_v_stroke_whose_tip_lies_between_clamped_nodes_frees_the_piece_between_its_arms():
    sim = sheet(triangles=120)  # 11 x 5 cells: the tip (0, 0.5) lies inside an edge of the clamped side
    sim.cut(V)
    drop, labels = drops(sim, 30)
    free = np.flatnonzero(~np.isin(np.arange(drop.size), labels[held_nodes(sim)]))
    assert free.size == 1  # the wedge and the right half of the sheet
    assert drop[free[0]] > 4.5
    held = np.delete(drop, free)
    assert np.all(np.abs(held) < 0.05)


def test_a_v_stroke_whose_tip_is_a_clamped_node_pins_the_piece_there_and_a_quasistatic_scene_lifts_it_out():
    sim = sheet(triangles=160)  # 13 x 6 cells: the tip is a node of the clamped edge, with material on both sides
    sim.cut(V)
    labels = pieces(sim)
    held = held_nodes(sim)
    counts = np.bincount(labels[held], minlength=labels.max() + 1)
    wedge = int(np.argmin(np.where(counts > 0, counts, np.iinfo(np.int64).max)))
    assert counts[wedge] == 1  # held at its tip only (the corner its material reaches), not by virtual copies
    tip = held[labels[held] == wedge][0]
    assert np.allclose(sim.mesh.p[:, tip], [0.0, 0.5])
    drop, _ = drops(sim, 30)
    assert drop[wedge] > 0.3  # it swings down about the tip
    assert np.allclose(sim.positions()[:, tip], [0.0, 0.5])
    quasistatic = sheet(dynamic=False, triangles=160)
    quasistatic.cut(V)  # a piece held at one point has no equilibrium to start from: lifted out
    assert quasistatic.removed_pieces == 1
    for _ in range(2):
        assert quasistatic.frame().converged


def test_a_v_stroke_in_a_quasistatic_scene_lifts_the_piece_out():
    sim = sheet(dynamic=False, triangles=120)
    sim.cut(V)
    assert sim.removed_pieces == 1 and sim.pieces() == 2  # the two triangles at the clamp stay
    assert sim.frame().converged
    assert np.abs(sim.u).max() < 0.1


# --- an excision of the held edge ---------------------------------------------------------------------------------

def test_an_excision_of_the_clamped_edge_through_elements_lets_the_body_fall():
    sim = sheet()
    sim.excise([[-0.1, -0.1], [0.05, -0.1], [0.05, 1.1], [-0.1, 1.1]])
    assert "fixed" not in sim.handles  # its copies left are virtual nodes: nothing is held
    drop, _ = drops(sim, 30)
    assert np.all(drop > 4.5)


def test_an_excision_of_half_the_clamped_edge_keeps_the_rest_held():
    sim = sheet()
    sim.excise([[-0.1, -0.1], [0.05, -0.1], [0.05, 0.5], [-0.1, 0.5]])
    held = held_nodes(sim)
    assert held.size and np.all(sim.mesh.p[1, held] >= 0.5 - 1e-9)
    on = nodes_with_material(sim.mesh, sim._regions)
    assert on[held].all()
    drop, _ = drops(sim, 10)
    assert np.abs(drop).max() < 0.5  # the sheet hangs from the upper half of its edge


def test_a_quasistatic_scene_refuses_an_excision_that_frees_every_piece():
    sim = sheet(dynamic=False)
    p, u = sim.mesh.p.copy(), sim.u.copy()
    with pytest.raises(ValueError, match="at least one handle"):
        sim.excise([[-0.1, -0.1], [0.05, -0.1], [0.05, 1.1], [-0.1, 1.1]])
    assert np.array_equal(sim.mesh.p, p) and np.array_equal(sim.u, u) and "fixed" in sim.handles


# --- the engine -----------------------------------------------------------------------------------------------------

MESH = rectangle(2.0, 1.0, 10, 5)
MAT = NeoHookean.from_young(1000.0, 0.3)


def test_a_cut_marks_its_virtual_nodes_and_the_handle_leaves_them():
    cut = element_cuts.cut_through(MESH, [[0.05, -0.1], [0.05, 1.1]])
    assert cut.material is not None and cut.material.shape == (cut.mesh.nvertices,)
    assert np.array_equal(cut.material, nodes_with_material(cut.mesh, cut.regions))
    left = np.flatnonzero(np.isclose(MESH.p[0], 0.0))
    copies = np.flatnonzero(np.isin(cut.parent, left))
    assert copies.size == 2 * left.size and cut.material[copies].sum() == left.size
    model = Model(MESH, MAT, handles=[Handle("left")], dt=0.05, gravity=(0.0, -9.81))
    moved, _ = model.remapped(cut)
    assert np.array_equal(moved.handles[0].nodes, np.sort(copies[cut.material[copies]]))
    assert topology.connected_components(moved.mesh.t, moved.mesh.nvertices)[0] == 2
    assert moved.unheld_nodes().size > 0  # the free piece: dynamic, it falls


def test_a_quasistatic_model_left_with_a_free_piece_is_refused():
    model = Model(MESH, MAT, handles=[Handle("left")], gravity=(0.0, -9.81))
    cut = element_cuts.cut_through(MESH, [[0.05, -0.1], [0.05, 1.1]])
    with pytest.raises(ParameterError, match="no\\s+handle holds") as err:
        model.remapped(cut)
    assert err.value.field == "handles"
    assert len(model.handles) == 1 and model.mesh is MESH  # the model is as it was
    whole = element_cuts.excise_through(MESH, [[-0.1, -0.1], [0.05, -0.1], [0.05, 1.1], [-0.1, 1.1]])
    with pytest.raises(ParameterError, match="at least one handle"):
        model.remapped(whole)


def test_handle_remap_refuses_a_material_mask_of_the_wrong_shape():
    model = Model(MESH, MAT, handles=[Handle("left")])
    h = model.handles[0]
    with pytest.raises(ParameterError, match="material"):
        h.remap(np.arange(MESH.nvertices), np.ones(3, dtype=bool))
    with pytest.raises(ParameterError, match="material"):
        h.remap(np.arange(MESH.nvertices), np.ones(MESH.nvertices))
    assert np.array_equal(h.remap(np.arange(MESH.nvertices)).nodes, h.nodes)


# --- random strokes ---------------------------------------------------------------------------------------------------

SMALL = rectangle(2.0, 1.0, 8, 4)
point = st.tuples(st.floats(-0.3, 2.3), st.floats(-0.3, 1.3))


@settings(max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(strokes=st.lists(st.lists(point, min_size=2, max_size=4), min_size=1, max_size=3))
def test_after_any_cuts_every_held_copy_has_material_at_its_place(strokes):
    held = np.flatnonzero(np.isclose(SMALL.p[0], 0.0))
    model = Model(SMALL, MAT, handles=[Handle(held)], dt=0.05)
    mesh, weights, regions, parent = SMALL, None, None, np.arange(SMALL.nvertices)
    for stroke in strokes:
        try:
            cut = element_cuts.cut_through(mesh, stroke, weights=weights, regions=regions)
        except ValueError:
            continue  # the stroke changes nothing
        model, _ = model.remapped(cut)
        mesh, weights, regions, parent = cut.mesh, cut.weights, cut.regions, parent[cut.parent]
    nodes = model.handles[0].nodes if model.handles else np.zeros(0, dtype=np.int64)
    on = nodes_with_material(mesh, regions)
    assert np.array_equal(nodes, expected_held(parent, on, held))  # no virtual node held, no real copy lost


def test_twenty_random_strokes_in_a_running_scene_hold_only_copies_with_material():
    rng = np.random.default_rng(24)
    sim = sheet(triangles=120)
    held = held_nodes(sim)
    parent = np.arange(sim.mesh.nvertices)
    done = 0
    for _ in range(20):
        a = rng.uniform([-0.2, -0.2], [2.2, 1.2])
        stroke = [a, a + rng.uniform(-1.0, 1.0, 2), a + rng.uniform(-1.0, 1.0, 2)]
        try:
            edit = sim.cut(stroke)
        except ValueError:
            continue
        done += 1
        parent = parent[edit.parent]
        sim.frame()
    assert done >= 10
    on = nodes_with_material(sim.mesh, sim._regions)
    assert np.array_equal(held_nodes(sim), expected_held(parent, on, held))
    assert np.all(np.isfinite(sim.u))
