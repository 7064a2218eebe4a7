"""The materials in three dimensions (tetrahedra): the physics of the 2D table, the 3D tensor helpers, the
rotation-preserving SVD of 3x3 matrices, the ITF extension and the projected tangent.

(That stress and tangent are the derivatives of the energy, in 2D and 3D, is checked for every material in one
table, ``test_derivatives.py``.)
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from tissuefem.engine.inversion import ITFClamped, ProjectedTangent, eigen_projection, projected_tangent
from tissuefem.engine.materials import (MATERIALS, Corotated, FiberReinforced, LinearElastic, NeoHookean,
                                        StableNeoHookean, TaylorNeoHookean, cofactor, cofactor_derivative, det,
                                        fiber_energy, fiber_invariant, fiber_stress, fiber_tangent, inverse,
                                        rotation_preserving_svd)
from tissuefem.engine.parameters import lame_parameters

from helpers import H, fd_derivative, matmul, random_F, rotation3

LAM, MU = 1.7, 0.6
NEL, NQP = 30, 3


def _rng(seed=0):
    return np.random.default_rng(seed)


def _as_matrices(F):
    """``[3, 3, *rest]`` -> ``[n, 3, 3]`` for numpy's linear algebra."""
    return np.moveaxis(F.reshape(3, 3, -1), -1, 0)


ISOTROPIC = {name: (lambda cls=cls: cls(LAM, MU)) for name, cls in MATERIALS.items()}
FRAME_INDIFFERENT = {
    **{name: make for name, make in ISOTROPIC.items() if name != "linear"},
    "itf-clamped": lambda: ITFClamped(NeoHookean(LAM, MU)),
    "stable+fibers(per element)": lambda: FiberReinforced(StableNeoHookean(LAM, MU), 2.5,
                                                          _rng(7).normal(size=(3, NEL))),
    "corotated+fibers(uniform)": lambda: FiberReinforced(Corotated(LAM, MU), 2.5, [0.3, -1.0, 0.5]),
}


def _table(table):
    return pytest.mark.parametrize("make", list(table.values()), ids=list(table))


def linear_tangent3(lam, mu):
    d = np.eye(3)
    return (lam * np.einsum("ij,kl->ijkl", d, d)
            + mu * (np.einsum("ik,jl->ijkl", d, d) + np.einsum("il,jk->ijkl", d, d)))


# --- the 3D tensor helpers ------------------------------------------------------------

def test_det_cofactor_inverse_match_numpy_and_the_cofactor_is_dJ_dF():
    F = random_F("positive", seed=6, dim=3)
    M = _as_matrices(F)
    np.testing.assert_allclose(det(F).ravel(), np.linalg.det(M), rtol=1e-13)
    Finv = np.moveaxis(np.linalg.inv(M), 0, -1).reshape(F.shape)
    np.testing.assert_allclose(inverse(F), Finv, atol=1e-12)
    np.testing.assert_allclose(cofactor(F), det(F) * Finv.swapaxes(0, 1), atol=1e-12)
    np.testing.assert_allclose(fd_derivative(det, F), cofactor(F), atol=1e-8)
    # d(cof F)/dF: linear in F in 3D (constant in 2D)
    np.testing.assert_allclose(fd_derivative(cofactor, F), cofactor_derivative(F), atol=1e-8)
    F2 = random_F("positive", seed=6)
    np.testing.assert_allclose(fd_derivative(cofactor, F2), cofactor_derivative(F2), atol=1e-8)
    # the cofactor is defined for singular F too
    assert np.all(np.isfinite(cofactor(np.zeros((3, 3))))) and det(np.diag([1.0, 2.0, 0.0])) == 0.0


def test_bad_shapes_are_refused_naming_F():
    for bad in (np.zeros((3, 2)), np.zeros((4, 4)), np.zeros((3,)), np.zeros((2, 3, 5))):
        for f in (det, cofactor, NeoHookean(LAM, MU).energy, Corotated(LAM, MU).tangent, rotation_preserving_svd,
                  ITFClamped(NeoHookean(LAM, MU)).stress):
            with pytest.raises(ValueError, match="F must be shaped"):
                f(bad)


# --- rest, frame indifference, isotropy, the small-strain limit ----------------------

@_table({**ISOTROPIC, **FRAME_INDIFFERENT})
def test_rest_is_energy_and_stress_free_and_a_single_matrix_works(make):
    m = make()
    I = np.broadcast_to(np.eye(3)[:, :, None, None], (3, 3, NEL, NQP))
    np.testing.assert_allclose(m.energy(I), 0.0, atol=1e-12)
    np.testing.assert_allclose(m.stress(I), 0.0, atol=1e-12)
    if not isinstance(m, FiberReinforced) or m.fibers.ndim == 1:
        F = random_F("positive", seed=3, shape=(4,), dim=3)
        psi, P, A = m.energy(F), m.stress(F), m.tangent(F)
        assert psi.shape == (4,) and P.shape == (3, 3, 4) and A.shape == (3, 3, 3, 3, 4)
        for n in range(4):
            assert np.shape(m.energy(F[..., n])) == ()
            np.testing.assert_allclose(m.stress(F[..., n]), P[..., n], rtol=1e-13, atol=1e-13)
            np.testing.assert_allclose(m.tangent(F[..., n]), A[..., n], rtol=1e-13, atol=1e-13)


@_table(FRAME_INDIFFERENT)
def test_frame_indifference(make):
    """``Psi(QF) = Psi(F)``, ``P(QF) = Q P(F)``, ``A(QF)_ijkl = Q_ia Q_kb A(F)_ajbl`` for rotations ``Q`` in SO(3):
    fibres are material directions (``g`` in the reference), so the fibre term is frame indifferent too."""
    m = make()
    F = random_F("positive", seed=8, dim=3)
    Q = rotation3(_rng(9), F.shape[2:])
    QF = matmul(Q, F)
    np.testing.assert_allclose(m.energy(QF), m.energy(F), rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(m.stress(QF), matmul(Q, m.stress(F)), rtol=1e-10, atol=1e-10)
    QAQ = np.einsum("ia...,kb...,ajbl...->ijkl...", Q, Q, m.tangent(F))
    np.testing.assert_allclose(m.tangent(QF), QAQ, rtol=1e-10, atol=1e-10)


@_table({name: make for name, make in FRAME_INDIFFERENT.items() if "fibers" not in name})
def test_isotropy_and_rotations_are_stress_free(make):
    """The isotropic models also have ``Psi(FQ) = Psi(F)``, and a rigid rotation costs nothing."""
    m = make()
    F = random_F("positive", seed=10, dim=3)
    Q = rotation3(_rng(11), F.shape[2:])
    np.testing.assert_allclose(m.energy(matmul(F, Q)), m.energy(F), rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(m.energy(Q), 0.0, atol=1e-11)
    np.testing.assert_allclose(m.stress(Q), 0.0, atol=1e-10)


def test_linear_elasticity_is_not_frame_indifferent_in_3d():
    Q = rotation3(_rng(12), ())
    assert LinearElastic(LAM, MU).energy(Q) > 1e-3 and NeoHookean(LAM, MU).energy(Q) == pytest.approx(0, abs=1e-12)


@pytest.mark.parametrize("cls", list(MATERIALS.values()), ids=list(MATERIALS))
@pytest.mark.parametrize("lam_mu", [(LAM, MU), lame_parameters(1000.0, 0.45), (-0.3, 1.0)],
                         ids=["generic", "E1000-nu0.45", "auxetic"])
def test_small_strain_limit_is_linear_elasticity_with_the_same_lame_parameters(cls, lam_mu):
    lam, mu = lam_mu
    m = cls(lam, mu)
    scale = abs(lam) + mu
    np.testing.assert_allclose(m.tangent(np.eye(3)), linear_tangent3(lam, mu), rtol=0, atol=1e-12 * scale)
    G = 1e-6 * np.array([[0.3, -0.7, 0.1], [0.2, 0.5, -0.4], [0.6, 0.0, -0.2]])
    P_lin = LinearElastic(lam, mu).stress(np.eye(3) + G)
    np.testing.assert_allclose(m.stress(np.eye(3) + G), P_lin, rtol=0, atol=1e-5 * np.abs(P_lin).max())


def test_stable_neo_hookean_rest_stability_in_both_dimensions():
    """The rest-stability condition ``P(I) = 0`` gives ``alpha = 1 + mu / lam_s`` in 2D and 3D (no log term)."""
    m = StableNeoHookean(LAM, MU)
    assert m.alpha == pytest.approx(1.0 + MU / (LAM + MU))
    for d in (2, 3):
        assert m.energy(np.eye(d)) == pytest.approx(0.0, abs=1e-15)
        np.testing.assert_allclose(m.stress(np.eye(d)), 0.0, atol=1e-15)
        # P(I) = (mu + lam_s (1 - alpha)) I: any other alpha leaves a stress at rest
        P = MU * np.eye(d) + m.lam_s * (1.0 - (m.alpha + 0.01)) * np.eye(d)
        assert np.abs(P).max() > 1e-3


def test_neo_hookean_3d_is_nan_when_inverted_and_the_safe_models_are_finite():
    F = np.concatenate([random_F("inverted", 2, (5,), dim=3), random_F("singular", 3, (5,), dim=3),
                        np.stack([np.zeros((3, 3)), np.diag([1.0, 2.0, 0.0]), np.diag([1.0, 1.0, -1.0])], axis=-1)],
                       axis=2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        bad = det(F) <= 0  # (a rotated singular F has J of either sign at round-off)
        assert bad.sum() >= 8
        psi = NeoHookean(LAM, MU).energy(F)
        assert np.all(np.isnan(psi[bad])) and np.all(np.isfinite(psi[~bad]))
        for make in {**ISOTROPIC, **FRAME_INDIFFERENT}.values():
            m = make()
            if m.inversion_safe and not (isinstance(m, FiberReinforced) and m.fibers.ndim > 1):
                assert np.all(np.isfinite(m.energy(F))) and np.all(np.isfinite(m.tangent(F)))


def test_corotated_3d_matches_its_definition_and_is_finite_where_the_rotation_is_undefined():
    F = random_F("positive", seed=13, shape=(20,), dim=3)
    U, s, V = rotation_preserving_svd(F)
    R = np.einsum("ia...,ja...->ij...", U, V)
    m = Corotated(LAM, MU)
    D = F - R
    np.testing.assert_allclose(m.energy(F), MU * np.einsum("ij...,ij...->...", D, D) + 0.5 * LAM * (det(F) - 1) ** 2)
    # s1 + s2 = 0: the polar rotation is undefined (flat in that pair), energy, stress, tangent stay finite
    Q = rotation3(_rng(14), ())
    F0 = Q @ np.diag([1.5, 0.7, -0.7])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isfinite(m.energy(F0)) and np.all(np.isfinite(m.stress(F0))) and np.all(np.isfinite(m.tangent(F0)))


def test_fibers_in_3d():
    g = np.array([0.0, 0.6, 0.8])
    F = np.diag([1.0, 1.2, 1.0])
    assert fiber_invariant(F, g) == pytest.approx(1.2**2 * 0.36 + 0.64)
    k = 3.0
    I4 = fiber_invariant(F, g)
    assert fiber_energy(F, g, k) == pytest.approx(k / 8 * (I4 - 1) ** 2)
    np.testing.assert_allclose(fiber_stress(F, g, k), fd_derivative(lambda X: fiber_energy(X, g, k), F), atol=1e-8)
    np.testing.assert_allclose(fiber_tangent(F, g, k), fd_derivative(lambda X: fiber_stress(X, g, k), F), atol=1e-7)
    # the fibre modulus: g g g g : (A - A_base) at rest is k, as in 2D
    m = FiberReinforced(NeoHookean(LAM, MU), k, [0.0, 3.0, 4.0])
    extra = m.tangent(np.eye(3)) - NeoHookean(LAM, MU).tangent(np.eye(3))
    assert np.einsum("i,j,k,l,ijkl->", g, g, g, g, extra) == pytest.approx(k)
    for bad in ([1.0, 0.0], [0.0, 0.0, 2.0]):  # a 2D fibre, a non-unit one
        with pytest.raises(ValueError, match="g"):
            fiber_energy(F, bad, k)


# --- the rotation-preserving SVD of 3x3 matrices ----------------------------------------

def _svd_cases():
    rng = _rng(21)
    Q1, Q2 = rotation3(rng, ()), rotation3(rng, ())
    special = [np.eye(3), 0.5 * np.eye(3), -np.eye(3), np.diag([1.0, 1.0, -1.0]), np.zeros((3, 3)),
               np.outer([1.0, 2.0, -1.0], [0.5, 0.0, 1.0]),  # rank 1
               np.diag([2.0, 0.0, 0.0]), np.diag([1.0, 1.0, 0.0]),  # flat: rank 1 and 2
               Q1 @ np.diag([2.0, 2.0, 0.5]) @ Q2.T, Q1 @ np.diag([1.0, 0.5, 0.5]) @ Q2.T,  # repeated values
               Q1 @ np.diag([1.0, 1.0, -1.0]) @ Q2.T, Q1 @ np.diag([3.0, 3.0, 3.0]) @ Q2.T,
               Q1 @ np.diag([1.0, 1e-12, -1e-12]) @ Q2.T]
    return np.concatenate([rng.normal(size=(3, 3, 300)), np.stack(special, axis=-1),
                           random_F("inverted", 4, (50,), dim=3), random_F("singular", 5, (50,), dim=3)], axis=-1)


def test_svd_reconstructs_with_rotations_and_only_the_smallest_value_signed():
    F = _svd_cases()
    U, s, V = rotation_preserving_svd(F)
    assert U.shape == V.shape == F.shape and s.shape == (3,) + F.shape[2:]
    assert np.all(np.isfinite(U)) and np.all(np.isfinite(s)) and np.all(np.isfinite(V))
    np.testing.assert_allclose(np.einsum("ia...,a...,ja...->ij...", U, s, V), F, atol=1e-13 * (1 + np.abs(F).max()))
    for W in (U, V):
        M = _as_matrices(W)
        np.testing.assert_allclose(np.einsum("nki,nkj->nij", M, M), np.broadcast_to(np.eye(3), M.shape), atol=1e-13)
        np.testing.assert_allclose(np.linalg.det(M), 1.0, atol=1e-13)  # proper rotations: SO(3)
    assert np.all(s[0] >= s[1]) and np.all(s[1] >= np.abs(s[2]))
    assert np.all(s[0] >= 0) and np.all(s[1] >= 0)  # at most one negative value, the smallest
    J = np.linalg.det(_as_matrices(F))
    np.testing.assert_allclose(s[0] * s[1] * s[2], J, atol=1e-12 * (1 + np.abs(F).max() ** 3))
    assert np.all(s[2][J < -1e-9] < 0) and np.all(s[2][J > 1e-9] > 0)
    ref = np.linalg.svd(_as_matrices(F), compute_uv=False)
    np.testing.assert_allclose(np.abs(s.T), ref, atol=1e-12 * (1 + np.abs(F).max()))


def test_svd_of_a_non_finite_matrix_is_nan_not_an_error():
    F = np.stack([np.eye(3), np.full((3, 3), np.nan)], axis=-1)
    U, s, V = rotation_preserving_svd(F)
    assert np.all(np.isfinite(s[:, 0])) and np.all(np.isnan(s[:, 1]))


# --- the projected tangent in 3D ----------------------------------------------------------

F3 = np.concatenate([random_F("positive", 31, (60,), dim=3), random_F("inverted", 32, (60,), dim=3),
                     random_F("singular", 33, (30,), dim=3), 0.6 * random_F("positive", 34, (60,), dim=3),
                     _svd_cases()[..., 300:]], axis=-1)


@pytest.mark.parametrize("cls", [TaylorNeoHookean, StableNeoHookean, Corotated, NeoHookean],
                         ids=lambda c: c.__name__)
def test_closed_form_projection_equals_the_numerical_one_and_is_positive_semidefinite(cls):
    m = cls.from_young(1000.0, 0.45)
    F = F3 if m.inversion_safe else F3[..., det(F3) > 0.05]
    closed = projected_tangent(m, F)
    scale = np.abs(m.tangent(F)).max()
    # the corotated rotation is undefined where two signed singular values sum to 0 (a flat F, s = (1, 1, -1)):
    # its tangent there depends on which singular vectors the SVD picked, so it is compared away from that set
    _, s, _ = rotation_preserving_svd(F)
    defined = (s[1] + s[2] > 1e-6) | (cls is not Corotated)
    numerical = eigen_projection(m.tangent(F[..., defined]))
    np.testing.assert_allclose(closed[..., defined], numerical, atol=1e-9 * scale)
    M = np.moveaxis(closed.reshape(9, 9, -1), -1, 0)
    assert np.all(np.isfinite(M)) and np.linalg.eigvalsh(M).min() > -1e-9 * scale
    np.testing.assert_allclose(eigen_projection(closed), closed, atol=1e-9 * scale)  # idempotent


def test_projected_tangent_falls_back_for_fibres_and_keeps_the_stress():
    m = FiberReinforced(Corotated(LAM, MU), 5.0, [1.0, 1.0, 0.0])
    F = random_F("inverted", 35, (40,), dim=3)
    P = ProjectedTangent(m)
    np.testing.assert_allclose(P.tangent(F), eigen_projection(m.tangent(F)))
    np.testing.assert_array_equal(P.stress(F), m.stress(F))
    w = np.linalg.eigvalsh(np.moveaxis(P.tangent(F).reshape(9, 9, -1), -1, 0))
    assert w.min() > -1e-9 * np.abs(w).max()


# --- the ITF extension in 3D -----------------------------------------------------------------

LAM_T, MU_T = 577.0, 385.0


def _sorted_values(rng, n):
    """Signed singular values in every region: nothing, one, two or three values below the threshold 0.3."""
    return np.concatenate([
        np.sort(rng.uniform(0.35, 3.0, (3, n)), axis=0)[::-1],
        np.stack([rng.uniform(0.5, 3.0, n), rng.uniform(0.35, 0.5, n), rng.uniform(-0.3, 0.28, n)]),
        np.stack([rng.uniform(0.5, 3.0, n), rng.uniform(0.21, 0.28, n), rng.uniform(-0.2, 0.2, n)]),
        np.stack([rng.uniform(0.26, 0.29, n), rng.uniform(0.21, 0.25, n), rng.uniform(-0.2, 0.2, n)]),
    ], axis=1)


def test_itf_3d_matches_the_model_above_the_clamp_and_is_continuous_through_J_zero():
    m, base = ITFClamped(NeoHookean(LAM_T, MU_T)), NeoHookean(LAM_T, MU_T)
    rng = _rng(41)
    s = _sorted_values(rng, 30)
    F = np.einsum("ia...,a...,ja...->ij...", rotation3(rng, (120,)), s, rotation3(rng, (120,)))
    above = slice(0, 30)
    np.testing.assert_allclose(m.energy(F[..., above]), base.energy(F[..., above]), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(m.stress(F[..., above]), base.stress(F[..., above]), rtol=1e-10, atol=1e-8)
    np.testing.assert_allclose(fd_derivative(m.energy, F), m.stress(F), atol=1e-6 * (1 + np.abs(m.stress(F)).max()))
    # through J = 0: the smallest value crosses zero, energy and stress change continuously
    for s0, s1 in ((2.0, 1.0), (1.0, 0.25), (0.2, 0.1)):
        t = np.array([-1e-7, 0.0, 1e-7])
        values = np.stack([np.full(3, s0), np.full(3, s1), t])
        e, g = m.diagonal_energy(values), m.diagonal_gradient(values)
        assert np.all(np.isfinite(e)) and np.all(np.isfinite(g))
        np.testing.assert_allclose(e[0], e[2], atol=1e-3 * (1 + abs(e[1])))
        np.testing.assert_allclose(g[:, 0], g[:, 2], atol=1e-3 * (1 + np.abs(g[:, 1]).max()))


@pytest.mark.parametrize("crossing", [(1.5, 1.0, None), (0.8, 0.31, None), (1.5, None, 0.1), (1.5, None, -0.2),
                                      (None, 0.2, 0.1), (None, 0.25, -0.25)])
def test_itf_3d_energy_and_gradient_are_continuous_across_the_threshold(crossing):
    """A value crossing ``c`` (``None`` above: the smallest, the middle or the largest) changes nothing to first
    order: energy and gradient agree on both sides."""
    m = ITFClamped(NeoHookean(LAM_T, MU_T))
    c, eps = m.threshold, 1e-7
    lo = np.array([[c - eps if v is None else v for v in crossing]]).T
    hi = np.array([[c + eps if v is None else v for v in crossing]]).T
    np.testing.assert_allclose(m.diagonal_energy(lo), m.diagonal_energy(hi), rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(m.diagonal_gradient(lo), m.diagonal_gradient(hi), rtol=1e-4, atol=1e-2)


def test_itf_2d_closed_form_energy_and_the_expansion_gradient_agree():
    """In 2D the doubly clamped energy keeps its closed form; the gradient (the d-dimensional expansion's, in every
    dimension) is its derivative in each of the three regions."""
    m = ITFClamped(NeoHookean(LAM_T, MU_T))
    rng = _rng(42)
    s = np.concatenate([np.stack([rng.uniform(0.4, 3, 50), rng.uniform(0.31, 0.39, 50)]),
                        np.stack([rng.uniform(0.5, 3, 50), rng.uniform(-0.4, 0.29, 50)]),
                        np.stack([rng.uniform(0.15, 0.29, 50), rng.uniform(-0.1, 0.14, 50)])], axis=1)
    g = m.diagonal_gradient(s)
    for i in range(2):
        step = np.zeros((2, 1))
        step[i] = 1e-6
        slope = (m.diagonal_energy(s + step) - m.diagonal_energy(s - step)) / 2e-6
        np.testing.assert_allclose(slope, g[i], rtol=1e-5, atol=1e-6 * np.abs(g).max())


def test_itf_3d_projected_tangent_is_positive_semidefinite_and_a_crushed_tet_is_pushed_out():
    m = ITFClamped(NeoHookean(LAM_T, MU_T))
    rng = _rng(43)
    F = np.concatenate([np.einsum("ia...,a...,ja...->ij...", rotation3(rng, (120,)), _sorted_values(rng, 30),
                                  rotation3(rng, (120,))), F3], axis=-1)
    A = m.tangent(F)
    M = np.moveaxis(A.reshape(9, 9, -1), -1, 0)
    w = np.linalg.eigvalsh(0.5 * (M + np.swapaxes(M, 1, 2)))
    assert np.all(np.isfinite(A)) and w.min() >= -1e-9 * np.abs(w).max()
    P = m.stress(np.zeros((3, 3)))
    assert np.all(np.isfinite(P)) and P[0, 0] < 0 and np.allclose(P, P[0, 0] * np.eye(3))
    assert np.all(np.isfinite(m.energy(F))) and m.energy(F).min() >= -1e-9
    assert m.stiffnesses[3] > 0 and m.stiffnesses[2] == m.stiffness
