"""Chapter 3 exercises: kinematics and 2D linear elasticity.

Fill in each function, then run ``python -m tissuefem grade ch03``.
You may use numpy; do not import the answer from tissuefem.
Index convention: F[i, j] = d phi_i / d X_j (row = spatial component, column = material direction).
"""

import numpy as np


def lame_from_young(E, nu, plane="strain"):
    """Exercise 3.1. The Lamé parameters ``(lam, mu)`` from Young's modulus ``E`` and Poisson's ratio ``nu``.

    ``plane="strain"``: the notes' formulas (eps_33 = 0). ``plane="stress"``
    (a thin sheet, sigma_33 = 0): mu is unchanged and lam is replaced by
    2 lam mu / (lam + 2 mu) -- derive it by eliminating eps_33 from sigma_33 = 0.
    Return a tuple of two floats.
    """
    raise NotImplementedError("Exercise 3.1: Lamé parameters from E and nu")


def deformation_gradient_p1(X_nodes, x_nodes):
    """Exercise 3.2. The deformation gradient of one linear triangle, F[i, j] = dx_i/dX_j.

    ``X_nodes`` and ``x_nodes`` are (2, 3) arrays: column a holds vertex a in the
    reference and in the deformed configuration (the layout of mesh.p[:, mesh.t[:, e]]).
    Hint: the P1 map is affine, so it carries each edge vector X_a - X_0 to x_a - x_0.
    Return a (2, 2) array.
    """
    raise NotImplementedError("Exercise 3.2: F of one triangle")


def linear_elastic_stress_2d(F, lam, mu):
    """Exercise 3.3. The linear-elastic first Piola-Kirchhoff stress of one 2x2 ``F``.

    eps = (F + F^T)/2 - I, Psi = mu eps:eps + lam/2 tr(eps)^2, P = dPsi/dF.
    Return a (2, 2) array.
    """
    raise NotImplementedError("Exercise 3.3: the linear-elastic stress")
