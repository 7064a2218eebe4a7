"""Figures of chapter 5 (anisotropic fibers)."""

from .figures import register, save  # noqa: F401
