"""One-dimensional hyperelastic materials (chapters 1 and 2): ``F = J = 1 + du/dX``; ``Psi(F)``, ``P = dPsi/dF`` and
``dP/dF`` on arrays of any shape (checked by finite differences in the tests).
"""

from __future__ import annotations

import numpy as np

from .parameters import check_lame, lame_parameters


def taylor_log(J):
    """``r(J) = (J-1) - (J-1)^2/2 + (J-1)^3/3``: the cubic Taylor polynomial of ``ln J`` at 1."""
    d = np.asarray(J, dtype=float) - 1.0
    return d - d**2 / 2.0 + d**3 / 3.0


def taylor_log_prime(J):
    """``r'(J) = 1 - (J-1) + (J-1)^2``, positive for every ``J`` (so ``r`` is monotone)."""
    d = np.asarray(J, dtype=float) - 1.0
    return 1.0 - d + d**2


class LameMaterial:
    """The base of the 1D, 2D and 3D materials: Lamé parameters ``lam``, ``mu`` (checked); a subclass gives the three
    maps ``energy(F)`` ``Psi``, ``stress(F)`` ``P = dPsi/dF`` and ``tangent(F)`` ``dP/dF``."""

    name = "material"
    #: True when energy, stress and tangent are finite for every F, including J <= 0.
    inversion_safe = True

    def __init__(self, lam, mu):
        self.lam, self.mu = check_lame(lam, mu)

    def __repr__(self):
        return f"{type(self).__name__}(lam={self.lam:g}, mu={self.mu:g})"


class Material1D(LameMaterial):
    """Base class: a 1D hyperelastic material with Lamé parameters ``lam`` and ``mu``."""

    @classmethod
    def from_young(cls, E, nu):
        """Build from Young's modulus ``E > 0`` and Poisson's ratio ``-1 < nu < 0.5``."""
        return cls(*lame_parameters(E, nu))

    @property
    def modulus(self) -> float:
        """Small-strain modulus ``dP/dF`` at ``F = 1``: ``lam + 2 mu`` for every model here."""
        return self.lam + 2.0 * self.mu


class Linear1D(Material1D):
    """Linear elasticity in 1D: with ``eps = F - 1`` the notes' ``mu eps_ij eps_ij + lam/2 eps_kk^2`` is ``Psi = (mu +
    lam/2) eps^2``, so ``P = (lam + 2 mu) eps``. Erratum: the notes print the modulus ``(2 mu - lam)`` (negative for
    lam > 2 mu)."""

    name = "linear"

    def energy(self, F):
        return 0.5 * self.modulus * (np.asarray(F, dtype=float) - 1.0) ** 2

    def stress(self, F):
        return self.modulus * (np.asarray(F, dtype=float) - 1.0)

    def tangent(self, F):
        return np.full(np.shape(F), self.modulus)


class VolumetricFamily1D(Material1D):
    """``Psi = mu/2 (F^2 - 1) + h(J)`` with ``J = F``: ``P = mu F + h'(F)``, ``dP/dF = mu + h''(F)``. A subclass gives
    ``volumetric(J) = (h, h', h'')``, the term the 2D and 3D models add to ``mu/2 (F:F - d)`` unchanged."""

    def energy(self, F):
        F = np.asarray(F, dtype=float)
        return 0.5 * self.mu * (F**2 - 1.0) + self.volumetric(F)[0]

    def stress(self, F):
        F = np.asarray(F, dtype=float)
        return self.mu * F + self.volumetric(F)[1]

    def tangent(self, F):
        return self.mu + self.volumetric(np.asarray(F, dtype=float))[2]


class NeoHookean1D(VolumetricFamily1D):
    """The notes' Neo-Hookean model in 1D: ``h(J) = -mu ln J + lam/2 (ln J)^2``, ``h' = (lam ln J - mu)/J`` (so the
    notes' ``P = mu F + (lam ln F - mu)/F``), ``h'' = (lam + mu - lam ln J)/J^2``. Undefined (NaN, without a warning)
    for ``J <= 0``, so a solver can detect inversion."""

    name = "neo-Hookean (ln J)"
    inversion_safe = False

    def volumetric(self, J):
        J = np.asarray(J, dtype=float)
        lnJ, invJ = np.full(J.shape, np.nan), np.full(J.shape, np.nan)
        np.log(J, out=lnJ, where=J > 0)
        np.divide(1.0, J, out=invJ, where=J > 0)
        lam, mu = self.lam, self.mu
        return -mu * lnJ + 0.5 * lam * lnJ**2, (lam * lnJ - mu) * invJ, (lam + mu - lam * lnJ) * invJ**2


class TaylorNeoHookean1D(VolumetricFamily1D):
    """Neo-Hookean with ``ln J`` replaced by its cubic Taylor polynomial ``r(J)`` (the notes' robust variant, Figure
    7): ``h = -mu r + lam/2 r^2``, ``h' = (lam r - mu) r'``, ``h'' = lam r'^2 + (lam r - mu) r''``; finite for all F."""

    name = "neo-Hookean (cubic r(J))"

    def volumetric(self, J):
        r, r1, r2 = taylor_log(J), taylor_log_prime(J), -1.0 + 2.0 * (np.asarray(J, dtype=float) - 1.0)  # r''(J)
        lam, mu = self.lam, self.mu
        return -mu * r + 0.5 * lam * r**2, (lam * r - mu) * r1, lam * r1**2 + (lam * r - mu) * r2
