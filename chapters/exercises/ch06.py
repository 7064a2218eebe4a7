"""Chapter 6 exercises: inversion.

Fill in each function, then run ``python -m tissuefem grade ch06``.
You may use numpy, scipy and scikit-fem; do not import the answer from tissuefem.

Conventions: ``F`` is a single 2x2 deformation gradient with
``F[i, j] = d phi_i / d X_j`` (indices 0 and 1), ``J = det F``.
"""

import numpy as np


def rotation_preserving_svd(F):
    """Exercise 6.1. The rotation-preserving SVD of one 2x2 matrix: ``F = U @ np.diag(s) @ V.T``.

    Return ``(U, s, V)``: ``U`` and ``V`` 2x2 *rotations* (orthogonal with
    determinant +1), ``s`` an array of shape (2,) with ``s[0] >= abs(s[1])``.
    The reflection an inverted element carries goes onto the smallest value:
    ``s[1] < 0`` exactly when ``det F < 0`` (and ``s[0] * s[1] == det F``).
    Every F has an answer, including F = 0 (then any rotations will do).

    Hint: write ``F = [[E + A, G - H], [G + H, E - A]]`` (a similarity part
    and an anti-similarity part). Multiply out ``rot(u) @ diag(s0, s1) @ rot(v).T``
    and compare: which combinations of ``s0, s1`` and of the angles ``u, v``
    appear with ``(E, H)`` and which with ``(A, G)``? ``np.arctan2`` and
    ``np.hypot`` avoid every special case.
    """
    raise NotImplementedError("Exercise 6.1: the rotation-preserving SVD")


def taylor_log(J):
    """Exercise 6.2. The notes' cubic Taylor polynomial of ln J about J = 1, and its derivative.

    Return the tuple ``(r, r_prime)`` of floats for a float ``J`` (any sign:
    the point of ``r`` is that it is defined for ``J <= 0``).
    """
    raise NotImplementedError("Exercise 6.2: r(J) and r'(J)")


def taylor_neo_hookean_stress(F, lam, mu):
    """Exercise 6.3. First Piola-Kirchhoff stress of the Taylor Neo-Hookean model.

    ``Psi = mu/2 (F:F - 2) - mu r(J) + lam/2 r(J)^2`` with the cubic ``r`` of
    exercise 6.2. Differentiate it yourself: ``dJ/dF`` is the *cofactor* of F
    (mind the erratum on the matrix the notes print). Must work for inverted
    F (``J <= 0``). Return a 2x2 numpy array.
    """
    raise NotImplementedError("Exercise 6.3: the Taylor Neo-Hookean stress")
