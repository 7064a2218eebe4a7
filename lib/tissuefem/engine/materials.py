"""Hyperelastic materials in two (plane strain) and three dimensions.

A material maps ``F[i, j] = d phi_i / d X_j`` shaped ``[d, d, *rest]`` (``d`` = 2 or 3, read from ``F.shape[0]``) to
``energy(F)`` ``Psi`` (shape ``rest``), ``stress(F)`` ``P = dPsi/dF`` and ``tangent(F)`` ``A[i, j, k, l] = dP_ij /
dF_kl`` (shape ``(d, d, d, d) + rest``). One code path serves both dimensions; where a closed form differs (the
determinant, the cofactor, the polar rotation), one function holds the 2x2 and the 3x3 form.

Derivations (checked by finite differences in the tests): ``dJ/dF = cof F = J F^-T`` (in 2D ``[[F11, -F10], [-F01,
F00]]``, in 3D ``cof F_ij = 1/2 e_imn e_jpq F_mp F_nq``) and ``d(cof F)_ij / dF_kl =: H_ijkl`` (in 2D the constant
``e_ik e_jl``, ``e_01 = 1, e_10 = -1``; in 3D ``e_ikm e_jln F_mn``, linear in ``F``), so a volumetric energy ``h(J)``
has ``P = h'(J) cof F`` and ``A = h''(J) cof F (x) cof F + h'(J) H``; ``mu/2 (F:F - d)`` has ``P = mu F``, ``A = mu
I4`` (``I4_ijkl = d_ik d_jl``). At ``F = I``, ``H_ijkl = d_ij d_kl - d_il d_jk`` in both dimensions, so ``h'(1) =
-mu`` and ``h''(1) = lam + mu`` make a model linearise to linear elasticity ``lam d_ij d_kl + mu (d_ik d_jl + d_il
d_jk)`` whatever ``d``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from .materials1d import LameMaterial, NeoHookean1D, TaylorNeoHookean1D
from .parameters import ParameterError, check_fiber_stiffness, check_real_array, lame_parameters

__all__ = [
    "det", "cofactor", "inverse", "cofactor_derivative", "det2", "rotation", "rotation_preserving_svd",
    "Material", "LinearElastic", "NeoHookean", "TaylorNeoHookean", "StableNeoHookean",
    "Corotated", "FiberFamily", "FiberReinforced", "fiber_invariant", "fiber_energy", "fiber_stress", "fiber_tangent",
    "check_fiber_stiffness", "vector_length", "MATERIALS", "material", "check_F",
]

#: The dimensions a field of matrices may have: triangles (2) and tetrahedra (3).
DIMENSIONS = (2, 3)


# --- tensor helpers for fields of d x d matrices ---------------------------------------

def check_F(F) -> np.ndarray:
    """``F`` as a float field of matrices ``[d, d, ...]``, ``d`` = 2 or 3, else a ``ParameterError``."""
    F = check_real_array("F", F)
    if F.ndim < 2 or F.shape[0] != F.shape[1] or F.shape[0] not in DIMENSIONS:
        raise ParameterError("F", f"F must be shaped [d, d, ...] with d = 2 or 3, got shape {F.shape}")
    return F


def det2(F):
    """``J = det F = F00 F11 - F01 F10`` for ``F`` shaped ``[2, 2, ...]``; shape ``F.shape[2:]``."""
    F = check_F(F)
    if F.shape[0] != 2:
        raise ParameterError("F", f"F must be shaped [2, 2, ...], got shape {F.shape}")
    return F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]


def _cofactor3(F) -> np.ndarray:
    """``cof F_ij = F_(i+1)(j+1) F_(i+2)(j+2) - F_(i+1)(j+2) F_(i+2)(j+1)`` (indices mod 3) for ``[3, 3, ...]``."""
    return np.array([[F[(i + 1) % 3, (j + 1) % 3] * F[(i + 2) % 3, (j + 2) % 3]
                      - F[(i + 1) % 3, (j + 2) % 3] * F[(i + 2) % 3, (j + 1) % 3] for j in range(3)]
                     for i in range(3)])


def det(F):
    """``J = det F`` for ``F`` shaped ``[d, d, ...]``, ``d`` = 2 (:func:`det2`) or 3 (``J = F_0j (cof F)_0j``)."""
    F = check_F(F)
    if F.shape[0] == 2:
        return det2(F)
    C = _cofactor3(F)
    return F[0, 0] * C[0, 0] + F[0, 1] * C[0, 1] + F[0, 2] * C[0, 2]


def cofactor(F):
    """``cof F = dJ/dF = J F^-T``, shape ``F.shape``: ``[[F11, -F10], [-F01, F00]]`` in 2D, ``1/2 e_imn e_jpq F_mp
    F_nq`` in 3D. Defined for every ``F``, also singular ones: the inversion-safe models use it rather than ``F^-T``."""
    F = check_F(F)
    return np.array([[F[1, 1], -F[1, 0]], [-F[0, 1], F[0, 0]]]) if F.shape[0] == 2 else _cofactor3(F)


def inverse(F):
    """``F^-1 = (cof F)^T / J`` for ``F`` shaped ``[d, d, ...]`` (singular ``F``: ``inf``/``NaN``, numpy's warning)."""
    return cofactor(F).swapaxes(0, 1) / det(F)


def _outer(a, b) -> np.ndarray:
    """``(a (x) b)_ijkl = a_ij b_kl`` for fields of d x d matrices."""
    return np.einsum("ij...,kl...->ijkl...", a, b)


def _constant4(T, rest) -> np.ndarray:
    """A constant tensor (the (d, d) identity, a (d, d, d, d) tangent) broadcast to ``T.shape + rest``."""
    return np.broadcast_to(T.reshape(T.shape + (1,) * len(rest)), T.shape + tuple(rest))


def _tensors(d) -> dict:
    """The constant tensors of dimension ``d``: ``delta``; ``I4 = d_ik d_jl = dF/dF``; ``I4T = d_il d_jk = dF^T/dF``;
    ``IXI = d_ij d_kl``; ``perm``, the permutation symbol ``e_ij`` (d = 2) or ``e_ijk`` (d = 3): the sign of each
    permutation of the indices (-1 to the number of inversions), 0 for a repeated index."""
    delta, perm = np.eye(d), np.zeros((d,) * d)
    for p in itertools.permutations(range(d)):
        perm[p] = (-1.0) ** sum(a > b for a, b in itertools.combinations(p, 2))
    return {"delta": delta, "I4": np.einsum("ik,jl->ijkl", delta, delta),
            "I4T": np.einsum("il,jk->ijkl", delta, delta), "IXI": np.einsum("ij,kl->ijkl", delta, delta), "perm": perm}


_TENSORS = {d: _tensors(d) for d in DIMENSIONS}
_HCOF2 = np.einsum("ik,jl->ijkl", _TENSORS[2]["perm"], _TENSORS[2]["perm"])  # 2D: e_ik e_jl, constant


def cofactor_derivative(F):
    """``H_ijkl = d(cof F)_ij / dF_kl``, shape ``(d, d, d, d) + rest``: the constant ``e_ik e_jl`` broadcast (2D) or
    ``e_ikm e_jln F_mn`` (3D)."""
    F = check_F(F)
    if F.shape[0] == 2:
        return _constant4(_HCOF2, F.shape[2:])
    e = _TENSORS[3]["perm"]
    return np.einsum("ikm,jln,mn...->ijkl...", e, e, F)


# --- the rotation-preserving SVD ------------------------------------------------------

def rotation(angle) -> np.ndarray:
    """The 2D rotation ``R = [[cos, -sin], [sin, cos]]`` by ``angle`` (radians, counter-clockwise); shape ``[2, 2,
    *angle.shape]``."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def _svd2(F):
    """The 2D closed form (no branch, finite for every ``F``): ``E = (F00 + F11)/2``, ``H = (F10 - F01)/2``, ``Fa =
    (F00 - F11)/2``, ``Ga = (F10 + F01)/2`` (similarity and anti-similarity parts), ``Q = hypot(E, H)``, ``R =
    hypot(Fa, Ga)``: ``s0 = Q + R``, ``s1 = Q - R`` (``s0 s1 = J``), ``U = rot((a1 + a2)/2)``, ``V = rot((a1 -
    a2)/2)`` with ``a1 = atan2(Ga, Fa)``, ``a2 = atan2(H, E)``."""
    E, H = 0.5 * (F[0, 0] + F[1, 1]), 0.5 * (F[1, 0] - F[0, 1])
    Fa, Ga = 0.5 * (F[0, 0] - F[1, 1]), 0.5 * (F[1, 0] + F[0, 1])
    Q, R = np.hypot(E, H), np.hypot(Fa, Ga)
    a1, a2 = np.arctan2(Ga, Fa), np.arctan2(H, E)
    return rotation(0.5 * (a2 + a1)), np.array([Q + R, Q - R]), rotation(0.5 * (a1 - a2))


def _svd3(F):
    """3D: LAPACK's SVD per sample (orthogonal ``U``, ``V``, ``s0 >= s1 >= s2 >= 0``; robust for repeated and zero
    singular values), then each reflection moved onto the smallest value: ``det U = -1`` flips ``U``'s last column
    and ``s2``, ``det V = -1`` flips ``V``'s and ``s2`` again, so ``F`` is unchanged, ``U``, ``V`` are rotations and
    ``sign s2 = sign J``. Samples with a non-finite entry give NaN."""
    rest = F.shape[2:]
    M = np.moveaxis(F.reshape((3, 3, -1)), -1, 0)
    U, s, Vt = np.full_like(M, np.nan), np.full(M.shape[:2], np.nan), np.full_like(M, np.nan)
    ok = np.all(np.isfinite(M), axis=(1, 2))
    u, w, vt = np.linalg.svd(M[ok])
    flip_u, flip_v = np.linalg.det(u) < 0, np.linalg.det(vt) < 0
    u[flip_u, :, 2] *= -1.0
    vt[flip_v, 2, :] *= -1.0
    w[:, 2] *= np.where(flip_u != flip_v, -1.0, 1.0)
    U[ok], s[ok], Vt[ok] = u, w, vt
    return (np.moveaxis(U, 0, -1).reshape((3, 3) + rest), np.moveaxis(s, 0, -1).reshape((3,) + rest),
            np.moveaxis(Vt.swapaxes(1, 2), 0, -1).reshape((3, 3) + rest))


def rotation_preserving_svd(F):
    """``(U [d, d, *rest], s [d, *rest], V [d, d, *rest])`` with ``F = U diag(s) V^T``, ``U``, ``V`` proper rotations
    and ``s0 >= ... >= |s_(d-1)|``: the reflection moved onto the smallest value, which carries the sign of ``J``
    (Irving, Teran, Fedkiw, "Invertible finite elements for robust simulation of large deformation", SCA 2004). 2D
    in closed form, 3D from LAPACK's SVD with the signs fixed."""
    F = check_F(F)
    return _svd2(F) if F.shape[0] == 2 else _svd3(F)


class Material(LameMaterial):
    """Base class: a hyperelastic material (2D plane strain or 3D, from ``F``) with Lamé parameters ``lam``, ``mu``."""

    #: Only linear elasticity has a meaningful plane-stress reduction by a modified lam.
    _plane_stress_ok = False

    @classmethod
    def from_young(cls, E, nu, plane: str = "strain"):
        """Build from Young's modulus and Poisson's ratio; ``plane="stress"`` (``lam -> 2 lam mu / (lam + 2 mu)``) is
        exact only for linear elasticity, the nonlinear models refuse it."""
        lam, mu = lame_parameters(E, nu, plane)
        if plane == "stress" and not cls._plane_stress_ok:
            raise ParameterError("plane", f"plane='stress' is only supported by LinearElastic; {cls.__name__} is "
                                          "plane strain (the plane-stress reduction of a nonlinear model is not a "
                                          "change of lam)")
        return cls(lam, mu)


class LinearElastic(Material):
    """Small-strain linear elasticity (the notes' first model), any ``d``: ``eps = (F + F^T)/2 - I``,
    ``Psi = mu eps:eps + lam/2 tr(eps)^2``, ``P = 2 mu eps + lam tr(eps) I``, ``A = lam d_ij d_kl + mu (d_ik d_jl +
    d_il d_jk)``. Not frame indifferent (a rotation has ``eps != 0``): small deformations only."""

    name = "linear"
    _plane_stress_ok = True

    def _strain(self, F):
        return 0.5 * (F + F.swapaxes(0, 1)) - _constant4(_TENSORS[F.shape[0]]["delta"], F.shape[2:])

    def energy(self, F):
        eps = self._strain(check_F(F))
        return self.mu * np.einsum("ij...,ij...->...", eps, eps) + 0.5 * self.lam * np.trace(eps) ** 2

    def stress(self, F):
        F = check_F(F)
        eps = self._strain(F)
        return 2.0 * self.mu * eps + self.lam * np.trace(eps) * _constant4(_TENSORS[F.shape[0]]["delta"], F.shape[2:])

    def tangent(self, F):
        F = check_F(F)
        T = _TENSORS[F.shape[0]]
        A = self.lam * T["IXI"] + self.mu * (T["I4"] + T["I4T"])
        return np.array(_constant4(A, F.shape[2:]))


# --- the Neo-Hookean family: mu/2 (F:F - d) + h(J) --------------------------------

class _NeoHookeanFamily(Material):
    """``Psi = mu/2 (F:F - d) + h(J)``, ``h(1) = 0`` (module docstring); a subclass gives ``volumetric(J) = (h, h',
    h'')``. ``h'(1) = -mu`` and ``h''(1) = lam + mu`` in every dimension, so one ``h`` serves triangles and tetrahedra
    (and the 1D bar: :class:`~tissuefem.engine.materials1d.VolumetricFamily1D`)."""

    def energy(self, F):
        F = check_F(F)
        h, _, _ = self.volumetric(det(F))
        return 0.5 * self.mu * (np.einsum("ij...,ij...->...", F, F) - float(F.shape[0])) + h

    def stress(self, F):
        F = check_F(F)
        _, h1, _ = self.volumetric(det(F))
        return self.mu * F + h1 * cofactor(F)

    def tangent(self, F):
        F = check_F(F)
        _, h1, h2 = self.volumetric(det(F))
        C = cofactor(F)
        rest = F.shape[2:]
        return (self.mu * _constant4(_TENSORS[F.shape[0]]["I4"], rest) + h2 * _outer(C, C)
                + h1 * cofactor_derivative(F))


class NeoHookean(_NeoHookeanFamily):
    """The notes' Neo-Hookean model, ``h(J) = -mu ln J + lam/2 (ln J)^2`` (:class:`NeoHookean1D`'s, in 2D and 3D),
    i.e. the notes' ``P = mu F + (lam ln J - mu) F^-T``. Erratum: the notes print ``F_ij F_ji = tr(F F)`` in the
    energy, not frame indifferent; their stress derives from ``F:F``, used here. NaN (without a warning) for ``J <=
    0``, so a solver can detect inversion."""

    name = "neo-Hookean"
    inversion_safe = False

    volumetric = NeoHookean1D.volumetric


class TaylorNeoHookean(_NeoHookeanFamily):
    """Neo-Hookean with ``ln J`` replaced by its cubic Taylor polynomial ``r(J)`` (the notes' robust variant; ``h =
    -mu r + lam/2 r^2``, :class:`TaylorNeoHookean1D`'s), so ``P = mu F + (lam r(J) - mu) r'(J) cof F`` with ``cof F =
    [[F22, -F21], [-F12, F11]]`` (1-based). Erratum: the notes print the adjugate ``[[F22, -F12], [-F21, F11]]``,
    which fails the finite-difference check. Finite for every F."""

    name = "neo-Hookean (cubic r(J))"

    volumetric = TaylorNeoHookean1D.volumetric


class StableNeoHookean(_NeoHookeanFamily):
    """Stable Neo-Hookean (Smith, de Goes, Kim, "Stable Neo-Hookean flesh simulation", ACM TOG 37(2), 2018), without
    the paper's ``-mu/2 ln(I_C + 1)`` term, in ``d`` dimensions:
    ``Psi = mu/2 (F:F - d) + lam_s/2 (J - alpha)^2 - mu^2 / (2 lam_s)``, ``P = mu F + lam_s (J - alpha) cof F``.
    At rest ``P(I) = (mu + lam_s (1 - alpha)) I``, so the paper's rest-stability condition ``P(I) = 0`` (``h'(1) =
    -mu``) fixes ``alpha = 1 + mu / lam_s`` in 2D and 3D alike, and ``h''(1) = lam + mu`` (module docstring) fixes
    ``lam_s = lam + mu > 0``; the constant makes ``Psi(I) = 0`` (the paper's is ``mu^2 / (2 lam_s)``). (The paper's
    3D ``alpha = 1 + 3 mu / (4 lam)`` and its remapped Lamé parameters come from the log term, absent here.)"""

    name = "stable neo-Hookean"

    def __init__(self, lam, mu):
        super().__init__(lam, mu)
        self.lam_s = self.lam + self.mu
        self.alpha = 1.0 + self.mu / self.lam_s

    def volumetric(self, J):
        J = np.asarray(J, dtype=float)
        d = J - self.alpha
        h = 0.5 * self.lam_s * d**2 - 0.5 * self.mu**2 / self.lam_s
        return h, self.lam_s * d, np.full(J.shape, self.lam_s)


#: Below this ``rho = tr S`` (2D) the polar rotation is ``R = I`` (:func:`_polar_rotation`): ``1/rho`` is finite
#: above; in 3D a pair of signed singular values summing to less has no rotation stiffness (its ``1/(s_a + s_b)``).
_RHO_MIN = math.sqrt(np.finfo(float).tiny)


def _polar_rotation(F):
    """The 2D polar rotation of ``F = R S`` as ``(R, rho)``: ``R = [[c, -s], [s, c]]`` maximises ``tr(R^T F)``, so
    ``theta = atan2(F10 - F01, F00 + F11)`` and ``rho = tr S = hypot(F00 + F11, F10 - F01)`` (for every F, also J <=
    0). Below :data:`_RHO_MIN` energy, stress and tangent all take ``R = I``."""
    x, y = F[0, 0] + F[1, 1], F[1, 0] - F[0, 1]
    rho, theta = np.hypot(x, y), np.arctan2(y, x)
    collapsed = rho < _RHO_MIN
    if np.any(collapsed):
        theta = np.where(collapsed, 0.0, theta)
    return rotation(theta), rho


def _rotation_derivative(F):
    """``dR/dF`` of the polar rotation. 2D: ``dtheta/dF = R'/rho``, ``R' = dR/dtheta = [[-s, -c], [c, -s]]``, so
    ``dR/dF = R' (x) R' / rho`` (0 below :data:`_RHO_MIN`, where ``R = I`` is constant). 3D, ``R = U V^T``
    (:func:`rotation_preserving_svd`): with ``M = U^T dF V``, ``dR = U W V^T``, ``W`` skew with ``W_ab = (M_ab -
    M_ba) / (s_a + s_b)``, i.e. ``dR/dF = sum_(a<b) 2/(s_a + s_b) T_ab (x) T_ab``, ``T_ab = (u_a v_b^T - u_b
    v_a^T)/sqrt 2`` (the 2D formula for the one pair); a pair with ``s_a + s_b`` below :data:`_RHO_MIN` contributes
    nothing (the rotation is undefined there, as in 2D)."""
    if F.shape[0] == 2:
        R, rho = _polar_rotation(F)
        Rp = np.array([[-R[1, 0], -R[0, 0]], [R[0, 0], -R[1, 0]]])
        inv_rho = np.zeros(rho.shape)
        np.divide(1.0, rho, out=inv_rho, where=rho >= _RHO_MIN)
        return inv_rho * _outer(Rp, Rp)
    U, s, V = rotation_preserving_svd(F)
    dR = np.zeros((3, 3) + F.shape)
    for a, b in ((0, 1), (0, 2), (1, 2)):
        T = (U[:, a][:, None] * V[:, b][None, :] - U[:, b][:, None] * V[:, a][None, :]) / math.sqrt(2.0)
        total = s[a] + s[b]
        weight = np.zeros(total.shape)
        np.divide(2.0, total, out=weight, where=total >= _RHO_MIN)
        dR = dR + weight * _outer(T, T)
    return dR


class Corotated(Material):
    """Fixed corotated elasticity (Stomakhin, Howes, Schroeder, Teran, "Energetically consistent invertible
    elasticity", SCA 2012): ``Psi = mu ||F - R||_F^2 + lam/2 (J - 1)^2``, ``R`` the polar rotation (2D:
    :func:`_polar_rotation`; 3D: ``U V^T`` of the rotation-preserving SVD). ``(F - R):dR = (S - I):(R^T dR) = 0``
    (symmetric against skew), so ``P = 2 mu (F - R) + lam (J - 1) cof F`` and the tangent (at ``F = I`` the linear
    one) is

        A = 2 mu (I4 - dR/dF) + lam cof F (x) cof F + lam (J - 1) H    (dR/dF: :func:`_rotation_derivative`).
    """

    name = "corotated"

    @staticmethod
    def _rotation(F):
        if F.shape[0] == 2:
            return _polar_rotation(F)[0]
        U, _, V = rotation_preserving_svd(F)
        return np.einsum("ia...,ja...->ij...", U, V)  # R = U V^T

    def energy(self, F):
        F = check_F(F)
        D = F - self._rotation(F)
        return self.mu * np.einsum("ij...,ij...->...", D, D) + 0.5 * self.lam * (det(F) - 1.0) ** 2

    def stress(self, F):
        F = check_F(F)
        return 2.0 * self.mu * (F - self._rotation(F)) + self.lam * (det(F) - 1.0) * cofactor(F)

    def tangent(self, F):
        F = check_F(F)
        C = cofactor(F)
        return (2.0 * self.mu * (_constant4(_TENSORS[F.shape[0]]["I4"], F.shape[2:]) - _rotation_derivative(F))
                + self.lam * _outer(C, C) + self.lam * (det(F) - 1.0) * cofactor_derivative(F))


# --- anisotropy: a fibre term -------------------------------------------------------

_UNIT_TOL = 1e-6


def vector_length(g) -> np.ndarray:
    """``|g|`` of vectors ``g`` ``(d, ...)``: ``hypot`` in 2D, the square root of the sum of squares in 3D (the one
    length of the engine's vectors: fibres, a probe's distances, stitches)."""
    return np.hypot(g[0], g[1]) if g.shape[0] == 2 else np.sqrt(np.einsum("i...,i...->...", g, g))


def _check_Fg(F, g):
    """``F`` shaped ``[d, d, ...]`` and unit fibres ``g`` ``(d, ...)`` broadcasting against it, both finite."""
    F = check_F(F)
    d = F.shape[0]
    g = check_real_array(f"g (an array of {d}D unit vectors)", g)  # complex g is refused, never truncated
    if g.ndim < 1 or g.shape[0] != d:
        raise ParameterError("g", f"g must be shaped ({d}, ...) for F of shape {F.shape}, got shape {g.shape}")
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(g))):
        raise ParameterError("F", "F and g must be finite")
    norm = vector_length(g)
    if np.any(np.abs(norm - 1.0) > _UNIT_TOL):
        raise ParameterError("g", f"g must be unit fiber directions (|g| = 1 within {_UNIT_TOL:g}); got lengths "
                                  f"between {norm.min():.6g} and {norm.max():.6g}: normalise g first")
    try:
        np.broadcast_shapes(F.shape[2:], g.shape[1:])
    except ValueError:
        raise ParameterError("g", f"g of shape {g.shape} does not broadcast against F of shape {F.shape}") from None
    return F, g


def fiber_invariant(F, g):
    """``I4 = |F g|^2``, the squared stretch of the unit fibre ``g`` ``(d, ...)``; a float for one ``F``. The
    ``fiber_*`` functions check their arguments, the ``*_term`` kernels (assembly's) do not."""
    F, g = _check_Fg(F, g)
    I4 = _fiber_kinematics(F, g)[1]
    return float(I4) if I4.ndim == 0 else I4


def fiber_energy(F, g, k):
    """``Psi_fiber = k/8 (I4 - 1)^2``."""
    return fiber_energy_term(*_check_Fg(F, g), check_fiber_stiffness(k, "k"))


def fiber_stress(F, g, k):
    """``P_fiber = k/2 (I4 - 1) (F g) g^T``."""
    return fiber_stress_term(*_check_Fg(F, g), check_fiber_stiffness(k, "k"))


def fiber_tangent(F, g, k):
    """``dP_fiber_ij / dF_kl = k a_i g_j a_k g_l + k/2 (I4 - 1) d_ik g_j g_l``, ``a = F g``."""
    return fiber_tangent_term(*_check_Fg(F, g), check_fiber_stiffness(k, "k"))


def _fiber_kinematics(F, g):
    a = np.einsum("ij...,j...->i...", F, g)  # a = F g, the deformed fiber
    return a, np.einsum("i...,i...->...", a, a)  # I4 = |F g|^2


def fiber_energy_term(F, g, k):
    _, I4 = _fiber_kinematics(F, g)
    return k / 8.0 * (I4 - 1.0) ** 2


def fiber_stress_term(F, g, k):
    a, I4 = _fiber_kinematics(F, g)
    return 0.5 * k * (I4 - 1.0) * np.einsum("i...,j...->ij...", a, g)


def fiber_tangent_term(F, g, k):
    a, I4 = _fiber_kinematics(F, g)
    # g's trailing axes align with the right end of F's (as in the energy and the stress): one direction (2,)
    # serves every F; spread it over I4's shape so that the d_ik g_j g_l term multiplies point by point
    g = np.broadcast_to(g.reshape(g.shape[:1] + (1,) * (I4.ndim - g.ndim + 1) + g.shape[1:]), g.shape[:1] + I4.shape)
    ag = np.einsum("i...,j...->ij...", a, g)
    gg = np.einsum("j...,l...->jl...", g, g)
    delta = _TENSORS[F.shape[0]]["delta"]
    return k * _outer(ag, ag) + 0.5 * k * (I4 - 1.0) * np.einsum("ik,jl...->ijkl...", delta, gg)


class FiberFamily(Material):
    """One family of fibres alone, ``Psi = k/8 (I4 - 1)^2`` (the :class:`~tissuefem.engine.terms.Fibers` term's
    density, and the fibre part of :class:`FiberReinforced`): ``stiffness`` ``k >= 0``; ``fibers`` (normalised here)
    ``(d,)``, ``(d, n_elements)`` or ``(d, n_elements, n_points)``, ``d`` = 2 or 3 the dimension of ``F``, aligned
    with the *leading* axes of ``F.shape[2:]``."""

    name = "fibers"

    def __init__(self, stiffness, fibers):
        self.lam = self.mu = 0.0
        self.stiffness = check_fiber_stiffness(stiffness, "stiffness")
        g = np.array(check_real_array("fibers (an array of vectors)", fibers))
        if g.ndim not in (1, 2, 3) or g.shape[0] not in DIMENSIONS:
            raise ParameterError("fibers", "fibers must be shaped (d,), (d, n_elements) or (d, n_elements, "
                                           f"n_points) with d = 2 or 3, got shape {g.shape}")
        norm = vector_length(g)
        if not (np.all(np.isfinite(g)) and np.all(norm > 0.0)):
            raise ParameterError("fibers", "fibers must be finite, none zero-length (a fibre needs a direction)")
        self.fibers = g / norm

    def _Fg(self, F):
        """``F`` checked and the fibres shaped to broadcast against ``F.shape[2:] = rest`` (aligned on the leading
        axes; one ``F`` at rest ``(d, d, 1)`` takes every element's fibre)."""
        F, g = check_F(F), self.fibers
        rest = tuple(F.shape[2:])
        if g.shape[0] != F.shape[0]:
            raise ParameterError("fibers", f"fibers are {g.shape[0]}D vectors but F is {F.shape[0]}D "
                                           f"(shape {F.shape})")
        extra = len(rest) - (g.ndim - 1)
        if extra < 0 or any(a != b and 1 not in (a, b) for a, b in zip(g.shape[1:], rest)):
            raise ParameterError("fibers", f"fibers of shape {g.shape} do not match F with trailing shape {rest}")
        return F, g.reshape(g.shape + (1,) * extra)

    def energy(self, F):
        return fiber_energy_term(*self._Fg(F), self.stiffness)

    def stress(self, F):
        return fiber_stress_term(*self._Fg(F), self.stiffness)

    def tangent(self, F):
        return fiber_tangent_term(*self._Fg(F), self.stiffness)


class FiberReinforced(Material):
    """An isotropic base material plus a fibre term (the notes' ``Psi_iso + Psi_fiber(g^T F^T F g)``):

        Psi = Psi_base(F) + k/8 (I4 - 1)^2,   I4 = |F g|^2,  a = F g,
        P_fiber = k/2 (I4 - 1) a (x) g,   A_fiber_ijkl = k a_i g_j a_k g_l + k/2 (I4 - 1) d_ik g_j g_l.

    ``I4 - 1 ~ 2 eps_ff`` for small strain, so ``k`` *is* the modulus added along the fibre; it resists compression
    as well as stretch. ``base``: any :class:`Material` (a ``FiberReinforced`` adds a second family); ``stiffness``
    and ``fibers``: those of :class:`FiberFamily`.
    """

    def __init__(self, base: Material, stiffness, fibers):
        if not isinstance(base, Material):
            raise ParameterError("base", f"base must be a Material instance, got {base!r}")
        self.base, self.family = base, FiberFamily(stiffness, fibers)
        self.stiffness, self.fibers = self.family.stiffness, self.family.fibers
        self.lam, self.mu, self.inversion_safe = base.lam, base.mu, base.inversion_safe
        self.name = f"{base.name} + fibers"

    @classmethod
    def from_young(cls, E, nu, plane: str = "strain", *, stiffness, fibers, base="neo-hookean"):
        """Build ``base`` (a class or a :data:`MATERIALS` name) from ``(E, nu)`` and add fibres."""
        base_cls = _lookup(base) if isinstance(base, str) else base
        return cls(base_cls.from_young(E, nu, plane), stiffness, fibers)

    def energy(self, F):
        return self.base.energy(F) + self.family.energy(F)

    def stress(self, F):
        return self.base.stress(F) + self.family.stress(F)

    def tangent(self, F):
        return self.base.tangent(F) + self.family.tangent(F)

    def __repr__(self):
        return f"FiberReinforced({self.base!r}, stiffness={self.stiffness:g}, fibers of shape {self.fibers.shape})"


#: The isotropic models by name (the keys accepted by :func:`material`).
MATERIALS = {"linear": LinearElastic, "neo-hookean": NeoHookean, "taylor-neo-hookean": TaylorNeoHookean,
             "stable-neo-hookean": StableNeoHookean, "corotated": Corotated}


def _lookup(name):
    try:
        return MATERIALS[name.lower()]
    except (KeyError, AttributeError):
        raise ParameterError("name", f"name must be one of {', '.join(sorted(MATERIALS))}; got {name!r}") from None


def material(name: str, E, nu, plane: str = "strain") -> Material:
    """Build the material ``name`` (a key of :data:`MATERIALS`) from Young's modulus and Poisson's ratio."""
    return _lookup(name).from_young(E, nu, plane)
