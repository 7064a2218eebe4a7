"""Tests of tissuefem.surgery.topology: cutting (node duplication along a path) and excising tissue.

What a cut must do: open exactly the drawn edges (a through-cut makes two
pieces, a crack stays closed at its tips), keep every triangle with its area
and vertex order, map every new node to an old one at the same place, and
carry the named boundaries over (the wound's faces named "cut").
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skfem import Basis, ElementTriP1, ElementVector, MeshTri

from tissuefem.engine.meshes import mesh_with_about, rectangle, signed_areas
from tissuefem.engine.model import region_nodes
from tissuefem.surgery.topology import (
    connected_components,
    cut_path,
    duplicate_along_edges,
    excise,
    incise,
)

ACROSS = [[0.5, -0.2], [0.5, 1.2]]  # a vertical stroke across the unit square
ALONG = [[-0.2, 0.5], [1.2, 0.5]]  # a horizontal one


def pieces(mesh):
    return connected_components(mesh.t, mesh.p.shape[1])[0]


def facet_lengths(mesh, name):
    f = mesh.facets[:, mesh.boundaries[name]]
    d = mesh.p[:, f[1]] - mesh.p[:, f[0]]
    return np.hypot(d[0], d[1])


def total_area(mesh):
    return float(np.abs(signed_areas(mesh)).sum())


def edge_use(t):
    """How many triangles use each undirected edge: dict (lo, hi) -> count."""
    e = np.concatenate([t[[0, 1]], t[[1, 2]], t[[2, 0]]], axis=1)
    e = np.sort(e, axis=0)
    keys, counts = np.unique(e, axis=1, return_counts=True)
    return {(int(a), int(b)): int(c) for (a, b), c in zip(keys.T, counts)}


def check_edit(old, edit):
    """Invariants of every edit: parents at the same place, triangles kept, no orphan node."""
    new = edit.mesh
    n_new = new.p.shape[1]
    assert edit.parent.shape == (n_new,)
    assert edit.elements.shape == (new.t.shape[1],)
    assert edit.parent.min() >= 0 and edit.parent.max() < old.p.shape[1]
    np.testing.assert_array_equal(new.p, old.p[:, edit.parent])
    # every new triangle is its old triangle, through parent, in the same vertex order
    np.testing.assert_array_equal(edit.parent[new.t], old.t[:, edit.elements])
    np.testing.assert_array_equal(signed_areas(new), signed_areas(old)[edit.elements])
    np.testing.assert_array_equal(np.unique(new.t), np.arange(n_new))


# --- a cut across the body -----------------------------------------------------------------------

def test_vertical_cut_across_makes_two_pieces_and_keeps_every_triangle():
    mesh = rectangle(1.0, 1.0, 8, 8)
    path = cut_path(mesh, ACROSS)
    np.testing.assert_allclose(mesh.p[0, path], 0.5)  # a grid line: the path is exact
    assert path.size == 9
    edit = incise(mesh, ACROSS)
    new = edit.mesh
    check_edit(mesh, edit)
    assert pieces(mesh) == 1 and pieces(new) == 2
    assert new.p.shape[1] == mesh.p.shape[1] + path.size  # every node of the path splits in two
    assert new.t.shape == mesh.t.shape
    np.testing.assert_array_equal(edit.elements, np.arange(mesh.t.shape[1]))
    assert total_area(new) == pytest.approx(1.0, rel=1e-12)
    assert np.all(signed_areas(new) > 0)  # no folded or flat triangle; orientation kept
    # the copies sit on their originals, which are exactly the path's nodes
    n = mesh.p.shape[1]
    np.testing.assert_array_equal(edit.parent[:n], np.arange(n))
    assert set(edit.parent[n:].tolist()) == set(path.tolist())
    # the two pieces are the two halves
    _, labels = connected_components(new.t, new.p.shape[1])
    for piece in (0, 1):
        nodes = np.flatnonzero(labels == piece)
        xs = new.p[0, nodes]
        assert np.all(xs <= 0.5) or np.all(xs >= 0.5)
        on_piece = np.isin(new.t[0], nodes)
        assert np.abs(signed_areas(new)[on_piece]).sum() == pytest.approx(0.5)
    # both faces of the wound are named: 2 x 8 facets of length 1/8
    assert edit.cut_edges.shape == (2, 8)
    np.testing.assert_allclose(facet_lengths(new, "cut").sum(), 2.0)
    assert sorted(new.boundaries) == ["bottom", "cut", "left", "right", "top"]


def test_transfer_carries_node_and_dof_fields():
    mesh = rectangle(1.0, 1.0, 4, 4)
    edit = incise(mesh, ACROSS)
    u = np.stack([mesh.p[0] ** 2, mesh.p[1] - 1.0])
    np.testing.assert_array_equal(edit.transfer(u), np.stack([edit.mesh.p[0] ** 2, edit.mesh.p[1] - 1.0]))
    dofs = u.T.ravel()  # scikit-fem's vector order: (x0, y0, x1, y1, ...)
    np.testing.assert_array_equal(edit.transfer_dofs(dofs), edit.transfer(u).T.ravel())
    fibers = np.arange(mesh.t.shape[1])
    np.testing.assert_array_equal(edit.transfer_elements(fibers), fibers)
    with pytest.raises(ValueError, match="values"):
        edit.transfer(np.zeros(3))
    with pytest.raises(ValueError, match="values"):
        edit.transfer_dofs(np.zeros(mesh.p.shape[1]))


def test_a_cut_mesh_works_with_scikit_fem():
    edit = incise(rectangle(1.0, 1.0, 6, 6), ACROSS)
    basis = Basis(edit.mesh, ElementVector(ElementTriP1()))
    assert basis.N == 2 * edit.mesh.p.shape[1]
    cut_dofs = basis.get_dofs("cut").flatten()
    assert cut_dofs.size == 2 * 2 * 7  # both faces, 7 nodes each, x and y


def test_a_sorted_scikit_fem_mesh_keeps_its_orientation_per_triangle():
    # MeshTri's default sorts each triangle's vertices, so orientations are mixed;
    # a cut must not flip any of them (copies get high indices; no re-sorting)
    mesh = MeshTri().refined(3)
    edit = incise(mesh, [[0.3, -1.0], [0.6, 2.0]])
    check_edit(mesh, edit)
    assert pieces(edit.mesh) == 2


# --- cracks --------------------------------------------------------------------------------------

def test_interior_crack_opens_but_its_tips_stay_closed():
    mesh = rectangle(1.0, 1.0, 8, 8)
    stroke = [[0.25, 0.5], [0.75, 0.5]]
    path = cut_path(mesh, stroke)
    assert path.size == 5
    edit = incise(mesh, stroke)
    new = edit.mesh
    check_edit(mesh, edit)
    assert pieces(new) == 1
    assert new.p.shape[1] == mesh.p.shape[1] + path.size - 2
    copied = set(edit.parent[mesh.p.shape[1]:].tolist())
    assert copied == set(path[1:-1].tolist())  # the tips are not duplicated
    # the crack faces are boundary now, named "cut": two faces of length 1/2
    cut = new.boundaries["cut"]
    assert set(cut.tolist()) <= set(new.boundary_facets().tolist())
    np.testing.assert_allclose(facet_lengths(new, "cut").sum(), 1.0)
    np.testing.assert_allclose(new.p[1, new.facets[:, cut]], 0.5)


def test_cut_from_the_boundary_that_ends_inside():
    mesh = rectangle(1.0, 1.0, 8, 8)
    stroke = [[-0.2, 0.5], [0.5, 0.5]]
    path = cut_path(mesh, stroke)
    assert mesh.p[0, path[0]] == 0.0 and mesh.p[0, path[-1]] == 0.5
    edit = incise(mesh, stroke)
    check_edit(mesh, edit)
    assert pieces(edit.mesh) == 1
    assert edit.mesh.p.shape[1] == mesh.p.shape[1] + path.size - 1
    copied = set(edit.parent[mesh.p.shape[1]:].tolist())
    assert path[0] in copied and path[-1] not in copied
    np.testing.assert_allclose(facet_lengths(edit.mesh, "left").sum(), 1.0)
    np.testing.assert_allclose(facet_lengths(edit.mesh, "cut").sum(), 1.0)


def test_an_endpoint_near_the_boundary_snaps_onto_it():
    mesh = rectangle(1.0, 1.0, 8, 8)
    path = cut_path(mesh, [[0.03, 0.52], [0.5, 0.52]])  # 0.03 < half an edge (1/16) from x = 0
    assert mesh.p[0, path[0]] == 0.0
    assert pieces(incise(mesh, [[0.5, 0.52], [0.97, 0.52]]).mesh) == 1


# --- several cuts --------------------------------------------------------------------------------

def test_crossing_cuts_make_four_pieces():
    mesh = rectangle(1.0, 1.0, 8, 8)
    # one after the other: the second stroke crosses the first wound
    first = incise(mesh, ACROSS)
    second = incise(first.mesh, ALONG)
    assert pieces(second.mesh) == 4
    check_edit(first.mesh, second)
    assert total_area(second.mesh) == pytest.approx(1.0)
    # both at once, with the bare node duplication: the centre gets three copies
    edges = []
    for stroke in (ACROSS, ALONG):
        path = cut_path(mesh, stroke)
        edges.append(np.stack([path[:-1], path[1:]]))
    new_t, parent = duplicate_along_edges(mesh.t, mesh.p.shape[1], np.concatenate(edges, axis=1))
    assert connected_components(new_t, parent.size)[0] == 4
    centre = int(region_nodes(mesh, {"near": [0.5, 0.5], "radius": 1e-9})[0])
    assert np.count_nonzero(parent == centre) == 4
    # 4 ends on the boundary and 2 x 6 inner path nodes get one copy each, the centre three
    assert parent.size == mesh.p.shape[1] + 4 + 12 + 3


def test_repeated_cuts_accumulate_the_cut_boundary_and_keep_the_old_names():
    mesh = rectangle(1.0, 1.0, 10, 10)
    first = incise(mesh, [[0.3, -0.1], [0.3, 1.1]])
    second = incise(first.mesh, [[0.7, -0.1], [0.7, 1.1]])
    assert pieces(second.mesh) == 3
    np.testing.assert_allclose(facet_lengths(first.mesh, "cut").sum(), 2.0)
    np.testing.assert_allclose(facet_lengths(second.mesh, "cut").sum(), 4.0)
    for name in ("left", "right", "bottom", "top"):
        np.testing.assert_allclose(facet_lengths(second.mesh, name).sum(), 1.0)
        assert set(second.mesh.boundaries[name].tolist()) <= set(second.mesh.boundary_facets().tolist())
    # every boundary facet has exactly one name
    named = np.concatenate([second.mesh.boundaries[k] for k in second.mesh.boundaries])
    assert np.array_equal(np.sort(named), np.sort(second.mesh.boundary_facets()))
    # the bottom boundary lost no facet to the wound: 10 facets, split among the three pieces
    assert second.mesh.boundaries["bottom"].size == 10


def test_subdomains_are_carried_over():
    mesh = rectangle(1.0, 1.0, 4, 4)
    mesh = mesh.with_subdomains({"lower": lambda x: x[1] < 0.5})
    edit = incise(mesh, ACROSS)
    np.testing.assert_array_equal(edit.mesh.subdomains["lower"], mesh.subdomains["lower"])
    ex = excise(mesh, [[-1, -1], [0.5, -1], [0.5, 2], [-1, 2]])
    np.testing.assert_array_equal(ex.elements[ex.mesh.subdomains["lower"]],
                                  np.intersect1d(mesh.subdomains["lower"], ex.elements))


# --- the path follows the stroke ------------------------------------------------------------------

def _distance_to_line(points, a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    return np.abs(d[0] * (points[1] - a[1]) - d[1] * (points[0] - a[0])) / np.hypot(d[0], d[1])


def test_path_follows_a_diagonal_stroke_within_an_element():
    mesh = mesh_with_about(2000)
    a, b = [-0.1, 0.05], [1.1, 0.7]
    path = cut_path(mesh, [a, b])
    h = 1.0 / 32  # mesh_with_about(2000) on the unit square: 32 x 31 cells
    assert _distance_to_line(mesh.p[:, path], a, b).max() <= h
    # consecutive path nodes are mesh edges; no node twice
    edges = set(map(tuple, np.sort(mesh.facets, axis=0).T.tolist()))
    assert all(tuple(sorted(pair)) in edges for pair in zip(path[:-1].tolist(), path[1:].tolist()))
    assert np.unique(path).size == path.size
    # it enters and leaves where the line crosses the boundary
    assert mesh.p[0, path[0]] == 0.0 and abs(mesh.p[1, path[0]] - (0.05 + 0.65 / 1.2 * 0.1)) <= h
    assert mesh.p[0, path[-1]] == 1.0 and abs(mesh.p[1, path[-1]] - (0.7 - 0.65 / 1.2 * 0.1)) <= h
    assert pieces(incise(mesh, [a, b]).mesh) == 2


def test_path_follows_a_bent_stroke():
    mesh = rectangle(1.0, 1.0, 16, 16)
    stroke = np.array([[0.1, 0.1], [0.5, 0.8], [0.9, 0.2]])
    path = cut_path(mesh, stroke)
    pts = mesh.p[:, path]
    d = np.minimum(_distance_to_line(pts, stroke[0], stroke[1]), _distance_to_line(pts, stroke[1], stroke[2]))
    assert d.max() <= 1.0 / 16
    assert path[0] == region_nodes(mesh, {"near": [0.125, 0.125], "radius": 1e-9})[0]


def test_cut_drawn_on_the_deformed_tissue_goes_where_it_was_drawn():
    mesh = rectangle(1.0, 1.0, 10, 10)
    deformed = mesh.p + np.stack([0.4 * mesh.p[1], np.zeros(mesh.p.shape[1])])  # a shear
    path = cut_path(mesh, [[0.7, -0.1], [0.7, 1.1]], positions=deformed)
    assert np.abs(deformed[0, path] - 0.7).max() <= 0.1 + 1e-12
    assert np.ptp(mesh.p[0, path]) > 0.3  # slanted in the reference configuration
    edit = incise(mesh, [[0.7, -0.1], [0.7, 1.1]], positions=deformed)
    assert pieces(edit.mesh) == 2
    np.testing.assert_array_equal(edit.mesh.p, mesh.p[:, edit.parent])  # reference coordinates


# --- excise --------------------------------------------------------------------------------------

def _rim_length(mesh, removed):
    """Length of the edges between a removed and a kept triangle (computed independently)."""
    total = 0.0
    use = {}
    for e in range(mesh.t.shape[1]):
        a, b, c = mesh.t[:, e]
        for pair in ((a, b), (b, c), (c, a)):
            use.setdefault(tuple(sorted(pair)), []).append(e)
    for (a, b), els in use.items():
        if len(els) == 2 and removed[els[0]] != removed[els[1]]:
            total += np.hypot(*(mesh.p[:, a] - mesh.p[:, b]))
    return total


def test_excise_a_square_in_the_middle():
    mesh = rectangle(1.0, 1.0, 10, 10)
    square = [[0.3, 0.3], [0.7, 0.3], [0.7, 0.7], [0.3, 0.7]]
    edit = excise(mesh, square)
    new = edit.mesh
    check_edit(mesh, edit)
    assert new.t.shape[1] == mesh.t.shape[1] - 32  # 4 x 4 cells, 2 triangles each
    assert new.p.shape[1] == mesh.p.shape[1] - 9  # the 3 x 3 nodes strictly inside
    assert np.all(np.diff(edit.parent) > 0)  # compact, in the old order
    assert np.all(np.diff(edit.elements) > 0)
    assert edit.cut_edges.shape == (2, 0)
    np.testing.assert_allclose(facet_lengths(new, "defect").sum(), 1.6)
    assert total_area(new) == pytest.approx(1.0 - 0.16)
    for name in ("left", "right", "bottom", "top"):
        np.testing.assert_allclose(facet_lengths(new, name).sum(), 1.0)


def test_excise_a_tilted_square_has_a_jagged_rim_of_the_right_length():
    mesh = rectangle(1.0, 1.0, 12, 12)
    diamond = [[0.5, 0.25], [0.75, 0.5], [0.5, 0.75], [0.25, 0.5]]
    edit = excise(mesh, diamond)
    removed = ~np.isin(np.arange(mesh.t.shape[1]), edit.elements)
    rim = facet_lengths(edit.mesh, "defect").sum()
    assert rim == pytest.approx(_rim_length(mesh, removed), rel=1e-12)
    perimeter = 4 * 0.25 * np.sqrt(2)
    assert perimeter * 0.8 <= rim <= perimeter * np.sqrt(2) * 1.1  # a staircase is at most sqrt(2) longer
    assert pieces(edit.mesh) == 1


def test_excise_with_a_mask_and_repeated_excisions_accumulate():
    mesh = rectangle(2.0, 1.0, 20, 10)
    first = excise(mesh, lambda c: np.hypot(c[0] - 0.5, c[1] - 0.5) < 0.2)
    second = excise(first.mesh, lambda c: np.hypot(c[0] - 1.5, c[1] - 0.5) < 0.2)
    rim1 = facet_lengths(first.mesh, "defect").sum()
    rim2 = facet_lengths(second.mesh, "defect").sum()
    assert rim2 == pytest.approx(2 * rim1)  # the same hole twice (the mesh is symmetric)
    assert pieces(second.mesh) == 1


def test_excise_then_cut_through_the_hole():
    mesh = rectangle(1.0, 1.0, 10, 10)
    holed = excise(mesh, [[0.3, 0.3], [0.7, 0.3], [0.7, 0.7], [0.3, 0.7]]).mesh
    cut = incise(holed, ACROSS)  # the stroke crosses the hole: both ends of the cut are open
    assert pieces(cut.mesh) == 2
    assert sorted(cut.mesh.boundaries) == ["bottom", "cut", "defect", "left", "right", "top"]
    np.testing.assert_allclose(facet_lengths(cut.mesh, "defect").sum(), 1.6)


def test_excise_rejects_bad_regions():
    mesh = rectangle(1.0, 1.0, 4, 4)
    with pytest.raises(ValueError, match="region selects no element"):
        excise(mesh, [[2, 2], [3, 2], [3, 3]])
    with pytest.raises(ValueError, match="region selects every element"):
        excise(mesh, [[-1, -1], [2, -1], [2, 2], [-1, 2]])
    with pytest.raises(ValueError, match="region"):
        excise(mesh, [[0, 0], [1, 1]])  # two points
    with pytest.raises(ValueError, match="region"):
        excise(mesh, [[0, 0], [1, 1], [2, 2]])  # no area
    with pytest.raises(ValueError, match="region"):
        excise(mesh, [[0, 0], [1, np.nan], [0, 1]])
    with pytest.raises(ValueError, match="region"):
        excise(mesh, lambda c: c[0, :3] < 0.5)  # not one bool per element
    with pytest.raises(ValueError, match="region"):
        excise(mesh, lambda c: c[0])  # not bool


# --- bad inputs ----------------------------------------------------------------------------------

@pytest.mark.parametrize(
    "polyline",
    [
        [[0.1, 0.2], [np.nan, 0.5]],
        [[0.1, 0.2]],
        [[0.1, 0.2, 0.3], [0.4, 0.5, 0.6]],
        [0.1, 0.2, 0.3, 0.4],
        "across",
        [[0.5, 0.5], [0.51, 0.5]],  # collapses to one node
    ],
    ids=["nan", "one-point", "three-columns", "flat", "text", "collapses"],
)
def test_bad_polylines_are_rejected(polyline):
    mesh = rectangle(1.0, 1.0, 4, 4)
    with pytest.raises(ValueError, match="polyline"):
        cut_path(mesh, polyline)
    with pytest.raises(ValueError, match="polyline"):
        incise(mesh, polyline)


def test_a_stroke_along_the_boundary_opens_nothing():
    mesh = rectangle(1.0, 1.0, 4, 4)
    with pytest.raises(ValueError, match="polyline opens no edge"):
        incise(mesh, [[0.1, 0.0], [0.9, 0.0]])


def test_bad_edges_are_rejected():
    mesh = rectangle(1.0, 1.0, 4, 4)  # node j * 5 + i at column i, row j
    n = mesh.p.shape[1]
    with pytest.raises(ValueError, match=r"edges: \(0, 2\).*not an edge"):
        duplicate_along_edges(mesh.t, n, [[0], [2]])
    with pytest.raises(ValueError, match="edges"):
        duplicate_along_edges(mesh.t, n, [[0, 1, 2]])  # shape (1, 3)
    with pytest.raises(ValueError, match="edges"):
        duplicate_along_edges(mesh.t, n, [[0], [n]])
    with pytest.raises(ValueError, match="edges"):
        duplicate_along_edges(mesh.t, n, [[0.5], [1.0]])
    with pytest.raises(ValueError, match="n_nodes"):
        duplicate_along_edges(mesh.t, -1, [[0], [1]])
    with pytest.raises(ValueError, match="t must"):
        duplicate_along_edges(mesh.t, 3, [[0], [1]])
    with pytest.raises(ValueError, match="positions"):
        cut_path(mesh, ACROSS, positions=np.zeros((2, 3)))


def test_nodes_near_a_point_and_the_errors():
    mesh = rectangle(1.0, 1.0, 4, 4)
    np.testing.assert_array_equal(region_nodes(mesh, {"near": [0.5, 0.5], "radius": 0.25}), [7, 11, 12, 13, 17])
    np.testing.assert_array_equal(region_nodes(mesh, {"near": [0.0, 0.0], "radius": 0.0}), [0])
    with pytest.raises(ValueError, match="region"):
        region_nodes(mesh, {"near": [0.1, 0.1], "radius": 0.1})
    for radius in (-1.0, np.nan, np.inf, "big"):
        with pytest.raises(ValueError, match="radius"):
            region_nodes(mesh, {"near": [0.5, 0.5], "radius": radius})
    for point in ([0.5], [np.nan, 0.5], "centre"):
        with pytest.raises(ValueError, match="near"):
            region_nodes(mesh, {"near": point, "radius": 0.1})


# --- the core duplication on hand-made meshes ----------------------------------------------------

def test_two_triangles_cut_along_their_shared_edge_come_apart():
    t = np.array([[0, 1], [1, 3], [2, 2]])  # (0, 1, 2) and (1, 3, 2) share the edge 1-2
    new_t, parent = duplicate_along_edges(t, 4, [[2], [1]])
    np.testing.assert_array_equal(new_t, [[0, 4], [1, 3], [2, 5]])
    np.testing.assert_array_equal(parent, [0, 1, 2, 3, 1, 2])
    assert connected_components(new_t, 6)[0] == 2


def test_three_cut_spokes_meet_at_an_interior_node():
    # a hexagon fan around node 0; cutting spokes 0-1, 0-3, 0-5 leaves three fans
    ring = np.arange(1, 7)
    t = np.stack([np.zeros(6, int), ring, np.roll(ring, -1)])
    new_t, parent = duplicate_along_edges(t, 7, [[0, 0, 0], [1, 3, 5]])
    assert np.count_nonzero(parent == 0) == 3  # node 0 and two copies
    # spokes 1, 3, 5 end on the boundary: each splits in two
    assert all(np.count_nonzero(parent == k) == 2 for k in (1, 3, 5))
    assert parent.size == 7 + 2 + 3
    assert connected_components(new_t, parent.size)[0] == 3
    np.testing.assert_array_equal(parent[new_t], t)
    # a single spoke is a crack with its tip at 0 (the ring closes round it) and its mouth at 1
    new_t, parent = duplicate_along_edges(t, 7, [[1], [0]])
    np.testing.assert_array_equal(parent, [0, 1, 2, 3, 4, 5, 6, 1])


def test_no_edges_change_nothing_and_inputs_are_not_modified():
    mesh = rectangle(1.0, 1.0, 4, 4)
    t = mesh.t.copy()
    new_t, parent = duplicate_along_edges(t, 25, np.zeros((2, 0), int))
    np.testing.assert_array_equal(new_t, t)
    np.testing.assert_array_equal(parent, np.arange(25))
    edges = np.array([[2, 7, 12, 17], [7, 12, 17, 22]])
    duplicate_along_edges(t, 25, edges)
    np.testing.assert_array_equal(t, mesh.t)
    np.testing.assert_array_equal(edges, [[2, 7, 12, 17], [7, 12, 17, 22]])


def test_the_input_mesh_is_not_modified_and_results_are_deterministic():
    mesh = rectangle(1.0, 1.0, 6, 6)
    p, t = mesh.p.copy(), mesh.t.copy()
    names = {k: v.copy() for k, v in mesh.boundaries.items()}
    stroke = np.array([[-0.1, 0.2], [0.6, 0.7], [1.1, 0.4]])
    a, b = incise(mesh, stroke), incise(mesh, stroke)
    c, d = excise(mesh, stroke), excise(mesh, stroke)
    np.testing.assert_array_equal(mesh.p, p)
    np.testing.assert_array_equal(mesh.t, t)
    assert sorted(mesh.boundaries) == sorted(names)
    for k in names:
        np.testing.assert_array_equal(mesh.boundaries[k], names[k])
    np.testing.assert_array_equal(stroke, [[-0.1, 0.2], [0.6, 0.7], [1.1, 0.4]])
    for x, y in ((a, b), (c, d)):
        np.testing.assert_array_equal(x.mesh.p, y.mesh.p)
        np.testing.assert_array_equal(x.mesh.t, y.mesh.t)
        np.testing.assert_array_equal(x.parent, y.parent)
        np.testing.assert_array_equal(x.cut_edges, y.cut_edges)
        for k in x.mesh.boundaries:
            np.testing.assert_array_equal(x.mesh.boundaries[k], y.mesh.boundaries[k])


# --- property: random straight cuts across a rectangle -------------------------------------------

@settings(max_examples=25, deadline=None, derandomize=True)
@given(
    nx=st.integers(3, 12),
    ny=st.integers(4, 12),
    height=st.floats(0.5, 2.0),
    y0=st.floats(0.3, 0.7),
    y1=st.floats(0.3, 0.7),
    diagonal=st.sampled_from(["alternate", "right", "left"]),
)
def test_random_straight_cuts_across_a_rectangle(nx, ny, height, y0, y1, diagonal):
    mesh = rectangle(1.0, height, nx, ny, diagonal=diagonal)
    edit = incise(mesh, [[-0.1, y0 * height], [1.1, y1 * height]])
    new = edit.mesh
    check_edit(mesh, edit)  # parents in place, triangles and areas kept, every node used
    assert new.t.shape == mesh.t.shape
    assert total_area(new) == pytest.approx(height, rel=1e-12)
    assert pieces(new) == 2
    # each node on an opened edge of a simple through-cut is copied exactly once
    assert new.p.shape[1] - mesh.p.shape[1] == np.unique(edit.cut_edges).size
    assert np.all(edit.parent[: mesh.p.shape[1]] == np.arange(mesh.p.shape[1]))
    uses = edge_use(new.t)
    for a, b in edit.cut_edges.T:  # the opened edges are no longer shared
        images = [k for k, c in uses.items() if {int(edit.parent[k[0]]), int(edit.parent[k[1]])} == {a, b}]
        assert len(images) == 2 and all(uses[k] == 1 for k in images)
