"""Exercises 4.4 and 4.5 (chapter 4): P1 assembly of q and K, and Newton with an energy line search.

Graded the same way for the library (``tissuefem.workbook.answers``) and the student's
``chapters/exercises/ch04.py``. The functions handed to an answer (the material's stress
and tangent, the energies to minimise) are written out in this file with numpy, so that
an answer graded in instructor mode runs no code of the library; the expected values come
from the library's own assembler and solver, run by the test.
"""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

from grading import assert_close, implementations
from tissuefem import Handle, Model, NeoHookean, rectangle, solve
from tissuefem.engine.assembly import P1Assembler
from tissuefem.workbook import answers

LAM, MU = 576.9230769230769, 384.61538461538464  # E = 1000, nu = 0.3


# --- two materials, written out for one F or for F[i, j, element] ------------------------------------

def nh_stress(F, lam=LAM, mu=MU):
    """Neo-Hookean: P = mu F + (lam ln J - mu) F^-T."""
    J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    FinvT = np.array([[F[1, 1], -F[1, 0]], [-F[0, 1], F[0, 0]]]) / J
    return mu * F + (lam * np.log(J) - mu) * FinvT


def nh_tangent(F, lam=LAM, mu=MU):
    """dP_ij/dF_kl = mu d_ik d_jl + lam F^-T_ij F^-T_kl - (lam ln J - mu) F^-T_il F^-T_kj."""
    J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    G = np.array([[F[1, 1], -F[1, 0]], [-F[0, 1], F[0, 0]]]) / J
    eye = np.eye(2).reshape((2, 2) + (1,) * (F.ndim - 2))
    return (mu * np.einsum("ik...,jl...->ijkl...", eye, eye) + lam * np.einsum("ij...,kl...->ijkl...", G, G)
            - (lam * np.log(J) - mu) * np.einsum("il...,kj...->ijkl...", G, G))


def svk_stress(F, lam=LAM, mu=MU):
    """St Venant-Kirchhoff: P = F S, S = lam tr(E) I + 2 mu E, E = (F^T F - I) / 2."""
    E = 0.5 * (np.einsum("ki...,kj...->ij...", F, F) - np.eye(2).reshape((2, 2) + (1,) * (F.ndim - 2)))
    S = 2 * mu * E + lam * (E[0, 0] + E[1, 1]) * np.eye(2).reshape((2, 2) + (1,) * (F.ndim - 2))
    return np.einsum("ik...,kj...->ij...", F, S)


def svk_tangent(F, lam=LAM, mu=MU):
    """dP_ij/dF_kl = d_ik S_lj + lam F_ij F_kl + mu (F_il F_kj + (F F^T)_ik d_jl)."""
    eye = np.eye(2).reshape((2, 2) + (1,) * (F.ndim - 2))
    E = 0.5 * (np.einsum("ki...,kj...->ij...", F, F) - eye)
    S = 2 * mu * E + lam * (E[0, 0] + E[1, 1]) * eye
    FFt = np.einsum("im...,km...->ik...", F, F)
    return (np.einsum("ik...,lj...->ijkl...", eye, S) + lam * np.einsum("ij...,kl...->ijkl...", F, F)
            + mu * (np.einsum("il...,kj...->ijkl...", F, F) + np.einsum("ik...,jl...->ijkl...", FFt, eye)))


class _Vectorised:
    """The test's material in the engine's layout (for the expected values only)."""

    def __init__(self, stress, tangent):
        self.stress, self.tangent = stress, tangent

    def energy(self, F):
        raise NotImplementedError


MATERIALS = {"neo-hookean": (nh_stress, nh_tangent), "st-venant-kirchhoff": (svk_stress, svk_tangent)}


def test_the_test_materials_are_consistent():
    """The tangents written here are the derivatives of the stresses (central differences)."""
    rng = np.random.default_rng(44)
    for stress, tangent in MATERIALS.values():
        F = np.eye(2) + 0.2 * rng.standard_normal((2, 2))
        A = tangent(F)
        h = 1e-6
        for k in range(2):
            for m in range(2):
                dF = np.zeros((2, 2))
                dF[k, m] = h
                np.testing.assert_allclose(A[:, :, k, m], (stress(F + dF) - stress(F - dF)) / (2 * h), rtol=1e-6,
                                           atol=1e-5)
    assert np.allclose(MATERIALS["neo-hookean"][0](np.eye(2)), 0.0)
    library = NeoHookean(LAM, MU)
    F = np.eye(2) + 0.2 * rng.standard_normal((2, 2))
    np.testing.assert_allclose(nh_stress(F), library.stress(F), rtol=1e-12)
    np.testing.assert_allclose(nh_tangent(F), library.tangent(F), rtol=1e-12)


# --- 4.4 P1 assembly ------------------------------------------------------------------------------

def _meshes():
    """(name, X, triangles): a structured block, and a patch with one clockwise triangle."""
    block = rectangle(2.0, 1.0, 4, 2)
    X = np.array([[0.0, 1.0, 1.0, 0.0, 0.5], [0.0, 0.0, 1.0, 1.0, 0.45]])
    t = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [0, 4, 3]]).T  # the last one clockwise
    return [("block", np.asarray(block.p, dtype=float), np.asarray(block.t)), ("patch", X, t)]


def _displacement(X, seed):
    rng = np.random.default_rng(seed)
    return 0.03 * rng.standard_normal(2 * X.shape[1])


def _loop(X, t, u, stress, tangent, *, area=True, transpose_P=False, blocked=False):
    """An element loop written independently of the answer, with switches that reproduce common slips."""
    n = X.shape[1]
    q, K = np.zeros(2 * n), np.zeros((2 * n, 2 * n))

    def dof(a, i):
        return i * n + a if blocked else 2 * a + i

    for e in range(t.shape[1]):
        v = t[:, e]
        Dm = X[:, v[1:]] - X[:, v[:1]]
        G = np.vstack([-np.linalg.inv(Dm).sum(axis=0), np.linalg.inv(Dm)])  # G[a, j] = dN_a/dX_j
        A_e = 0.5 * abs(np.linalg.det(Dm)) if area else 1.0
        ue = np.array([[u[dof(a, i)] for a in v] for i in range(2)])  # (2, 3)
        F = np.eye(2) + ue @ G
        P, A = stress(F), tangent(F)
        if transpose_P:
            P, A = P.T, A.transpose(1, 0, 3, 2)
        for a in range(3):
            for i in range(2):
                q[dof(v[a], i)] += A_e * P[i] @ G[a]
                for b in range(3):
                    for k in range(2):
                        K[dof(v[a], i), dof(v[b], k)] += A_e * G[a] @ A[i, :, k, :] @ G[b]
    return q, K


@pytest.mark.parametrize("answer", implementations("ch04", "assemble_p1", answers.assemble_p1))
@pytest.mark.parametrize("material", list(MATERIALS))
@pytest.mark.parametrize("mesh", [m[0] for m in _meshes()])
def test_ex4_4_assembly_matches_the_library(answer, material, mesh):
    (_, X, t), = [m for m in _meshes() if m[0] == mesh]
    stress, tangent = MATERIALS[material]
    u = _displacement(X, 7)
    library = P1Assembler(SimpleNamespace(p=X, t=t), _Vectorised(stress, tangent))
    q_expected, K_expected = library.residual(u), library.tangent(u).toarray()
    q, K = answer(X, t, u, stress, tangent)
    K = K.toarray() if sp.issparse(K) else np.asarray(K)
    slips = {}
    for hint, switches in (("each triangle's share is A_e P_ij dN_a/dX_j: the area A_e is missing", dict(area=False)),
                           ("P_ij dN_a/dX_j, not P_ji: the stress is transposed (F[i, j] = dphi_i/dX_j)",
                            dict(transpose_P=True)),
                           ("dof numbering: node a owns dofs 2a and 2a + 1 (interleaved), not a and n + a",
                            dict(blocked=True))):
        q_slip, K_slip = _loop(X, t, u, stress, tangent, **switches)
        slips[hint] = (q_slip, K_slip)
    assert_close(q, q_expected, f"q, the internal forces ({material}, {mesh} mesh)", rtol=1e-9, atol=1e-9,
                 slips={h: v[0] for h, v in slips.items()})
    assert_close(K, K_expected, f"K, the tangent ({material}, {mesh} mesh)", rtol=1e-9, atol=1e-8,
                 slips={h: v[1] for h, v in slips.items()})


@pytest.mark.parametrize("answer", implementations("ch04", "assemble_p1", answers.assemble_p1))
def test_ex4_4_rest_and_rigid_motions_carry_no_force(answer):
    (_, X, t), _ = _meshes()
    stress, tangent = MATERIALS["neo-hookean"]
    q, K = answer(X, t, np.zeros(2 * X.shape[1]), stress, tangent)
    K = K.toarray() if sp.issparse(K) else np.asarray(K)
    assert_close(q, np.zeros_like(q), "q at rest (u = 0)", atol=1e-9)
    assert_close(K, K.T, "K at rest against its transpose (K is symmetric)", atol=1e-8)
    c, s = np.cos(0.7), np.sin(0.7)
    x = np.array([[c, -s], [s, c]]) @ X + np.array([[0.3], [-0.2]])
    u = (x - X).T.reshape(-1)  # node a: dofs 2a, 2a + 1
    q_rigid, _ = answer(X, t, u, stress, tangent)
    assert_close(q_rigid, np.zeros_like(q_rigid), "q after a rigid rotation and translation", atol=1e-8)
    ones = np.tile([1.0, 0.0], X.shape[1])
    assert_close(K @ ones, np.zeros(2 * X.shape[1]), "K times a translation in x (K must annihilate it)", atol=1e-8)


# --- 4.5 Newton with a backtracking line search -------------------------------------------------------

class Recorder:
    """Wraps the problem's functions: counts calls and keeps the points where the Hessian was asked for."""

    def __init__(self, energy, gradient, hessian):
        self._energy, self._gradient, self._hessian = energy, gradient, hessian
        self.iterates = []

    def energy(self, u):
        return self._energy(np.array(u, dtype=float))

    def gradient(self, u):
        return self._gradient(np.array(u, dtype=float))

    def hessian(self, u):
        u = np.array(u, dtype=float)
        if not np.isfinite(self._energy(u)):
            raise AssertionError("you accepted a point where the energy is nan (an inverted element): a comparison "
                                 "with nan is always False, so test `E_new <= ...` to accept, not `E_new > ...` to reject")
        self.iterates.append(u)
        return self._hessian(u)


def soft_abs(c=(1.0, -2.0, 0.5)):
    """E = sum sqrt(1 + (x_i - c_i)^2) + 0.01 |x|^2 / 2: plain Newton from 3 away overshoots and diverges."""
    c = np.asarray(c)

    def energy(x):
        return float(np.sum(np.sqrt(1 + (x - c) ** 2)) + 0.005 * x @ x)

    def gradient(x):
        return (x - c) / np.sqrt(1 + (x - c) ** 2) + 0.01 * x

    def hessian(x):
        return np.diag((1 + (x - c) ** 2) ** -1.5 + 0.01)

    return energy, gradient, hessian


def log_barrier():
    """E = x - 2 ln x + (y - 1)^2 with y held: from x = 5 the full Newton step lands at x = -2.5, where E is nan."""
    def energy(z):
        x, y = z
        return float(x - 2 * np.log(x) + (y - 1) ** 2) if x > 0 else float("nan")

    def gradient(z):
        x, y = z
        return np.array([1 - 2 / x, 2 * (y - 1)])

    def hessian(z):
        x, _ = z
        return np.array([[2 / x**2, 0.0], [0.0, 2.0]])

    return energy, gradient, hessian


def _assembled_block(nx=8, ny=4):
    """The stretched block of chapter 4 as numpy functions of u (Neo-Hookean, P1), and its handles."""
    mesh = rectangle(2.0, 1.0, nx, ny)
    X, t = np.asarray(mesh.p, dtype=float), np.asarray(mesh.t)
    Dm = X[:, t[1:]] - X[:, t[:1]]  # (2, 2, nel)
    inv = np.linalg.inv(np.moveaxis(Dm, -1, 0))  # (nel, 2, 2)
    G = np.concatenate([-inv.sum(axis=1, keepdims=True), inv], axis=1)  # (nel, 3, 2)
    area = 0.5 * np.abs(np.linalg.det(np.moveaxis(Dm, -1, 0)))
    dofs = (2 * t.T[:, :, None] + np.arange(2)).reshape(-1, 6)  # (nel, 6): vertex a, component i
    n = 2 * X.shape[1]

    def F_of(u):
        ue = u[dofs].reshape(-1, 3, 2)  # (nel, a, i)
        return np.eye(2) + np.einsum("eai,eaj->eij", ue, G)

    def energy(u):
        F = F_of(u)
        J = np.linalg.det(F)
        if np.any(J <= 0):
            return float("nan")
        psi = 0.5 * MU * (np.sum(F * F, axis=(1, 2)) - 2) - MU * np.log(J) + 0.5 * LAM * np.log(J) ** 2
        return float(area @ psi)

    def gradient(u):
        P = np.moveaxis(nh_stress(np.moveaxis(F_of(u), 0, -1)), -1, 0)  # (nel, 2, 2)
        local = np.einsum("e,eij,eaj->eai", area, P, G).reshape(-1, 6)
        return np.bincount(dofs.ravel(), weights=local.ravel(), minlength=n)

    def hessian(u):
        A = np.moveaxis(nh_tangent(np.moveaxis(F_of(u), 0, -1)), -1, 0)  # (nel, 2, 2, 2, 2)
        local = np.einsum("e,eaj,eijkl,ebl->eaibk", area, G, A, G).reshape(-1, 6, 6)
        rows = np.broadcast_to(dofs[:, :, None], local.shape)
        cols = np.broadcast_to(dofs[:, None, :], local.shape)
        return sp.csr_matrix((local.ravel(), (rows.ravel(), cols.ravel())), shape=(n, n))

    left = np.flatnonzero(np.isclose(X[0], 0.0))
    right = np.flatnonzero(np.isclose(X[0], 2.0))
    u0 = np.zeros(n)
    u0[2 * right], u0[2 * right + 1] = 0.6, 0.4
    held = np.concatenate([2 * left, 2 * left + 1, 2 * right, 2 * right + 1])
    free = np.setdiff1d(np.arange(n), held)
    return mesh, energy, gradient, hessian, u0, free


def _library_minimiser(energy, gradient, hessian, u0, free):
    return answers.newton_line_search(u0, energy, gradient, hessian, free, rtol=1e-12, max_iterations=100)


def _check_descent(rec, energy, u0, u, what):
    energies = [energy(x) for x in rec.iterates] + [energy(u)]
    assert np.isfinite(energy(u)), f"{what}: the energy of your answer is not finite (an inverted element?): " \
                                   "a trial point with E = nan must be rejected (a comparison with nan is False)"
    rises = [k for k in range(1, len(energies)) if energies[k] > energies[k - 1] + 1e-12 * abs(energies[k - 1])]
    assert not rises, (f"{what}: the energy rose at iteration {rises[0]} ({energies[rises[0] - 1]:.6g} -> "
                       f"{energies[rises[0]]:.6g}): accept a step only if it lowers the energy (halve alpha)")


@pytest.mark.parametrize("answer", implementations("ch04", "newton_line_search", answers.newton_line_search))
def test_ex4_5_the_line_search_tames_an_overshooting_newton(answer):
    energy, gradient, hessian = soft_abs()
    rec = Recorder(energy, gradient, hessian)
    u0 = np.array([4.0, -5.0, 3.5])
    u, iterations = answer(u0, rec.energy, rec.gradient, rec.hessian, np.arange(3), rtol=1e-10)
    _check_descent(rec, energy, u0, u, "soft |x|")
    expected, it_lib = _library_minimiser(energy, gradient, hessian, u0, np.arange(3))
    assert_close(u, expected, "the minimiser of sum sqrt(1 + (x - c)^2) + 0.005 |x|^2", rtol=1e-6, atol=1e-8)
    assert np.linalg.norm(gradient(u)) <= 1e-10 * np.linalg.norm(gradient(u0)) * 1.01, \
        "not converged: stop only when ||g_f|| <= rtol ||g_f(u0)||"
    assert abs(iterations - it_lib) <= 3, \
        f"{iterations} iterations where the library takes {it_lib}: count the accepted Newton steps"


@pytest.mark.parametrize("answer", implementations("ch04", "newton_line_search", answers.newton_line_search))
def test_ex4_5_a_nan_energy_is_rejected_and_held_dofs_stay(answer):
    energy, gradient, hessian = log_barrier()
    rec = Recorder(energy, gradient, hessian)
    u0 = np.array([5.0, 7.0])
    u, iterations = answer(u0, rec.energy, rec.gradient, rec.hessian, np.array([0]), rtol=1e-10)
    _check_descent(rec, energy, u0, u, "x - 2 ln x")
    assert_close(u[1], 7.0, "the held dof (not in free: it keeps its value from u0)")
    assert_close(u[0], 2.0, "the minimiser x = 2 of x - 2 ln x", rtol=1e-8)


@pytest.mark.parametrize("answer", implementations("ch04", "newton_line_search", answers.newton_line_search))
def test_ex4_5_stops_after_max_iterations(answer):
    energy, gradient, hessian = soft_abs()
    u0 = np.array([4.0, -5.0, 3.5])
    u, iterations = answer(u0, energy, gradient, hessian, np.arange(3), rtol=1e-12, max_iterations=2)
    assert iterations == 2, f"{iterations} iterations with max_iterations = 2"
    assert energy(u) < energy(u0), "two accepted steps must lower the energy"


@pytest.mark.parametrize("answer", implementations("ch04", "newton_line_search", answers.newton_line_search))
def test_ex4_5_solves_the_stretched_block_of_chapter_4(answer):
    mesh, energy, gradient, hessian, u0, free = _assembled_block()
    rec = Recorder(energy, gradient, hessian)
    u, iterations = answer(u0, rec.energy, rec.gradient, rec.hessian, free, rtol=1e-10)
    _check_descent(rec, energy, u0, u, "the block")
    held = np.setdiff1d(np.arange(u0.size), free)
    assert_close(u[held], u0[held], "the handles' dofs (they must keep their prescribed values)")
    model = Model(mesh, NeoHookean(LAM, MU), handles=[Handle("left"), Handle("right", (0.6, 0.4))])
    expected = solve(model, rtol=1e-12).u
    assert_close(u, expected, "the equilibrium of the block (the library's solve)", rtol=1e-6, atol=1e-8)
    assert iterations <= 30, f"{iterations} Newton iterations for the block: the library needs well under 30"
