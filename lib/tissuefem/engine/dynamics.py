"""Backward Euler for elastodynamics, written as an incremental potential.

The semi-discrete equations of motion are ``M a = f_ext - f_int(u)`` with the
mass matrix ``M_ab = int rho0 N_a N_b dX`` (per displacement component).
Backward Euler takes ``v^{n+1} = (u^{n+1} - u^n)/dt`` and
``a^{n+1} = (v^{n+1} - v^n)/dt`` and evaluates the forces at ``n + 1``:

    q(u) = M (u - u^n - dt v^n) / dt^2 + f_int(u) - f_ext = 0.

Multiplied by ``dt^2`` this is the gradient of the *incremental potential*

    E(u) = 1/2 (u - u_tilde)^T M (u - u_tilde) + dt^2 [W(u) - f_ext^T u],
    u_tilde = u^n + dt v^n,

with ``W`` the stored energy. So one time step is the minimisation of ``E``:
Newton with the energy line search of :mod:`tissuefem.newton` makes every
step safe, and for a positive mass matrix ``E`` is bounded below whenever
``W`` is (which is why backward Euler is stable for any ``dt``). The notes
print the inertia term of this residual as ``M[u^{m+1} + dt v^m]`` and leave
``dt^2`` off the loads: see the README's errata.

This module is the core of time stepping (chapter 7 builds on it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, asm

from .newton import NewtonResult, newton_solve

__all__ = ["mass_matrix", "external_with_gravity", "backward_euler_residual", "BackwardEuler", "StepReport"]


def mass_matrix(basis, density: float, lumped: bool = False) -> sp.csr_matrix:
    """``M = int rho0 v . w dX`` on a vector basis; ``lumped=True`` puts each row sum on the diagonal."""
    rho = float(density)
    if not (np.isfinite(rho) and rho > 0):
        raise ValueError(f"density must be finite and > 0, got {density!r}")

    @BilinearForm
    def mass(u, v, w):
        return rho * (u[0] * v[0] + u[1] * v[1])

    M = asm(mass, basis).tocsr()
    if lumped:
        diagonal = np.asarray(M.sum(axis=1)).ravel()
        # relative to the mean: P2 vertices get a row sum that is zero up to round-off
        if not np.all(diagonal > 1e-8 * np.mean(np.abs(diagonal))):
            raise ValueError(
                "mass='lumped': row-sum lumping gives some dofs zero or negative mass with this element "
                "(P2 triangles' vertices get none); use mass='consistent'"
            )
        return sp.diags(diagonal).tocsr()
    return M


def external_with_gravity(problem, density: float, gravity=None) -> np.ndarray:
    """The problem's external force vector plus the body force ``rho0 g`` of an optional gravity ``(gx, gy)``."""
    external = problem.external.copy()
    if gravity is None:
        return external
    try:
        g = np.asarray(gravity, dtype=float)
    except (TypeError, ValueError):
        g = None
    if g is None or g.shape != (2,) or not np.all(np.isfinite(g)):
        raise ValueError(f"gravity must be a finite vector (gx, gy), got {gravity!r}")
    return external + problem._body_force_vector(float(density) * g)


def backward_euler_residual(M, u, u_n, v_n, dt, f_int, f_ext) -> np.ndarray:
    """The backward-Euler residual multiplied by ``dt^2``: ``M (u - u_n - dt v_n) + dt^2 (f_int - f_ext)``.

    ``f_int`` is the internal force at ``u`` (``int grad N : P(F(u))``) and
    ``f_ext`` the external one (tractions and body force), both dof vectors.
    It is the gradient of the incremental potential, and zero at the step's
    solution ``u = u^{n+1}``.
    """
    return M @ (u - u_n - dt * v_n) + dt**2 * (f_int - f_ext)


@dataclass
class StepReport:
    """What one backward-Euler step did."""

    converged: bool
    status: str
    iterations: int
    residual_norm: float
    energy: float  # incremental potential at the accepted state
    newton: NewtonResult


class BackwardEuler:
    """Backward-Euler time stepping of a :class:`~tissuefem.quasistatic.QuasistaticProblem`'s body.

    The problem supplies mesh, material, handles (prescribed positions, moved
    by user input between steps), tractions and body force; this class adds
    inertia. State: displacement ``u`` and velocity ``v`` (dof vectors).

    Parameters
    ----------
    problem
        The body (its ``handles`` are applied at the end of each step).
    dt
        Time step ``> 0``.
    density
        ``rho0 > 0`` (mass per reference area).
    mass
        ``"lumped"`` (default) or ``"consistent"``.
    gravity
        Optional ``(gx, gy)``: adds the body force ``rho0 g``.
    """

    def __init__(self, problem, dt: float, density: float = 1.0, mass: str = "lumped", gravity=None):
        dt = float(dt)
        if not (np.isfinite(dt) and dt > 0):
            raise ValueError(f"dt must be finite and > 0, got {dt!r}")
        if mass not in ("lumped", "consistent"):
            raise ValueError(f"mass must be 'lumped' or 'consistent', got {mass!r}")
        self.problem, self.dt, self.density = problem, dt, float(density)
        self.M = mass_matrix(problem.basis, density, lumped=(mass == "lumped"))
        self.external = external_with_gravity(problem, self.density, gravity)
        self.u = problem.basis.zeros()
        self.v = problem.basis.zeros()
        self.time = 0.0

    def incremental_potential(self, u, u_tilde) -> float:
        d = u - u_tilde
        return 0.5 * float(d @ (self.M @ d)) + self.dt**2 * (self.problem.strain_energy(u) - self.external @ u)

    def residual(self, u, u_tilde) -> np.ndarray:
        """Gradient of the incremental potential: ``M (u - u_tilde) + dt^2 (f_int(u) - f_ext)``."""
        return backward_euler_residual(self.M, u, self.u, (u_tilde - self.u) / self.dt, self.dt,
                                       self.problem.internal_force(u), self.external)

    def tangent(self, u) -> sp.csr_matrix:
        return (self.M + self.dt**2 * self.problem.tangent(u)).tocsr()

    def step(self, **newton_options) -> StepReport:
        """Advance one step. On failure the state (``u``, ``v``, ``time``) is left exactly as it was."""
        u_tilde = self.u + self.dt * self.v
        fixed, values = self.problem.prescribed()
        x0 = u_tilde.copy()
        x0[fixed] = values
        newton_options.setdefault("line_search", "energy")
        result = newton_solve(
            x0,
            lambda x: self.residual(x, u_tilde),
            self.tangent,
            fixed=fixed,
            energy=lambda x: self.incremental_potential(x, u_tilde),
            **newton_options,
        )
        energy = self.incremental_potential(result.x, u_tilde)
        report = StepReport(result.converged, result.status, result.iterations, result.residual_norm, energy, result)
        if result.converged:
            self.v = (result.x - self.u) / self.dt
            self.u = result.x
            self.time += self.dt
        return report

    def kinetic_energy(self) -> float:
        return 0.5 * float(self.v @ (self.M @ self.v))

    def total_energy(self) -> float:
        """Kinetic plus stored minus the work potential of the (constant) loads."""
        return self.kinetic_energy() + self.problem.strain_energy(self.u) - float(self.external @ self.u)
