"""Two-dimensional hyperelastic materials (plane strain).

A material maps ``F[i, j] = d phi_i / d X_j`` shaped ``[2, 2, *rest]`` to ``energy(F)`` ``Psi`` (shape ``rest``),
``stress(F)`` ``P = dPsi/dF`` and ``tangent(F)`` ``A[i, j, k, l] = dP_ij / dF_kl`` (shape ``(2, 2, 2, 2) + rest``).

Derivations (checked by finite differences in the tests): ``dJ/dF = cof F = J F^-T = [[F11, -F10], [-F01, F00]]`` is
*linear* in ``F``, ``d(cof F)_ij / dF_kl = e_ik e_jl =: H_ijkl`` (``e_01 = 1, e_10 = -1``), so a volumetric energy
``h(J)`` has ``P = h'(J) cof F`` and ``A = h''(J) cof F (x) cof F + h'(J) H``; ``mu/2 (F:F - 2)`` has ``P = mu F``,
``A = mu I4`` (``I4_ijkl = d_ik d_jl``). At ``F = I``, ``H_ijkl = d_ij d_kl - d_il d_jk``, so ``h'(1) = -mu`` and
``h''(1) = lam + mu`` make a model linearise to linear elasticity ``lam d_ij d_kl + mu (d_ik d_jl + d_il d_jk)``.
"""

from __future__ import annotations

import math

import numpy as np

from .materials1d import LameMaterial, safe_log, taylor_log, taylor_log_prime, taylor_log_second
from .parameters import ParameterError, check_fiber_stiffness, check_real_array, lame_parameters

__all__ = [
    "det2", "cofactor2", "inv2", "Material", "LinearElastic", "NeoHookean", "TaylorNeoHookean", "StableNeoHookean",
    "Corotated", "FiberReinforced", "fiber_invariant", "fiber_energy", "fiber_stress", "fiber_tangent",
    "check_fiber_stiffness", "MATERIALS", "material",
]


# --- 2x2 tensor helpers ---------------------------------------------------------

def _as_F(F) -> np.ndarray:
    F = check_real_array("F", F)
    if F.ndim < 2 or F.shape[:2] != (2, 2):
        raise ParameterError("F", f"F must be shaped [2, 2, ...], got shape {F.shape}")
    return F


def det2(F):
    """``J = det F = F00 F11 - F01 F10`` for ``F`` shaped ``[2, 2, ...]``; shape ``F.shape[2:]``."""
    F = _as_F(F)
    return F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]


def cofactor2(F):
    """The cofactor ``cof F = dJ/dF = J F^-T = [[F11, -F10], [-F01, F00]]``; shape ``F.shape``. Defined for every
    ``F`` (also singular ones): the inversion-safe models use it rather than ``F^-T``."""
    F = _as_F(F)
    return np.array([[F[1, 1], -F[1, 0]], [-F[0, 1], F[0, 0]]])


def inv2(F):
    """``F^-1 = (cof F)^T / J`` for ``F`` shaped ``[2, 2, ...]`` (singular ``F``: ``inf``/``NaN``, numpy's warning)."""
    F = _as_F(F)
    return cofactor2(F).swapaxes(0, 1) / det2(F)


def _outer(a, b) -> np.ndarray:
    """``(a (x) b)_ijkl = a_ij b_kl`` for fields of 2x2 matrices."""
    return np.einsum("ij...,kl...->ijkl...", a, b)


def _constant4(T, rest) -> np.ndarray:
    """A constant tensor (the (2, 2) identity, a (2, 2, 2, 2) tangent) broadcast to ``T.shape + rest``."""
    return np.broadcast_to(T.reshape(T.shape + (1,) * len(rest)), T.shape + tuple(rest))


_DELTA = np.eye(2)
_PERM = np.array([[0.0, 1.0], [-1.0, 0.0]])  # 2D permutation symbol e_ij
_I4 = np.einsum("ik,jl->ijkl", _DELTA, _DELTA)  # d_ik d_jl = dF/dF
_I4T = np.einsum("il,jk->ijkl", _DELTA, _DELTA)  # d_il d_jk = dF^T/dF
_IXI = np.einsum("ij,kl->ijkl", _DELTA, _DELTA)  # d_ij d_kl
_HCOF = np.einsum("ik,jl->ijkl", _PERM, _PERM)  # H_ijkl = e_ik e_jl = d(cof F)_ij / dF_kl (constant)


class Material(LameMaterial):
    """Base class: a 2D hyperelastic material with Lamé parameters ``lam`` and ``mu``."""

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
    """Small-strain linear elasticity (the notes' first model): ``eps = (F + F^T)/2 - I``,
    ``Psi = mu eps:eps + lam/2 tr(eps)^2``, ``P = 2 mu eps + lam tr(eps) I``, ``A = lam d_ij d_kl + mu (d_ik d_jl +
    d_il d_jk)``. Not frame indifferent (a rotation has ``eps != 0``): small deformations only."""

    name = "linear"
    _plane_stress_ok = True

    def _strain(self, F):
        return 0.5 * (F + F.swapaxes(0, 1)) - _constant4(_DELTA, F.shape[2:])

    def energy(self, F):
        eps = self._strain(_as_F(F))
        tr = eps[0, 0] + eps[1, 1]
        return self.mu * np.einsum("ij...,ij...->...", eps, eps) + 0.5 * self.lam * tr**2

    def stress(self, F):
        F = _as_F(F)
        eps = self._strain(F)
        tr = eps[0, 0] + eps[1, 1]
        return 2.0 * self.mu * eps + self.lam * tr * _constant4(_DELTA, F.shape[2:])

    def tangent(self, F):
        F = _as_F(F)
        A = self.lam * _IXI + self.mu * (_I4 + _I4T)
        return np.array(_constant4(A, F.shape[2:]))


# --- the Neo-Hookean family: mu/2 (F:F - 2) + h(J) --------------------------------

class _NeoHookeanFamily(Material):
    """``Psi = mu/2 (F:F - 2) + h(J)``, ``h(1) = 0`` (module docstring); subclasses give ``_h(J) = (h, h', h'')``."""

    def _h(self, J):
        raise NotImplementedError

    def energy(self, F):
        F = _as_F(F)
        h, _, _ = self._h(det2(F))
        return 0.5 * self.mu * (np.einsum("ij...,ij...->...", F, F) - 2.0) + h

    def stress(self, F):
        F = _as_F(F)
        _, h1, _ = self._h(det2(F))
        return self.mu * F + h1 * cofactor2(F)

    def tangent(self, F):
        F = _as_F(F)
        _, h1, h2 = self._h(det2(F))
        C = cofactor2(F)
        rest = F.shape[2:]
        return self.mu * _constant4(_I4, rest) + h2 * _outer(C, C) + h1 * _constant4(_HCOF, rest)


class NeoHookean(_NeoHookeanFamily):
    """The notes' Neo-Hookean model: ``h(J) = -mu ln J + lam/2 (ln J)^2``, ``h' = (lam ln J - mu)/J``,
    ``h'' = (lam + mu - lam ln J)/J^2``, i.e. the notes' ``P = mu F + (lam ln J - mu) F^-T``. Erratum: the notes print
    ``F_ij F_ji = tr(F F)`` in the energy, not frame indifferent; their stress derives from ``F:F``, used here.
    NaN (without a warning) for ``J <= 0``, so a solver can detect inversion."""

    name = "neo-Hookean"
    inversion_safe = False

    def _h(self, J):
        J = np.asarray(J, dtype=float)
        lnJ = safe_log(J)
        invJ = np.full(J.shape, np.nan)
        np.divide(1.0, J, out=invJ, where=J > 0)
        lam, mu = self.lam, self.mu
        h = -mu * lnJ + 0.5 * lam * lnJ**2
        h1 = (lam * lnJ - mu) * invJ
        h2 = (lam + mu - lam * lnJ) * invJ**2
        return h, h1, h2


class TaylorNeoHookean(_NeoHookeanFamily):
    """Neo-Hookean with ``ln J`` replaced by its cubic Taylor polynomial ``r(J)`` (the notes' robust variant,
    :func:`~tissuefem.engine.materials1d.taylor_log`): ``h = -mu r + lam/2 r^2``, ``h' = (lam r - mu) r'``,
    ``h'' = lam r'^2 + (lam r - mu) r''``, so ``P = mu F + (lam r(J) - mu) r'(J) cof F`` with
    ``cof F = [[F22, -F21], [-F12, F11]]`` (1-based). Erratum: the notes print the adjugate ``[[F22, -F12], [-F21,
    F11]]``, which fails the finite-difference check. Finite for every F."""

    name = "neo-Hookean (cubic r(J))"

    def _h(self, J):
        r, r1, r2 = taylor_log(J), taylor_log_prime(J), taylor_log_second(J)
        lam, mu = self.lam, self.mu
        return -mu * r + 0.5 * lam * r**2, (lam * r - mu) * r1, lam * r1**2 + (lam * r - mu) * r2


class StableNeoHookean(_NeoHookeanFamily):
    """Stable Neo-Hookean (Smith, de Goes, Kim, ACM TOG 37(2), 2018), 2D, without the log term:
    ``Psi = mu/2 (F:F - 2) + lam_s/2 (J - alpha)^2 - mu^2 / (2 lam_s)``, ``P = mu F + lam_s (J - alpha) cof F``.
    ``h'(1) = -mu`` (rest is stress free) fixes ``alpha = 1 + mu / lam_s``, ``h''(1) = lam + mu`` (module docstring)
    fixes ``lam_s = lam + mu > 0``; the constant makes ``Psi(I) = 0`` (the paper's is ``mu^2 / (2 lam_s)``)."""

    name = "stable neo-Hookean"

    def __init__(self, lam, mu):
        super().__init__(lam, mu)
        self.lam_s = self.lam + self.mu
        self.alpha = 1.0 + self.mu / self.lam_s

    def _h(self, J):
        J = np.asarray(J, dtype=float)
        d = J - self.alpha
        h = 0.5 * self.lam_s * d**2 - 0.5 * self.mu**2 / self.lam_s
        return h, self.lam_s * d, np.full(J.shape, self.lam_s)


#: Below this ``rho = tr S`` the polar rotation is ``R = I`` (:func:`_polar_rotation`): ``1/rho`` is finite above.
_RHO_MIN = math.sqrt(np.finfo(float).tiny)


def _polar_rotation(F):
    """The 2D polar rotation of ``F = R S`` as ``(R, c, s, rho)``, ``R = [[c, -s], [s, c]]``: ``R`` maximises
    ``tr(R^T F)``, so ``theta = atan2(F10 - F01, F00 + F11)`` and ``rho = tr S = hypot(F00 + F11, F10 - F01)`` (for
    every F, also J <= 0). Below :data:`_RHO_MIN` energy, stress and tangent all take ``R = I``."""
    x, y = F[0, 0] + F[1, 1], F[1, 0] - F[0, 1]
    rho, theta = np.hypot(x, y), np.arctan2(y, x)
    c, s = np.cos(theta), np.sin(theta)
    collapsed = rho < _RHO_MIN
    if np.any(collapsed):
        c = np.where(collapsed, 1.0, c)
        s = np.where(collapsed, 0.0, s)
    return np.array([[c, -s], [s, c]]), c, s, rho


class Corotated(Material):
    """Fixed corotated elasticity (Stomakhin, Howes, Schroeder, Teran, SCA 2012):
    ``Psi = mu ||F - R||_F^2 + lam/2 (J - 1)^2``, ``R`` the polar rotation (:func:`_polar_rotation`).
    ``(F - R):dR = (S - I):(R^T dR) = 0`` (symmetric against skew), so ``P = 2 mu (F - R) + lam (J - 1) cof F``; with
    ``dtheta/dF = R'/rho``, ``R' = dR/dtheta = [[-s, -c], [c, -s]]``, the tangent (at ``F = I`` the linear one) is

        A = 2 mu (I4 - R' (x) R' / rho) + lam cof F (x) cof F + lam (J - 1) H.
    """

    name = "corotated"

    def energy(self, F):
        F = _as_F(F)
        D = F - _polar_rotation(F)[0]
        return self.mu * np.einsum("ij...,ij...->...", D, D) + 0.5 * self.lam * (det2(F) - 1.0) ** 2

    def stress(self, F):
        F = _as_F(F)
        return 2.0 * self.mu * (F - _polar_rotation(F)[0]) + self.lam * (det2(F) - 1.0) * cofactor2(F)

    def tangent(self, F):
        F = _as_F(F)
        _, c, s, rho = _polar_rotation(F)
        Rp = np.array([[-s, -c], [c, -s]])
        inv_rho = np.zeros(rho.shape)
        np.divide(1.0, rho, out=inv_rho, where=rho >= _RHO_MIN)  # R = I (constant) below it
        C = cofactor2(F)
        J = det2(F)
        rest = F.shape[2:]
        return (2.0 * self.mu * (_constant4(_I4, rest) - inv_rho * _outer(Rp, Rp)) + self.lam * _outer(C, C)
                + self.lam * (J - 1.0) * _constant4(_HCOF, rest))


# --- anisotropy: a fibre term -------------------------------------------------------

_UNIT_TOL = 1e-6


def _check_Fg(F, g):
    """``F`` shaped ``[2, 2, ...]`` and unit fibres ``g`` ``(2, ...)`` broadcasting against it, both finite."""
    F = _as_F(F)
    g = check_real_array("g (an array of 2D unit vectors)", g)  # complex g is refused, never truncated
    if g.ndim < 1 or g.shape[0] != 2:
        raise ParameterError("g", f"g must be shaped (2, ...), got shape {g.shape}")
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(g))):
        raise ParameterError("F", "F and g must be finite")
    norm = np.hypot(g[0], g[1])
    if np.any(np.abs(norm - 1.0) > _UNIT_TOL):
        raise ParameterError("g", f"g must be unit fiber directions (|g| = 1 within {_UNIT_TOL:g}); got lengths "
                                  f"between {norm.min():.6g} and {norm.max():.6g}: normalise g first")
    try:
        np.broadcast_shapes(F.shape[2:], g.shape[1:])
    except ValueError:
        raise ParameterError("g", f"g of shape {g.shape} does not broadcast against F of shape {F.shape}") from None
    return F, g


def fiber_invariant(F, g):
    """``I4 = |F g|^2``, the squared stretch of the unit fibre ``g`` ``(2, ...)``; a float for one ``F``. The
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
    return k * _outer(ag, ag) + 0.5 * k * (I4 - 1.0) * np.einsum("ik,jl...->ijkl...", _DELTA, gg)


class FiberReinforced(Material):
    """An isotropic base material plus a fibre term (the notes' ``Psi_iso + Psi_fiber(g^T F^T F g)``):

        Psi = Psi_base(F) + k/8 (I4 - 1)^2,   I4 = |F g|^2,  a = F g,
        P_fiber = k/2 (I4 - 1) a (x) g,   A_fiber_ijkl = k a_i g_j a_k g_l + k/2 (I4 - 1) d_ik g_j g_l.

    ``I4 - 1 ~ 2 eps_ff`` for small strain, so ``k`` *is* the modulus added along the fibre (:meth:`fiber_modulus`);
    it resists compression as well as stretch. ``base``: any :class:`Material` (a ``FiberReinforced`` adds a second
    family); ``stiffness`` ``k >= 0``; ``fibers`` (normalised here) ``(2,)``, ``(2, n_elements)`` or ``(2, n_elements,
    n_points)``, aligned with the *leading* axes of ``F.shape[2:]``.
    """

    def __init__(self, base: Material, stiffness, fibers):
        if not isinstance(base, Material):
            raise ParameterError("base", f"base must be a Material instance, got {base!r}")
        self.base, self.stiffness = base, check_fiber_stiffness(stiffness, "stiffness")
        self.fibers = self._check_fibers(fibers)
        self.lam, self.mu, self.inversion_safe = base.lam, base.mu, base.inversion_safe
        self.name = f"{base.name} + fibers"

    @staticmethod
    def _check_fibers(fibers) -> np.ndarray:
        g = np.array(check_real_array("fibers (an array of 2D vectors)", fibers))
        if g.ndim not in (1, 2, 3) or g.shape[0] != 2:
            raise ParameterError("fibers", "fibers must be shaped (2,), (2, n_elements) or (2, n_elements, "
                                           f"n_points), got shape {g.shape}")
        if not np.all(np.isfinite(g)):
            raise ParameterError("fibers", "fibers contains non-finite entries")
        norm = np.hypot(g[0], g[1])
        if not np.all(norm > 0.0):
            raise ParameterError("fibers", "fibers contains zero-length vectors (a fibre needs a direction)")
        return g / norm

    @classmethod
    def from_young(cls, E, nu, plane: str = "strain", *, stiffness, fibers, base="neo-hookean"):
        """Build ``base`` (a class or a :data:`MATERIALS` name) from ``(E, nu)`` and add fibres."""
        base_cls = _lookup(base) if isinstance(base, str) else base
        return cls(base_cls.from_young(E, nu, plane), stiffness, fibers)

    def fiber_modulus(self) -> float:
        """The small-strain stiffness added along the fibre, ``g_i g_j g_k g_l (A - A_base)_ijkl`` at ``F = I``: k."""
        return self.stiffness

    def _g(self, rest) -> np.ndarray:
        """Fibres shaped to broadcast against ``F.shape[2:] = rest`` (aligned on the leading axes)."""
        g, rest = self.fibers, tuple(rest)
        extra = len(rest) - (g.ndim - 1)
        try:
            ok = extra >= 0 and np.broadcast_shapes(g.shape[1:] + (1,) * extra, rest) == rest
        except ValueError:
            ok = False
        if not ok:
            raise ParameterError("fibers", f"fibers of shape {g.shape} do not match F with trailing shape {rest}")
        return g.reshape(g.shape + (1,) * extra)

    def energy(self, F):
        F = _as_F(F)
        return self.base.energy(F) + fiber_energy_term(F, self._g(F.shape[2:]), self.stiffness)

    def stress(self, F):
        F = _as_F(F)
        return self.base.stress(F) + fiber_stress_term(F, self._g(F.shape[2:]), self.stiffness)

    def tangent(self, F):
        F = _as_F(F)
        return self.base.tangent(F) + fiber_tangent_term(F, self._g(F.shape[2:]), self.stiffness)

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
