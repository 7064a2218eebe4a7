"""Exercises of chapter 5 (anisotropic fibers), graded for the library and for the student.

Expected values are computed here independently: the fiber energy is written
out entry by entry and differentiated by central differences. It is a
polynomial of degree 4 in F, so the differences are accurate to O(h^2)
with no surprises.
"""

import numpy as np
import pytest

from grading import assert_close, implementations
from helpers import fd_derivative
from tissuefem.workbook import answers

K_VALUES = [1.0, 4000.0]


def _unit(angle):
    return np.array([np.cos(angle), np.sin(angle)])


# F: rest, a rotation, a stretch, a simple shear, compression and a general F
CASES = [
    (np.eye(2), _unit(0.3)),
    (np.array([[np.cos(0.7), -np.sin(0.7)], [np.sin(0.7), np.cos(0.7)]]), _unit(1.1)),
    (np.diag([1.3, 0.9]), _unit(0.0)),
    (np.array([[1.0, 0.4], [0.0, 1.0]]), _unit(np.pi / 2)),
    (np.diag([0.7, 1.1]), _unit(-0.5)),
    (np.array([[1.2, -0.3], [0.25, 0.85]]), _unit(2.4)),
]
IDS = ["rest", "rotation", "stretch", "shear", "compression", "general"]


def _I4(F, g):
    # squared length of the deformed fiber F g, written with explicit sums
    return sum(sum(F[i, j] * g[j] for j in range(2)) ** 2 for i in range(2))


def _psi(F, g, k):
    return k / 8.0 * (_I4(F, g) - 1.0) ** 2


def _unit_matrix(i, j):
    E = np.zeros((2, 2))
    E[i, j] = 1.0
    return E


def _fd_stress(F, g, k, h=1e-6):
    return fd_derivative(lambda G: _psi(G, g, k), F, h)


def _fd_tangent(F, g, k, h=1e-4):
    A = np.zeros((2, 2, 2, 2))
    for i in range(2):
        for j in range(2):
            for m in range(2):
                for n in range(2):
                    a, b = h * _unit_matrix(i, j), h * _unit_matrix(m, n)
                    A[i, j, m, n] = (_psi(F + a + b, g, k) - _psi(F + a - b, g, k)
                                     - _psi(F - a + b, g, k) + _psi(F - a - b, g, k)) / (4 * h * h)
    return A


@pytest.mark.parametrize("answer", implementations("ch05", "fiber_invariant", answers.fiber_invariant))
@pytest.mark.parametrize("F, g", CASES, ids=IDS)
def test_ex5_1_fiber_invariant(answer, F, g):
    slips = {"g^T F F^T g: the notes' transposed F (erratum 13); the fiber's stretch is |F g|^2 = g^T F^T F g":
             g @ F @ F.T @ g}
    assert_close(answer(F, g), _I4(F, g), "I4 = g^T F^T F g", slips=slips)


@pytest.mark.parametrize("answer", implementations("ch05", "fiber_invariant", answers.fiber_invariant))
def test_ex5_1_fiber_invariant_is_the_squared_fiber_stretch(answer):
    # simple shear x = (X + 0.5 Y, Y): a vertical fiber of length 1 becomes (0.5, 1), of squared length 1.25
    F = np.array([[1.0, 0.5], [0.0, 1.0]])
    assert_close(answer(F, np.array([0.0, 1.0])), 1.25, "I4 of a vertical fiber under simple shear")
    assert_close(answer(F, np.array([1.0, 0.0])), 1.0, "I4 of a horizontal fiber under simple shear")


@pytest.mark.parametrize("answer", implementations("ch05", "fiber_stress", answers.fiber_stress))
@pytest.mark.parametrize("k", K_VALUES)
@pytest.mark.parametrize("F, g", CASES, ids=IDS)
def test_ex5_2_fiber_stress(answer, F, g, k):
    expected = _fd_stress(F, g, k)
    assert_close(answer(F, g, k), expected, f"P_fiber (compared with a finite difference of Psi_fiber), k = {k}",
                 rtol=1e-6, atol=1e-7 * k)


@pytest.mark.parametrize("answer", implementations("ch05", "fiber_stress", answers.fiber_stress))
def test_ex5_2_fiber_stress_vanishes_at_rest_and_under_rotation(answer):
    R = CASES[1][0]
    for F in (np.eye(2), R):
        assert_close(answer(F, _unit(0.8), 100.0), np.zeros((2, 2)), "P_fiber when the fiber keeps its length")


@pytest.mark.parametrize("answer", implementations("ch05", "fiber_tangent", answers.fiber_tangent))
@pytest.mark.parametrize("k", K_VALUES)
@pytest.mark.parametrize("F, g", CASES, ids=IDS)
def test_ex5_3_fiber_tangent(answer, F, g, k):
    expected = _fd_tangent(F, g, k)
    assert_close(answer(F, g, k), expected, f"A_fiber (second differences of Psi_fiber), k = {k}",
                 rtol=1e-5, atol=1e-6 * k)


@pytest.mark.parametrize("answer", implementations("ch05", "fiber_tangent", answers.fiber_tangent))
def test_ex5_3_fiber_tangent_at_rest_adds_k_along_the_fiber_only(answer):
    g, k = _unit(0.6), 7.0
    n = np.array([-g[1], g[0]])  # across the fiber
    A = np.asarray(answer(np.eye(2), g, k))
    assert_close(np.einsum("ijkl,i,j,k,l->", A, g, g, g, g), k, "A_ffff at F = I")
    for a, b, c, d in [(g, g, n, n), (n, n, n, n), (g, n, g, n), (n, g, n, g)]:
        assert_close(np.einsum("ijkl,i,j,k,l->", A, a, b, c, d), 0.0, "a component of A_fiber(I) other than ffff")


@pytest.mark.parametrize("answer", implementations("ch05", "fiber_modulus_gain", answers.fiber_modulus_gain))
@pytest.mark.parametrize("k", K_VALUES)
@pytest.mark.parametrize("angle_deg", [0.0, 20.0, 45.0, 60.0, 90.0, 135.0, -30.0])
def test_ex5_4_fiber_modulus_gain(answer, k, angle_deg):
    # second difference of Psi_fiber along F = I + eps e e^T, e at angle_deg from the fiber g = (1, 0)
    theta = np.deg2rad(angle_deg)
    e = np.array([np.cos(theta), np.sin(theta)])
    g = np.array([1.0, 0.0])
    h = 1e-4

    def psi(eps):
        return _psi(np.eye(2) + eps * np.outer(e, e), g, k)

    expected = (psi(h) - 2.0 * psi(0.0) + psi(-h)) / h**2
    assert_close(answer(k, angle_deg), expected, f"extra modulus at {angle_deg} degrees from the fiber, k = {k}",
                 rtol=1e-7, atol=1e-9 * k)
