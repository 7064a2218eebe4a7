"""Inversion-robust building blocks: the rotation-preserving SVD and the definiteness fix, in 2D and 3D.

**Rotation-preserving SVD** (:func:`tissuefem.engine.materials.rotation_preserving_svd`, with the 3D corotated model
that needs it): ``F = U diag(s) V^T``, ``U``, ``V`` proper rotations, the sign of ``J`` on the smallest singular value.

**The definiteness fix** (Teran, Sifakis, Irving, Fedkiw, "Robust quasistatic finite elements and flesh simulation",
SCA 2005). For an isotropic material ``A(F)`` is ``A_hat = A(diag(s))`` rotated by ``U``, ``V``, block diagonal: a
*stretch* block over ``(dF_00, ..., dF_(d-1)(d-1))`` (the Hessian in the singular values, 2x2 or 3x3) and for each
pair ``a < b`` a *twist/flip* block ``[[b, c], [c, b]]`` over ``(dF_ab, dF_ba)`` with eigenvalues ``(psi_a - psi_b)/
(s_a - s_b)`` and ``(psi_a + psi_b)/(s_a + s_b)``, ``psi_i = dPsi/ds_i`` (one pair in 2D, three in 3D). Clamping each
block's eigenvalues and rotating back gives the closest positive semi-definite tangent. ``A_hat`` is the material's
own tangent (no 0/0 at ``s_a = s_b``).
"""

from __future__ import annotations

import itertools

import numpy as np

from .materials import Corotated, NeoHookean, StableNeoHookean, TaylorNeoHookean, check_F, rotation_preserving_svd
from .parameters import ParameterError, check_real

__all__ = ["rotation_preserving_svd", "diagonal", "eigen_projection", "projected_tangent", "ProjectedTangent",
           "ITFClamped"]


def diagonal(s) -> np.ndarray:
    """``diag(s)`` for ``s [d, *rest]`` as ``[d, d, *rest]``."""
    s = np.asarray(s, dtype=float)
    out = np.zeros(s.shape[:1] + s.shape)
    out[np.arange(s.shape[0]), np.arange(s.shape[0])] = s
    return out


def _clamp_eigenvalues(M, floor):
    """Symmetric matrices ``M`` ``[k, k, *rest]`` (symmetrised first) with their eigenvalues raised to ``floor``; a
    sample with a non-finite entry (``ln J`` inverted) gives NaN."""
    k, rest = M.shape[0], M.shape[2:]
    M = np.moveaxis(M.reshape((k, k, -1)), -1, 0)
    ok = np.all(np.isfinite(M), axis=(1, 2))
    w, Q = np.linalg.eigh(0.5 * (M[ok] + np.swapaxes(M[ok], 1, 2)))
    out = np.full(M.shape, np.nan)
    out[ok] = np.einsum("nab,nb,ncb->nac", Q, np.maximum(w, floor), Q)
    return np.moveaxis(out, 0, -1).reshape((k, k) + rest)


def eigen_projection(A, floor: float = 0.0):
    """Clamp the eigenvalues of each ``d^2 x d^2`` tangent ``A [d,d,d,d,*rest]`` at ``floor`` numerically: the closed
    form's reference, and the fallback for materials not isotropic (fibers) or not frame indifferent (linear)."""
    A = np.asarray(A, dtype=float)
    d = A.shape[0]
    return _clamp_eigenvalues(A.reshape((d * d, d * d) + A.shape[4:]), floor).reshape(A.shape)


def projected_tangent(material, F, floor: float = 0.0):
    """``material.tangent(F)`` with eigenvalues below ``floor`` raised to it (Teran et al. 2005): in diagonal space
    for the isotropic, frame-indifferent models, else by :func:`eigen_projection`."""
    if type(material) not in (NeoHookean, TaylorNeoHookean, StableNeoHookean, Corotated, ITFClamped):
        return eigen_projection(material.tangent(F), floor)
    U, s, V = rotation_preserving_svd(F)
    return _rotate_back(U, V, _project_diagonal_blocks(np.asarray(material.tangent(diagonal(s)), dtype=float), floor))


def _blocks(d):
    """The index pairs ``(i, j)`` of the diagonal-space blocks (module docstring): stretch, then twist/flip ones."""
    return [tuple((a, a) for a in range(d))] + [((a, b), (b, a)) for a, b in itertools.combinations(range(d), 2)]


def _rotate_back(U, V, A_hat):
    """``A_ijkl = U_ia V_jb U_kc V_ld A_hat_abcd`` for the block form above, as ``sum A_hat[ab, cd] E_ab (x) E_cd``
    over the blocks, with ``E_ab = u_a v_b^T``: outer products of d x d fields. (numpy's optimised ``einsum`` of
    the five operands is faster here, but it sums in another order, and chapter 6's crush figure would change.)"""
    d = U.shape[0]
    E = {(a, b): U[:, a][:, None] * V[:, b][None, :] for a in range(d) for b in range(d)}
    out = 0.0
    for block in _blocks(d):
        W = [sum((A_hat[p + q] * E[q] for q in block[1:]), A_hat[p + block[0]] * E[block[0]]) for p in block]
        for p, Wp in zip(block, W):
            out = out + E[p][:, :, None, None] * Wp[None, None]
    return out


def _clamp_pair(a, b, d, floor):
    """The eigenvalues of symmetric 2x2 blocks ``[[a, b], [b, d]]`` clamped at ``floor`` (closed form): the new
    ``(a, d, b)``."""
    mean, rad = 0.5 * (a + d), np.hypot(0.5 * (a - d), b)
    t = 0.5 * np.arctan2(2.0 * b, a - d)  # the larger eigenvalue's eigenvector is (cos t, sin t)
    c, s = np.cos(t), np.sin(t)
    hi, lo = np.maximum(mean + rad, floor), np.maximum(mean - rad, floor)
    return hi * c * c + lo * s * s, hi * s * s + lo * c * c, (hi - lo) * c * s


def _project_diagonal_blocks(A, floor):
    """Clamp the eigenvalues of a diagonal-space tangent's symmetric blocks at ``floor``: every 2x2 block in closed
    form (:func:`_clamp_pair`), the 3D stretch block numerically."""
    out = np.zeros_like(A)
    for block in _blocks(A.shape[0]):
        if len(block) == 2:
            (i, j), (k, l) = block
            a, b, d = A[i, j, i, j], 0.5 * (A[i, j, k, l] + A[k, l, i, j]), A[k, l, k, l]
            out[i, j, i, j], out[k, l, k, l], out[i, j, k, l] = _clamp_pair(a, b, d, floor)
            out[k, l, i, j] = out[i, j, k, l]
        else:
            S = _clamp_eigenvalues(np.stack([np.stack([A[p + q] for q in block]) for p in block]), floor)
            for x, p in enumerate(block):
                for y, q in enumerate(block):
                    out[p + q] = S[x, y]
    return out


class ProjectedTangent:
    """A material whose tangent is the positive semi-definite projection of another's (energy and stress, hence the
    equilibrium, are the wrapped material's). Projecting in every step costs Newton its quadratic convergence (about
    7 steps a frame instead of 2 on chapter 8's drag); ``adaptive=True`` keeps the exact ``tangent`` and offers the
    projection as ``safe_tangent``, for when the exact direction is not downhill."""

    def __init__(self, material, floor: float = 0.0, adaptive: bool = False):
        self.material = material
        self.floor = check_real("floor", floor, 0.0)
        self.adaptive = bool(adaptive)
        self.lam, self.mu = material.lam, material.mu
        self.inversion_safe = material.inversion_safe
        self.name = f"{material.name} (projected tangent{', when needed' if self.adaptive else ''})"

    def energy(self, F):
        return self.material.energy(F)

    def stress(self, F):
        return self.material.stress(F)

    def tangent(self, F):
        return self.material.tangent(F) if self.adaptive else projected_tangent(self.material, F, self.floor)

    def safe_tangent(self, F):
        """The projected (positive semi-definite) tangent."""
        return projected_tangent(self.material, F, self.floor)

    def __repr__(self):
        return f"ProjectedTangent({self.material!r}, floor={self.floor:g}, adaptive={self.adaptive})"


class ITFClamped:
    """The ``ln J`` :class:`~tissuefem.engine.materials.NeoHookean` made invertible after Irving, Teran and Fedkiw
    (2004/2006). In diagonal space ``Psi(F) = Psi_hat(s)`` (rotation-preserving SVD, ``s1 < 0`` inverted) and
    ``P = U diag(psi) V^T``, ``psi_i = dPsi_hat/ds_i``; below the ``threshold`` ``c`` (``0 < c < 1``) the base model
    is *extrapolated*:

    * ``s1 >= c``: the base model itself;
    * ``s1 < c <= s0``: ``Psi(s0, c) + psi_1(s0, c) d1 + k/2 d1^2``, ``d_i = s_i - c``;
    * ``s0 < c``: ``Psi + psi_0 d0 + psi_1 d1 + Psi_01 d0 d1 + k/2 (d0^2 + d1^2)`` from ``(c, c)``.

    Each piece extends the previous one, so the energy is C1 and the stress its exact gradient (ITF's original clamps
    ``P_hat`` with no consistent energy), and the spring ``stiffness`` ``k`` (default ``d2Psi/ds1^2(c, c)``) pushes
    back even an element crushed to a point. ``project`` (default) makes the tangent positive semi-definite (the energy
    has a kink at ``s0 + s1 = 0``); else it is the exact Hessian (a central difference for the third derivative). Only
    ``ln J``: the spring bounds the energy below only while ``psi_1(s0, c)`` grows slower than ``sqrt(Psi)``; the
    polynomial models do not, and need no clamping. Where the physical answer has ``s1 < c`` the model departs from it.

    **In d dimensions** (the 2D pieces above are its ``d = 2`` case; the 2D energy keeps their closed form) the
    clamped values ``C = {i : s_i < c}`` are a suffix of the sorted ``s``; with ``s^ = s`` clamped to ``c`` on ``C``
    and ``d_i = s_i - c`` on ``C`` (0 elsewhere) the extension is the expansion to first order in each clamped value::

        Psi(s) = Psi(s^) + sum_i psi_i(s^) d_i + sum_(i<j) Psi_ij(s^) d_i d_j + k/2 sum_i d_i^2.

    It is C1 across every threshold because the ``ln J`` energy's mixed derivatives in three distinct values vanish
    (``Psi_ij = lam/(s_i s_j)``); the default ``k`` is ``d2Psi/ds^2`` at ``s = (c, ..., c)`` of that dimension.
    """

    inversion_safe = True

    def __init__(self, material, threshold: float = 0.3, stiffness: float | None = None, project: bool = True):
        if type(material) is not NeoHookean:
            raise ParameterError("material", f"material must be the ln J NeoHookean model, got {material!r}: "
                                 "the other models are finite through inversion (and their extension is not "
                                 "bounded below)")
        c = check_real("threshold", threshold, 0.0, 1.0, lo_open=True, hi_open=True)
        self.base, self.threshold, self.project = material, c, bool(project)
        self.lam, self.mu = material.lam, material.mu
        D = diagonal(np.full((2, 1), c))  # the doubly clamped 2D piece's Psi, psi_i and Psi_01 at (c, c)
        self._psi_cc = float(material.energy(D)[0])
        self._g_cc = float(material.stress(D)[0, 0, 0])
        self._h01_cc = float(material.tangent(D)[0, 0, 1, 1, 0])
        #: the spring stiffness by dimension: the given one, else d2Psi/ds^2 at (c, ..., c)
        self.stiffnesses = {d: check_real("stiffness", stiffness if stiffness is not None else material.tangent(
            diagonal(np.full((d, 1), c)))[d - 1, d - 1, d - 1, d - 1, 0], 0.0, lo_open=True) for d in (2, 3)}
        self.stiffness = self.stiffnesses[2]
        self.name = f"ITF-clamped {material.name}"

    def __repr__(self):
        return (f"ITFClamped({self.base!r}, threshold={self.threshold:g}, stiffness={self.stiffness:g}, "
                f"project={self.project})")

    def _expansion(self, s):
        """``(s, mask C, s^, d, k, psi^, H^)`` for ``s [d, *rest]``: the clamped copy ``s^``, ``d = s - c`` on ``C`` (0
        elsewhere), the base model's gradient ``psi^ [d, *rest]`` and Hessian ``H^ [d, d, *rest]`` at ``diag(s^)``."""
        s = np.asarray(s, dtype=float)
        dim, c = s.shape[0], self.threshold
        clamped = s < c
        s_hat = np.where(clamped, c, s)
        dd = np.where(clamped, s - c, 0.0)
        D = diagonal(s_hat)
        psi = np.einsum("ii...->i...", self.base.stress(D))  # P_ii
        H = np.einsum("iijj...->ij...", self.base.tangent(D))  # A_iijj
        return s, clamped, s_hat, dd, self.stiffnesses[dim], psi, H

    def diagonal_energy(self, s) -> np.ndarray:
        """``Psi_hat(s)`` for signed singular values ``s [d, *rest]`` (``s0 >= ... >= |s_(d-1)|``): the expansion of
        the class docstring; in 2D the doubly clamped piece in its closed form (whose floats the chapters record)."""
        s, _, s_hat, dd, k, psi, H = self._expansion(s)
        out = np.asarray(self.base.energy(diagonal(s_hat)), dtype=float) + np.einsum("i...,i...->...", psi, dd)
        for i, j in itertools.combinations(range(s.shape[0]), 2):
            out = out + H[i, j] * dd[i] * dd[j]
        out = np.asarray(out + 0.5 * k * np.einsum("i...,i...->...", dd, dd))
        if s.shape[0] == 2:
            both = s[0] < self.threshold
            d0, d1 = dd[0][both], dd[1][both]
            out[both] = (self._psi_cc + self._g_cc * (d0 + d1) + self._h01_cc * d0 * d1
                         + 0.5 * k * (d0**2 + d1**2))
        return out

    def diagonal_gradient(self, s) -> np.ndarray:
        """``psi_i = dPsi_hat/ds_i``, shape ``[d, *rest]``."""
        s, _, _, dd, k, psi, H = self._expansion(s)
        off = H * (1.0 - np.eye(s.shape[0])).reshape((s.shape[0],) * 2 + (1,) * (s.ndim - 1))
        return psi + np.einsum("ij...,j...->i...", off, dd) + k * dd

    def diagonal_tangent(self, s) -> np.ndarray:
        """The exact tangent ``A_hat = A(diag(s))`` in diagonal space, ``[d, d, d, d, *rest]``: the base model's where
        nothing is clamped, else the Hessian of the expansion (``k`` on clamped diagonals, ``Psi_jj + sum_i
        dPsi_ji/ds_j d_i`` on free ones, the third derivative by a central difference) with the twist/flip blocks
        ``(psi_a -+ psi_b)/(s_a -+ s_b)`` from the gradient."""
        s = np.asarray(s, dtype=float)
        dim, rest = s.shape[0], s.shape[1:]
        sub = s[-1] < self.threshold  # something clamped (the smallest value first)
        A = np.zeros((dim,) * 4 + rest)
        A[..., ~sub] = self.base.tangent(diagonal(s[:, ~sub]))
        if not sub.any():
            return A
        s, clamped, s_hat, dd, k, _, H = self._expansion(s[:, sub])
        g = self.diagonal_gradient(s)
        Ht = H.copy()
        for j in range(dim):
            step = 1e-6 * np.maximum(1.0, s_hat[j])
            lo, hi = s_hat.copy(), s_hat.copy()
            lo[j], hi[j] = lo[j] - step, hi[j] + step
            A_hi, A_lo = self.base.tangent(diagonal(hi)), self.base.tangent(diagonal(lo))
            for i in range(dim):
                if i != j:
                    Ht[j, j] = Ht[j, j] + (A_hi[j, j, i, i] - A_lo[j, j, i, i]) / (2 * step) * dd[i]
            Ht[j, j] = np.where(clamped[j], k, Ht[j, j])
        B = np.zeros((dim,) * 4 + s.shape[1:])
        i = np.arange(dim)[:, None]
        B[i, i, i.T, i.T] = Ht  # B_iijj = Ht_ij
        for a, b in itertools.combinations(range(dim), 2):
            gap, total = s[a] - s[b], s[a] + s[b]
            limit = 0.5 * (Ht[a, a] + Ht[b, b]) - Ht[a, b]  # (psi_a - psi_b)/(s_a - s_b) as s_a -> s_b
            twist = np.where(gap > 1e-9, (g[a] - g[b]) / np.where(gap > 1e-9, gap, 1.0), limit)
            flip = (g[a] + g[b]) / np.maximum(total, 1e-9)  # s_a + s_b >= 0; the energy has a kink at 0
            B[a, b, a, b] = B[b, a, b, a] = 0.5 * (twist + flip)
            B[a, b, b, a] = B[b, a, a, b] = 0.5 * (twist - flip)
        A[..., sub] = B
        return A

    # the material interface (F shaped [d, d, *rest], also a single d x d matrix)
    @staticmethod
    def _field(F):
        F = check_F(F)
        return F.reshape(F.shape[:2] + (-1,)), F.shape[2:]

    def energy(self, F):
        F, rest = self._field(F)
        _, s, _ = rotation_preserving_svd(F)
        return self.diagonal_energy(s).reshape(rest)

    def stress(self, F):
        F, rest = self._field(F)
        U, s, V = rotation_preserving_svd(F)
        psi = self.diagonal_gradient(s)
        return np.einsum("ia...,a...,ja...->ij...", U, psi, V).reshape(F.shape[:2] + rest)

    def tangent(self, F):
        F, rest = self._field(F)
        U, s, V = rotation_preserving_svd(F)
        A = self.diagonal_tangent(s)
        if self.project:
            A = _project_diagonal_blocks(A, 0.0)
        if F.shape[0] == 2:
            A = np.einsum("ia...,jb...,kc...,ld...,abcd...->ijkl...", U, V, U, V, A, optimize=True)
        else:
            A = _rotate_back(U, V, A)  # block diagonal in diagonal space
        return A.reshape(F.shape[:2] * 2 + rest)
