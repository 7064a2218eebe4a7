"""The library's answers to the exercises, graded with the student's checks (``tests/grading.py``): each has
its stub's name and signature (``chapters/exercises/chNN.py``) and calls the engine wherever it computes the
answer."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import scipy.sparse as sp

from ..engine.assembly import P1Assembler
from ..engine.bar1d import Bar1D, Traction
from ..engine.contact import barrier
from ..engine.inversion import rotation_preserving_svd
from ..engine.linsolve import LinearInfo
from ..engine.materials import LinearElastic, NeoHookean, TaylorNeoHookean, fiber_invariant, fiber_stress, fiber_tangent
from ..engine.materials1d import NeoHookean1D, taylor_log as _r, taylor_log_prime as _r_prime
from ..engine.minimize import newton
from ..engine.parameters import lame_parameters
from ..surgery.geometry import polygon_area
from ..surgery.scene import Scene
from ..surgery.topology import duplicate_along_edges
from .fibers import fiber_modulus_gain
from .measure import best_within_budget, observed_rates
from .measure import pareto_front as _pareto_front

__all__ = [
    "linear_modulus_1d", "assemble_stiffness_1d",
    "neo_hookean_stress_1d", "neo_hookean_tangent_1d", "newton_step_1d",
    "lame_from_young", "deformation_gradient_p1", "linear_elastic_stress_2d",
    "neo_hookean_energy_2d", "neo_hookean_stress_2d", "element_forces_p1", "assemble_p1", "newton_line_search",
    "fiber_invariant", "fiber_stress", "fiber_tangent", "fiber_modulus_gain",
    "rotation_preserving_svd", "taylor_log", "taylor_neo_hookean_stress",
    "backward_euler_residual", "budgeted_newton",
    "duplicate_cut_nodes", "scene_file_text",
    "pareto_front", "observed_rates", "best_within_budget",
    "clip_stroke", "piece_shares", "signed_gap", "skin_energy",
    "deformation_gradient_tet", "neo_hookean_stress_3d",
]


def linear_modulus_1d(lam, mu):
    """Exercise 1.1: the 1D small-strain modulus ``dP/dF`` at rest, ``lam + 2 mu`` (the notes print ``2 mu - lam``)."""
    return NeoHookean1D(lam, mu).modulus


def assemble_stiffness_1d(nodes, modulus) -> np.ndarray:
    """Exercise 1.2: the dense P1 stiffness ``A_ij = modulus int N_i' N_j' dX`` on the given nodes."""
    return Bar1D(nodes=nodes).stiffness(modulus).toarray()


def neo_hookean_stress_1d(F, lam, mu):
    """Exercise 2.1: ``P(F) = mu F + (lam ln F - mu) / F``."""
    return NeoHookean1D(lam, mu).stress(F)


def neo_hookean_tangent_1d(F, lam, mu):
    """Exercise 2.2: ``dP/dF = mu + (mu + lam (1 - ln F)) / F^2``."""
    return NeoHookean1D(lam, mu).tangent(F)


def newton_step_1d(nodes, u, lam, mu, traction) -> np.ndarray:
    """Exercise 2.3: one Newton step ``u + du``, ``dq/du du = -q(u)``, for the 1D Neo-Hookean bar (left end
    fixed, traction at the right), by the library's minimiser limited to one plain iteration."""
    bar = Bar1D(nodes=nodes)
    material = NeoHookean1D(lam, mu)
    u0 = _shaped("u", u, (bar.ndofs,)).copy()
    u0[0] = 0.0
    return newton(u0, lambda x: bar.residual(x, material, right=Traction(traction)),
                  lambda x: bar.tangent(x, material), free=np.arange(1, bar.ndofs), line_search=None,
                  max_iterations=1, rtol=0.0).x


def _shaped(name, value, shape) -> np.ndarray:
    """``value`` as a float array of ``shape`` (one ``F``: (2, 2); a triangle's vertex columns: (2, 3))."""
    a = np.asarray(value, dtype=float)
    if a.shape != shape:
        raise ValueError(f"{name} must be shaped {shape}, got shape {a.shape}")
    return a


def lame_from_young(E, nu, plane: str = "strain") -> tuple[float, float]:
    """Exercise 3.1: ``(lam, mu)`` from Young's modulus and Poisson's ratio (plane strain or stress)."""
    return lame_parameters(E, nu, plane)


def _p1_gradients(X):
    """Area (volume) and shape-function gradients ``(d + 1, d)`` of one linear triangle with vertices ``X`` ``(2,
    3)``, or of one linear tetrahedron with vertices ``X`` ``(3, 4)``."""
    Dm = X[:, 1:] - X[:, :1]
    d = Dm.shape[0]
    if abs(np.linalg.det(Dm)) <= 1e-14 * max(1.0, float(np.abs(Dm).max()) ** d):
        raise ValueError("X_nodes is a degenerate (zero-area) triangle" if d == 2 else
                         "X_nodes is a degenerate (zero-volume) tetrahedron")
    grads = np.linalg.inv(Dm)  # row a-1 is grad N_a for a = 1 ... d (since N_a(X_b) = d_ab)
    return abs(np.linalg.det(Dm)) / (2.0 if d == 2 else 6.0), np.vstack([-grads.sum(axis=0), grads])


def _deformation_gradient(X_nodes, x_nodes, d):
    """``F = sum_a x_a (grad N_a)^T`` of one linear triangle (``d = 2``) or tetrahedron (``d = 3``)."""
    X, x = _shaped("X_nodes", X_nodes, (d, d + 1)), _shaped("x_nodes", x_nodes, (d, d + 1))
    return x @ _p1_gradients(X)[1]


def deformation_gradient_p1(X_nodes, x_nodes) -> np.ndarray:
    """Exercise 3.2: ``F[i, j] = dx_i/dX_j`` of one linear triangle: ``F = sum_a x_a (grad N_a)^T``."""
    return _deformation_gradient(X_nodes, x_nodes, 2)


def linear_elastic_stress_2d(F, lam, mu) -> np.ndarray:
    """Exercise 3.3: ``P = 2 mu eps + lam tr(eps) I``, ``eps = (F + F^T)/2 - I``, for one 2x2 ``F``."""
    return LinearElastic(lam, mu).stress(_shaped("F", F, (2, 2)))


def neo_hookean_energy_2d(F, lam, mu) -> float:
    """Exercise 4.1: ``Psi = mu/2 (F:F - 2) - mu ln J + lam/2 (ln J)^2`` for one 2x2 ``F``."""
    return float(NeoHookean(lam, mu).energy(_shaped("F", F, (2, 2))))


def neo_hookean_stress_2d(F, lam, mu) -> np.ndarray:
    """Exercise 4.2: ``P = mu F + (lam ln J - mu) F^-T`` for one 2x2 ``F``."""
    return NeoHookean(lam, mu).stress(_shaped("F", F, (2, 2)))


def element_forces_p1(X_nodes, x_nodes, lam, mu) -> np.ndarray:
    """Exercise 4.3: the Neo-Hookean forces on the vertices of one linear triangle, ``f_ia = A P_ij dN_a/dX_j``."""
    X = _shaped("X_nodes", X_nodes, (2, 3))
    area, grads = _p1_gradients(X)
    return area * NeoHookean(lam, mu).stress(deformation_gradient_p1(X, x_nodes)) @ grads.T


class _PointwiseMaterial:
    """A material given as two functions of one 2x2 ``F`` (exercise 4.4), evaluated element by element
    in the array layout the engine's assemblers use (``F[i, j, element]``)."""

    def __init__(self, stress, tangent):
        self._stress, self._tangent = stress, tangent

    def energy(self, F):
        raise NotImplementedError("exercise 4.4 gives the stress and the tangent only")

    def stress(self, F):
        return np.stack([np.asarray(self._stress(F[:, :, e]), dtype=float) for e in range(F.shape[-1])], axis=-1)

    def tangent(self, F):
        return np.stack([np.asarray(self._tangent(F[:, :, e]), dtype=float) for e in range(F.shape[-1])], axis=-1)


def assemble_p1(X_nodes, triangles, u, stress, tangent):
    """Exercise 4.4: ``(q, K)`` of a P1 mesh, by the engine's fast assembler with the given ``P(F)`` and ``dP/dF``."""
    X = np.asarray(X_nodes, dtype=float)
    t = np.asarray(triangles)
    if X.ndim != 2 or X.shape[0] != 2 or t.ndim != 2 or t.shape[0] != 3:
        raise ValueError(f"X_nodes must be (2, n_nodes) and triangles (3, n_triangles), got {X.shape} and {t.shape}")
    assembler = P1Assembler(SimpleNamespace(p=X, t=t), _PointwiseMaterial(stress, tangent))
    return assembler.residual(u), assembler.tangent(u)


def newton_line_search(u0, energy, gradient, hessian, free, rtol=1e-8, max_iterations=50):
    """Exercise 4.5: Newton with the energy line search, by the engine's one minimiser."""
    result = newton(np.asarray(u0, dtype=float), gradient, lambda x: sp.csr_matrix(hessian(x)), energy=energy,
                    free=np.asarray(free), rtol=rtol, max_iterations=max_iterations)
    return result.x, result.iterations


def taylor_log(J):
    """Exercise 6.2: ``(r(J), r'(J))``, the notes' cubic Taylor polynomial of ``ln J`` at 1 and its derivative."""
    return _r(J), _r_prime(J)


def taylor_neo_hookean_stress(F, lam, mu):
    """Exercise 6.3: ``P = mu F + (lam r - mu) r' cof F`` (the cofactor, not the notes' adjugate)."""
    return TaylorNeoHookean(lam, mu).stress(F)


def backward_euler_residual(M, u, u_n, v_n, dt, f_int, f_ext):
    """Exercise 7.1: ``M (u - u_n - dt v_n) + dt^2 (f_int - f_ext)``: ``dt^2`` times the gradient of the
    model's potential with its inertia term (:class:`~tissuefem.engine.terms.Inertia`)."""
    u = np.asarray(u, dtype=float)
    return M @ (u - (u_n + dt * v_n)) + dt**2 * (np.asarray(f_int) - np.asarray(f_ext))


class _StepFunction:
    """The minimiser's linear-solver role played by a user's ``newton_step(x, g)``."""

    def __init__(self, step):
        self.step = step

    def matrix(self, assemble, mask, force=False):
        return assemble()  # here: the iterate itself (see budgeted_newton)

    def solve(self, x, rhs, *, atol=0.0):
        return np.asarray(self.step(x, -rhs), dtype=float), LinearInfo()


def budgeted_newton(x0, energy, gradient, newton_step, clock, budget, rtol):
    """Exercise 7.2: one budgeted frame, by the library's minimiser with the frame's own Newton step."""
    result = newton(np.asarray(x0, dtype=float), gradient, lambda x: x, energy=energy,
                    linear=_StepFunction(newton_step), clock=clock, budget=budget, rtol=rtol, max_iterations=50)
    return result.x, result.iterations, result.converged


def duplicate_cut_nodes(t, n_nodes, cut_edges):
    """Exercise 8.1: node duplication along a cut (the library's cutting core)."""
    return duplicate_along_edges(t, n_nodes, cut_edges)


def scene_file_text():
    """Exercise 8.2: the scene of the exercise, built in Python and written by :meth:`Scene.to_toml`."""
    return Scene(
        name="tug",
        domain={"shape": "rectangle", "width": 3.0, "height": 1.0, "triangles": 600},
        material={"model": "corotated", "youngs_modulus": 5000.0, "poisson_ratio": 0.4, "density": 1.1},
        effects={
            "inertia": {"time_step": 0.02},
            "gravity": {"acceleration": [0.0, -9.81]},
            "fibers": {"stiffness": 2000.0, "direction": [1.0, 0.0]},
            "handles": [{"name": "fixed", "region": "left"},
                        {"name": "tip", "region": {"near": [3.0, 0.5], "radius": 0.1}, "target": [0.5, 0.0]}],
        },
    ).to_toml()


def pareto_front(costs, errors):
    """Exercise 9.1: indices of the non-dominated settings, by increasing cost (a list)."""
    return _pareto_front(costs, errors).tolist()


def _barycentric(triangle, p):
    T = np.asarray(triangle, dtype=float)
    J = np.column_stack([T[1] - T[0], T[2] - T[0]])
    xi = np.linalg.solve(J, np.asarray(p, dtype=float) - T[0])
    return np.array([1.0 - xi.sum(), xi[0], xi[1]])


def clip_stroke(triangle, a, b):
    """Exercise 10.1: the parameters ``(s0, s1)`` of the part of ``a -> b`` inside the triangle, or ``None``."""
    la, lb = _barycentric(triangle, a), _barycentric(triangle, b)
    lo, hi = 0.0, 1.0
    for k in range(3):
        slope = lb[k] - la[k]
        if abs(slope) < 1e-15:
            if la[k] < 0.0:
                return None
            continue
        s = -la[k] / slope  # where lambda_k crosses zero
        if slope > 0:
            lo = max(lo, s)
        else:
            hi = min(hi, s)
    return (lo, hi) if hi - lo > 1e-12 else None


def piece_shares(triangle, point, direction):
    """Exercise 10.2: the area fractions ``(left, right)`` of the triangle on the two sides of a line."""
    T = np.asarray(triangle, dtype=float)
    p, d = np.asarray(point, dtype=float), np.asarray(direction, dtype=float)

    def side(q):
        return d[0] * (q[1] - p[1]) - d[1] * (q[0] - p[0])  # > 0: left of the line

    kept = []
    for i in range(3):
        q, r = T[i], T[(i + 1) % 3]
        sq, sr = side(q), side(r)
        if sq >= 0:
            kept.append(q)
        if (sq > 0 > sr) or (sq < 0 < sr):
            kept.append(q + sq / (sq - sr) * (r - q))
    if len(kept) < 3:
        return 0.0, 1.0
    left = float(min(1.0, abs(polygon_area(kept)) / abs(polygon_area(list(T)))))
    return left, 1.0 - left


def signed_gap(p, a, b):
    """Exercise 10.3: ``(sigma, d sigma / d p)``, the gap along the outward normal (material on the left)."""
    p, a, b = (np.asarray(v, dtype=float) for v in (p, a, b))
    e = b - a
    n = np.array([e[1], -e[0]]) / np.hypot(*e)
    return float(n @ (p - a)), n


def skin_energy(sigma, distance, stiffness, length):
    """Exercise 10.4: the point's barrier energy and its derivative in the gap (the contact term's ``beta``)."""
    zeta = 1.0 + float(sigma) / float(distance)
    b0, b1, _ = barrier(zeta)
    scale = float(stiffness) * float(length)
    return scale * float(distance) * float(b0), scale * float(b1)


def deformation_gradient_tet(X_nodes, x_nodes) -> np.ndarray:
    """Exercise 11.1: ``F[i, j] = dx_i/dX_j`` of one linear tetrahedron: ``F = sum_a x_a (grad N_a)^T`` (= ``D_s
    D_m^-1``, the edge vectors)."""
    return _deformation_gradient(X_nodes, x_nodes, 3)


def neo_hookean_stress_3d(F, lam, mu) -> np.ndarray:
    """Exercise 11.2: ``P = mu F + (lam ln J - mu) F^-T`` for one 3x3 ``F``."""
    return NeoHookean(lam, mu).stress(_shaped("F", F, (3, 3)))
