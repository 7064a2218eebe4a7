"""The nonlinear elasticity weak form as scikit-fem forms: the readable reference path.

The notes' weak form of ``-P_ij,j = f_i`` is ``int_B0 w_i,j P_ij(F) dX = int_dB0 w_i P_ij n_j dS + int_B0 w_i f_i dX``
for every test function ``w``, ``F = I + grad u``. With the same shape functions for ``u`` and ``w`` the left-hand side
is the internal force ``q(u)``; Newton needs its derivative (``dF = grad du``):

    q_a(u)       = int grad(v_a) : P(F) dX                      residual_form
    dq_a/du_b    = int grad(v_a) : A(F) : grad(du_b) dX        tangent_form
    E(u)         = int Psi(F) dX,   q = dE/du                   energy_form

with ``A_ijkl = dP_ij/dF_kl``. The test function ``v`` plays ``w`` (``grad(v)[i, j] = w_i,j``), so each form below is
one line that reads like its equation::

    >>> from skfem import Basis, ElementTriP1, ElementVector, MeshTri, asm
    >>> from tissuefem.engine.materials import NeoHookean
    >>> basis, mat = Basis(MeshTri().refined(2), ElementVector(ElementTriP1())), NeoHookean(lam=1.0, mu=1.0)
    >>> q = asm(residual_form(mat), basis, u=basis.interpolate(basis.zeros()))
    >>> float(abs(q).max())
    0.0

The material is bound by closure because scikit-fem passes only arrays through ``w``; per-quadrature-point fibres
``(2, n_elements, n_points)`` must match the basis's quadrature. The forms evaluate the material once per pair of local
basis functions: clear but not fast, the reference that faster assembly is tested against.
"""

from __future__ import annotations

import numpy as np
from skfem import BilinearForm, Functional, LinearForm
from skfem.helpers import ddot, eye, grad

from .materials import Material

__all__ = ["deformation_gradient", "residual_form", "tangent_form", "energy_form"]


def deformation_gradient(u) -> np.ndarray:
    """``F = I + grad u`` for an interpolated displacement field; shape ``[d, d, elements, points]``."""
    grad_u = grad(u)
    return eye(np.ones_like(grad_u[0, 0]), grad_u.shape[0]) + grad_u


def residual_form(material: Material) -> LinearForm:
    """``q_a(u) = int P(F) : grad(v_a) dX`` (the notes' ``int w_i,j P_ij dX``) at ``F = I + grad u``."""
    @LinearForm
    def residual(v, w):
        return ddot(material.stress(deformation_gradient(w["u"])), grad(v))
    return residual


def tangent_form(material: Material) -> BilinearForm:
    """``K_ab = int (A(F) : grad(du_b)) : grad(v_a) dX``, the derivative of :func:`residual_form`."""
    @BilinearForm
    def tangent(du, v, w):
        A = material.tangent(deformation_gradient(w["u"]))
        return ddot(np.einsum("ijkl...,kl...->ij...", A, grad(du)), grad(v))  # (A : grad du) : grad v
    return tangent


def energy_form(material: Material) -> Functional:
    """``E(u) = int Psi(F) dX``, whose gradient is :func:`residual_form`."""
    @Functional
    def energy(w):
        return material.energy(deformation_gradient(w["u"]))
    return energy
