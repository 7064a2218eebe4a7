"""Exercises of chapters 3 and 4, graded the same way for the library and for the student.

Expected values are computed here independently (closed forms, a static
condensation of the 3D stiffness, least-squares fits, finite differences of
energies written out in this file), never by calling the answer.
"""

import numpy as np
import pytest

from grading import assert_close, implementations
from helpers import fd_derivative
from tissuefem.workbook import answers

LAME = [(1.0, 1.0), (576.9230769, 384.6153846), (0.0, 2.5), (10.0, 0.3)]
YOUNG = [(1000.0, 0.3), (1.0, 0.0), (250.0, 0.45), (10.0, -0.5)]


def _rotation(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def _test_Fs():
    """A few deformation gradients with J > 0: near identity, stretched, sheared, turned, compressed."""
    rng = np.random.default_rng(11)
    Fs = [np.eye(2) + 0.15 * rng.standard_normal((2, 2)) for _ in range(3)]
    Fs += [np.diag([1.5, 0.8]), np.array([[1.0, 0.7], [0.0, 1.0]]),
           _rotation(1.1) @ np.array([[1.3, 0.2], [0.2, 0.7]]), np.diag([0.4, 0.6])]
    return Fs


F_CASES = _test_Fs()


# --- chapter 3 -----------------------------------------------------------------

def _plane_stress_by_condensation(lam, mu):
    """In-plane (lam*, mu*) of a 3D isotropic solid with sigma_33 = 0, by static condensation.

    The normal-stress block of the 3D stiffness is C = lam 1 1^T + 2 mu I (3x3);
    eliminating eps_33 from sigma_33 = 0 leaves C2 = C_ab - C_a3 C_3b / C_33, whose
    off-diagonal entry is lam* and whose diagonal is lam* + 2 mu*.
    """
    C = lam * np.ones((3, 3)) + 2 * mu * np.eye(3)
    C2 = C[:2, :2] - np.outer(C[:2, 2], C[2, :2]) / C[2, 2]
    return C2[0, 1], 0.5 * (C2[0, 0] - C2[0, 1])


@pytest.mark.parametrize("answer", implementations("ch03", "lame_from_young", answers.lame_from_young))
@pytest.mark.parametrize("E, nu", YOUNG)
def test_ex3_1_lame_from_young(answer, E, nu):
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    assert_close(answer(E, nu), (lam, mu), f"(lam, mu) in plane strain for E={E}, nu={nu}")
    assert_close(answer(E, nu, "strain"), (lam, mu), "plane='strain' (the default)")
    assert_close(answer(E, nu, plane="stress"), _plane_stress_by_condensation(lam, mu),
                 f"(lam*, mu) in plane stress for E={E}, nu={nu} (sigma_33 = 0 eliminated from the 3D law)")


def _affine_fit(X, x):
    """Solve x_a = A X_a + c for (A, c) from three vertex pairs (a 6x6 linear system)."""
    M = np.zeros((6, 6))
    rhs = np.zeros(6)
    for a in range(3):
        for i in range(2):
            row = 2 * a + i
            M[row, 2 * i:2 * i + 2] = X[:, a]  # A[i, 0] X_0a + A[i, 1] X_1a
            M[row, 4 + i] = 1.0  # + c_i
            rhs[row] = x[i, a]
    sol = np.linalg.solve(M, rhs)
    return sol[:4].reshape(2, 2), sol[4:]


def _signed_area(V):
    return 0.5 * ((V[0, 1] - V[0, 0]) * (V[1, 2] - V[1, 0]) - (V[0, 2] - V[0, 0]) * (V[1, 1] - V[1, 0]))


def _triangles():
    """Reference and deformed vertices (2, 3): random non-degenerate, not inverted; a rigid motion; rest."""
    rng = np.random.default_rng(5)
    cases = []
    while len(cases) < 4:
        X = rng.uniform(-1, 2, (2, 3))
        if _signed_area(X) < 0:
            X = X[:, [0, 2, 1]]  # counter-clockwise
        x = X + 0.3 * rng.standard_normal((2, 3))
        if _signed_area(X) > 0.2 and _signed_area(x) > 0.2 * _signed_area(X):  # keep J > 0.2
            cases.append((X, x))
    X = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    cases.append((X, _rotation(0.7) @ X + np.array([[2.0], [-1.0]])))  # a rigid motion
    cases.append((X, X))  # no motion
    return cases


@pytest.mark.parametrize("answer", implementations("ch03", "deformation_gradient_p1", answers.deformation_gradient_p1))
@pytest.mark.parametrize("case", range(len(_triangles())))
def test_ex3_2_deformation_gradient_p1(answer, case):
    X, x = _triangles()[case]
    A, _ = _affine_fit(X, x)
    assert_close(answer(X, x), A, "F of the triangle (the linear part of the affine map X -> x)")
    perm = [1, 2, 0]
    assert_close(answer(X[:, perm], x[:, perm]), A, "F with the vertices listed in another order")


def _linear_energy(F, lam, mu):
    eps = 0.5 * (F + F.T) - np.eye(2)
    return mu * np.sum(eps * eps) + 0.5 * lam * np.trace(eps) ** 2


@pytest.mark.parametrize("answer", implementations("ch03", "linear_elastic_stress_2d", answers.linear_elastic_stress_2d))
@pytest.mark.parametrize("lam, mu", LAME)
def test_ex3_3_linear_elastic_stress(answer, lam, mu):
    for F in F_CASES:
        expected = fd_derivative(lambda G: _linear_energy(G, lam, mu), F)
        assert_close(answer(F, lam, mu), expected, f"P(F) for F = {F.tolist()} (a finite difference of Psi)",
                     rtol=1e-6, atol=1e-7)
    theta = 0.9
    assert_close(answer(_rotation(theta), lam, mu), 2 * (lam + mu) * (np.cos(theta) - 1) * np.eye(2),
                 "P of a rigid rotation (2 (lam + mu)(cos theta - 1) I)")


# --- chapter 4 -----------------------------------------------------------------

def _neo_energy(F, lam, mu):
    J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    return 0.5 * mu * (np.sum(F * F) - 2.0) - mu * np.log(J) + 0.5 * lam * np.log(J) ** 2


@pytest.mark.parametrize("answer", implementations("ch04", "neo_hookean_energy_2d", answers.neo_hookean_energy_2d))
@pytest.mark.parametrize("lam, mu", LAME)
def test_ex4_1_neo_hookean_energy(answer, lam, mu):
    for F in F_CASES:
        assert_close(answer(F, lam, mu), _neo_energy(F, lam, mu), f"Psi(F) for F = {F.tolist()}")
        assert_close(answer(_rotation(2.0) @ F, lam, mu), _neo_energy(F, lam, mu),
                     "Psi(R F) (frame indifference: a rotation afterwards costs nothing)")
    for theta in (0.0, 0.5, np.pi / 2, 3.0):
        assert_close(answer(_rotation(theta), lam, mu), 0.0, f"Psi of a rigid rotation by {theta}", atol=1e-10)


@pytest.mark.parametrize("answer", implementations("ch04", "neo_hookean_stress_2d", answers.neo_hookean_stress_2d))
@pytest.mark.parametrize("lam, mu", LAME)
def test_ex4_2_neo_hookean_stress(answer, lam, mu):
    for F in F_CASES:
        expected = fd_derivative(lambda G: _neo_energy(G, lam, mu), F)
        assert_close(answer(F, lam, mu), expected, f"P(F) for F = {F.tolist()} (a finite difference of Psi)",
                     rtol=1e-6, atol=1e-6)
    R = _rotation(0.8)
    assert_close(answer(R, lam, mu), np.zeros((2, 2)), "P of a rigid rotation", atol=1e-10)
    F = F_CASES[5]
    assert_close(answer(R @ F, lam, mu), R @ answer(F, lam, mu), "P(R F) = R P(F) (objectivity)")


def _element_energy(X, x, lam, mu):
    A, _ = _affine_fit(X, x)
    return abs(_signed_area(X)) * _neo_energy(A, lam, mu)


@pytest.mark.parametrize("answer", implementations("ch04", "element_forces_p1", answers.element_forces_p1))
@pytest.mark.parametrize("case", range(4))
def test_ex4_3_element_forces(answer, case):
    lam, mu = LAME[case]
    X, x = _triangles()[case]
    h = 1e-6
    expected = np.zeros((2, 3))
    for i in range(2):
        for a in range(3):
            dx = np.zeros((2, 3))
            dx[i, a] = h
            expected[i, a] = (_element_energy(X, x + dx, lam, mu) - _element_energy(X, x - dx, lam, mu)) / (2 * h)
    f = answer(X, x, lam, mu)
    assert_close(f, expected, "vertex forces (a finite difference of the element energy A Psi)", rtol=1e-6, atol=1e-6)
    scale = np.abs(expected).max()
    assert_close(np.sum(f, axis=1), np.zeros(2), "the sum of the three forces (must vanish)", atol=1e-10 * scale)
    torque = np.sum(x[0] * f[1] - x[1] * f[0])
    assert_close(torque, 0.0, "the torque of the forces about the origin (must vanish)", atol=1e-9 * scale)
