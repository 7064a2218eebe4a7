"""Chapter 2 exercises: 1D Neo-Hookean elasticity and Newton's method.

Fill in each function, then run ``python -m tissuefem grade ch02``.
You may use numpy, scipy and scikit-fem; do not import the answer from tissuefem.
"""

import numpy as np


def neo_hookean_stress_1d(F, lam, mu):
    """Exercise 2.1. The 1D Neo-Hookean first Piola-Kirchhoff stress P(F) = dPsi/dF.

    Psi(F) = mu/2 (F^2 - 1) - mu ln F + lam/2 (ln F)^2. ``F`` may be a number
    or a numpy array (F > 0); return the same shape.
    """
    raise NotImplementedError("Exercise 2.1: the 1D Neo-Hookean stress")


def neo_hookean_tangent_1d(F, lam, mu):
    """Exercise 2.2. The tangent modulus dP/dF of the 1D Neo-Hookean model (F > 0)."""
    raise NotImplementedError("Exercise 2.2: the 1D Neo-Hookean tangent dP/dF")


def newton_step_1d(nodes, u, lam, mu, traction):
    """Exercise 2.3. One Newton step for a P1 Neo-Hookean bar.

    The bar has node coordinates ``nodes``; its left end is fixed (u = 0) and
    its right end carries the traction ``traction`` (P at the right end); no
    body force. Given the current nodal displacements ``u`` (u[0] = 0), build
    the residual q(u) = int N_i' P(F) dX - g and the tangent dq/du on the free
    nodes, solve dq/du du = -q, and return u + du (with u[0] = 0).
    """
    raise NotImplementedError("Exercise 2.3: one Newton step")
