"""Chapter 9's reference verified against exact solutions, in 2D and 3D: the linear chain on Timoshenko and
Goodier's cantilever (:func:`beam_problem_tip`, :func:`beam_convergence`), the nonlinear one on a manufactured
solution (:func:`manufactured_convergence`), on triangles (``dim=2``) or tetrahedra (``dim=3``)."""

from __future__ import annotations

import math

import numpy as np
from skfem import Basis, FacetBasis, LinearForm, asm

from ..engine.constants import TISSUE_E, TISSUE_NU
from ..engine.materials import LinearElastic
from ..engine.materials import material as make_material
from ..engine.meshes import box, rectangle
from ..engine.model import Handle, Model
from ..engine.parameters import check_count
from ..engine.stepping import solve
from ..engine.terms import Load
from .measure import fitted_exponent, relative_l2_error
from .studies import bending_gradient, bending_map

__all__ = ["beam_exact", "beam_problem_tip", "beam_convergence", "manufactured_map", "manufactured_gradient",
           "manufactured_body_force", "manufactured_error", "manufactured_convergence"]

#: the 3D manufactured map: the arch's angle advances by ``TWIST * Z`` (in units of X), thickness swells by SWELL
TWIST, SWELL = 0.5, 0.1


def beam_exact(X, *, length=48.0, depth=12.0, load=1000.0, E=3.0e7, nu=0.3) -> np.ndarray:
    """Timoshenko and Goodier (*Theory of Elasticity*): the plane-stress displacement ``(2, n)`` of the
    cantilever ``0 <= x <= L``, ``|y| <= D/2``, ``I = D^3 / 12``, under the end shear load ``P`` at ``x = L``:

        u_x = -P y / (6 E I) [6 L x - 3 x^2 + (2 + nu) (y^2 - D^2/4)],
        u_y =  P / (6 E I) [3 nu y^2 (L - x) + (4 + 5 nu) D^2 x / 4 + 3 L x^2 - x^3].

    Its stresses ``sigma_xx = -P (L - x) y / I``, ``sigma_yy = 0``, ``sigma_xy = P / (2 I) (D^2/4 - y^2)``
    are free on ``y = +-D/2`` and at ``x = L`` the parabolic shear of resultant ``P``. With ``E / (1 - nu^2)``
    and ``nu / (1 - nu)`` in place of ``E`` and ``nu`` it is the plane-strain state, ``u_z = 0``, exact in 3D
    for a bar whose faces ``z = const`` carry ``sigma_zz = nu sigma_xx`` (:func:`beam_problem_tip`).
    """
    x, y = np.asarray(X, dtype=float)[:2]
    I = depth**3 / 12.0
    c = load / (6.0 * E * I)
    ux = -c * y * (6.0 * length * x - 3.0 * x**2 + (2.0 + nu) * (y**2 - depth**2 / 4.0))
    uy = c * (3.0 * nu * y**2 * (length - x) + (4.0 + 5.0 * nu) * depth**2 * x / 4.0 + 3.0 * length * x**2 - x**3)
    return np.array([ux, uy])


def beam_problem_tip(nx: int, ny: int, order: int = 2, *, nz: int | None = None, width=6.0, length=48.0,
                     depth=12.0, load=1000.0, E=3.0e7, nu=0.3) -> tuple[float, float]:
    """``(computed, exact)`` tip deflection ``u_y(L, 0)`` of :func:`beam_exact`'s cantilever, held on the
    exact displacement at ``x = 0`` and loaded by the exact tractions ``sigma n``: in 2D (``nz=None``, plane
    stress, 8.9e-3 with the defaults) the end shear; in 3D (``nz`` layers of tetrahedra across ``width``, the
    plane-strain state, 8.138e-3) also ``sigma_zz = nu sigma_xx`` on the faces ``z = 0, width``."""
    check_count("order", order, 1, 2)
    dim = 2 if nz is None else 3
    exact = dict(length=length, depth=depth, load=load, E=E, nu=nu)
    sides = {"left": lambda p: np.isclose(p[0], 0.0), "right": lambda p: np.isclose(p[0], length)}
    if dim == 2:  # plane stress
        mesh, material = rectangle(length, depth, int(nx), int(ny)), LinearElastic.from_young(E, nu, "stress")
    else:  # plane strain, held so by the faces z = 0 and z = width
        mesh, material = box(length, depth, width, int(nx), int(ny), int(nz)), LinearElastic.from_young(E, nu)
        exact.update(E=E / (1.0 - nu**2), nu=nu / (1.0 - nu))
        sides["faces"] = lambda p: np.isclose(p[2], 0.0) | np.isclose(p[2], width)
    mesh = mesh.translated([0.0, -depth / 2.0, 0.0][:dim]).with_boundaries(sides)

    def displacement(X):
        return np.vstack([beam_exact(X, **exact), np.zeros((dim - 2, X.shape[1]))])

    model = Model(mesh, material, order=order, handles=[Handle("left", lambda X: X + displacement(X))])
    I = depth**3 / 12.0
    loaded = np.concatenate([mesh.boundaries[side] for side in sides if side != "left"])
    facets = FacetBasis(mesh, model.basis.elem, facets=loaded, intorder=2 * order + 2)

    @LinearForm
    def traction(v, w):
        sxx = -load * (length - w.x[0]) * w.x[1] / I
        sxy = load / (2.0 * I) * (depth**2 / 4.0 - w.x[1] ** 2)
        t = [sxx * w.n[0] + sxy * w.n[1], sxy * w.n[0]]  # sigma n
        if dim == 3:
            t.append(nu * sxx * w.n[2])
        return sum(t[i] * v[i] for i in range(dim))

    model.add_term(Load("end shear" if dim == 2 else "end shear and faces' sigma_zz", asm(traction, facets)))
    result = solve(model, linear_solver="direct")
    if not result.converged:
        raise RuntimeError(f"the cantilever did not converge ({result.status})")
    tip = int(np.argmin(np.sum((mesh.p - np.array([length, 0.0, 0.0][:dim])[:, None]) ** 2, axis=0)))
    exact_tip = float(beam_exact(np.array([[length], [0.0]]), **exact)[1, 0])
    return float(result.u[model.basis.nodal_dofs[1, tip]]), exact_tip


def beam_convergence(refinements=(1, 2, 4), order: int = 2, dim: int = 3) -> list[dict]:
    """The tip deflection of :func:`beam_problem_tip` on the meshes ``4 n x n`` (``x nz``, ``nz = max(1, n //
    2)`` layers across the width 6 in 3D) for ``n`` in ``refinements``: one dict per mesh, ``n``, ``tip``,
    ``exact`` and the relative error."""
    check_count("dim", dim, 2, 3)
    rows = []
    for n in refinements:
        n = int(n)
        computed, exact = beam_problem_tip(4 * n, n, order, nz=None if dim == 2 else max(1, n // 2))
        rows.append({"n": n, "order": int(order), "dim": dim, "tip": computed, "exact": exact,
                     "relative_error": abs(computed / exact - 1.0)})
    return rows


def manufactured_map(X) -> np.ndarray:
    """The manufactured deformation ``x = phi(X)``, shaped like ``X``: in 2D chapter 3's arch
    (:func:`~tissuefem.workbook.studies.bending_map`); in 3D that arch with its angle advanced along ``Z``
    (``X -> X + TWIST Z``) and its thickness swollen, ``z = Z (1 + SWELL sin X)``."""
    X = np.asarray(X, dtype=float)
    if X.shape[0] == 2:
        return bending_map(X)
    x, y = bending_map(np.stack([X[0] + TWIST * X[2], X[1]]))
    return np.stack([x, y, X[2] * (1.0 + SWELL * np.sin(X[0]))])


def manufactured_gradient(X) -> np.ndarray:
    """The exact ``F`` of :func:`manufactured_map`, ``[d, d, *X.shape[1:]]``; in 3D ``J = J_arch (1 + SWELL
    (sin X - TWIST Z cos X)) > 0``."""
    X = np.asarray(X, dtype=float)
    if X.shape[0] == 2:
        return bending_gradient(X)
    G = bending_gradient(np.stack([X[0] + TWIST * X[2], X[1]]))
    zero = np.zeros_like(X[0])
    return np.array([[G[0, 0], G[0, 1], TWIST * G[0, 0]], [G[1, 0], G[1, 1], TWIST * G[1, 0]],
                     [SWELL * X[2] * np.cos(X[0]), zero, 1.0 + SWELL * np.sin(X[0])]])


def manufactured_body_force(material, X, step: float = 1e-4) -> np.ndarray:
    """The body force ``b = -Div P(F(X))`` (``(Div P)_i = dP_iJ/dX_J``) that holds :func:`manufactured_map` in
    equilibrium, shaped like ``X`` (2D or 3D); central differences of step ``step`` (relative error about
    1e-8)."""
    X = np.asarray(X, dtype=float)
    d = X.shape[0]
    b = np.zeros_like(X)
    for J in range(d):
        e = np.zeros((d,) + (1,) * (X.ndim - 1))
        e[J] = step
        dP = material.stress(manufactured_gradient(X + e))[:, J] - material.stress(manufactured_gradient(X - e))[:, J]
        b -= dP / (2.0 * step)
    return b


def manufactured_error(material, n: int, order: int, load_steps: int = 4, dim: int = 2) -> float:
    """Relative ``L2`` error of the displacement against :func:`manufactured_map` on the block ``[0, 2] x [0,
    1]`` (``2n x n`` cells of two triangles) or ``[0, 2] x [0, 1]^2`` (``dim=3``: ``2n x n x n`` cells of six
    tetrahedra), P``order``, held on it on the whole boundary under :func:`manufactured_body_force` (Newton to
    ``1e-11``)."""
    dim = check_count("dim", dim, 2, 3)
    mesh = rectangle(2.0, 1.0, 2 * int(n), int(n)) if dim == 2 else box(2.0, 1.0, 1.0, 2 * int(n), int(n), int(n))

    def boundary(X):
        return np.isclose(X[0], 0.0) | np.isclose(X[0], 2.0) | np.any(np.isclose(X[1:], 0.0) | np.isclose(X[1:], 1.0),
                                                                         axis=0)

    model = Model(mesh, material, order=order, handles=[Handle(boundary, manufactured_map)])

    @LinearForm
    def body(v, w):
        b = manufactured_body_force(material, w.x)
        return sum(b[i] * v[i] for i in range(dim))

    model.add_term(Load("manufactured body force", asm(body, Basis(mesh, model.basis.elem, intorder=2 * order + 2))))
    result = solve(model, load_steps=load_steps, rtol=1e-11)
    if not result.converged:
        raise RuntimeError(f"manufactured solution: P{order}, n = {n}, {dim}D did not converge ({result.status})")
    return relative_l2_error(model, result.u, lambda x: manufactured_map(x) - x, intorder=2 * order + 3)


#: the default mesh sizes ``n`` (``h = 1/n``) of :func:`manufactured_convergence`, by dimension and order
MANUFACTURED_SIZES = {2: {1: (4, 8, 16, 32), 2: (2, 4, 8, 16)}, 3: {1: (2, 4, 8), 2: (1, 2, 4)}}


def manufactured_convergence(models=("neo-hookean", "stable-neo-hookean", "corotated"), sizes=None,
                             E: float = TISSUE_E, nu: float = TISSUE_NU, dim: int = 2) -> list[dict]:
    """One dict per model and order (``sizes``: order -> values of ``n``, ``h = 1/n``; default
    :data:`MANUFACTURED_SIZES`): the relative L2 errors of the displacement against the manufactured solution
    in ``dim`` dimensions, the rates and the fitted rate, ``order + 1`` for this smooth solution."""
    dim = check_count("dim", dim, 2, 3)
    sizes = MANUFACTURED_SIZES[dim] if sizes is None else sizes
    rows = []
    for name in models:
        mat = make_material(name, E, nu)
        for order, ns in sizes.items():
            ns = [int(n) for n in ns]
            errors = [manufactured_error(mat, n, int(order), dim=dim) for n in ns]
            h = [1.0 / n for n in ns]
            rates = [math.log(e0 / e1) / math.log(h0 / h1) for e0, e1, h0, h1 in zip(errors, errors[1:], h, h[1:])]
            rows.append({"model": name, "order": int(order), "dim": dim, "n": ns, "h": h, "errors": errors,
                         "rates": rates, "fitted_rate": fitted_exponent(h, errors) if len(ns) >= 2 else float("nan"),
                         "expected_rate": int(order) + 1})
    return rows
