"""Chapter 9's reference verified against exact solutions: the linear chain on Timoshenko and Goodier's
cantilever (:func:`beam_problem_tip`), the nonlinear one on a manufactured solution
(:func:`manufactured_convergence`)."""

from __future__ import annotations

import math

import numpy as np
from skfem import Basis, FacetBasis, LinearForm, MeshTri, asm

from ..engine.constants import TISSUE_E, TISSUE_NU
from ..engine.materials import LinearElastic
from ..engine.materials import material as make_material
from ..engine.meshes import rectangle
from ..engine.model import Handle, Model
from ..engine.parameters import check_count
from ..engine.stepping import solve
from ..engine.terms import Load
from .measure import fitted_exponent
from .studies import bending_gradient, bending_map

__all__ = ["beam_exact", "beam_problem_tip", "manufactured_body_force", "manufactured_error",
           "manufactured_convergence"]


def beam_exact(X, *, length=48.0, depth=12.0, load=1000.0, E=3.0e7, nu=0.3) -> np.ndarray:
    """Timoshenko and Goodier (*Theory of Elasticity*): the plane-stress displacement ``(2, n)`` of the
    cantilever ``0 <= x <= L``, ``|y| <= D/2``, ``I = D^3 / 12``, under the end shear load ``P`` at ``x = L``:

        u_x = -P y / (6 E I) [6 L x - 3 x^2 + (2 + nu) (y^2 - D^2/4)],
        u_y =  P / (6 E I) [3 nu y^2 (L - x) + (4 + 5 nu) D^2 x / 4 + 3 L x^2 - x^3].

    Its stresses ``sigma_xx = -P (L - x) y / I``, ``sigma_yy = 0``, ``sigma_xy = P / (2 I) (D^2/4 - y^2)``
    are free on ``y = +-D/2`` and at ``x = L`` the parabolic shear of resultant ``P``.
    """
    x, y = np.asarray(X, dtype=float)
    I = depth**3 / 12.0
    c = load / (6.0 * E * I)
    ux = -c * y * (6.0 * length * x - 3.0 * x**2 + (2.0 + nu) * (y**2 - depth**2 / 4.0))
    uy = c * (3.0 * nu * y**2 * (length - x) + (4.0 + 5.0 * nu) * depth**2 * x / 4.0 + 3.0 * length * x**2 - x**3)
    return np.array([ux, uy])


def beam_problem_tip(nx: int, ny: int, order: int = 2, *, length=48.0, depth=12.0, load=1000.0, E=3.0e7,
                     nu=0.3) -> tuple[float, float]:
    """``(computed, exact)`` tip deflection ``u_y(L, 0)`` of :func:`beam_exact`'s cantilever, held on the
    exact displacement at ``x = 0`` and loaded by the exact shear at ``x = L`` (8.9e-3 with the defaults)."""
    check_count("order", order, 1, 2)
    mesh = rectangle(length, depth, int(nx), int(ny))
    mesh = MeshTri(mesh.p - np.array([[0.0], [depth / 2.0]]), mesh.t)
    mesh = mesh.with_boundaries({"left": lambda p: np.isclose(p[0], 0.0),
                                 "right": lambda p: np.isclose(p[0], length)})
    material = LinearElastic.from_young(E, nu, plane="stress")
    exact = dict(length=length, depth=depth, load=load, E=E, nu=nu)
    model = Model(mesh, material, order=order, handles=[Handle("left", lambda X: X + beam_exact(X, **exact))])
    I = depth**3 / 12.0
    right = FacetBasis(mesh, model.basis.elem, facets=mesh.boundaries["right"], intorder=2 * order + 2)

    @LinearForm
    def shear(v, w):
        return load / (2.0 * I) * (depth**2 / 4.0 - w.x[1] ** 2) * v[1]

    model.add_term(Load("end shear", asm(shear, right)))
    result = solve(model, linear_solver="direct")
    if not result.converged:
        raise RuntimeError(f"the cantilever did not converge ({result.status})")
    tip = int(np.argmin(np.hypot(mesh.p[0] - length, mesh.p[1])))
    exact_tip = float(beam_exact(np.array([[length], [0.0]]), **exact)[1, 0])
    return float(result.u[model.basis.nodal_dofs[1, tip]]), exact_tip


def manufactured_body_force(material, X, step: float = 1e-4) -> np.ndarray:
    """The body force ``b = -Div P(F(X))`` (``(Div P)_i = dP_iJ/dX_J``) that holds chapter 3's
    :func:`~tissuefem.workbook.studies.bending_map` in equilibrium, shaped like ``X``; central differences of
    step ``step`` (relative error about 1e-8)."""
    X = np.asarray(X, dtype=float)
    b = np.zeros_like(X)
    for J in range(2):
        e = np.zeros((2,) + (1,) * (X.ndim - 1))
        e[J] = step
        dP = material.stress(bending_gradient(X + e))[:, J] - material.stress(bending_gradient(X - e))[:, J]
        b -= dP / (2.0 * step)
    return b


def manufactured_error(material, n: int, order: int, load_steps: int = 4) -> float:
    """Relative ``L2`` error against the bending map of the block ``[0, 2] x [0, 1]`` (``2n x n`` cells,
    P``order``) held on it at every edge under :func:`manufactured_body_force` (Newton to ``1e-11``)."""
    mesh = rectangle(2.0, 1.0, 2 * int(n), int(n))

    def boundary(X):
        return np.isclose(X[0], 0.0) | np.isclose(X[0], 2.0) | np.isclose(X[1], 0.0) | np.isclose(X[1], 1.0)

    model = Model(mesh, material, order=order, handles=[Handle(boundary, bending_map)])

    @LinearForm
    def body(v, w):
        b = manufactured_body_force(material, w.x)
        return b[0] * v[0] + b[1] * v[1]

    model.add_term(Load("manufactured body force", asm(body, Basis(mesh, model.basis.elem, intorder=2 * order + 2))))
    result = solve(model, load_steps=load_steps, rtol=1e-11)
    if not result.converged:
        raise RuntimeError(f"manufactured solution: P{order}, n = {n} did not converge ({result.status})")
    quad = Basis(mesh, model.basis.elem, intorder=2 * order + 3)
    uh = np.asarray(quad.interpolate(result.u))
    x = quad.mapping.F(quad.quadrature[0])
    ue = bending_map(x) - x
    return float(np.sqrt(np.sum(np.sum((uh - ue) ** 2, axis=0) * quad.dx) / np.sum(np.sum(ue**2, axis=0) * quad.dx)))


def manufactured_convergence(models=("neo-hookean", "stable-neo-hookean", "corotated"), sizes=None,
                             E: float = TISSUE_E, nu: float = TISSUE_NU) -> list[dict]:
    """One dict per model and order (``sizes``: order -> values of ``n``, ``h = 1/n``): the errors against the
    manufactured solution, the rates and the fitted rate, ``order + 1`` for this smooth solution."""
    sizes = {1: (4, 8, 16, 32), 2: (2, 4, 8, 16)} if sizes is None else sizes
    rows = []
    for name in models:
        mat = make_material(name, E, nu)
        for order, ns in sizes.items():
            ns = [int(n) for n in ns]
            errors = [manufactured_error(mat, n, int(order)) for n in ns]
            h = [1.0 / n for n in ns]
            rates = [math.log(e0 / e1) / math.log(h0 / h1) for e0, e1, h0, h1 in zip(errors, errors[1:], h, h[1:])]
            rows.append({"model": name, "order": int(order), "n": ns, "h": h, "errors": errors, "rates": rates,
                         "fitted_rate": fitted_exponent(h, errors) if len(ns) >= 2 else float("nan"),
                         "expected_rate": int(order) + 1})
    return rows
