"""Exercises of chapter 6 (inversion), graded for the library and for the student.

The rotation-preserving SVD is not unique (a rotation has equal singular
values, F = 0 has no preferred rotation at all), so it is graded by its
defining properties and by numpy's singular values, not against one answer.
The Taylor stress is compared with central differences of the energy, written
out here entry by entry from the notes' formula (a polynomial in F: the
differences are accurate to O(h^2) with no surprises).
"""

import numpy as np
import pytest

from grading import assert_close, implementations
from helpers import fd_derivative
from tissuefem.workbook import answers


def _rot(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def _det(F):
    return F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]


_RNG = np.random.default_rng(6)
SVD_CASES = {
    "identity": np.eye(2),
    "rotation": _rot(2.0),
    "half-turn": -np.eye(2),                      # a rotation by pi: J = +1, not inverted
    "reflection": np.diag([1.0, -1.0]),
    "rotated-reflection": _rot(0.7) @ np.diag([2.0, -2.0]),
    "zero": np.zeros((2, 2)),
    "line": np.array([[1.0, 0.0], [0.0, 0.0]]),  # collapsed to a line: J = 0
    "shear": np.array([[1.0, 0.8], [0.0, 1.0]]),
    "inverted-shear": np.array([[0.9, 0.5], [-0.1, -0.4]]),
    "built-inverted": _rot(0.4) @ np.diag([1.5, -0.5]) @ _rot(-0.9).T,
    "tiny": 1e-9 * np.array([[1.0, 2.0], [-3.0, 0.5]]),
    **{f"random-{k}": _RNG.normal(size=(2, 2)) for k in range(6)},
}


# --- 6.1 the rotation-preserving SVD ---------------------------------------------------------

@pytest.mark.parametrize("answer", implementations("ch06", "rotation_preserving_svd", answers.rotation_preserving_svd))
@pytest.mark.parametrize("name", list(SVD_CASES))
def test_ex6_1_rotation_preserving_svd(answer, name):
    F = SVD_CASES[name]
    scale = max(1.0, np.abs(F).max())
    out = answer(F.copy())
    assert len(out) == 3, "return the tuple (U, s, V)"
    U, s, V = (np.asarray(a, dtype=float) for a in out)
    assert U.shape == (2, 2) and V.shape == (2, 2), f"U and V must be 2x2, got shapes {U.shape}, {V.shape}"
    assert s.shape == (2,), f"s must have shape (2,), got {s.shape}"
    assert np.all(np.isfinite(U)) and np.all(np.isfinite(s)) and np.all(np.isfinite(V)), "U, s, V must be finite"
    assert_close(U @ np.diag(s) @ V.T, F, f"U diag(s) V^T for F = {name}", rtol=1e-10, atol=1e-12 * scale)
    for M, label in ((U, "U"), (V, "V")):
        assert_close(M.T @ M, np.eye(2), f"{label}^T {label} (a rotation is orthogonal)", atol=1e-12)
        assert_close(_det(M), 1.0, f"det {label} (a rotation, not a reflection)", atol=1e-12)
    assert s[0] >= abs(s[1]) - 1e-12 * scale, f"need s[0] >= |s[1]|, got s = {s}"
    assert_close(s[0] * s[1], _det(F), "s[0] s[1] = det F", atol=1e-12 * scale**2)
    J = _det(F)
    if abs(J) > 1e-12 * scale**2:
        assert np.sign(s[1]) == np.sign(J), f"s[1] must carry the sign of det F = {J:.3g}, got s = {s}"
    # the magnitudes are the ordinary singular values
    assert_close(np.array([s[0], abs(s[1])]), np.linalg.svd(F, compute_uv=False),
                 "(s[0], |s[1]|) against numpy's singular values", atol=1e-12 * scale)


@pytest.mark.parametrize("answer", implementations("ch06", "rotation_preserving_svd", answers.rotation_preserving_svd))
def test_ex6_1_svd_of_a_rotation_and_a_reflection(answer):
    # a rotation is not inverted: s = (1, 1); a mirror image is: s = (1, -1)
    _, s, _ = answer(_rot(1.3))
    assert_close(np.asarray(s, dtype=float), [1.0, 1.0], "s of a rotation")
    _, s, _ = answer(np.diag([-1.0, 1.0]))
    assert_close(np.asarray(s, dtype=float), [1.0, -1.0], "s of the reflection diag(-1, 1)")
    _, s, _ = answer(np.zeros((2, 2)))
    assert_close(np.asarray(s, dtype=float), [0.0, 0.0], "s of F = 0")


# --- 6.2 the cubic Taylor polynomial of ln J ---------------------------------------------------

def _r(J):
    d = J - 1.0
    return d - d * d / 2.0 + d * d * d / 3.0


def _r_prime(J):
    d = J - 1.0
    return 1.0 - d + d * d


@pytest.mark.parametrize("answer", implementations("ch06", "taylor_log", answers.taylor_log))
@pytest.mark.parametrize("J", [1.0, 1.3, 0.7, 0.2, 0.0, -0.5, -2.0, 3.0])
def test_ex6_2_taylor_log(answer, J):
    out = answer(J)
    assert len(out) == 2, "return the tuple (r, r_prime)"
    r, r1 = out
    assert_close(r, _r(J), f"r({J})")
    assert_close(r1, _r_prime(J), f"r'({J})")


@pytest.mark.parametrize("answer", implementations("ch06", "taylor_log", answers.taylor_log))
def test_ex6_2_taylor_log_matches_ln_near_one_and_is_increasing(answer):
    for J in (0.9, 0.99, 1.01, 1.1):
        r, _ = answer(J)
        # a cubic Taylor polynomial: the error is about (J - 1)^4 / 4
        assert abs(float(r) - np.log(J)) < 0.5 * abs(J - 1.0) ** 4, f"r({J}) should match ln {J} to O((J-1)^4)"
    h = 1e-6
    for J in (-1.0, 0.0, 0.5, 2.0):
        _, r1 = answer(J)
        fd = (float(answer(J + h)[0]) - float(answer(J - h)[0])) / (2 * h)
        assert_close(r1, fd, f"r'({J}) against a central difference of r", rtol=1e-7)
        assert float(r1) > 0, "r' > 0 for every J (r is increasing)"


# --- 6.3 the Taylor Neo-Hookean stress ----------------------------------------------------------

LAM, MU = 576.9230769230769, 384.61538461538464  # E = 1000, nu = 0.3, plane strain
STRESS_CASES = {
    "rest": np.eye(2),
    "rotation": _rot(0.6),
    "stretch": np.diag([1.3, 0.8]),
    "shear": np.array([[1.0, 0.4], [0.0, 1.0]]),
    "inverted-shear": np.array([[0.9, 0.5], [-0.1, -0.4]]),
    "mirror": np.diag([1.0, -1.0]),
    "flat": np.array([[1.0, 0.3], [0.0, 0.0]]),
    "general": np.array([[1.2, -0.3], [0.25, 0.85]]),
}


def _taylor_energy(F, lam, mu):
    J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
    FF = sum(F[i, j] ** 2 for i in range(2) for j in range(2))
    return mu / 2.0 * (FF - 2.0) - mu * _r(J) + lam / 2.0 * _r(J) ** 2


def _fd_stress(F, lam, mu, h=1e-6):
    return fd_derivative(lambda G: _taylor_energy(G, lam, mu), F, h)


@pytest.mark.parametrize("answer", implementations("ch06", "taylor_neo_hookean_stress", answers.taylor_neo_hookean_stress))
@pytest.mark.parametrize("name", list(STRESS_CASES))
def test_ex6_3_taylor_neo_hookean_stress(answer, name):
    F = STRESS_CASES[name]
    expected = _fd_stress(F, LAM, MU)
    assert_close(answer(F.copy(), LAM, MU), expected,
                 f"P of the Taylor model at F = {name} (against a central difference of the energy)",
                 rtol=1e-6, atol=1e-5)


@pytest.mark.parametrize("answer", implementations("ch06", "taylor_neo_hookean_stress", answers.taylor_neo_hookean_stress))
def test_ex6_3_stress_uses_the_cofactor_not_the_adjugate(answer):
    # with F01 != F10 the printed adjugate gives a different matrix: only the cofactor is dPsi/dF
    F = np.array([[1.1, 0.6], [-0.2, 0.7]])
    J = _det(F)
    cof = np.array([[F[1, 1], -F[1, 0]], [-F[0, 1], F[0, 0]]])
    expected = MU * F + (LAM * _r(J) - MU) * _r_prime(J) * cof
    assert_close(answer(F, LAM, MU), expected, "P = mu F + (lam r - mu) r' cof F")


@pytest.mark.parametrize("answer", implementations("ch06", "taylor_neo_hookean_stress", answers.taylor_neo_hookean_stress))
def test_ex6_3_stress_vanishes_at_rest_and_at_zero(answer):
    assert_close(answer(np.eye(2), LAM, MU), np.zeros((2, 2)), "P at rest", atol=1e-9)
    # F = 0 is a stationary point of the Taylor model: both F and cof F vanish
    assert_close(answer(np.zeros((2, 2)), LAM, MU), np.zeros((2, 2)), "P at F = 0", atol=1e-9)
