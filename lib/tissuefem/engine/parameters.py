"""Material parameters: Lamé constants from Young's modulus and Poisson's ratio."""

from __future__ import annotations

import math


def _check_positive_finite(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def check_young_poisson(E, nu) -> tuple[float, float]:
    """Validate Young's modulus ``E > 0`` and Poisson's ratio ``-1 < nu < 0.5``."""
    E = _check_positive_finite("E (Young's modulus)", E)
    try:
        nu = float(nu)
    except (TypeError, ValueError):
        raise ValueError(f"nu (Poisson's ratio) must be a real number, got {nu!r}") from None
    if not math.isfinite(nu) or not (-1.0 < nu < 0.5):
        raise ValueError(f"nu (Poisson's ratio) must lie in (-1, 0.5), got {nu!r}")
    return E, nu


def lame_parameters(E, nu, plane: str = "strain") -> tuple[float, float]:
    """Lamé parameters ``(lam, mu)`` from Young's modulus and Poisson's ratio.

    ``lam = E nu / ((1 + nu)(1 - 2 nu))`` and ``mu = E / (2 (1 + nu))``
    (the notes' formula, where Young's modulus is written K). In 2D this is
    plane strain; ``plane="stress"`` gives the plane-stress value
    ``lam* = 2 lam mu / (lam + 2 mu)`` used by linear elasticity for thin
    sheets.

    The admissible range is ``E > 0`` and ``-1 < nu < 0.5`` (the notes say
    "between 0 and 1/2"; auxetic materials with ``nu < 0`` are admissible
    too). ``nu -> 0.5`` makes ``lam`` blow up: nearly incompressible.
    """
    E, nu = check_young_poisson(E, nu)
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    if plane == "strain":
        return lam, mu
    if plane == "stress":
        return 2.0 * lam * mu / (lam + 2.0 * mu), mu
    raise ValueError(f"plane must be 'strain' or 'stress', got {plane!r}")


def check_lame(lam, mu) -> tuple[float, float]:
    """Validate Lamé parameters given directly: ``mu > 0`` and ``lam > -2 mu / 3``.

    ``lam > -2 mu / 3`` (a positive bulk modulus ``lam + 2 mu / 3``) is exactly
    what ``-1 < nu < 0.5`` maps to through :func:`lame_parameters`.
    """
    mu = _check_positive_finite("mu (shear modulus)", mu)
    try:
        lam = float(lam)
    except (TypeError, ValueError):
        raise ValueError(f"lam (first Lamé parameter) must be a real number, got {lam!r}") from None
    if not math.isfinite(lam) or lam <= -2.0 * mu / 3.0:
        raise ValueError(
            f"lam (first Lamé parameter) must be finite and > -2 mu / 3 = {-2.0 * mu / 3.0}, got {lam!r}"
        )
    return lam, mu
