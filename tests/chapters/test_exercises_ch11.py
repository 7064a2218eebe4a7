"""Exercises of chapter 11 (tissue in 3D), graded the same way for the library and for the student.

Expected values are computed here independently (an affine fit of the four vertex pairs, signed volumes written
out, central differences of the energy written in this file), never by calling the answer.
"""

import numpy as np
import pytest

from grading import assert_close, implementations
from helpers import fd_derivative
from tissuefem.workbook import answers

LAME = [(1.0, 1.0), (576.9230769, 384.6153846), (0.0, 2.5), (10.0, 0.3)]


def _rotation(axis, angle):
    """The rotation by ``angle`` about ``axis`` (Rodrigues' formula)."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


# --- 11.1 the deformation gradient of a tetrahedron ---------------------------------------------------------------

def _affine_fit(X, x):
    """Solve ``x_a = A X_a + c`` for ``(A, c)`` from the four vertex pairs: a 12 x 12 linear system."""
    M, rhs = np.zeros((12, 12)), np.zeros(12)
    for a in range(4):
        for i in range(3):
            row = 3 * a + i
            M[row, 3 * i:3 * i + 3] = X[:, a]  # A[i, :] . X_a
            M[row, 9 + i] = 1.0  # + c_i
            rhs[row] = x[i, a]
    sol = np.linalg.solve(M, rhs)
    return sol[:9].reshape(3, 3), sol[9:]


def _signed_volume(V):
    """Six times the signed volume of the tetrahedron with vertex columns ``V`` (3, 4), written out."""
    a, b, c = V[:, 1] - V[:, 0], V[:, 2] - V[:, 0], V[:, 3] - V[:, 0]
    return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]))


def _tetrahedra():
    """Reference and deformed vertices (3, 4): random, a rigid motion, a shear, an inverted one (a mirror), rest."""
    rng = np.random.default_rng(111)
    X = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    skew = np.array([[0.2, 1.3, -0.4, 0.5], [0.1, 0.2, 0.9, -0.3], [-0.2, 0.4, 0.1, 1.1]])
    cases = {}
    for k in range(3):
        Xk = skew + 0.2 * rng.standard_normal((3, 4))
        if _signed_volume(Xk) < 0:
            Xk = Xk[:, [0, 2, 1, 3]]
        cases[f"random {k}"] = (Xk, (np.eye(3) + 0.4 * rng.standard_normal((3, 3))) @ Xk + rng.standard_normal((3, 1)))
    R = _rotation([1.0, -2.0, 0.5], 0.8)
    cases["rigid motion"] = (skew, R @ skew + np.array([[1.0], [2.0], [-3.0]]))
    cases["shear"] = (X, np.array([[1.0, 0.6, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) @ X)
    cases["inverted (mirrored in z)"] = (skew, np.diag([1.0, 1.0, -1.0]) @ skew)
    cases["rest"] = (skew, skew.copy())
    return cases


TETS = _tetrahedra()


@pytest.mark.parametrize("answer", implementations("ch11", "deformation_gradient_tet",
                                                   answers.deformation_gradient_tet))
@pytest.mark.parametrize("name", list(TETS))
def test_ex11_1_deformation_gradient_tet(answer, name):
    X, x = TETS[name]
    expected, _ = _affine_fit(X, x)
    Dm, Ds = X[:, 1:] - X[:, :1], x[:, 1:] - x[:, :1]
    slips = {"you return D_s D_m^-1 transposed: F[i, j] = dx_i/dX_j (row: spatial component)": expected.T,
             "you return D_m^-1 D_s: the inverse goes on the right, F D_m = D_s": np.linalg.solve(Dm, Ds),
             "you return the deformed edge vectors D_s alone: divide by the rest ones (times D_m^-1)": Ds,
             "you return D_m D_s^-1, the inverse map's gradient: F = D_s D_m^-1": Dm @ np.linalg.inv(Ds)}
    got = answer(X.copy(), x.copy())
    assert_close(got, expected, f"F of the tetrahedron '{name}' (against an affine fit of its four vertices)",
                 slips=slips)


@pytest.mark.parametrize("answer", implementations("ch11", "deformation_gradient_tet",
                                                   answers.deformation_gradient_tet))
def test_ex11_1_det_F_is_the_volume_ratio_and_carries_the_inversion(answer):
    for name, (X, x) in TETS.items():
        F = np.asarray(answer(X.copy(), x.copy()), dtype=float)
        assert_close(np.linalg.det(F), _signed_volume(x) / _signed_volume(X),
                     f"det F of '{name}' (the ratio of signed volumes, negative when inverted)", rtol=1e-9)
    X, x = TETS["rigid motion"]
    F = np.asarray(answer(X.copy(), x.copy()), dtype=float)
    assert_close(F.T @ F, np.eye(3), "F^T F of a rigid motion (a rotation: no strain)", atol=1e-10)


# --- 11.2 the 3D Neo-Hookean stress --------------------------------------------------------------------------------

def _energy(F, lam, mu):
    """``Psi = mu/2 (F:F - 3) - mu ln J + lam/2 (ln J)^2``, J written out with the rule of Sarrus."""
    J = (F[0, 0] * F[1, 1] * F[2, 2] + F[0, 1] * F[1, 2] * F[2, 0] + F[0, 2] * F[1, 0] * F[2, 1]
         - F[0, 2] * F[1, 1] * F[2, 0] - F[0, 0] * F[1, 2] * F[2, 1] - F[0, 1] * F[1, 0] * F[2, 2])
    return 0.5 * mu * (np.sum(F * F, axis=(0, 1)) - 3.0) - mu * np.log(J) + 0.5 * lam * np.log(J) ** 2


def _stress_cases():
    rng = np.random.default_rng(112)
    cases = {f"near rest {k}": np.eye(3) + 0.15 * rng.standard_normal((3, 3)) for k in range(2)}
    cases["stretched"] = np.diag([1.5, 0.8, 0.9])
    cases["sheared"] = np.array([[1.0, 0.7, 0.0], [0.0, 1.0, 0.3], [0.0, 0.0, 1.0]])
    cases["turned and stretched"] = _rotation([0.3, 1.0, -0.6], 1.2) @ np.array(
        [[1.3, 0.2, 0.1], [0.2, 0.7, 0.0], [0.1, 0.0, 1.1]])
    cases["compressed"] = np.diag([0.4, 0.6, 0.5])
    return cases


STRESS_CASES = _stress_cases()


@pytest.mark.parametrize("answer", implementations("ch11", "neo_hookean_stress_3d", answers.neo_hookean_stress_3d))
@pytest.mark.parametrize("lam, mu", LAME)
@pytest.mark.parametrize("name", list(STRESS_CASES))
def test_ex11_2_neo_hookean_stress_3d(answer, name, lam, mu):
    F = STRESS_CASES[name]
    expected = fd_derivative(lambda G: _energy(G, lam, mu), F, 1e-6)
    J = np.linalg.det(F)
    inv_T = np.linalg.inv(F).T
    terms = {"μF": mu * F, "−μF⁻ᵀ": -mu * inv_T, "λ ln J F⁻ᵀ": lam * np.log(J) * inv_T}
    slips = {"F⁻¹ where dJ/dF needs F⁻ᵀ: cof F = J F⁻ᵀ (the transpose of the adjugate)":
             mu * F + (lam * np.log(J) - mu) * inv_T.T}
    assert_close(answer(F.copy(), lam, mu), expected,
                 f"P of the 3D Neo-Hookean model at F = {name} (against a central difference of the energy)",
                 rtol=1e-6, atol=1e-5 * (1.0 + lam + mu), terms=terms, slips=slips)


@pytest.mark.parametrize("answer", implementations("ch11", "neo_hookean_stress_3d", answers.neo_hookean_stress_3d))
def test_ex11_2_no_stress_at_rest_and_frame_indifference(answer):
    lam, mu = 576.9230769, 384.6153846
    assert_close(answer(np.eye(3), lam, mu), np.zeros((3, 3)), "P at rest (F = I)", atol=1e-9)
    R = _rotation([1.0, 1.0, -0.4], 0.9)
    assert_close(answer(R.copy(), lam, mu), np.zeros((3, 3)), "P of a rigid rotation (F = R)", atol=1e-9)
    F = STRESS_CASES["turned and stretched"]
    assert_close(answer(R @ F, lam, mu), R @ np.asarray(answer(F.copy(), lam, mu), dtype=float),
                 "P(R F) = R P(F): a turn of the deformed body turns the stress with it", rtol=1e-9, atol=1e-9)
