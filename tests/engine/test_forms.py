"""The scikit-fem forms: residual = gradient of the energy, tangent = Jacobian of the residual.

Checked on a small mesh with P1 and P2 vector elements, for every material
(table-driven), by finite differences of the *assembled* quantities.
"""

from __future__ import annotations

import numpy as np
import pytest
from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, MeshTri, asm
from skfem.models.elasticity import linear_elasticity

from tissuefem.engine.forms import deformation_gradient, energy_form, residual_form, tangent_form
from tissuefem.engine.materials import (
    MATERIALS,
    Corotated,
    FiberReinforced,
    NeoHookean,
    StableNeoHookean,
    TaylorNeoHookean,
)

LAM, MU = 1.7, 0.6
H = 1e-6


@pytest.fixture(scope="module", params=[ElementTriP1, ElementTriP2], ids=["P1", "P2"])
def basis(request):
    return Basis(MeshTri().refined(2), ElementVector(request.param()))


def _per_point_fibers(basis, seed=3):
    return np.random.default_rng(seed).normal(size=(2, basis.nelems, basis.X.shape[1]))


def _per_element_fibers(basis, seed=4):
    return np.random.default_rng(seed).normal(size=(2, basis.nelems))


# each entry builds a material for a given basis (fibre fields must match its elements and points)
MODELS = {
    **{name: (lambda b, cls=cls: cls(LAM, MU)) for name, cls in MATERIALS.items()},
    "neo-hookean+fibers(per point)": lambda b: FiberReinforced(
        NeoHookean(LAM, MU), 3.0, _per_point_fibers(b)
    ),
    "corotated+fibers(per element)": lambda b: FiberReinforced(
        Corotated(LAM, MU), 3.0, _per_element_fibers(b)
    ),
}
table = pytest.mark.parametrize("make", list(MODELS.values()), ids=list(MODELS))


def _random_u(basis, scale=0.005, seed=0):
    return scale * np.random.default_rng(seed).normal(size=basis.N)


def _residual(mat, basis, u):
    return asm(residual_form(mat), basis, u=basis.interpolate(u))


def _energy(mat, basis, u):
    return asm(energy_form(mat), basis, u=basis.interpolate(u))


@table
def test_tangent_is_jacobian_of_residual(basis, make):
    mat = make(basis)
    u = _random_u(basis)
    K = asm(tangent_form(mat), basis, u=basis.interpolate(u)).toarray()
    K_fd = np.empty_like(K)
    for b in range(basis.N):
        du = np.zeros(basis.N)
        du[b] = H
        K_fd[:, b] = (_residual(mat, basis, u + du) - _residual(mat, basis, u - du)) / (2 * H)
    assert np.all(np.isfinite(K))
    assert np.abs(K - K_fd).max() <= 1e-6 * np.abs(K).max()


@table
def test_residual_is_gradient_of_energy(basis, make):
    mat = make(basis)
    u = _random_u(basis, seed=1)
    q = _residual(mat, basis, u)
    q_fd = np.empty_like(q)
    for b in range(basis.N):
        du = np.zeros(basis.N)
        du[b] = H
        q_fd[b] = (_energy(mat, basis, u + du) - _energy(mat, basis, u - du)) / (2 * H)
    assert np.abs(q).max() > 1e-3  # a genuinely loaded state
    assert np.abs(q - q_fd).max() <= 1e-6 * np.abs(q).max()


@table
def test_rest_state_has_zero_residual_and_energy(basis, make):
    mat = make(basis)
    u0 = basis.zeros()
    np.testing.assert_allclose(_residual(mat, basis, u0), 0.0, atol=1e-14)
    assert _energy(mat, basis, u0) == pytest.approx(0.0, abs=1e-14)


@pytest.mark.parametrize("cls", list(MATERIALS.values()), ids=list(MATERIALS))
def test_tangent_at_rest_is_linear_elasticity(basis, cls):
    """At u = 0 every model's tangent is scikit-fem's linear-elasticity stiffness (same Lamé)."""
    K = asm(tangent_form(cls(LAM, MU)), basis, u=basis.interpolate(basis.zeros()))
    K_lin = asm(linear_elasticity(Lambda=LAM, Mu=MU), basis)
    assert abs(K - K_lin).max() <= 1e-10


def test_neo_hookean_tangent_at_rest_from_young(basis):
    mat = NeoHookean.from_young(1000.0, 0.45)
    K = asm(tangent_form(mat), basis, u=basis.interpolate(basis.zeros()))
    K_lin = asm(linear_elasticity(Lambda=mat.lam, Mu=mat.mu), basis)
    assert abs(K - K_lin).max() <= 1e-10 * abs(K_lin).max()


def test_deformation_gradient(basis):
    # u(X) = G X is reproduced exactly by P1 and P2: F = I + G everywhere
    G = np.array([[0.1, -0.2], [0.3, 0.05]])
    u = basis.project(lambda x: np.einsum("ij,j...->i...", G, x))
    F = deformation_gradient(basis.interpolate(u))
    assert F.shape == (2, 2, basis.nelems, basis.X.shape[1])
    np.testing.assert_allclose(F, (np.eye(2) + G)[:, :, None, None] + 0 * F, atol=1e-12)


def test_energy_of_homogeneous_stretch(basis):
    # unit square: the total energy of a homogeneous F is Psi(F) (area 1)
    G = np.array([[0.2, 0.1], [-0.05, -0.1]])
    u = basis.project(lambda x: np.einsum("ij,j...->i...", G, x))
    for mat in (StableNeoHookean(LAM, MU), TaylorNeoHookean(LAM, MU)):
        assert _energy(mat, basis, u) == pytest.approx(float(mat.energy(np.eye(2) + G)), rel=1e-12)


def test_per_point_fibers_must_match_quadrature(basis):
    mat = FiberReinforced(NeoHookean(LAM, MU), 1.0, np.ones((2, basis.nelems, basis.X.shape[1] + 1)))
    with pytest.raises(ValueError, match="fibers"):
        _residual(mat, basis, basis.zeros())
