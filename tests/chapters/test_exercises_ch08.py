"""Exercises of chapter 8 (virtual surgery), graded for the library and the student.

Exercise 8.1 may number the copies of the cut nodes in any order and let any
fan keep the original node, so it is graded by invariants, not by comparing
arrays: the number of copies, ``parent[new_t] == t``, which edges are still
shared by two triangles, and how many pieces the mesh falls into.

The hand-made mesh is the 4 x 2 grid of :func:`tissuefem.engine.meshes.rectangle`
(``rectangle(4.0, 2.0, 4, 2)``), 15 nodes and 16 triangles, numbered::

    10--11--12--13--14
     |   |   |   |   |
     5---6---7---8---9
     |   |   |   |   |
     0---1---2---3---4

(each square is cut into two triangles along a diagonal).
"""

import numpy as np
import pytest
from skfem import MeshTri

from grading import implementations
from tissuefem import rectangle
from tissuefem.surgery import topology
from tissuefem.workbook import answers

GRID = rectangle(4.0, 2.0, 4, 2)
ROW = [(5, 6), (6, 7), (7, 8), (8, 9)]  # the middle row, left to right
COLUMN = [(2, 7), (7, 12)]  # the middle column, bottom to top


def _edges(pairs):
    return np.array(pairs, dtype=np.int64).T.reshape(2, -1)


def _edge_triangles(t):
    """Sorted node pair -> list of the triangles that contain that edge."""
    out = {}
    for e in range(t.shape[1]):
        a, b, c = (int(v) for v in t[:, e])
        for x, y in ((a, b), (b, c), (c, a)):
            out.setdefault((min(x, y), max(x, y)), []).append(e)
    return out


def _pieces(t, n_nodes):
    return topology.connected_components(t, n_nodes)[0]


def check_cut(answer, t, n_nodes, cut_pairs, copies, pieces):
    """Run the answer and check every invariant of a correct cut, with messages a student can act on."""
    t = np.array(t, dtype=np.int64)
    t_before = t.copy()
    cut = _edges(cut_pairs)
    cut_before = cut.copy()
    result = answer(t, n_nodes, cut)
    assert isinstance(result, tuple) and len(result) == 2, "return a tuple (new_t, parent)"
    new_t, parent = (np.asarray(r) for r in result)
    np.testing.assert_array_equal(t, t_before, err_msg="do not modify t")
    np.testing.assert_array_equal(cut, cut_before, err_msg="do not modify cut_edges")

    assert new_t.shape == t.shape, f"new_t must have the shape of t, {t.shape}; got {new_t.shape}"
    assert np.issubdtype(new_t.dtype, np.integer), f"new_t must hold integers, got dtype {new_t.dtype}"
    assert parent.ndim == 1 and np.issubdtype(parent.dtype, np.integer), "parent must be a 1D integer array"
    assert parent.size == n_nodes + copies, (
        f"expected {copies} copies, so parent of length {n_nodes} + {copies} = {n_nodes + copies}; "
        f"got length {parent.size} ({parent.size - n_nodes} copies)"
    )
    np.testing.assert_array_equal(parent[:n_nodes], np.arange(n_nodes),
                                  err_msg="the original nodes keep their numbers: parent[i] == i for i < n_nodes")
    assert new_t.min() >= 0 and new_t.max() < parent.size, "new_t refers to a node that does not exist"
    for e in range(t.shape[1]):
        assert np.array_equal(parent[new_t[:, e]], t[:, e]), (
            f"triangle {e}: new_t[:, {e}] = {new_t[:, e].tolist()} maps through parent to "
            f"{parent[new_t[:, e]].tolist()}, but the triangle is {t[:, e].tolist()} (same order)"
        )
    unused = np.setdiff1d(np.arange(parent.size), new_t)
    assert unused.size == 0, f"nodes {unused.tolist()} are used by no triangle (a copy nobody uses?)"

    # which edges are shared by two triangles now
    before = _edge_triangles(t)
    after = _edge_triangles(new_t)
    cut_keys = {(min(a, b), max(a, b)) for a, b in cut_pairs}
    for (a, b), tris in before.items():
        if len(tris) != 2:
            continue  # a boundary edge: nothing to open
        images = [k for k in after if tuple(sorted((int(parent[k[0]]), int(parent[k[1]])))) == (a, b)]
        shared = [k for k in images if len(after[k]) == 2]
        if (a, b) in cut_keys:
            assert not shared, (
                f"the cut edge ({a}, {b}) is still shared by triangles {before[(a, b)]} "
                f"(as the edge {shared[0]} of new_t): it should be open"
            )
        else:
            assert len(shared) == 1, (
                f"the edge ({a}, {b}) is not cut, so triangles {tris} must still share it; "
                f"in new_t they do not (a node was copied on one side only?)"
            )
    got = _pieces(new_t, parent.size)
    assert got == pieces, f"the cut mesh should fall into {pieces} piece(s), got {got}"
    return new_t, parent


# --- 8.1 duplicate the nodes along a cut ---------------------------------------------------------

ANSWERS = implementations("ch08", "duplicate_cut_nodes", answers.duplicate_cut_nodes)


@pytest.mark.parametrize("answer", ANSWERS)
def test_ex8_1_two_triangles_come_apart(answer):
    # (0, 1, 2) and (1, 3, 2) share the edge 1-2; both ends of it are on the boundary
    check_cut(answer, [[0, 1], [1, 3], [2, 2]], 4, [(1, 2)], copies=2, pieces=2)


@pytest.mark.parametrize("answer", ANSWERS)
@pytest.mark.parametrize(
    "cut_pairs, copies, pieces",
    [
        (ROW, 5, 2),  # boundary to boundary: all 5 nodes of the row split
        (COLUMN, 3, 2),
        (ROW[1:3], 1, 1),  # a crack 6-7-8: only 7 splits; the tips 6 and 8 stay closed
        (ROW[:2], 2, 1),  # from the boundary node 5 to the tip 7: 5 and 6 split
        (ROW + COLUMN, 9, 4),  # an X: 5, 6, 8, 9, 2, 12 get one copy each, 7 (four fans) three
    ],
    ids=["row-through", "column-through", "crack", "boundary-to-tip", "cross"],
)
def test_ex8_1_cuts_on_a_small_grid(answer, cut_pairs, copies, pieces):
    check_cut(answer, GRID.t, GRID.p.shape[1], cut_pairs, copies, pieces)


@pytest.mark.parametrize("answer", ANSWERS)
def test_ex8_1_edges_in_any_order_and_repeated(answer):
    pairs = [(9, 8), (6, 5), (7, 6), (8, 7), (6, 7)]  # reversed, shuffled, one twice
    check_cut(answer, GRID.t, GRID.p.shape[1], pairs, copies=5, pieces=2)


@pytest.mark.parametrize("answer", ANSWERS)
def test_ex8_1_no_cut_changes_nothing(answer):
    new_t, parent = check_cut(answer, GRID.t, GRID.p.shape[1], [], copies=0, pieces=1)
    np.testing.assert_array_equal(new_t, GRID.t)


@pytest.mark.parametrize("answer", ANSWERS)
def test_ex8_1_on_a_scikit_fem_mesh(answer):
    # MeshTri().refined(2): a 4 x 4 grid on the unit square, vertices sorted in every triangle
    mesh = MeshTri().refined(2)
    row = np.flatnonzero(np.isclose(mesh.p[1], 0.5))
    row = row[np.argsort(mesh.p[0, row])]
    pairs = list(zip(row[:-1].tolist(), row[1:].tolist()))
    new_t, parent = check_cut(answer, mesh.t, mesh.p.shape[1], pairs, copies=5, pieces=2)
    # every piece lies on one side of the cut
    _, labels = topology.connected_components(new_t, parent.size)
    y = mesh.p[1, parent]
    for piece in np.unique(labels):
        side = y[labels == piece]
        assert np.all(side <= 0.5) or np.all(side >= 0.5)


# --- 8.2 a scene file --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("answer", implementations("ch08", "scene_file_text", answers.scene_file_text))
def test_ex8_2_scene_file(answer):
    import tomllib

    from tissuefem import Scene, Simulation

    text = answer()
    assert isinstance(text, str), f"return the TOML text as a string, got {type(text).__name__}"
    tomllib.loads(text)  # valid TOML
    scene = Scene.from_toml(text)  # a valid scene (a ValueError names the wrong field)
    got = scene.to_dict()
    assert got["name"] == "tug"
    assert got["domain"] == {"shape": "rectangle", "width": 3.0, "height": 1.0, "triangles": 600}
    assert got["material"] == {"model": "corotated", "youngs_modulus": 5000.0, "poisson_ratio": 0.4,
                               "density": 1.1}
    effects = got["effects"]
    assert sorted(effects) == ["fibers", "gravity", "handles", "inertia"], f"effects: {sorted(effects)}"
    assert effects["inertia"]["time_step"] == 0.02
    assert effects["gravity"]["acceleration"] == [0.0, -9.81]
    assert effects["fibers"]["stiffness"] == 2000.0
    direction = np.asarray(effects["fibers"]["direction"], dtype=float)
    assert abs(direction[1]) < 1e-12 < direction[0], f"fibers along x, got {direction}"
    handles = {h["name"]: h for h in effects["handles"]}
    assert set(handles) == {"fixed", "tip"}
    assert handles["fixed"]["region"] == "left" and handles["fixed"]["target"] == [0.0, 0.0]
    assert handles["tip"]["target"] == [0.5, 0.0]
    # the simulation it describes: the tip handle holds the nodes within 0.1 of (3, 0.5)
    sim = Simulation(scene, clock=lambda: 0.0)  # a fake clock: no budget miss on a busy machine
    X = sim.model.X
    near = np.flatnonzero(np.hypot(X[0] - 3.0, X[1] - 0.5) <= 0.1 + 1e-9)
    assert np.array_equal(np.sort(sim.handles["tip"].nodes), near)
    assert sim.terms == ["inertia", "elastic", "fibers", "gravity"]
    report = sim.frame()
    assert report.converged and np.all(np.isfinite(sim.u))
