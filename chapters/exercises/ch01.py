"""Chapter 1 exercises: 1D linear elasticity.

Fill in each function, then run ``python -m tissuefem grade ch01``.
You may use numpy and scikit-fem; do not import the answer from tissuefem.
"""

import numpy as np


def linear_modulus_1d(lam, mu):
    """Exercise 1.1. The 1D small-strain modulus E1 such that P = E1 (F - 1).

    Start from the notes' energy Psi = mu eps_ij eps_ij + lam/2 eps_kk^2 with a
    single component eps = F - 1, and differentiate. (The notes print 2 mu - lam:
    is that right?)
    """
    raise NotImplementedError("Exercise 1.1: derive the 1D modulus")


def assemble_stiffness_1d(nodes, modulus):
    """Exercise 1.2. The dense P1 stiffness matrix A_ij = modulus * int N_i' N_j' dX.

    ``nodes`` is an increasing array of node coordinates (not necessarily
    uniform); return an (n, n) numpy array, n = len(nodes). Hint: on an element
    of length h the shape-function derivatives are -1/h and +1/h.
    """
    raise NotImplementedError("Exercise 1.2: assemble the 1D stiffness matrix")
