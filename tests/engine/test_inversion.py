"""Rotation-preserving SVD and the definiteness fix (projected tangent)."""

import numpy as np
import pytest

from tissuefem.engine.inversion import ProjectedTangent, eigen_projection, projected_tangent, rotation_preserving_svd
from tissuefem.engine.materials import (Corotated, FiberReinforced, LinearElastic, NeoHookean, StableNeoHookean,
                                 TaylorNeoHookean)
from tissuefem.engine.meshes import rectangle
from tissuefem import Handle, Model, solve

RNG = np.random.default_rng(7)
F_RANDOM = RNG.normal(size=(2, 2, 500))
# special cases: identity, uniform scaling, rotation, reflection, collapse, a line, coincident singular values
theta = 0.7
R = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
F_SPECIAL = np.stack([np.eye(2), 0.5 * np.eye(2), R, np.diag([1.0, -1.0]), np.zeros((2, 2)),
                      np.array([[1.0, 0.0], [0.0, 0.0]]), -np.eye(2), R @ np.diag([2.0, -2.0])], axis=-1)
F_ALL = np.concatenate([F_RANDOM, F_SPECIAL], axis=-1)


def _det(F):
    return F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]


def test_svd_reconstructs_with_rotations_and_signed_smallest_value():
    U, s, V = rotation_preserving_svd(F_ALL)
    np.testing.assert_allclose(np.einsum("ia...,a...,ja...->ij...", U, s, V), F_ALL, atol=1e-13)
    np.testing.assert_allclose(_det(U), 1.0, atol=1e-13)
    np.testing.assert_allclose(_det(V), 1.0, atol=1e-13)
    np.testing.assert_allclose(np.einsum("ki...,kj...->ij...", U, U), np.eye(2)[..., None] * np.ones(F_ALL.shape[-1]),
                               atol=1e-13)
    assert np.all(s[0] >= np.abs(s[1]) - 1e-13)
    np.testing.assert_allclose(s[0] * s[1], _det(F_ALL), atol=1e-12)
    assert np.all(np.isfinite(U)) and np.all(np.isfinite(V)) and np.all(np.isfinite(s))
    # singular values agree with numpy's, up to the sign moved onto the smallest
    ref = np.linalg.svd(np.moveaxis(F_ALL, -1, 0), compute_uv=False)
    np.testing.assert_allclose(s[0], ref[:, 0], atol=1e-12)
    np.testing.assert_allclose(np.abs(s[1]), ref[:, 1], atol=1e-12)


ISOTROPIC = [TaylorNeoHookean, StableNeoHookean, Corotated]


@pytest.mark.parametrize("cls", ISOTROPIC + [NeoHookean], ids=lambda c: c.__name__)
def test_closed_form_projection_equals_numerical_eigen_projection(cls):
    material = cls.from_young(1000.0, 0.3)
    F = F_ALL if material.inversion_safe else F_ALL[..., _det(F_ALL) > 0.05]
    closed = projected_tangent(material, F)
    numerical = eigen_projection(material.tangent(F))
    scale = np.abs(numerical).max()
    np.testing.assert_allclose(closed, numerical, atol=1e-10 * scale)


@pytest.mark.parametrize("cls", ISOTROPIC, ids=lambda c: c.__name__)
def test_projection_is_psd_and_finite_and_idempotent(cls):
    material = cls.from_young(1000.0, 0.45)
    P = projected_tangent(material, F_ALL)
    assert np.all(np.isfinite(P))
    M = np.moveaxis(P.reshape(4, 4, -1), -1, 0)
    assert np.linalg.eigvalsh(M).min() > -1e-9 * np.abs(M).max()
    np.testing.assert_allclose(eigen_projection(P), P, atol=1e-9 * np.abs(P).max())


def _rot(a):
    return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])


def test_projection_leaves_a_definite_tangent_alone():
    """Under stretch (singular values >= 1) the Neo-Hookean tangent is positive semi-definite.

    (Under compression it is not, even near rest: the rotation mode's eigenvalue
    (psi0 + psi1)/(s0 + s1) turns negative as soon as J < 1.)
    """
    material = NeoHookean.from_young(1000.0, 0.3)
    a, b = RNG.uniform(0, 2 * np.pi, (2, 50))
    s = RNG.uniform(1.0, 1.5, (2, 50))
    F = np.einsum("ian,an,jan->ijn", _rot(a), s, _rot(b))
    np.testing.assert_allclose(projected_tangent(material, F), material.tangent(F), atol=1e-9 * 1000)
    compressed = np.einsum("ian,an,jan->ijn", _rot(a), 0.9 * np.ones((2, 50)), _rot(b))
    assert not np.allclose(projected_tangent(material, compressed), material.tangent(compressed))


def test_fallback_for_linear_and_fiber_materials():
    for material in (LinearElastic.from_young(1000.0, 0.3),
                     FiberReinforced(TaylorNeoHookean.from_young(1000.0, 0.3), 500.0, np.array([1.0, 0.0]))):
        np.testing.assert_allclose(projected_tangent(material, F_RANDOM), eigen_projection(material.tangent(F_RANDOM)))


def test_projected_newton_reaches_the_same_equilibrium():
    mesh = rectangle(2.0, 1.0, 8, 4)
    material = TaylorNeoHookean.from_young(1000.0, 0.3)
    handles = [Handle("left"), Handle("right", (-0.8, 0.3))]
    plain = solve(Model(mesh, material, handles=handles), load_steps=2, rtol=1e-12)
    projected = solve(Model(mesh, ProjectedTangent(material), handles=handles), load_steps=2, rtol=1e-12,
                                                                                            max_iterations=200)
    assert plain.converged and projected.converged
    np.testing.assert_allclose(projected.u, plain.u, atol=1e-8)
    with pytest.raises(ValueError, match="floor"):
        ProjectedTangent(material, floor=-1.0)


# --- ITF threshold extrapolation ----------------------------------------------------------------

from helpers import fd_stress, fd_tangent  # noqa: E402
from tissuefem.engine.inversion import ITFClamped, diagonal  # noqa: E402

LAM, MU = 577.0, 385.0


def _itf(**kw):
    return ITFClamped(NeoHookean(LAM, MU), **kw)


# every region: normal (s1 >= c), one crushed (s1 < c <= s0, also inverted), both crushed; away from s0 + s1 = 0
_RNG = np.random.default_rng(11)
_S = np.concatenate([
    np.stack([_RNG.uniform(0.4, 3, 50), _RNG.uniform(0.31, 0.39, 50)]),
    np.stack([_RNG.uniform(0.5, 3, 50), _RNG.uniform(-0.4, 0.29, 50)]),
    np.stack([_RNG.uniform(0.15, 0.29, 50), _RNG.uniform(-0.1, 0.14, 50)]),
], axis=1)
_A1, _A2 = _RNG.uniform(-np.pi, np.pi, (2, _S.shape[1]))
F_ITF = np.einsum("ia...,a...,ja...->ij...", np.stack([np.stack([np.cos(_A1), -np.sin(_A1)]),
                                                       np.stack([np.sin(_A1), np.cos(_A1)])]),
                  _S, np.stack([np.stack([np.cos(_A2), -np.sin(_A2)]), np.stack([np.sin(_A2), np.cos(_A2)])]))


def test_itf_stress_is_the_gradient_of_its_energy_in_every_region():
    m = _itf()
    P = m.stress(F_ITF)
    scale = 1 + np.abs(P).max()
    np.testing.assert_allclose(fd_stress(m, F_ITF), P, atol=1e-6 * scale)


def test_itf_exact_tangent_matches_finite_differences_of_stress():
    m = _itf(project=False)
    A = m.tangent(F_ITF)
    np.testing.assert_allclose(fd_tangent(m, F_ITF), A, atol=2e-5 * (1 + np.abs(A).max()))


def test_itf_is_the_base_model_above_the_threshold_and_stress_free_at_rest():
    m, base = _itf(), NeoHookean(LAM, MU)
    F = F_ITF[..., :50]  # region s1 >= c
    np.testing.assert_allclose(m.energy(F), base.energy(F), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(m.stress(F), base.stress(F), rtol=1e-10, atol=1e-8)
    I = np.eye(2)[..., None]
    assert abs(m.energy(I)[0]) < 1e-12 and np.abs(m.stress(I)).max() < 1e-10


@pytest.mark.parametrize("s0", [0.2, 0.3, 1.0, 4.0])
def test_itf_energy_and_stress_are_continuous_across_the_threshold(s0):
    m = _itf()
    c, eps = m.threshold, 1e-7
    for s in ([s0, c - eps], [s0, c + eps]), ([c - eps, c - 0.05], [c + eps, c - 0.05]):
        if s[0][0] < abs(s[0][1]) or s[1][0] < abs(s[1][1]):
            continue
        lo, hi = np.array(s[0])[:, None], np.array(s[1])[:, None]
        np.testing.assert_allclose(m.diagonal_energy(lo), m.diagonal_energy(hi), rtol=1e-5, atol=1e-3)
        np.testing.assert_allclose(m.diagonal_gradient(lo), m.diagonal_gradient(hi), rtol=1e-4, atol=1e-2)


def test_itf_pushes_a_collapsed_element_outward_with_finite_force():
    m = _itf()
    P = m.stress(np.zeros((2, 2, 1)))[..., 0]
    assert np.all(np.isfinite(P))
    assert P[0, 0] < 0 and np.isclose(P[0, 0], P[1, 1]) and abs(P[0, 1]) < 1e-12  # -p I: energy falls as F grows
    mirror = m.stress(np.diag([1.0, -1.0])[..., None])
    assert np.all(np.isfinite(mirror)) and np.all(np.isfinite(m.tangent(np.diag([1.0, -1.0])[..., None])))


def test_itf_projected_tangent_is_positive_semidefinite_everywhere():
    m = _itf()
    F = np.concatenate([F_ITF, F_ALL], axis=-1)
    A = m.tangent(F)
    assert np.all(np.isfinite(A))
    M = np.moveaxis(A.reshape(4, 4, -1), -1, 0)
    w = np.linalg.eigvalsh(0.5 * (M + np.swapaxes(M, 1, 2)))
    assert w.min() >= -1e-9 * np.abs(w).max()


def test_itf_extended_energy_is_bounded_below():
    m = _itf()
    s0 = np.geomspace(1e-3, 100.0, 200)
    S0, T = np.meshgrid(s0, np.linspace(-1.0, 1.0, 201))
    e = m.diagonal_energy(np.stack([S0.ravel(), (S0 * T).ravel()]))
    assert np.all(np.isfinite(e)) and e.min() >= -1e-9


def test_itf_rejects_bad_arguments():
    with pytest.raises(ValueError, match="material"):
        ITFClamped(StableNeoHookean(LAM, MU))
    with pytest.raises(ValueError, match="material"):
        ITFClamped(LinearElastic(LAM, MU))
    for bad in (0.0, 1.0, -0.2, np.nan):
        with pytest.raises(ValueError, match="threshold"):
            _itf(threshold=bad)
    for bad in (0.0, -1.0, np.inf):
        with pytest.raises(ValueError, match="stiffness"):
            _itf(stiffness=bad)


def test_projected_tangent_accepts_the_itf_model():
    m = _itf(project=False)
    np.testing.assert_allclose(projected_tangent(m, F_ITF), _itf().tangent(F_ITF), atol=1e-8 * np.abs(m.tangent(F_ITF)).max())
    assert np.all(np.isfinite(diagonal(np.zeros((2, 3)))))


def test_itf_accepts_a_single_matrix_like_the_other_materials():
    m = _itf()
    F = np.array([[0.5, 0.2], [0.1, -0.3]])
    assert np.shape(m.energy(F)) == () and m.stress(F).shape == (2, 2) and m.tangent(F).shape == (2, 2, 2, 2)
    np.testing.assert_allclose(m.stress(F), m.stress(F[..., None])[..., 0])
