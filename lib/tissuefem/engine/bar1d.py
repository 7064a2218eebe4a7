"""One-dimensional bars with scikit-fem: the notes' "1D elasticity" section (chapters 1-2).

The bar ``[a, b]``, displacement ``u(X)``, ``F = 1 + du/dX``. The notes' discrete equations: ``A u = F_ext + g`` with
``A_ij = E1 int N_i' N_j' dX`` (linear), ``q_i(u) = int N_i' P(F(u)) dX - F_ext_i - g_i = 0`` (nonlinear),
``F_ext_i = int f N_i dX``, ``g_i = N_i(b) P(b) - N_i(a) P(a)``. Errata: ``E1 = lam + 2 mu`` (the notes print
``2 mu - lam``); ``q`` subtracts ``g`` (the notes print ``+ g_i``, contradicting their linear system).

Each end is a :class:`Displacement` or a :class:`Traction` ``t = P n`` (``n`` the outward normal): a positive value
points along +X, pulling at the right end and pushing at the left.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp
from skfem import (Basis, BilinearForm, ElementLineP1, ElementLineP2, Functional, LinearForm, MeshLine, asm, condense,
                   solve)

from .materials1d import Material1D
from .minimize import NewtonResult, newton
from .parameters import ParameterError, check_count, check_real, check_real_array


@dataclass(frozen=True)
class Displacement:
    """Prescribed end displacement ``u(end) = value`` (a Dirichlet condition)."""

    value: float = 0.0


@dataclass(frozen=True)
class Traction:
    """Prescribed end traction ``t = P n`` (X component of the applied force per reference area)."""

    value: float = 0.0


def _as_end(condition, name):
    if not isinstance(condition, (Displacement, Traction)):
        raise ParameterError(name, f"{name} must be Displacement(value) or Traction(value), got {condition!r}")
    if not np.isfinite(condition.value):
        raise ParameterError(name, f"{name} has a non-finite value {condition.value!r}")
    return condition


# --- the scikit-fem forms (read them next to the equations above) --------------

@BilinearForm
def _stiffness(u, v, w):
    # A_ij = E1 * int N_i' N_j' dX
    return w["modulus"] * u.grad[0] * v.grad[0]


@LinearForm
def _body_force(v, w):
    # F_ext_i = int f N_i dX
    return w["f"] * v


def nonlinear_forms(material: Material1D):
    """``(internal_force, tangent, strain_energy)`` as scikit-fem forms at ``w["u"]``: ``int N_i' P(F) dX``,
    ``int N_i' dP/dF N_j' dX``, ``int Psi(F) dX`` (the material bound by closure: ``w`` passes only arrays)."""
    @LinearForm
    def internal_force(v, w):
        F = 1.0 + w["u"].grad[0]
        return material.stress(F) * v.grad[0]

    @BilinearForm
    def tangent(du, v, w):
        F = 1.0 + w["u"].grad[0]
        return material.tangent(F) * du.grad[0] * v.grad[0]

    @Functional
    def strain_energy(w):
        F = 1.0 + w["u"].grad[0]
        return material.energy(F)
    return internal_force, tangent, strain_energy


class Bar1D:
    """A 1D bar ``[a, b]`` meshed uniformly with ``n`` elements of Lagrange order 1 or 2."""

    def __init__(self, a: float = 0.0, b: float = 1.0, n: int = 10, order: int = 1, nodes=None):
        if nodes is not None:
            nodes = check_real_array("nodes", nodes)
            if nodes.ndim != 1 or nodes.size < 2 or not np.all(np.isfinite(nodes)) or np.any(np.diff(nodes) <= 0):
                raise ParameterError("nodes", "nodes must be a 1D array of at least 2 finite, strictly increasing "
                                              f"coordinates (no element of zero or negative length), got {nodes!r}")
            mesh = MeshLine(nodes)
        else:
            if not check_real("a", a) < check_real("b", b):
                raise ParameterError("b", f"the bar needs finite ends with a < b, got a={a!r}, b={b!r}")
            mesh = MeshLine(np.linspace(a, b, check_count("n (number of elements)", n) + 1))
        if order not in (1, 2):
            raise ParameterError("order", f"order must be 1 or 2, got {order!r}")
        self.mesh, self.order = mesh, order
        self.a, self.b = float(mesh.p[0].min()), float(mesh.p[0].max())
        element = ElementLineP1() if order == 1 else ElementLineP2()
        # P1: one quadrature point would do; P2 stresses vary, so integrate generously.
        self.basis = Basis(mesh, element, intorder=2 * order + 2)
        self.dof_a = int(self.basis.get_dofs(lambda x: np.isclose(x[0], self.a)).all()[0])
        self.dof_b = int(self.basis.get_dofs(lambda x: np.isclose(x[0], self.b)).all()[0])

    @property
    def ndofs(self) -> int:
        return self.basis.N

    @property
    def nodes(self) -> np.ndarray:
        """Reference coordinate ``X`` of every degree of freedom."""
        return self.basis.doflocs[0]

    def stiffness(self, modulus: float) -> sp.csr_matrix:
        """``A_ij = modulus * int N_i' N_j' dX``."""
        return asm(_stiffness, self.basis, modulus=float(modulus)).tocsr()

    def body_force(self, f=0.0) -> np.ndarray:
        """``F_ext_i = int f(X) N_i dX`` for a number or a callable ``f(X)``."""
        X = np.asarray(self.basis.global_coordinates())[0]
        values = f(X) if callable(f) else np.full_like(X, check_real("f (body force)", f))
        return asm(_body_force, self.basis, f=values)

    def boundary_term(self, left=Traction(0.0), right=Traction(0.0)) -> np.ndarray:
        """``g_i = N_i(b) t_b + N_i(a) t_a``: the tractions at the end dofs (Dirichlet ends contribute 0)."""
        g = np.zeros(self.ndofs)
        for dof, end, name in ((self.dof_a, left, "left"), (self.dof_b, right, "right")):
            if isinstance(_as_end(end, name), Traction):
                g[dof] += end.value
        return g

    def _loads(self, f, left, right):
        """``(fixed, u_D, F_ext + g)``: the mask of the Displacement ends' dofs, their values (0 elsewhere) and the
        load vector of the body force ``f`` and the tractions."""
        rhs = self.body_force(f) + self.boundary_term(left, right)  # checks both ends
        fixed, u_D = np.zeros(self.ndofs, dtype=bool), np.zeros(self.ndofs)
        for dof, end in ((self.dof_a, left), (self.dof_b, right)):
            if isinstance(end, Displacement):
                fixed[dof], u_D[dof] = True, end.value
        if not fixed.any():
            raise ParameterError("left", "at least one end needs a Displacement condition: with tractions at both "
                                         "ends the bar can translate freely and the stiffness matrix is singular")
        return fixed, u_D, rhs

    def solve_linear(self, modulus: float, f=0.0, left=Displacement(0.0), right=Traction(0.0)) -> np.ndarray:
        """Solve ``A u = F_ext + g`` with the given end conditions (``A_II u_I = (F_ext + g)_I - A_ID u_D``, ``D``
        the fixed dofs); returns the dof vector ``u``."""
        check_real("modulus", modulus, 0.0, lo_open=True)
        fixed, u_D, rhs = self._loads(f, left, right)
        return solve(*condense(self.stiffness(modulus).tocsc(), rhs, x=u_D, D=np.flatnonzero(fixed)))

    def internal_force(self, u, material: Material1D) -> np.ndarray:
        """``int N_i' P(F(u)) dX``."""
        return asm(nonlinear_forms(material)[0], self.basis, u=self.basis.interpolate(u))

    def tangent(self, u, material: Material1D) -> sp.csr_matrix:
        """``dq_i/du_j = int N_i' dP/dF N_j' dX``."""
        return asm(nonlinear_forms(material)[1], self.basis, u=self.basis.interpolate(u)).tocsr()

    def strain_energy(self, u, material: Material1D) -> float:
        """``int Psi(F(u)) dX``."""
        return float(asm(nonlinear_forms(material)[2], self.basis, u=self.basis.interpolate(u)))

    def residual(self, u, material, f=0.0, left=Displacement(0.0), right=Traction(0.0)):
        """The notes' ``q(u) = int N' P dX - F_ext - g``."""
        return self.internal_force(u, material) - (self.body_force(f) + self.boundary_term(left, right))

    def solve_nonlinear(self, material: Material1D, f=0.0, left=Displacement(0.0), right=Traction(0.0),
                        load_steps: int = 1, **newton_options) -> tuple[np.ndarray, list[NewtonResult]]:
        """Load stepping + Newton from ``u = 0``: ramp the loads (and prescribed displacements) over ``load_steps``;
        returns the final displacement and each step's Newton result, stopping at the last converged state if a step
        fails."""
        load_steps = check_count("load_steps", load_steps)
        fixed, u_D, external = self._loads(f, left, right)
        u = np.zeros(self.ndofs)
        newton_options.setdefault("line_search", None)  # the notes' plain iteration (chapter 2 adds safeguards)
        newton_options.setdefault("atol", 1e-12)
        results = []
        for s in np.arange(1, load_steps + 1) / load_steps:
            x0 = np.where(fixed, s * u_D, u)
            result = newton(x0, lambda x: self.internal_force(x, material) - s * external,
                            lambda x: self.tangent(x, material), free=~fixed,
                            energy=lambda x: self.strain_energy(x, material) - s * external @ x, **newton_options)
            results.append(result)
            if not result.converged:
                break
            u = result.x
        return u, results

    def errors(self, u, exact: Callable, exact_derivative: Callable) -> tuple[float, float]:
        """``(||u - u_exact||_L2, |u - u_exact|_H1)`` by quadrature."""
        @Functional
        def l2(w):
            return (w["uh"] - exact(w.x[0])) ** 2

        @Functional
        def h1(w):
            return (w["uh"].grad[0] - exact_derivative(w.x[0])) ** 2
        uh = self.basis.interpolate(u)
        return float(np.sqrt(asm(l2, self.basis, uh=uh))), float(np.sqrt(asm(h1, self.basis, uh=uh)))


def uniform_bar_stretch(material: Material1D, traction: float, F0: float = 1.0, tol: float = 1e-14) -> float:
    """The uniform stretch ``F`` of a bar with one end fixed and an end traction ``T`` (``P(F) = T``, so
    ``u(X) = (F - 1)(X - a)``): scalar Newton with a bisection safeguard on ``F > 0``."""
    lo, hi = 1e-12, 2.0
    while material.stress(hi) < traction:
        hi *= 2.0
        if hi > 1e12:
            raise ParameterError("traction", f"no stretch balances traction {traction!r}")
    F = min(max(F0, lo), hi)
    for _ in range(200):
        g = float(material.stress(F)) - traction
        if abs(g) <= tol * max(1.0, abs(traction), material.modulus):
            return F
        lo, hi = (lo, F) if g > 0 else (F, hi)
        step = F - g / float(material.tangent(F))
        F = step if lo < step < hi else 0.5 * (lo + hi)
    return F
