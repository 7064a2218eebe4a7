"""Chapter 4 exercises: 2D Neo-Hookean elasticity.

Fill in each function, then run ``python -m tissuefem grade ch04``.
You may use numpy and scipy; do not import the answer from tissuefem.
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


def assemble_p1(X_nodes, triangles, u, stress, tangent):
    """Exercise 4.4. The internal force vector q and the tangent K of a hyperelastic body on P1 triangles.

    - ``X_nodes``: (2, n_nodes) reference coordinates; column a is node a.
    - ``triangles``: (3, n_triangles) integer node numbers (counter-clockwise or
      clockwise: use the absolute area).
    - ``u``: (2 n_nodes,) displacements, node a owning the dofs 2a (u_1) and
      2a + 1 (u_2).
    - ``stress(F)`` returns P (2, 2) of one 2x2 F; ``tangent(F)`` returns
      A (2, 2, 2, 2) with A[i, j, k, l] = dP_ij/dF_kl. Call them once per triangle.

    On a triangle e with area A_e, constant shape-function gradients
    dN_a/dX_j and F = I + sum_a u_a (grad N_a)^T (exercise 3.2):

        q[2a + i]          += A_e P_ij dN_a/dX_j
        K[2a + i, 2b + k]  += A_e dN_a/dX_j A_ijkl dN_b/dX_l

    summed over the triangles that contain the nodes a and b. Return
    ``(q, K)``: q a (2 n_nodes,) array, K a (2 n_nodes, 2 n_nodes) array (a dense
    numpy array or a scipy sparse matrix).
    """
    raise NotImplementedError("Exercise 4.4: P1 assembly of the residual and the tangent")


def newton_line_search(u0, energy, gradient, hessian, free, rtol=1e-8, max_iterations=50):
    """Exercise 4.5. Newton's method with a backtracking line search on the energy.

    - ``energy(u) -> float`` (it may be ``nan`` or ``inf`` where an element is
      inverted: such a point is never accepted);
    - ``gradient(u) -> (n,)`` array, ``hessian(u) -> (n, n)`` (dense or sparse);
    - ``free``: the indices of the unknowns; every other entry of ``u`` keeps its
      value from ``u0`` (those are the handles' prescribed displacements).

    Each iteration: solve H_ff d = -g_f on the free dofs; try u + alpha d with
    alpha = 1, 1/2, 1/4, ... and accept the first alpha whose energy is finite
    and satisfies E(u + alpha d) <= E(u) + 1e-4 alpha g_f . d (Armijo); give up
    after 30 halvings. Stop when ||g_f|| <= rtol ||g_f(u0)|| (converged) or after
    ``max_iterations`` steps. Return ``(u, iterations)``: the last accepted
    iterate and the number of accepted steps.
    """
    raise NotImplementedError("Exercise 4.5: Newton with a backtracking energy line search")
