"""Self-contact of the boundary: surfaces that touch, press and slide, and never pass through each other.

The term's derivatives are checked in the finite-difference table (tests/engine/test_derivatives.py); here:
the barrier's shape, the two surface builders (plain meshes and cuts through elements), that contact
costs nothing when nothing is near (and nothing at all without it), that the collision detection keeps
every step out of the walls, that a folded sheet and a wound pressed shut never interpenetrate (checked
geometrically after every frame), that a handle dragging tissue through tissue is reported and undone,
and that bad input is refused by name.
"""

import numpy as np
import pytest

from tissuefem import Handle, Model, StableNeoHookean, Stepper, rectangle
from tissuefem.engine import stepping
from tissuefem.engine.contact import Contact, ContactSurface, barrier
from tissuefem.engine.meshes import mean_edge_length
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery.element_cuts import cut_through, material_areas
from tissuefem.surgery.surfaces import contact_surface
from tissuefem.surgery.topology import excise, incise

MATERIAL = StableNeoHookean(100.0, 60.0)


# ------------------------------------------------------------------------------------------------ geometry checks

def _segment_distance(y, a, b):
    """Distance from points y (2, m) to segments a -> b (2, k): (m, k)."""
    e = (b - a)[:, None, :]
    w = y[:, :, None] - a[:, None, :]
    t = np.clip((w * e).sum(0) / (e * e).sum(0), 0.0, 1.0)
    return np.hypot(*(w - t * e))


def _inside_material(y, x, t, regions):
    """For points y (2, m): (m, n_elements) bool, inside the deformed material of each element (its triangle,
    or its region's polygons carried by the element's affine map)."""
    a, b, c = x[:, t[0]], x[:, t[1]], x[:, t[2]]
    det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    w = y[:, :, None] - a[:, None, :]
    xi = ((c[1] - a[1]) * w[0] - (c[0] - a[0]) * w[1]) / det
    eta = (-(b[1] - a[1]) * w[0] + (b[0] - a[0]) * w[1]) / det
    inside = (xi >= 0) & (eta >= 0) & (xi + eta <= 1)
    for e, region in (regions or {}).items():
        hit = np.zeros(y.shape[1], dtype=bool)
        for poly in region.polygons:
            hit |= _winding(np.stack([xi[:, e], eta[:, e]]), poly) != 0
        inside[:, e] &= hit
    return inside


def _winding(q, poly):
    w = np.zeros(q.shape[1], dtype=int)
    for (ax, ay), (bx, by) in zip(poly, np.roll(poly, -1, axis=0)):
        side = (bx - ax) * (q[1] - ay) - (by - ay) * (q[0] - ax)
        w += ((ay <= q[1]) & (by > q[1]) & (side > 0)).astype(int)
        w -= ((ay > q[1]) & (by <= q[1]) & (side < 0)).astype(int)
    return w


def assert_no_interpenetration(model, u, regions=None):
    """Geometrically, at the displacement ``u``: (1) no surface point lies inside the material of an element it
    does not belong to deeper than its skin (``d^``, plus its rest offset where parts of the surface lie closer
    than that at rest) from the rest of the surface; (2) no two segments cross each other by more than the
    deepest skin (each poking through the other by more)."""
    contact = model.contact
    surface = contact.surface
    skins = (contact.distance + contact.offset) * (1 + 1e-6)
    tol = skins.max()
    x = model.positions(u)
    y = surface.positions(x)
    a, b = surface.segments
    t = np.asarray(model.mesh.t)
    inside = _inside_material(y, x, t, regions)
    own_nodes = [set(surface.nodes[i][surface.weights[i] > 0].tolist()) for i in range(surface.n_points)]
    dist = _segment_distance(y, y[:, a], y[:, b])
    dist[a, np.arange(a.size)] = np.inf
    dist[b, np.arange(b.size)] = np.inf
    depth = dist.min(axis=1)
    for i in np.flatnonzero(inside.any(axis=1) & (depth > skins)):
        holders = [e for e in np.flatnonzero(inside[i]) if not own_nodes[i] <= set(t[:, e].tolist())]
        assert not holders, f"surface point {i} is {depth[i]:.3g} deep inside element(s) {holders} (skin {skins[i]:.3g})"
    # deep crossings of segments that share no point
    ya, yb = y[:, a], y[:, b]
    e = yb - ya
    side_a = (e[0][None, :] * (ya[1][:, None] - ya[1][None, :]) - e[1][None, :] * (ya[0][:, None] - ya[0][None, :]))
    side_b = (e[0][None, :] * (yb[1][:, None] - ya[1][None, :]) - e[1][None, :] * (yb[0][:, None] - ya[0][None, :]))
    L = np.hypot(*e)[None, :]
    da, db = side_a / L, side_b / L  # [i, j]: signed distances of segment i's ends from segment j's line
    opposite = (da * db < 0) & (da.T * db.T < 0)
    poke = np.minimum(np.abs(da), np.abs(db))
    deep = opposite & (poke > tol) & (poke.T > tol)
    share = (a[:, None] == a[None, :]) | (a[:, None] == b[None, :]) | (b[:, None] == a[None, :]) | (b[:, None] == b[None, :])
    crossing = np.argwhere(deep & ~share)
    assert crossing.size == 0, f"segments {crossing[:3].tolist()} cross each other by more than d^"


# ------------------------------------------------------------------------------------------------ the barrier

def test_the_barrier_starts_twice_differentiably_and_is_infinite_at_the_wall():
    zeta = np.array([1.0, 1.0 - 1e-6, 0.5, 1e-12, 1.5])
    b0, b1, b2 = barrier(zeta)
    assert b0[0] == b1[0] == b2[0] == 0.0 and b0[4] == b1[4] == b2[4] == 0.0
    assert abs(b0[1]) < 1e-17 and abs(b1[1]) < 1e-11 and abs(b2[1]) < 1e-5  # O(s^3), O(s^2), O(s) at 1 - s
    assert b0[2] > 0 and b1[2] < 0 and b2[2] > 0
    assert b0[3] > 20 and np.all(np.isfinite([b0, b1, b2]))  # large, finite: the wall is never reached
    # the derivatives are derivatives
    z, h = np.linspace(0.05, 0.95, 7), 1e-6
    np.testing.assert_allclose((barrier(z + h)[0] - barrier(z - h)[0]) / (2 * h), barrier(z)[1], rtol=1e-6)
    np.testing.assert_allclose((barrier(z + h)[1] - barrier(z - h)[1]) / (2 * h), barrier(z)[2], rtol=1e-6)


# ------------------------------------------------------------------------------------------------ surfaces

def _loops(surface):
    """Lengths of the surface's loops (every segment followed by its next); fails on an open end."""
    assert np.all(surface.next >= 0) and np.all(surface.previous >= 0)
    np.testing.assert_array_equal(surface.previous[surface.next], np.arange(surface.n_segments))
    seen = np.zeros(surface.n_segments, dtype=bool)
    loops = []
    for start in range(surface.n_segments):
        k, s = 0, start
        while not seen[s]:
            seen[s], k, s = True, k + 1, surface.next[s]
        if k:
            loops.append(k)
    return loops


def _enclosed(surface, x):
    y = surface.positions(x)
    a, b = surface.segments
    d = y[:, b] - y[:, a]
    return 0.5 * float(np.sum(y[0, a] * y[1, b] - y[0, b] * y[1, a])), float(np.hypot(*d).sum())


def test_the_surface_of_a_plain_mesh_is_its_boundary_counter_clockwise_round_the_material():
    mesh = rectangle(2.0, 1.0, 8, 4)
    surface = ContactSurface.from_mesh(mesh)
    assert _loops(surface) == [24]
    area, length = _enclosed(surface, mesh.p)
    assert area == pytest.approx(2.0) and length == pytest.approx(6.0)
    # after an edge cut the lips are boundary facets between duplicated nodes, flagged as wound
    cut = incise(mesh, [[1.0, 1.2], [1.0, 0.3]])
    surface = ContactSurface.from_mesh(cut.mesh)
    area, length = _enclosed(surface, cut.mesh.p)
    assert _loops(surface) == [surface.n_segments] and area == pytest.approx(2.0)
    assert length == pytest.approx(6.0 + 2 * 0.75) and surface.wound.sum() == 6
    # a clockwise mesh gives the same (counter-clockwise) surface
    flipped = type(mesh)(mesh.p, mesh.t[[0, 2, 1]], sort_t=False)
    assert _enclosed(ContactSurface.from_mesh(flipped), mesh.p)[0] == pytest.approx(2.0)


CRACK = [[1.013, 1.3], [1.013, 0.47]]  # from the top edge to inside (off the grid's nodes)
ACROSS = [[1.124, -0.2], [1.04, 1.2]]  # through the whole strip


@pytest.mark.parametrize("strokes", [[CRACK], [ACROSS], [CRACK, [[0.4, 0.63], [1.6, 0.71]]]], ids=["crack", "across", "crossed"])
def test_the_surface_of_a_cut_through_elements_follows_the_material(strokes):
    mesh = rectangle(2.0, 1.0, 8, 4)
    cut = cut_through(mesh, strokes[0])
    for stroke in strokes[1:]:
        cut = cut_through(cut.mesh, stroke, weights=cut.weights, regions=cut.regions)
    surface = contact_surface(cut.mesh, cut.weights, cut.regions)
    x = cut.mesh.p
    loops = _loops(surface)
    area, length = _enclosed(surface, x)
    # round the material exactly once: the enclosed area is the material's, with no phantom edge counted
    assert area == pytest.approx(material_areas(cut.mesh, cut.weights).sum(), rel=1e-12)
    y = surface.positions(x)
    wound_length = np.hypot(*(y[:, surface.segments[1]] - y[:, surface.segments[0]]))[surface.wound].sum()
    assert length == pytest.approx(6.0 + wound_length, rel=1e-12)
    if len(strokes) == 1:
        # both lips of every opened piece of the (last) wound lie on wound segments of the surface
        w = cut.wound
        ends = w.positions(x)[w.opened]
        a, b = y[:, surface.segments[0][surface.wound]], y[:, surface.segments[1][surface.wound]]
        for end in (ends[:, 0], ends[:, 1], ends.mean(axis=1)):
            assert _segment_distance(end.T, a, b).min(axis=1).max() < 1e-12
        opened = np.hypot(*(w.reference[w.opened, 1] - w.reference[w.opened, 0]).T).sum()
        assert wound_length == pytest.approx(opened, rel=1e-12)
        assert len(loops) == (2 if strokes[0] is ACROSS else 1)
    # lips come in pairs that coincide at rest, with opposite orientations
    assert surface.wound.sum() % 2 == 0
    # points are combinations of one element's nodes, weights summing to 1
    np.testing.assert_allclose(surface.weights.sum(axis=1), 1.0)
    # without regions, the mesh's boundary
    plain = contact_surface(mesh)
    assert plain.n_segments == ContactSurface.from_mesh(mesh).n_segments == 24


# ------------------------------------------------------------------------------------------------ cost

def test_a_surface_far_from_itself_is_inactive_and_costs_no_coupling():
    mesh = rectangle(2.0, 1.0, 16, 8)
    slot = excise(mesh, [[0.6, 0.3], [1.4, 0.3], [1.4, 0.7], [0.6, 0.7]]).mesh  # a hole whose sides are far apart
    h = mean_edge_length(mesh)
    model = Model(slot, MATERIAL, handles=[Handle("left")], contact=dict(distance=0.1 * h, stiffness=100.0))
    contact, u = model.contact, model.zeros()
    assert contact.energy(u) == 0.0 and not np.any(contact.gradient(u))
    assert contact.active_pairs(u).shape == (2, 0)
    assert contact.pairs.keys.size == 0  # nothing within reach: an empty list
    K = model.hessian(u)
    assert model.pattern.nnz == model.assembler.nnz and K.nnz == model.assembler.nnz  # no widening
    # a few frames of a drag: still nothing near, nothing active, no pattern rebuilt
    stepper = Stepper(model, linear_solver="direct")
    model.add_handle(Handle("right", name="pull"))
    for k in range(1, 4):
        assert stepper.step({"pull": (0.05 * k, 0.02 * k)}).converged
        assert contact.active_pairs(stepper.u).size == 0
    assert model.pattern.nnz == model.assembler.nnz


def test_a_model_without_contact_takes_no_contact_path(monkeypatch):
    model = Model(rectangle(1.0, 1.0, 4, 4), MATERIAL, handles=[Handle("left"), Handle("right", name="pull")])
    assert model.contact is None and model.step_limit is None and not model.notes_steps
    assert model._pattern_terms == [] and model.pattern.base_positions is None
    seen = {}
    real = stepping.newton

    def spy(*args, **kwargs):
        seen.update(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(stepping, "newton", spy)
    report = Stepper(model).step({"pull": (0.05, 0.0)})
    assert report.converged and seen["step_limit"] is None and report.crossed == 0
    assert report.contact_status == "clear"


# ------------------------------------------------------------------------------------------------ collision detection

def _two_bodies():
    """A square body and a small triangle beside it: one surface of two loops, no element between them."""
    p = np.array([[0.0, 0.5, 1.0, 1.0, 1.0, 0.5, 0.0, 0.0, 0.5, 1.4, 1.6, 1.5],
                  [0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 0.5, 0.5, 0.4, 0.4, 0.6]])
    square = [[0, 1, 8], [1, 2, 3], [1, 3, 8], [3, 4, 5], [3, 5, 8], [5, 6, 7], [5, 7, 8], [7, 0, 8]]
    t = np.array(square + [[9, 10, 11]]).T
    from skfem import MeshTri
    return MeshTri(p, t)


def _inside_depth(q, polygon):
    """How deep the points q (2, m) lie inside a closed polygon (k, 2) (0 outside)."""
    inside = _winding(q, polygon) != 0
    a, b = polygon.T, np.roll(polygon, -1, axis=0).T
    return np.where(inside, _segment_distance(q, a, b).min(axis=1), 0.0)


def test_the_collision_detection_keeps_every_step_out_of_the_walls():
    mesh = _two_bodies()
    d = 0.02
    model = Model(mesh, MATERIAL, contact=dict(distance=d, stiffness=100.0))
    contact = model.contact
    square, triangle = [0, 1, 2, 3, 4, 5, 6, 7], [9, 10, 11]
    rng = np.random.default_rng(3)
    limited = 0
    for trial in range(150):
        u = np.zeros(model.n_dofs)
        du = np.zeros(model.n_dofs)
        # the triangle starts outside, right of the square, and moves through it; the square wobbles
        u.reshape(-1, 2)[triangle] = rng.uniform([-0.2, -0.4], [0.2, 0.4])
        du.reshape(-1, 2)[triangle] = rng.uniform([-1.6, -0.5], [-0.2, 0.5]) + rng.normal(0, 0.05, (3, 2))
        du.reshape(-1, 2)[:9] = rng.normal(0, 0.03, (9, 2))
        fraction = contact.max_step(u, du)
        limited += fraction < 1
        for tau in np.linspace(0.0, fraction, 60):
            x = model.positions(u + tau * du)
            assert _inside_depth(x[:, triangle], x[:, square].T).max() < d, (trial, tau)
            assert _inside_depth(x[:, square], x[:, triangle].T).max() < d, (trial, tau)
    assert limited > 50  # most of these steps would have gone through


def test_a_handle_dragging_tissue_through_tissue_is_reported_and_undone():
    mesh = _two_bodies()
    model = Model(mesh, MATERIAL, handles=[Handle(np.arange(9), name="square"), Handle(np.array([9, 10, 11]),
                                                                                          name="tool")],
                  contact=dict(distance=0.02, stiffness=100.0))
    stepper = Stepper(model, linear_solver="direct")
    path = [(-0.2, 0.0), (-0.6, 0.0), (-0.6, 0.05), (-0.2, 0.0), (0.0, 0.0)]
    crossed = []
    for target in path:
        report = stepper.step({"tool": target})
        assert np.all(np.isfinite(stepper.u)) and np.isfinite(report.residual_norm)
        crossed.append(report.crossed)
        assert ("points through the surface" in repr(report)) == (report.crossed > 0)
    assert crossed[0] == 0 and crossed[1] > 0 and crossed[2] > 0  # dragged in, and kept in
    assert crossed[-1] == 0  # undone: nothing through any more
    assert stepper.last_report.contact_status == "clear"


# ------------------------------------------------------------------------------------------------ frames

def test_a_body_thrown_at_another_bounces_off_it():
    mesh = _two_bodies()
    model = Model(mesh, MATERIAL, dt=0.01, density=1.0, handles=[Handle(np.arange(9), name="square")],
                  contact=dict(distance=0.01, stiffness=100.0))
    stepper = Stepper(model, linear_solver="direct")
    v = np.zeros(model.n_dofs)
    v.reshape(-1, 2)[[9, 10, 11]] = (-10.0, 0.0)  # the triangle flies left at the square
    stepper.reset(None, v)
    touched = False
    for _ in range(30):
        report = stepper.step()
        assert report.converged and report.crossed == 0
        assert_no_interpenetration(model, stepper.u)
        touched |= model.contact.active_pairs(stepper.u).size > 0
    assert touched and stepper.v.reshape(-1, 2)[[9, 10, 11], 0].mean() > 0  # it hit, and it is flying back


def test_a_sheet_folded_onto_itself_never_interpenetrates():
    mesh = rectangle(3.0, 0.1, 40, 2)
    h = mean_edge_length(mesh)
    table = Handle({"box": [-1.0, -0.01, 1.2, 0.01]}, name="table")  # the left part lies on a table
    model = Model(mesh, StableNeoHookean(577.0, 385.0), handles=[table, Handle("right", name="end")],
                  contact=dict(distance=0.1 * h, stiffness=5770.0))
    stepper = Stepper(model, linear_solver="reuse")
    centre = np.array([[1.8], [0.25]])

    def fold(theta, drop):  # the right end turned about the centre over the left half, then pressed down onto it
        R = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        return lambda P: centre + R @ (P - centre) - np.array([[0.0], [drop]])

    # turned over (12 frames), lowered to just above the left part (4), then pressed on it by less than d^ a frame
    # (a handle is obeyed: one that jumps deeper than d^ into the tissue in one frame drags its nodes through)
    path = ([(th, 0.0) for th in np.linspace(0, np.pi, 13)[1:]] + [(np.pi, dr) for dr in np.linspace(0, 0.29, 5)[1:]]
            + [(np.pi, dr) for dr in np.linspace(0.29, 0.33, 9)[1:]])
    for theta, drop in path:
        report = stepper.step({"end": fold(theta, drop)})
        assert report.converged and report.crossed == 0
        assert_no_interpenetration(model, stepper.u)
    contact = model.contact
    assert contact.active_pairs(stepper.u).shape[1] > 0  # pressed onto itself
    assert 0 < contact.overlap(stepper.u) < contact.distance


@pytest.mark.parametrize("kind", ["edges", "elements"])
def test_a_closed_incision_pressed_shut_never_interpenetrates(kind):
    mesh = rectangle(2.0, 1.0, 16, 8)
    h = mean_edge_length(mesh)
    regions = None
    if kind == "edges":
        cut = incise(mesh, [[0.93, 1.2], [1.07, 0.25]])
        mesh, weights, surface = cut.mesh, None, None
    else:
        cut = cut_through(mesh, [[0.93, 1.2], [1.07, 0.25]])
        mesh, weights, regions = cut.mesh, cut.weights, cut.regions
        surface = contact_surface(mesh, weights, regions)
    model = Model(mesh, MATERIAL, weights=weights, handles=[Handle("left"), Handle("right", name="push")],
                  contact=dict(surface=surface, distance=0.1 * h, stiffness=100.0))
    contact = model.contact
    assert contact.energy(model.zeros()) == 0.0  # lips that touch feel nothing
    stepper = Stepper(model, linear_solver="reuse")
    pressed = [(-0.03 * k, 0.01 * k) for k in range(1, 7)]
    released = [(-0.03 * k, 0.06) for k in range(5, -1, -1)] + [(0.05, 0.0)]
    for target in pressed + released:
        report = stepper.step({"push": target})
        assert report.converged and report.crossed == 0
        assert_no_interpenetration(model, stepper.u, regions)
        if target == pressed[-1]:
            assert contact.active_pairs(stepper.u).shape[1] > 5  # the lips press on each other
            assert 0 < contact.overlap(stepper.u) < contact.distance
    assert contact.active_pairs(stepper.u).size == 0  # pulled open again: nothing touches


# ------------------------------------------------------------------------------------------------ bad input

def test_bad_contact_input_is_refused_by_name():
    mesh = rectangle(1.0, 1.0, 4, 4)
    X = mesh.p
    surface = ContactSurface.from_mesh(mesh)
    for kwargs, field in [(dict(distance=-0.01, stiffness=1.0), "contact.distance"),
                          (dict(distance=0.0, stiffness=1.0), "contact.distance"),
                          (dict(distance=float("nan"), stiffness=1.0), "contact.distance"),
                          (dict(distance=0.01, stiffness=float("inf")), "contact.stiffness"),
                          (dict(distance=0.01, stiffness=-3.0), "contact.stiffness"),
                          (dict(distance=0.2, stiffness=1.0), "contact.distance"),  # deeper than half a segment
                          (dict(distance=0.01, stiffness=1.0, skin=0.0), "contact.skin")]:
        with pytest.raises(ValueError, match=field.replace(".", r"\.")):
            Contact(X, surface, **kwargs)
        with pytest.raises(ValueError, match=field.replace(".", r"\.")):
            Model(mesh, MATERIAL, contact=kwargs)
    with pytest.raises(ValueError, match=r"contact\.surface\.nodes"):
        ContactSurface([[0], [99]], [[1.0], [1.0]], [[0], [1]], n_nodes=25)
    with pytest.raises(ValueError, match=r"contact\.surface\.nodes"):
        ContactSurface([[0], [-1]], [[1.0], [1.0]], [[0], [1]], n_nodes=25)
    with pytest.raises(ValueError, match=r"contact\.surface\.weights"):
        ContactSurface([[0], [1]], [[1.0], [np.nan]], [[0], [1]], n_nodes=25)
    with pytest.raises(ValueError, match=r"contact\.surface\.segments"):
        ContactSurface([[0], [1]], [[1.0], [1.0]], [[0], [2]], n_nodes=25)
    with pytest.raises(ValueError, match=r"contact\.surface"):
        Contact(X, ContactSurface([[0], [1]], [[1.0], [1.0]], [[0], [1]], n_nodes=9), 0.01, 1.0)
    with pytest.raises(ValueError, match="zero length"):
        Contact(X, ContactSurface([[0], [0]], [[1.0], [1.0]], [[0], [1]], n_nodes=25), 0.01, 1.0)
    for bad in (None, X, "mesh"):  # not a triangle mesh: refused by name, not an AttributeError
        with pytest.raises(ParameterError, match="mesh must be a triangle mesh") as refused:
            ContactSurface.from_mesh(bad)
        assert refused.value.field == "mesh"
    with pytest.raises(ParameterError, match=r"contact\.surface must be a ContactSurface") as refused:
        Contact(X, "boundary", 0.01, 1.0)
    assert refused.value.field == "contact.surface"
    with pytest.raises(ValueError, match=r"contact\.stiffness: missing"):
        Model(mesh, MATERIAL, contact=dict(distance=0.01))
    with pytest.raises(ValueError, match="contact: unknown"):
        Model(mesh, MATERIAL, contact=dict(distance=0.01, stiffness=1.0, stiffnes=2.0))
    with pytest.raises(ValueError, match="contact must be a table"):
        Model(mesh, MATERIAL, contact=0.01)


# ------------------------------------------------------------------------------------------------ remap

def test_remap_carries_the_contact_across_an_edge_cut_and_a_cut_through_elements(monkeypatch):
    mesh = rectangle(2.0, 1.0, 16, 8)
    h = mean_edge_length(mesh)
    contact = Contact(mesh.p, ContactSurface.from_mesh(mesh), 0.1 * h, 100.0, skin=0.5 * h)
    stroke = [[0.93, 1.2], [1.07, 0.25]]
    edge = incise(mesh, stroke)  # no surface of its own: the new mesh's boundary, with the lips
    moved = contact.remap(edge)
    assert (moved.distance, moved.stiffness, moved.skin) == (contact.distance, contact.stiffness, 0.5 * h)
    np.testing.assert_array_equal(moved.X, edge.mesh.p)
    np.testing.assert_array_equal(moved.surface.segments, ContactSurface.from_mesh(edge.mesh).segments)
    assert moved.surface.wound.sum() > 0 and moved.energy(np.zeros(2 * moved.n_nodes)) == 0.0  # lips touch freely
    # a default skin follows the new surface (the median length of its segments)
    default = Contact(mesh.p, ContactSurface.from_mesh(mesh), 0.1 * h, 100.0).remap(edge)
    assert default.skin == np.median(default.rest_length)
    # through elements: the surface the cut knows (where the material ends) when it offers one, else the boundary
    cut = cut_through(mesh, stroke)
    assert contact.remap(cut).n_nodes == cut.mesh.p.shape[1]
    material = contact_surface(cut.mesh, cut.weights, cut.regions)
    monkeypatch.setattr(type(cut), "contact_surface", lambda self: material)
    moved = contact.remap(cut)
    assert moved.surface is material and moved.energy(np.zeros(2 * moved.n_nodes)) == 0.0
    assert (moved.distance, moved.stiffness, moved.skin) == (contact.distance, contact.stiffness, 0.5 * h)
    with pytest.raises(ParameterError, match="meshmap must be a MeshMap"):
        contact.remap(cut.mesh)


# ------------------------------------------------------------------------------------------------ scenes

def _scene(**effects):
    from tissuefem.surgery.scene import Scene
    data = {"domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 400},
            "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
            "effects": {"handles": [{"name": "fixed", "region": "left"}, {"name": "push", "region": "right"}],
                        **effects}}
    return Scene.from_dict(data)


def test_a_scene_names_contact_or_pays_nothing():
    from tissuefem.surgery.scene import Scene
    from tissuefem.surgery.simulation import Simulation
    assert Simulation(_scene()).model.contact is None  # not named: no term, no hook
    scene = _scene(contact={})
    assert Scene.from_toml(scene.to_toml()) == scene and Scene.from_json(scene.to_json()) == scene
    sim = Simulation(scene, clock=lambda: 0.0)  # a fake clock: the frame's budget never runs out under load
    contact = sim.model.contact
    assert "contact" in sim.terms and contact.stiffness == 1000.0  # default: Young's modulus
    edges = ContactSurface.from_mesh(sim.mesh).segment_positions(sim.mesh.p)
    assert contact.distance == pytest.approx(0.25 * np.median(np.hypot(*(edges[:, 1] - edges[:, 0]).T)))
    assert sim.frame({"push": (0.05, 0.0)}).converged
    with pytest.raises(ValueError, match=r"effects\.contact\.distance"):
        Simulation(_scene(contact={"distance": 0.5}))  # deeper than half a boundary edge
    for bad, field in [({"distance": -1.0}, "distance"), ({"stiffness": float("nan")}, "stiffness"),
                       ({"stiffness": -2.0}, "stiffness"), ({"distance": "0.1"}, "distance")]:
        with pytest.raises(ValueError, match=rf"effects\.contact\.{field}"):
            _scene(contact=bad)


def test_a_wound_cut_in_a_running_simulation_is_part_of_the_contact_surface():
    from tissuefem.surgery.simulation import Simulation
    sim = Simulation(_scene(contact={}), clock=lambda: 0.0)  # a fake clock: no budget miss under load
    assert sim.model.contact.surface.wound.sum() == 0
    sim.frame({"push": (0.02, 0.0)})
    sim.cut([[1.0, 1.2], [1.0, 0.3]])  # a crack from the top edge, made on the stretched sheet
    surface = sim.model.contact.surface
    # the new lips coincide: (next to) no contact energy (where a cut leaves features smaller than the skin, their
    # rest offsets are measured in the reference state, and the stretched sheet has moved them a little)
    assert surface.wound.sum() > 0 and sim.model.contact.energy(sim.u) < 1e-6
    for k in range(1, 6):  # pushed back and on: the crack is pressed shut
        report = sim.frame({"push": (0.02 - 0.03 * k, 0.0)})
        assert report.converged and report.crossed == 0
        assert_no_interpenetration(sim.model, sim.u)
    assert sim.model.contact.active_pairs(sim.u).shape[1] > 0


# ------------------------------------------------------------------------------------------------ sliding lips

def test_an_advancement_flap_cut_through_elements_slides_its_lips_and_converges_in_every_frame():
    from tissuefem.surgery.flaps import advancement_flap
    result = advancement_flap(method="elements", contact=True, tighten_frames=20, n_triangles=1500,
                              clock=lambda: 0.0)
    model = result.simulation.model
    contact = model.contact
    assert contact is not None and contact.surface.wound.sum() > 0
    statuses = [report.status for report in result.reports]
    # the lips never pass through each other: no point is deeper than its skin behind the surface it is near
    assert contact.overlap(result.simulation.u) < contact.distance
    assert all(report.crossed == 0 for report in result.reports)
    assert statuses == ["converged"] * len(statuses), statuses


def test_contact_surface_refuses_a_mesh_without_facets_by_name():
    """Something with ``p`` and ``t`` but no facets or boundaries is not a triangle mesh: refused naming ``mesh``."""
    from types import SimpleNamespace

    fake = SimpleNamespace(p=np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), t=np.array([[0], [1], [2]]))
    with pytest.raises(ParameterError, match="mesh must be a triangle mesh") as err:
        contact_surface(fake)
    assert err.value.field == "mesh"
