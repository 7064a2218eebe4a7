"""Chapter 4 exercises: 2D Neo-Hookean elasticity.

Fill in each function, then run ``python -m tissuefem grade ch04``.
You may use numpy; do not import the answer from tissuefem.
Index convention: F[i, j] = d phi_i / d X_j.
"""

import numpy as np


def neo_hookean_energy_2d(F, lam, mu):
    """Exercise 4.1. The Neo-Hookean energy density of one 2x2 ``F`` with J = det F > 0.

    Psi = mu/2 (F:F - 2) - mu ln J + lam/2 (ln J)^2, with F:F = F_ij F_ij
    (not the notes' F_ij F_ji). Return a float.
    """
    raise NotImplementedError("Exercise 4.1: the 2D Neo-Hookean energy")


def neo_hookean_stress_2d(F, lam, mu):
    """Exercise 4.2. The Neo-Hookean first Piola-Kirchhoff stress P = dPsi/dF of one 2x2 ``F`` (J > 0).

    Hint: d(F:F)/dF = 2 F and dJ/dF = J F^-T. Return a (2, 2) array.
    """
    raise NotImplementedError("Exercise 4.2: the 2D Neo-Hookean stress")


def element_forces_p1(X_nodes, x_nodes, lam, mu):
    """Exercise 4.3. The Neo-Hookean internal forces on the 3 vertices of one linear triangle.

    ``X_nodes`` and ``x_nodes`` are (2, 3) arrays, column a = vertex a (as in
    exercise 3.2). Return a (2, 3) array f with f[i, a] = A P_ij dN_a/dX_j: the
    triangle's contribution to the internal force q (A = reference area, N_a
    the linear shape functions, P the Neo-Hookean stress of the triangle's F).
    It is also the derivative of the triangle's energy A Psi(F) with respect
    to x_nodes[i, a].
    """
    raise NotImplementedError("Exercise 4.3: the forces of one triangle")
