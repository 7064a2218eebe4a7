"""The ghost penalty that holds the pieces of triangles cut through (engine.terms.GhostPenalty).

A thin piece holds its virtual nodes with a stiffness proportional to its weight; a grab (a stitch, contact) on its
lip reaches them with the lip point's barycentric coefficients, so they spike. Measured here: the largest jump of
displacement between a virtual node and a real neighbour, over the largest jump between two real neighbours, when a
crack that passes 5 % of an element from a grid line has a lip point of its thinnest corner piece dragged; at three
mesh sizes it stays near 1 with the penalty, and grows past 9 without (measured: 9.0, 11.1, 13.7; with: 1.07, 0.97,
0.96), and the tangent's condition number falls to about an uncut sheet's. The penalty is zero for linear fields (the patch
test on a mesh cut through elements, its pieces tied) and rigid motions, and absent where nothing is cut.
"""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from tissuefem.engine.materials import NeoHookean
from tissuefem.engine.meshes import rectangle
from tissuefem.engine.model import Handle, Model
from tissuefem.engine.parameters import ParameterError, lame_parameters
from tissuefem.engine.stepping import solve
from tissuefem.engine.terms import GhostPenalty, Term
from tissuefem.surgery.element_cuts import cut_through, node_material

LAM, MU = lame_parameters(1000.0, 0.3)
MATERIAL = NeoHookean(LAM, MU)


class Grab(Term):
    """A stiff spring pulling a point inside an element (barycentric ``bary`` of its ``nodes``) by ``d``."""

    quadratic = True
    name = "grab"

    def __init__(self, nodes, bary, d, k=1e4 * MU):
        self.dofs, self.bary, self.d, self.k = np.stack([2 * nodes, 2 * nodes + 1]), bary, np.asarray(d), k

    def _gap(self, u):
        return u[self.dofs] @ self.bary - self.d

    def energy(self, u):
        return 0.5 * self.k * float(self._gap(u) @ self._gap(u))

    def gradient(self, u):
        g = np.zeros(np.size(u))
        g[self.dofs] += self.k * self._gap(u)[:, None] * self.bary[None]
        return g

    def bind(self, pattern):
        super().bind(pattern)
        self.positions = pattern.positions(np.repeat(self.dofs, 3, axis=1).ravel(), np.tile(self.dofs, (1, 3)).ravel())
        self.values = self.k * np.tile(np.outer(self.bary, self.bary).ravel(), 2)

    def add_hessian(self, u, data, safe=False):
        np.add.at(data, self.positions, self.values)


def cracked(nx, delta=0.05):
    """A 2 x 1 sheet with a crack from the top to mid-height, ``delta`` elements right of the grid line x = 1."""
    x = 1.0 + delta * 2.0 / nx
    return cut_through(rectangle(2.0, 1.0, nx, nx // 2), [[x, 1.3], [x, 0.5]])


def without_ghost(model):
    model.set_terms([t for t in model.terms if not isinstance(t, GhostPenalty)])
    return model


def spike(cut, u):
    """The largest displacement jump from a virtual node to a real neighbour over the largest between real ones."""
    real = node_material(cut.mesh, cut.regions)
    t, U = cut.mesh.t, u.reshape(-1, 2)
    edges = np.unique(np.sort(np.concatenate([t[[0, 1]], t[[1, 2]], t[[0, 2]]], axis=1), axis=0), axis=1)
    jump = np.hypot(*(U[edges[0]] - U[edges[1]]).T)
    both, one = real[edges[0]] & real[edges[1]], real[edges[0]] != real[edges[1]]
    return jump[one].max() / jump[both].max()


def grabbed(cut, ghost):
    """Equilibrium with the sheet's ends held and a lip point of the thinnest corner piece (one real node, near the
    crack's mouth) dragged by (0.02, 0.02)."""
    wound, w = cut.wound, cut.weights
    corner = node_material(cut.mesh, cut.regions)[wound.nodes].sum(axis=1) == 1
    candidates = np.flatnonzero(wound.opened & corner & (w[wound.element] < 0.05))
    i = candidates[np.argmax(wound.reference[candidates, :, 1].mean(axis=1))]
    grab = Grab(wound.nodes[i], wound.barycentric[i].mean(axis=0), (0.02, 0.02))
    model = Model(cut.mesh, MATERIAL, weights=w, handles=[Handle("left"), Handle("right")], terms=[grab])
    if not ghost:
        without_ghost(model)
    result = solve(model)
    assert result.converged
    return result.u, model


def condition(model):
    x = model.X
    held = np.flatnonzero(np.isclose(x[0], 0.0) | np.isclose(x[0], 2.0))
    free = np.setdiff1d(np.arange(model.n_dofs), np.concatenate([2 * held, 2 * held + 1]))
    ev = np.linalg.eigvalsh(model.hessian(np.zeros(model.n_dofs))[free][:, free].toarray())
    return ev[-1] / ev[0]


def test_a_grabbed_thin_piece_does_not_spike_at_any_mesh_size():
    for nx in (8, 16, 32):
        cut = cracked(nx)
        assert cut.weights.min() < 0.005  # a corner piece of 0.25 % of its triangle
        u, model = grabbed(cut, ghost=True)
        assert "ghost penalty" in model.term_names
        assert spike(cut, u) < 1.5
        u_bare, _ = grabbed(cut, ghost=False)
        assert spike(cut, u_bare) > 6.0  # the same grab without the penalty
    # the tangent at rest is conditioned about like an uncut sheet's (measured 316, 183 uncut, 6860 without; 8 x 4)
    cut = cracked(8)
    with_ghost = condition(Model(cut.mesh, MATERIAL, weights=cut.weights))
    bare = condition(without_ghost(Model(cut.mesh, MATERIAL, weights=cut.weights)))
    uncut = condition(Model(rectangle(2.0, 1.0, 8, 4), MATERIAL))
    assert with_ghost < 2.0 * uncut and bare > 10.0 * with_ghost


def test_the_patch_test_passes_on_a_mesh_cut_through_elements_with_its_pieces_tied():
    cut = cracked(8, delta=0.3)
    p = cut.mesh.p
    A, c = np.array([[0.04, 0.015], [-0.02, 0.03]]), np.array([[0.01], [-0.02]])
    u_linear = (A @ p + c).T.ravel()  # a linear displacement field
    model = Model(cut.mesh, MATERIAL, weights=cut.weights)
    ghost = next(t for t in model.terms if isinstance(t, GhostPenalty))
    assert ghost.energy(u_linear) < 1e-12 * MU and np.abs(ghost.gradient(u_linear)).max() < 1e-10 * MU
    # tie the pieces: every copy of a node moves with the first (u = T v), the boundary held at the linear field
    _, group = np.unique(np.round(p, 12), axis=1, return_inverse=True)
    assert group.max() + 1 < p.shape[1]  # there are copies
    T = sp.csr_matrix((np.ones(2 * group.size), (np.arange(2 * group.size), (2 * group[:, None] + [0, 1]).ravel())))
    boundary = np.isclose(p[0], 0) | np.isclose(p[0], 2) | np.isclose(p[1], 0) | np.isclose(p[1], 1)
    held_groups = np.unique(group[boundary])
    held = np.zeros(T.shape[1], dtype=bool)
    held[2 * held_groups], held[2 * held_groups + 1] = True, True
    v = np.zeros(T.shape[1])
    v[held] = (T.T @ u_linear)[held] / (T.T @ np.ones(T.shape[0]))[held]
    for _ in range(10):
        u = T @ v
        r = T.T @ model.gradient(u)
        if np.abs(r[~held]).max() < 1e-11 * MU:
            break
        K = (T.T @ model.hessian(u) @ T).tocsc()
        v[~held] -= spla.spsolve(K[~held][:, ~held], r[~held])
    assert np.abs(T @ v - u_linear).max() < 1e-12


def test_a_rigid_motion_costs_nothing_and_an_uncut_mesh_has_no_penalty():
    cut = cracked(16)
    model = Model(cut.mesh, MATERIAL, weights=cut.weights)
    ghost = next(t for t in model.terms if isinstance(t, GhostPenalty))
    assert ghost.pairs.shape[1] > 0
    X = cut.mesh.p
    R = np.array([[np.cos(1.0), -np.sin(1.0)], [np.sin(1.0), np.cos(1.0)]])
    u = (R @ X + np.array([[0.3], [-0.7]]) - X).T.ravel()
    assert abs(ghost.energy(u)) < 1e-12 * MU and np.abs(ghost.gradient(u)).max() < 1e-10 * MU
    assert abs(model.energy(u)) < 1e-9 * MU
    # a non-linear field is penalised (the jump of the gradient across an edge of a piece); the gradient and the
    # Hessian in the model's pattern are the energy's derivatives
    bent = (0.1 * X[0] ** 2 * np.array([[0.0], [1.0]])).T.ravel()
    assert ghost.energy(bent) > 0.0
    v = np.random.default_rng(0).standard_normal(bent.size)
    eps = 1e-6
    slope = (ghost.energy(bent + eps * v) - ghost.energy(bent - eps * v)) / (2 * eps)
    assert slope == pytest.approx(ghost.gradient(bent) @ v, rel=1e-6)
    data = model.pattern.zeros()
    ghost.add_hessian(bent, data)
    assert np.allclose(model.pattern.csr(data) @ v, ghost.gradient(v), rtol=1e-12, atol=1e-9 * MU)
    # nothing cut, nothing added: the uncut model's terms are as they were
    assert Model(rectangle(2.0, 1.0, 8, 4), MATERIAL).term_names == ["elastic"]
    assert Model(rectangle(2.0, 1.0, 8, 4), MATERIAL, weights=np.ones(64)).term_names == ["elastic"]


def test_bad_input_is_refused_by_name():
    cut = cracked(8)
    for kwargs, field in [({"weights": cut.weights[:-1]}, "weights"), ({"modulus": -1.0}, "ghost_penalty.modulus"),
                          ({"gamma": np.nan}, "ghost_penalty.gamma"), ({"light": 2.0}, "ghost_penalty.light")]:
        args = {"mesh": cut.mesh, "weights": cut.weights, "modulus": MU} | kwargs
        with pytest.raises(ParameterError, match=field.replace(".", r"\.")):
            GhostPenalty(**args)
