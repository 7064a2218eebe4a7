"""Chapter 11 exercises: tissue in 3D.

Fill in each function, then run ``python -m tissuefem grade ch11``.
You may use numpy; do not import the answer from tissuefem.
Index convention: F[i, j] = d phi_i / d X_j (row = spatial component, column = material direction),
indices 0, 1, 2; ``J = det F``.
"""

import numpy as np


def deformation_gradient_tet(X_nodes, x_nodes):
    """Exercise 11.1. The deformation gradient of one linear tetrahedron, F[i, j] = dx_i/dX_j.

    ``X_nodes`` and ``x_nodes`` are (3, 4) arrays: column a holds vertex a in the
    reference and in the deformed configuration (the layout of mesh.p[:, mesh.t[:, e]]).
    Hint: the P1 map is affine, so it carries each edge vector X_a - X_0 to x_a - x_0;
    put the three edges side by side as the columns of two 3x3 matrices.
    Must work for an inverted tetrahedron too (then det F < 0). Return a (3, 3) array.
    """
    raise NotImplementedError("Exercise 11.1: F of one tetrahedron")


def neo_hookean_stress_3d(F, lam, mu):
    """Exercise 11.2. First Piola-Kirchhoff stress of the 3D Neo-Hookean model.

    ``Psi = mu/2 (F:F - 3) - mu ln J + lam/2 (ln J)^2`` for one 3x3 ``F`` with
    ``J > 0``. Differentiate it yourself: ``dJ/dF`` is the cofactor ``cof F = J F^-T``
    (in 3D each column of cof F is a cross product of two columns of F).
    The grader compares your P with central differences of this energy.
    Return a (3, 3) array.
    """
    raise NotImplementedError("Exercise 11.2: the 3D Neo-Hookean stress")
