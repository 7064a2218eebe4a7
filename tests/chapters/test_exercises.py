"""Exercises of every chapter, graded the same way for the library and for the student.

Expected values are computed here independently (closed forms, finite
differences, a hand-written element loop), never by calling the answer.
"""

import numpy as np
import pytest

from grading import assert_close, implementations
from tissuefem.workbook import answers

LAME = [(1.0, 1.0), (576.9230769, 384.6153846), (0.0, 2.5), (10.0, 0.3)]


# --- chapter 1 -----------------------------------------------------------------

@pytest.mark.parametrize("answer", implementations("ch01", "linear_modulus_1d", answers.linear_modulus_1d))
@pytest.mark.parametrize("lam, mu", LAME)
def test_ex1_1_linear_modulus(answer, lam, mu):
    # d/deps of (mu + lam/2) eps^2 is (2 mu + lam) eps
    slips = {"the notes' printed modulus 2μ − λ: it is 2μ + λ (erratum 1)": 2 * mu - lam,
             "μ + λ/2 is the energy's coefficient of ε²; the modulus is the stress's, 2μ + λ": mu + lam / 2}
    assert_close(answer(lam, mu), 2 * mu + lam, f"1D modulus for lam={lam}, mu={mu}",
                 terms={"2μ": 2 * mu, "λ": lam}, slips=slips)


@pytest.mark.parametrize("answer", implementations("ch01", "assemble_stiffness_1d", answers.assemble_stiffness_1d))
@pytest.mark.parametrize("nodes", [[0.0, 1.0], [0.0, 0.5, 1.0], [0.0, 0.1, 0.4, 1.0, 2.5], np.linspace(-1, 3, 9)])
def test_ex1_2_stiffness(answer, nodes):
    nodes = np.asarray(nodes, dtype=float)
    modulus = 3.0
    expected, times_h = np.zeros((nodes.size, nodes.size)), np.zeros((nodes.size, nodes.size))
    for e in range(nodes.size - 1):
        h = nodes[e + 1] - nodes[e]
        expected[e:e + 2, e:e + 2] += modulus / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
        times_h[e:e + 2, e:e + 2] += modulus * h * np.array([[1.0, -1.0], [-1.0, 1.0]])
    got = answer(nodes, modulus)
    got = got.toarray() if hasattr(got, "toarray") else got
    slips = {"E h instead of E/h: N' = ±1/h, and ∫ N_i' N_j' dX over an element is ±1/h": times_h}
    assert_close(got, expected, f"stiffness matrix on nodes {nodes}", slips=slips)


# --- chapter 2 -----------------------------------------------------------------

F_VALUES = np.array([0.2, 0.5, 0.9, 1.0, 1.1, 1.7, 3.0])


def _psi(F, lam, mu):
    return 0.5 * mu * (F**2 - 1) - mu * np.log(F) + 0.5 * lam * np.log(F) ** 2


def _stress(F, lam, mu):
    return mu * F + (lam * np.log(F) - mu) / F


@pytest.mark.parametrize("answer", implementations("ch02", "neo_hookean_stress_1d", answers.neo_hookean_stress_1d))
@pytest.mark.parametrize("lam, mu", LAME)
def test_ex2_1_stress(answer, lam, mu):
    h = 1e-6 * F_VALUES
    expected = (_psi(F_VALUES + h, lam, mu) - _psi(F_VALUES - h, lam, mu)) / (2 * h)
    got = answer(F_VALUES, lam, mu)
    F = F_VALUES
    terms = {"μF": mu * F, "−μ/F": -mu / F, "λ ln F / F": lam * np.log(F) / F}
    assert_close(got, expected, "P(F) (compared with a finite difference of Psi)", rtol=1e-6, atol=1e-6,
                 terms=terms)
    assert_close(answer(1.0, lam, mu), 0.0, "P(1) (no stress at rest)", atol=1e-12)


@pytest.mark.parametrize("answer", implementations("ch02", "neo_hookean_tangent_1d", answers.neo_hookean_tangent_1d))
@pytest.mark.parametrize("lam, mu", LAME)
def test_ex2_2_tangent(answer, lam, mu):
    h = 1e-6 * F_VALUES
    expected = (_stress(F_VALUES + h, lam, mu) - _stress(F_VALUES - h, lam, mu)) / (2 * h)
    F = F_VALUES
    terms = {"μ": mu, "μ/F²": mu / F**2, "λ/F²": lam / F**2, "−λ ln F / F²": -lam * np.log(F) / F**2}
    assert_close(answer(F_VALUES, lam, mu), expected, "dP/dF (compared with a finite difference of P)",
                 rtol=1e-6, atol=1e-6, terms=terms)
    assert_close(answer(1.0, lam, mu), lam + 2 * mu, "dP/dF at F = 1 (the linear modulus)")


def _hand_newton_step(nodes, u, lam, mu, traction):
    """An independent dense element loop for the P1 bar (left end fixed)."""
    n = nodes.size
    q, K = np.zeros(n), np.zeros((n, n))
    for e in range(n - 1):
        h = nodes[e + 1] - nodes[e]
        F = 1.0 + (u[e + 1] - u[e]) / h
        P = _stress(F, lam, mu)
        dP = mu + (mu + lam * (1.0 - np.log(F))) / F**2
        q[e:e + 2] += P * np.array([-1.0, 1.0])
        K[e:e + 2, e:e + 2] += dP / h * np.array([[1.0, -1.0], [-1.0, 1.0]])
    q[-1] -= traction
    du = np.linalg.solve(K[1:, 1:], -q[1:])
    return np.concatenate([[0.0], u[1:] + du])


@pytest.mark.parametrize("answer", implementations("ch02", "newton_step_1d", answers.newton_step_1d))
@pytest.mark.parametrize("traction", [0.0, 100.0, -200.0])
def test_ex2_3_newton_step(answer, traction):
    lam, mu = 576.9230769, 384.6153846
    nodes = np.array([0.0, 0.2, 0.45, 0.7, 1.0])
    u = np.array([0.0, 0.01, 0.03, 0.02, 0.05])
    expected = _hand_newton_step(nodes, u, lam, mu, traction)
    slips = {
        "the update has the wrong sign: solve (dq/du) du = −q, then return u + du": 2 * u - expected,
        "the traction enters with the wrong sign: q = ∫ N_i' P dX − g (erratum 2)":
            _hand_newton_step(nodes, u, lam, mu, -traction),
        "the traction is missing from the residual q": _hand_newton_step(nodes, u, lam, mu, 0.0),
        "you return the update du alone: return u + du": expected - u,
    }
    assert_close(answer(nodes, u, lam, mu, traction), expected, f"u after one Newton step (traction {traction})",
                 slips=slips)
