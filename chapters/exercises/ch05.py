"""Chapter 5 exercises: anisotropic fibers.

Fill in each function, then run ``python -m tissuefem grade ch05``.
You may use numpy, scipy and scikit-fem; do not import the answer from tissuefem.

Conventions: ``F`` is a single 2x2 deformation gradient with
``F[i, j] = d phi_i / d X_j``; ``g`` is a unit fiber direction of shape (2,)
in the reference configuration; ``k >= 0`` is the fiber modulus of
``Psi_fiber = k/8 (I4 - 1)^2``.
"""

import numpy as np


def fiber_invariant(F, g):
    """Exercise 5.1. The invariant I4 = g^T F^T F g: the squared stretch of the fiber g.

    Return a float.
    """
    raise NotImplementedError("Exercise 5.1: the fiber invariant I4")


def fiber_stress(F, g, k):
    """Exercise 5.2. The fiber part of the first Piola-Kirchhoff stress, P_fiber = dPsi_fiber/dF.

    Psi_fiber = k/8 (I4 - 1)^2. Use the chain rule through I4: derive dI4/dF
    first. Return a 2x2 numpy array.
    """
    raise NotImplementedError("Exercise 5.2: the fiber stress")


def fiber_tangent(F, g, k):
    """Exercise 5.3. The fiber tangent A[i, j, k, l] = dP_fiber[i, j] / dF[k, l].

    Return a numpy array of shape (2, 2, 2, 2).
    """
    raise NotImplementedError("Exercise 5.3: the fiber tangent")


def fiber_modulus_gain(k, angle_deg):
    """Exercise 5.4. How much stiffer does the fiber make a small uniaxial strain at an angle?

    Pull along the unit direction e that makes ``angle_deg`` degrees with the
    fiber: F = I + eps e e^T with eps small. Return the extra modulus
    d^2 Psi_fiber / d eps^2 at eps = 0 (a float): k along the fiber, 0 across.
    """
    raise NotImplementedError("Exercise 5.4: the small-strain modulus the fiber adds at an angle")
