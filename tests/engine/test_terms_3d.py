"""The tools on tetrahedra: the probe (a ball), sutures and fibres through the same classes as in 2D.

The finite-difference checks of every term in 2D and 3D are in ``test_derivatives.py``; here the physics of the
3D tools: a vertex's share of the boundary's area, a ball pressed into a block's top face pushes it down and is
pushed back along the radius, stitches pull their ends together (node to node and from inside tetrahedra), a fibre
along x stiffens a stretch along x only; a model with all of them steps with the stepper and the real-time solver,
and takes and drops a tool while it runs. What stays 2D (self-contact, the ghost penalty of cuts) refuses a
tetrahedron mesh by name.
"""

from __future__ import annotations

import numpy as np
import pytest

from tissuefem import Handle, Model, NeoHookean, StableNeoHookean, Stepper, rectangle
from tissuefem.engine.meshes import box
from tissuefem.engine.parameters import ParameterError
from tissuefem.engine.realtime import RealtimeSolver
from tissuefem.engine.terms import Fibers, GhostPenalty, Probe, Sutures, boundary_lengths

E_LAM, E_MU = 1e4, 5e3


@pytest.fixture(scope="module")
def block():
    return box(1.0, 0.5, 0.6, 4, 2, 3)


# --- a vertex's share of the boundary --------------------------------------------------------------------------

def test_boundary_weights_are_a_third_of_each_boundary_triangle():
    mesh = box(2.0, 1.0, 0.5, 4, 2, 2)
    w = boundary_lengths(mesh)
    assert w.shape == (mesh.nvertices,)
    assert w.sum() == pytest.approx(2 * (2.0 * 1.0 + 1.0 * 0.5 + 2.0 * 0.5))  # the box's surface area
    p = mesh.p
    on_surface = np.isclose(p, 0.0).any(axis=0) | np.isclose(p, [[2.0], [1.0], [0.5]]).any(axis=0)
    assert np.all(w[~on_surface] == 0) and np.all(w[on_surface] > 0)
    # each face's share: the nodes of the top face (y = 1) carry its area 1, less what its edges give other faces
    top = np.isclose(p[1], 1.0)
    assert w[top].sum() > 2.0 * 0.5


def test_boundary_weights_of_triangles_are_half_of_each_boundary_edge():
    mesh = rectangle(2.0, 1.0, 4, 2)
    w = boundary_lengths(mesh)
    assert w.sum() == pytest.approx(6.0)
    corner = np.flatnonzero(np.isclose(mesh.p[0], 0.0) & np.isclose(mesh.p[1], 0.0))[0]
    assert w[corner] == pytest.approx(0.5 * (0.5 + 0.5))  # half of its two edges, 0.5 long each


# --- the probe: a ball ------------------------------------------------------------------------------------------

def _pressed_block(block, depth=0.03, radius=0.3):
    centre = [0.5, 0.5 + radius - depth, 0.3]
    model = Model(block, NeoHookean(E_LAM, E_MU), handles=[Handle("bottom")],
                  probes=[dict(center=centre, radius=radius, stiffness=1e6)])
    return model, model.probes[0]


def test_a_ball_pressed_into_the_top_face_pushes_it_down_along_the_radius(block):
    model, probe = _pressed_block(block)
    assert probe.describe() == "probe: ball r = 0.3 at (0.5, 0.77, 0.3), k = 1e+06"
    u0 = model.zeros()
    inside = probe._contact(u0)[0]
    assert inside.size >= 1 and np.allclose(block.p[1, inside], 0.5)  # nodes of the top face only
    f = probe.forces(u0)
    radial = block.p[:, inside] - probe.center[:, None]
    cos = np.sum(f[:, inside] * radial, axis=0) / (np.linalg.norm(f[:, inside], axis=0) *
                                                   np.linalg.norm(radial, axis=0))
    np.testing.assert_allclose(cos, 1.0)  # pushed away from the centre
    stepper = Stepper(model)
    assert stepper.step().converged
    x = model.positions(stepper.u)
    assert np.all(np.isfinite(x))
    assert x[1, inside].max() < 0.5  # pressed down
    assert 0 < probe.penetration(stepper.u) < 0.03  # the tissue gave way, the penalty still holds it in


def test_a_node_at_the_very_centre_is_pushed_up():
    mesh = box(1.0, 1.0, 1.0, 2, 2, 2)
    top_centre = np.flatnonzero(np.all(np.isclose(mesh.p, [[0.5], [1.0], [0.5]]), axis=0))[0]
    model = Model(mesh, NeoHookean(E_LAM, E_MU), handles=[Handle("bottom")],
                  probes=[dict(center=[0.5, 1.0, 0.5], radius=0.2, stiffness=1e4)])
    f = model.probes[0].forces(model.zeros())
    assert f[0, top_centre] == 0 and f[2, top_centre] == 0 and f[1, top_centre] > 0
    assert np.all(np.isfinite(model.hessian(model.zeros()).data))


def test_a_ball_is_moved_and_checked_in_three_dimensions(block):
    _, probe = _pressed_block(block)
    probe.move([0.2, 0.9, 0.1])
    assert probe.center.tolist() == [0.2, 0.9, 0.1]
    with pytest.raises(ParameterError, match=r"probe center must be a finite vector \(x, y, z\)"):
        probe.move([0.2, 0.9])
    with pytest.raises(ParameterError, match=r"farther than .* from the domain's centre \(0.5, 0.25, 0.3\)"):
        probe.move([0.2, 1e6, 0.1])
    assert probe.center.tolist() == [0.2, 0.9, 0.1]  # a refusal keeps it
    with pytest.raises(ParameterError, match="probe center"):
        Probe(block.p, boundary_lengths(block), [0.5, 0.5], 0.1, 1e3)


# --- sutures ------------------------------------------------------------------------------------------------

def test_stitches_between_nodes_pull_their_ends_together(block):
    p = block.p  # the block held at its right end: the stitch squeezes the diagonal of its free left end's face
    a = np.flatnonzero(np.all(np.isclose(p, [[0.0], [0.5], [0.0]]), axis=0))[0]
    b = np.flatnonzero(np.all(np.isclose(p, [[0.0], [0.0], [0.6]]), axis=0))[0]
    gap = np.linalg.norm(p[:, a] - p[:, b])
    model = Model(block, NeoHookean(E_LAM, E_MU), handles=[Handle("right")],
                  sutures={"pairs": [[a], [b]], "stiffness": 1e6, "gaps": p[:, [a]] - p[:, [b]]})
    stitches = model.sutures
    assert stitches.distances(model.zeros()) == pytest.approx(gap)
    assert stitches.energy(model.zeros()) == 0  # placed slack
    stepper = Stepper(model)
    for s in (0.15, 0.3):  # tightened in two steps: 30 % of the gap taken up
        stitches.tighten(s)
        assert stepper.step().converged
    assert 0.68 * gap < stitches.distances(stepper.u)[0] < 0.75 * gap  # the stiff stitch gives little
    assert stitches.forces(stepper.u)[0] > 0


def test_stitch_ends_inside_tetrahedra_move_with_their_four_nodes(block):
    t = block.t
    w = np.array([[[0.1], [0.2], [0.3], [0.4]], [[0.25], [0.25], [0.25], [0.25]]])
    pairs = np.stack([t[:, [0]], t[:, [40]]])  # (2 ends, 4 corners, 1 stitch)
    stitches = Sutures(block.p, pairs, 1e3, np.zeros((3, 1)), coefficients=w)
    u = np.random.default_rng(0).normal(size=3 * block.nvertices) * 0.01
    x = block.p + u.reshape(-1, 3).T
    ends = stitches.ends(u)
    np.testing.assert_allclose(ends[0, :, 0], x[:, t[:, 0]] @ w[0, :, 0])
    np.testing.assert_allclose(ends[1, :, 0], x[:, t[:, 40]].mean(axis=1))
    with pytest.raises(ValueError, match=r"sutures.gaps .* shaped \(3, 1\)"):
        Sutures(block.p, pairs, 1e3, np.zeros((2, 1)), coefficients=w)
    with pytest.raises(ValueError, match="barycentric"):
        Sutures(block.p, pairs, 1e3, np.zeros((3, 1)), coefficients=w[:, :3])


# --- fibres ---------------------------------------------------------------------------------------------------

def test_a_fibre_along_x_stores_energy_for_a_stretch_along_x_only():
    mesh = box(1.0, 1.0, 1.0, 2, 2, 2)
    k, stretch = 40.0, 1.2
    model = Model(mesh, NeoHookean(E_LAM, E_MU), fibers=(k, [2.0, 0.0, 0.0]))  # normalised
    fibres = model.terms_of(Fibers)[0]
    assert fibres.directions.shape == (3, mesh.nelements) and np.allclose(fibres.directions[0], 1.0)
    X = model.dof_points
    for axis, expected in [(0, k / 8 * (stretch**2 - 1) ** 2), (1, 0.0), (2, 0.0)]:
        x = X.copy()
        x[axis] *= stretch
        u = (x - X)[model.component, np.arange(model.n_dofs)]
        assert fibres.energy(u) == pytest.approx(expected, abs=1e-12)  # per unit volume, on a unit cube


def test_fibre_directions_must_be_of_the_mesh_dimension(block):
    with pytest.raises(ValueError, match=r"fibers.direction must be shaped \(3,\) or \(3, n_elements=144\)"):
        Model(block, NeoHookean(E_LAM, E_MU), fibers=(1.0, [1.0, 0.0]))
    with pytest.raises(ParameterError, match="zero-length"):
        Model(block, NeoHookean(E_LAM, E_MU), fibers=(1.0, [0.0, 0.0, 0.0]))
    per_element = np.random.default_rng(1).normal(size=(3, block.nelements))
    model = Model(block, NeoHookean(E_LAM, E_MU), fibers=(1.0, per_element))
    np.testing.assert_allclose(np.linalg.norm(model.terms_of(Fibers)[0].directions, axis=0), 1.0)


# --- a model with every tool ----------------------------------------------------------------------------------

def _tool_model(block, **kw):
    """The block held at its left end, under gravity, with fibres, a ball pressed 0.02 into its top face at a node,
    and a stitch across the diagonal of its free end's face."""
    p = block.p
    a = np.flatnonzero(np.all(np.isclose(p, [[1.0], [0.0], [0.0]]), axis=0))[0]
    b = np.flatnonzero(np.all(np.isclose(p, [[1.0], [0.5], [0.6]]), axis=0))[0]
    return Model(block, StableNeoHookean(E_LAM, E_MU), handles=[Handle("left")], gravity=(0.0, -9.81, 0.0),
                 fibers=(2e3, [1.0, 0.0, 0.5]),
                 probes=[dict(center=[0.75, 0.5 + 0.25 - 0.02, 0.4], radius=0.25, stiffness=1e6)],
                 sutures={"pairs": [[a], [b]], "stiffness": 1e4, "gaps": p[:, [a]] - p[:, [b]], "tightness": 0.1},
                 **kw)


def test_a_3d_model_with_probe_sutures_and_fibres_steps(block):
    model = _tool_model(block)
    assert model.term_names == ["elastic", "fibers", "probe", "sutures", "gravity"]
    stepper = Stepper(model)
    gap = model.sutures.distances(stepper.u)[0]
    for s in (0.1, 0.2):
        model.sutures.tighten(s)
        report = stepper.step()
        assert report.converged and np.all(np.isfinite(stepper.u))
    assert model.sutures.distances(stepper.u)[0] < gap  # pulled together
    assert model.probes[0].penetration(stepper.u) > 0


def test_a_3d_real_time_frame_with_every_tool_converges_and_takes_and_drops_a_tool(block):
    model = _tool_model(block, dt=1 / 30)
    solver = RealtimeSolver(model, budget=1.0)  # a loaded test machine must not cut the frame short
    for _ in range(2):
        report = solver.step()
        assert report.converged and np.all(np.isfinite(solver.u))
    base = model.pattern.nnz
    probe = Probe(model.X, model.boundary_lengths, [0.25, 0.5 + 0.1 - 0.01, 0.2], 0.1, 1e6, label="second")
    model.add_term(probe)
    assert model.probes[-1] is probe and model.pattern.nnz == base  # a probe couples no two nodes
    stitches = model.sutures
    model.remove_term(stitches)
    assert model.sutures is None and model.pattern.nnz < base  # the stitch's couplings went with it
    solver = RealtimeSolver(model, budget=1.0)
    report = solver.step()
    assert report.converged and probe.penetration(solver.u) > 0 and np.all(np.isfinite(solver.u))
    model.add_term(stitches)
    assert model.pattern.nnz == base


# --- what stays 2D ----------------------------------------------------------------------------------------------

def test_the_ghost_penalty_of_cuts_refuses_tetrahedra_by_name(block):
    with pytest.raises(ParameterError, match="ghost penalty.*2D only"):
        GhostPenalty(block, np.full(block.nelements, 0.5), 1.0)
