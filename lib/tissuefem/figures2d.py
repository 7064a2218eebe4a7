"""Figures of chapters 3 and 4 (2D kinematics, linear elasticity, Neo-Hookean quasistatics)."""

from .figures import register, save  # noqa: F401
