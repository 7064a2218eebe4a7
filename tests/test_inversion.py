"""Rotation-preserving SVD and the definiteness fix (projected tangent)."""

import numpy as np
import pytest

from tissuefem.inversion import ProjectedTangent, eigen_projection, projected_tangent, rotation_preserving_svd
from tissuefem.materials import (Corotated, FiberReinforced, LinearElastic, NeoHookean, StableNeoHookean,
                                 TaylorNeoHookean)
from tissuefem.meshes import rectangle
from tissuefem.quasistatic import Handle, QuasistaticProblem

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
    plain = QuasistaticProblem(mesh, material, handles=handles).solve(load_steps=2, rtol=1e-12)
    projected = QuasistaticProblem(mesh, ProjectedTangent(material), handles=handles).solve(load_steps=2, rtol=1e-12,
                                                                                            max_iter=200)
    assert plain.converged and projected.converged
    np.testing.assert_allclose(projected.u, plain.u, atol=1e-8)
    with pytest.raises(ValueError, match="floor"):
        ProjectedTangent(material, floor=-1.0)
