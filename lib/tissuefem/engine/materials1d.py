"""One-dimensional hyperelastic materials (chapters 1 and 2): ``F = J = 1 + du/dX``; ``Psi(F)``, ``P = dPsi/dF`` and
``dP/dF`` on arrays of any shape (checked by finite differences in the tests).

* Linear: ``eps = F - 1``, the notes' ``mu eps_ij eps_ij + lam/2 eps_kk^2`` is ``(mu + lam/2) eps^2``, so
  ``P = (2 mu + lam) eps``. Erratum: the notes print the modulus ``(2 mu - lam)`` (negative for lam > 2 mu).
* Neo-Hookean: ``Psi = mu/2 (F^2 - 1) - mu ln F + lam/2 (ln F)^2``, ``P = mu F + (lam ln F - mu) / F`` (the notes'),
  ``dP/dF = mu + (mu + lam (1 - ln F)) / F^2`` (``2 mu + lam`` at ``F = 1``).
* Cubic Taylor ``r(J)`` of ``ln`` about 1 (the notes' robust variant, Figure 7): ``P = mu F + (lam r - mu) r'``,
  ``dP/dF = mu + lam r'^2 + (lam r - mu) r''``.
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


def taylor_log_second(J):
    """``r''(J) = -1 + 2 (J-1)``."""
    d = np.asarray(J, dtype=float) - 1.0
    return -1.0 + 2.0 * d


def safe_log(F):
    """``ln F`` where ``F > 0``, NaN elsewhere without a warning: NaN, not an exception, lets a solver report it."""
    F = np.asarray(F, dtype=float)
    out = np.full(F.shape, np.nan)
    np.log(F, out=out, where=F > 0)
    return out


class LameMaterial:
    """The base of the 1D and the 2D materials: Lamé parameters ``lam``, ``mu`` (checked) and the three maps."""

    name = "material"
    #: True when energy, stress and tangent are finite for every F, including J <= 0.
    inversion_safe = True

    def __init__(self, lam, mu):
        self.lam, self.mu = check_lame(lam, mu)

    def energy(self, F):
        raise NotImplementedError

    def stress(self, F):
        raise NotImplementedError

    def tangent(self, F):
        raise NotImplementedError

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
    """Linear elasticity in 1D: ``Psi = (mu + lam/2)(F - 1)^2``, ``P = (lam + 2 mu)(F - 1)``."""

    name = "linear"

    def energy(self, F):
        return 0.5 * self.modulus * (np.asarray(F, dtype=float) - 1.0) ** 2

    def stress(self, F):
        return self.modulus * (np.asarray(F, dtype=float) - 1.0)

    def tangent(self, F):
        return np.full(np.shape(F), self.modulus)


class NeoHookean1D(Material1D):
    """The notes' Neo-Hookean model in 1D, with ``ln J``. Undefined (NaN) for ``F <= 0``."""

    name = "neo-Hookean (ln J)"
    inversion_safe = False

    def energy(self, F):
        F = np.asarray(F, dtype=float)
        lnF = safe_log(F)
        return 0.5 * self.mu * (F**2 - 1.0) - self.mu * lnF + 0.5 * self.lam * lnF**2

    def stress(self, F):
        F = np.asarray(F, dtype=float)
        lnF = safe_log(F)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.mu * F + (self.lam * lnF - self.mu) / F

    def tangent(self, F):
        F = np.asarray(F, dtype=float)
        lnF = safe_log(F)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.mu + (self.mu + self.lam * (1.0 - lnF)) / F**2


class TaylorNeoHookean1D(Material1D):
    """Neo-Hookean with ``ln J`` replaced by its cubic Taylor polynomial ``r(J)``: finite for all F."""

    name = "neo-Hookean (cubic r(J))"

    def energy(self, F):
        F = np.asarray(F, dtype=float)
        r = taylor_log(F)
        return 0.5 * self.mu * (F**2 - 1.0) - self.mu * r + 0.5 * self.lam * r**2

    def stress(self, F):
        F = np.asarray(F, dtype=float)
        return self.mu * F + (self.lam * taylor_log(F) - self.mu) * taylor_log_prime(F)

    def tangent(self, F):
        F = np.asarray(F, dtype=float)
        r, r1, r2 = taylor_log(F), taylor_log_prime(F), taylor_log_second(F)
        return self.mu + self.lam * r1**2 + (self.lam * r - self.mu) * r2
