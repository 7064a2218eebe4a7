"""Inversion-robust building blocks: the rotation-preserving SVD and the definiteness fix.

Rotation-preserving SVD (Irving, Teran, Fedkiw 2004/2006)
---------------------------------------------------------
An ordinary SVD ``F = U S V^T`` has ``S >= 0`` and may return reflections for
``U`` or ``V``. For an inverted element (``J < 0``) ITF instead keep ``U`` and
``V`` proper rotations and move the reflection onto the smallest singular
value, which then carries the sign of ``J``: ``F = U diag(s0, s1) V^T`` with
``det U = det V = 1`` and ``s0 >= |s1|``.

In 2D this has a closed form. Split ``F`` into a similarity part and an
anti-similarity part,

    F = [[E + Fa, Ga - H], [Ga + H, E - Fa]],  E = (F00 + F11)/2,  H = (F10 - F01)/2,
                                                 Fa = (F00 - F11)/2, Ga = (F10 + F01)/2,

with ``Q = hypot(E, H)`` and ``R = hypot(Fa, Ga)``. Then ``s0 = Q + R``,
``s1 = Q - R`` (so ``s0 s1 = Q^2 - R^2 = J``), and with
``a1 = atan2(Ga, Fa)``, ``a2 = atan2(H, E)`` the rotations are ``U = rot((a1 + a2)/2)``
and ``V = rot((a1 - a2)/2)``: indeed ``rot(u) diag(s0, s1) rot(v)^T`` is ``Q rot(u - v)``
plus ``R`` times the reflection ``[[cos(u + v), sin(u + v)], [sin(u + v), -cos(u + v)]]``. No branch, no iteration, finite for every F
(including F = 0, where every rotation is a valid answer).

The definiteness fix (Teran, Sifakis, Irving, Fedkiw 2005)
-----------------------------------------------------------
For an isotropic material the tangent rotates with the SVD:
``A(F) = (U x V) A_hat(S) (U x V)^T`` with ``A_hat = A(diag(s))``. In the
basis ``(dF_00, dF_11 | dF_01, dF_10)`` of diagonal space ``A_hat`` is block
diagonal: a 2x2 *stretch* block (the Hessian of ``Psi`` in the singular
values) and a 2x2 *twist/flip* block ``[[b, c], [c, b]]`` with eigenvalues
``b + c = (psi0 - psi1)/(s0 - s1)`` (twist) and ``b - c = (psi0 + psi1)/(s0 + s1)``
(flip), ``psi_i = dPsi/ds_i``. Clamping each block's negative eigenvalues
and rotating back gives the closest positive semi-definite tangent. Because
``A_hat`` is taken from the material's own tangent at the diagonal ``F``
(not from the divided differences), nothing divides 0 by 0 when
``s0 = s1``. Newton with this tangent always computes a descent direction.
"""

from __future__ import annotations

import numpy as np


def _rotation(angle) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def rotation_preserving_svd(F):
    """``F = U diag(s) V^T`` with ``U``, ``V`` rotations and ``s[0] >= |s[1]|``; ``s[1] < 0`` iff ``J < 0``.

    ``F`` is shaped ``[2, 2, *rest]``; returns ``U [2, 2, *rest]``,
    ``s [2, *rest]``, ``V [2, 2, *rest]``.
    """
    F = np.asarray(F, dtype=float)
    if F.shape[:2] != (2, 2):
        raise ValueError(f"F must be shaped [2, 2, ...], got {F.shape}")
    E = 0.5 * (F[0, 0] + F[1, 1])
    H = 0.5 * (F[1, 0] - F[0, 1])
    Fa = 0.5 * (F[0, 0] - F[1, 1])
    Ga = 0.5 * (F[1, 0] + F[0, 1])
    Q = np.hypot(E, H)
    R = np.hypot(Fa, Ga)
    a1 = np.arctan2(Ga, Fa)
    a2 = np.arctan2(H, E)
    U = _rotation(0.5 * (a2 + a1))
    V = _rotation(0.5 * (a1 - a2))
    return U, np.array([Q + R, Q - R]), V


def diagonal(s) -> np.ndarray:
    """``diag(s)`` for ``s [2, *rest]`` as ``[2, 2, *rest]``."""
    s = np.asarray(s, dtype=float)
    out = np.zeros((2, 2) + s.shape[1:])
    out[0, 0], out[1, 1] = s[0], s[1]
    return out


def _project_sym2(a, b, d, floor):
    """Clamp the eigenvalues of the symmetric 2x2 blocks ``[[a, b], [b, d]]`` at ``floor`` (closed form)."""
    mean = 0.5 * (a + d)
    rad = np.hypot(0.5 * (a - d), b)
    lam_hi, lam_lo = mean + rad, mean - rad
    # unit eigenvector of lam_hi: (cos t, sin t) with t = atan2(2b, a - d) / 2 (well defined; rad = 0 -> any)
    t = 0.5 * np.arctan2(2.0 * b, a - d)
    c, s = np.cos(t), np.sin(t)
    hi, lo = np.maximum(lam_hi, floor), np.maximum(lam_lo, floor)
    return hi * c * c + lo * s * s, (hi - lo) * c * s, hi * s * s + lo * c * c


def eigen_projection(A, floor: float = 0.0):
    """Numerical projection: clamp the eigenvalues of each 4x4 tangent ``A [2,2,2,2,*rest]`` at ``floor``.

    The reference the closed form is tested against, and the fallback for
    materials that are not isotropic (fibers) or not frame indifferent (linear).
    """
    A = np.asarray(A, dtype=float)
    rest = A.shape[4:]
    M = np.moveaxis(A.reshape((4, 4, -1)), -1, 0)
    M = 0.5 * (M + np.swapaxes(M, 1, 2))
    w, Q = np.linalg.eigh(M)
    P = np.einsum("nab,nb,ncb->nac", Q, np.maximum(w, floor), Q)
    return np.moveaxis(P, 0, -1).reshape((2, 2, 2, 2) + rest)


def _rotation_invariant(material) -> bool:
    from .materials import Corotated, NeoHookean, StableNeoHookean, TaylorNeoHookean

    return type(material) in (NeoHookean, TaylorNeoHookean, StableNeoHookean, Corotated)


def projected_tangent(material, F, floor: float = 0.0):
    """The positive semi-definite projection of ``material.tangent(F)`` (Teran et al. 2005).

    Closed form in diagonal space for the isotropic, frame-indifferent models
    (Neo-Hookean family, corotated); other materials (linear elasticity, fiber
    terms) fall back to :func:`eigen_projection`. Eigenvalues below ``floor`` (default 0)
    are raised to ``floor``; positive ones are kept, so where the tangent is
    already positive semi-definite it is returned unchanged (up to round-off).
    Returns ``[2, 2, 2, 2, *rest]`` like ``material.tangent``.
    """
    if not _rotation_invariant(material):
        return eigen_projection(material.tangent(F), floor)
    U, s, V = rotation_preserving_svd(F)
    A = np.asarray(material.tangent(diagonal(s)), dtype=float)
    out = np.zeros_like(A)
    # stretch block over (dF00, dF11)
    a, b, d = A[0, 0, 0, 0], 0.5 * (A[0, 0, 1, 1] + A[1, 1, 0, 0]), A[1, 1, 1, 1]
    a, b, d = _project_sym2(a, b, d, floor)
    out[0, 0, 0, 0], out[0, 0, 1, 1], out[1, 1, 0, 0], out[1, 1, 1, 1] = a, b, b, d
    # twist/flip block over (dF01, dF10): [[p, c], [c, q]] (p = q for isotropic materials)
    a, b, d = A[0, 1, 0, 1], 0.5 * (A[0, 1, 1, 0] + A[1, 0, 0, 1]), A[1, 0, 1, 0]
    a, b, d = _project_sym2(a, b, d, floor)
    out[0, 1, 0, 1], out[0, 1, 1, 0], out[1, 0, 0, 1], out[1, 0, 1, 0] = a, b, b, d
    # rotate back: A_ijkl = U_ia V_jb U_kc V_ld A_hat_abcd
    return np.einsum("ia...,jb...,kc...,ld...,abcd...->ijkl...", U, V, U, V, out, optimize=True)


class ProjectedTangent:
    """A material whose tangent is the positive semi-definite projection of another's.

    Energy and stress are the wrapped material's, so a Newton solve still
    converges to the same equilibrium; only the search direction changes (it
    is always a descent direction for the energy). Works with the fast
    assembler and with the scikit-fem forms alike.
    """

    def __init__(self, material, floor: float = 0.0):
        if not np.isfinite(floor) or floor < 0:
            raise ValueError(f"floor must be finite and >= 0, got {floor!r}")
        self.material = material
        self.floor = float(floor)
        self.lam, self.mu = material.lam, material.mu
        self.inversion_safe = material.inversion_safe
        self.name = f"{material.name} (projected tangent)"

    def energy(self, F):
        return self.material.energy(F)

    def stress(self, F):
        return self.material.stress(F)

    def tangent(self, F):
        return projected_tangent(self.material, F, self.floor)

    def __repr__(self):
        return f"ProjectedTangent({self.material!r}, floor={self.floor:g})"
