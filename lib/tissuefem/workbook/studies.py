"""Reusable studies of chapters 3 and 4, and the reference answers of their exercises.

Chapter 3 (kinematics, 2D linear elasticity)
    :func:`rotation`, :func:`bending_map` / :func:`bending_gradient` (a smooth
    example deformation with its exact ``F``), :func:`displacement_from_map`
    (the nodal displacement vector of a map on a mesh),
    :func:`rigid_rotation_response` (energy and stress of ``F = R(theta)``) and
    :func:`rotated_block` (a block whose left edge is turned rigidly).

Chapter 4 (2D Neo-Hookean quasistatics)
    :func:`block_problem` (the tissue block stretched and sheared by two
    handles), :class:`QuadratureAssembler` (vectorised assembly for P2, the
    counterpart of :class:`tissuefem.assembly.P1Assembler`),
    :func:`relative_l2_error` and :func:`cost_accuracy_study`, the first
    measurement of what accuracy costs in time, with :data:`RECORDED_COST_ACCURACY`
    (one recorded run, for the deterministic lecture figure).

Reference answers of the exercises (``chapters/exercises/ch03.py``, ``ch04.py``)
    :func:`lame_from_young`, :func:`deformation_gradient_p1`,
    :func:`linear_elastic_stress_2d`, :func:`neo_hookean_energy_2d`,
    :func:`neo_hookean_stress_2d`, :func:`element_forces_p1`.

Index convention as everywhere in the package: ``F[i, j] = d phi_i / d X_j``.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import Basis, ElementVector

from ..engine.materials import LinearElastic, Material, NeoHookean
from ..engine.meshes import rectangle
from .bench.common import median_time
from ..engine.parameters import lame_parameters
from ..engine.quasistatic import Handle, QuasistaticProblem, QuasistaticResult

__all__ = [
    "rotation",
    "bending_map",
    "bending_gradient",
    "displacement_from_map",
    "rigid_rotation_response",
    "rotated_block",
    "BLOCK_HANDLE",
    "block_problem",
    "handle_force",
    "QuadratureAssembler",
    "relative_l2_error",
    "newton_iteration_time",
    "cost_accuracy_study",
    "format_cost_accuracy",
    "RECORDED_COST_ACCURACY",
    "lame_from_young",
    "deformation_gradient_p1",
    "linear_elastic_stress_2d",
    "neo_hookean_energy_2d",
    "neo_hookean_stress_2d",
    "element_forces_p1",
]


def _count(name, value) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def _sizes(name, values) -> tuple[int, ...]:
    try:
        values = tuple(values)
    except TypeError:
        raise ValueError(f"{name} must be a sequence of positive integers, got {values!r}") from None
    return tuple(_count(name, v) for v in values)


# =============================================================================
# chapter 3: kinematics
# =============================================================================

def rotation(theta) -> np.ndarray:
    """The rotation ``R(theta) = [[cos, -sin], [sin, cos]]``; shape ``[2, 2, *theta.shape]``.

    ``theta`` in radians, counter-clockwise.
    """
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


# The example deformation of chapter 3 and of the kinematics figure: the block
# [0, 2] x [0, 1] bent into an arch around the centre C below it. Material lines
# X = const become rays, Y = const become circular arcs of radius r(Y).
_BEND_CENTRE = np.array([4.3, -2.3])
_BEND_ANGLE = 0.35  # a: radians of arc per unit length of X
_BEND_RADIUS = 2.6  # r0: radius of the arc Y = 0
_BEND_THICKNESS = 1.15  # b: radial length of a unit of Y (a 15 % stretch across)


def bending_map(X) -> np.ndarray:
    """The example deformation ``x = phi(X)`` of chapter 3: a block bent into an arch.

    With ``theta = a (X - 1)`` and ``r = r0 + b Y``,
    ``phi(X, Y) = C + r (sin theta, cos theta)``. ``X`` is shaped ``(2, ...)``;
    returns the same shape. The bottom edge (``Y = 0``, radius ``r0``) is
    shortened, the top edge stretched; ``J = a b r > 0`` everywhere.
    """
    X = np.asarray(X, dtype=float)
    theta = _BEND_ANGLE * (X[0] - 1.0)
    r = _BEND_RADIUS + _BEND_THICKNESS * X[1]
    return np.stack([_BEND_CENTRE[0] + r * np.sin(theta), _BEND_CENTRE[1] + r * np.cos(theta)])


def bending_gradient(X) -> np.ndarray:
    """The exact deformation gradient of :func:`bending_map`, ``F[i, j] = d phi_i / d X_j``.

    ``d theta/dX = a`` and ``dr/dY = b`` give
    ``F = [[a r cos theta, b sin theta], [-a r sin theta, b cos theta]]`` and
    ``J = det F = a b r``. Shape ``[2, 2, *X.shape[1:]]``.
    """
    X = np.asarray(X, dtype=float)
    theta = _BEND_ANGLE * (X[0] - 1.0)
    r = _BEND_RADIUS + _BEND_THICKNESS * X[1]
    a, b = _BEND_ANGLE, _BEND_THICKNESS
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[a * r * c, b * s], [-a * r * s, b * c]])


def displacement_from_map(mesh, phi) -> np.ndarray:
    """The P1 nodal displacement vector ``u = phi(X) - X`` of a map, in scikit-fem's dof order.

    Node ``n`` carries the dofs ``2 n`` (x) and ``2 n + 1`` (y), the ordering of
    ``ElementVector(ElementTriP1())`` and of :class:`~tissuefem.assembly.P1Assembler`.
    ``phi`` maps ``(2, n)`` reference points to ``(2, n)`` deformed points.
    """
    X = np.asarray(mesh.p, dtype=float)
    x = np.asarray(phi(X), dtype=float)
    if x.shape != X.shape:
        raise ValueError(f"phi must map (2, n) points to (2, n) points, got shape {x.shape} for {X.shape}")
    return (x - X).T.reshape(-1)


def rigid_rotation_response(material: Material, angles) -> dict:
    """Energy density and stress of a rigid rotation ``F = R(theta)`` for each angle (radians).

    Returns ``{"angle", "energy", "stress_norm"}`` (arrays shaped like
    ``angles``); ``stress_norm`` is the Frobenius norm ``|P|``. A frame
    indifferent model gives zero for both; linear elasticity gives
    ``eps = (cos theta - 1) I``, hence ``Psi = 2 (lam + mu)(1 - cos theta)^2``
    and ``P = 2 (lam + mu)(cos theta - 1) I``.
    """
    angles = np.asarray(angles, dtype=float)
    R = rotation(angles.reshape(-1))
    energy = np.asarray(material.energy(R)).reshape(angles.shape)
    P = material.stress(R)
    stress_norm = np.sqrt(np.einsum("ij...,ij...->...", P, P)).reshape(angles.shape)
    return {"angle": angles, "energy": energy, "stress_norm": stress_norm}


def rotated_block(material: Material, theta, n: int = 8, width: float = 1.0, height: float = 1.0):
    """Quasistatic equilibrium of a block whose left edge is turned rigidly by ``theta``.

    The left edge is clamped to a wall that rotates by ``theta`` (radians)
    about the edge's midpoint; the other edges are free. A frame-indifferent
    model answers with a rigid rotation of the whole block (zero energy);
    linear elasticity, which only knows infinitesimal rotations, strains the
    block and changes its area. The nonlinear solve turns the wall in steps of
    at most 15 degrees. Returns ``(problem, result)``.
    """
    n = _count("n", n)
    try:
        theta = float(theta)
    except (TypeError, ValueError):
        raise ValueError(f"theta must be an angle in radians, got {theta!r}") from None
    if not math.isfinite(theta):
        raise ValueError(f"theta must be finite, got {theta!r}")
    mesh = rectangle(width, height, max(1, round(n * width / height)), n)
    R = rotation(theta)
    pivot = np.array([[0.0], [0.5 * height]])

    def wall(X):
        return pivot + R @ (X - pivot)

    handle = Handle("left", wall)
    problem = QuasistaticProblem(mesh, material, handles=[handle])
    if isinstance(material, LinearElastic):  # linear: one Newton step, whatever the angle
        return problem, problem.solve()
    # Ramp the *angle*: load stepping ramps the handle's displacement linearly, which for a
    # large turn squeezes the edge through shorter (for 180 degrees: zero-length) segments.
    steps = max(1, math.ceil(abs(theta) / (np.pi / 12)))
    u, history = None, []
    for k in range(1, steps + 1):
        Rk = rotation(theta * k / steps)
        handle.move(lambda X, Rk=Rk: pivot + Rk @ (X - pivot))
        result = problem.solve(u0=u)
        history += result.steps
        if not result.converged:
            break
        u = result.u
    handle.move(wall)
    return problem, QuasistaticResult(result.u, result.converged, history)


# =============================================================================
# chapter 4: the stretched and sheared tissue block
# =============================================================================

#: The default handle motion of chapter 4's block [0, 2] x [0, 1]: the right edge moves by (0.6, 0.4).
BLOCK_HANDLE = (0.6, 0.4)


def block_problem(n: int = 8, order: int = 1, material: Material | None = None, handle=BLOCK_HANDLE,
                  width: float = 2.0, height: float = 1.0, assembly: str = "fast") -> QuasistaticProblem:
    """Chapter 4's tissue block: ``[0, width] x [0, height]``, left edge fixed, right edge moved by ``handle``.

    The mesh is :func:`tissuefem.meshes.rectangle` with ``n`` cells across
    the height (cell size ``h = height / n``) and square cells. ``material``
    defaults to ``NeoHookean.from_young(1000, 0.3)``. ``assembly="fast"``
    uses :class:`~tissuefem.assembly.P1Assembler` for P1 and
    :class:`QuadratureAssembler` for P2; ``"forms"`` the scikit-fem forms.
    """
    n = _count("n", n)
    if material is None:
        material = NeoHookean.from_young(1000.0, 0.3)
    mesh = rectangle(width, height, max(1, round(n * width / height)), n)
    problem = QuasistaticProblem(mesh, material, order=order, assembly=assembly,
                                 handles=[Handle("left"), Handle("right", handle)])
    if order == 2 and assembly == "fast":
        # QuasistaticProblem takes its energy, residual and tangent from `assembler` when set
        problem.assembler = QuadratureAssembler(problem.basis, material)
    return problem


def handle_force(problem: QuasistaticProblem, u, boundary: str) -> np.ndarray:
    """The resultant force ``(f1, f2)`` a handle on ``boundary`` exerts on the body at equilibrium.

    At a prescribed dof the internal force ``q_a(u) = int grad(v_a) : P dX`` is
    not balanced by a load but by the handle, so the handle's force is the sum
    of ``q - f_ext`` over the boundary's dofs, per component. (Force per unit
    thickness in plane strain.) This is what a haptic device would render.
    """
    if problem.mesh.boundaries is None or boundary not in problem.mesh.boundaries:
        raise ValueError(f"boundary {boundary!r} is not a named boundary of the mesh")
    dofs = np.asarray(problem.basis.get_dofs(boundary).all(), dtype=int)
    q = problem.internal_force(u) - problem.external
    return np.array([q[dofs[problem.component[dofs] == i]].sum() for i in range(2)])


class QuadratureAssembler:
    """Vectorised energy, residual and tangent for a vector Lagrange basis on triangles (P1, P2).

    The same sums as the scikit-fem forms of :mod:`tissuefem.forms`, done at
    once for every element and quadrature point instead of once per pair of
    local basis functions: with the scalar shape functions ``N_a`` of the
    element and the quadrature weights ``dx`` (weight times Jacobian),

        F_ij      = d_ij + sum_a u_ai dN_a/dX_j                     (per element and point)
        E         = sum_e,q Psi(F) dx
        r_ai      = sum_e,q P_ij dN_a/dX_j dx
        K_ai,bk   = sum_e,q A_ijkl dN_a/dX_j dN_b/dX_l dx

    scattered into a sparsity pattern computed once (like ``P1Assembler``).
    For P1 :class:`~tissuefem.assembly.P1Assembler` is faster still (one
    point per element); this class is what makes P2 affordable.

    Parameters
    ----------
    basis
        ``Basis(mesh, ElementVector(ElementTriPk()))``; its quadrature is used.
        Local vector function ``2 a + i`` is ``N_a e_i`` (scikit-fem's layout).
    material
        A material of :mod:`tissuefem.materials`.
    """

    def __init__(self, basis, material: Material):
        if not isinstance(getattr(basis, "elem", None), ElementVector):
            raise ValueError(f"basis must be a scikit-fem Basis with an ElementVector element, got {basis!r}")
        self.basis, self.material = basis, material
        nloc = len(basis.basis) // 2
        self.n_local = nloc
        # grad N_a: component 0 of the vector function N_a e_0
        self._G = np.array([basis.basis[2 * a][0].grad[0] for a in range(nloc)])  # (nloc, 2, nel, nq)
        self._dx = basis.dx  # (nel, nq)
        self._GW = self._G * self._dx
        dofs = np.asarray(basis.element_dofs, dtype=np.int64)  # (2 nloc, nel), row 2 a + i
        nel, n = dofs.shape[1], basis.N
        self.n_dofs = n
        self._dofs = dofs
        self._dofs_flat = dofs.reshape(-1)
        rows = np.broadcast_to(dofs[:, None, :], (2 * nloc, 2 * nloc, nel)).reshape(-1)
        cols = np.broadcast_to(dofs[None, :, :], (2 * nloc, 2 * nloc, nel)).reshape(-1)
        keys, inverse = np.unique(rows * n + cols, return_inverse=True)
        self.nnz = keys.size
        self._indices = (keys % n).astype(np.int32)
        self._indptr = np.concatenate([[0], np.cumsum(np.bincount(keys // n, minlength=n))]).astype(np.int32)
        self._scatter = inverse.reshape(-1)

    @property
    def indptr(self) -> np.ndarray:
        """The fixed CSR row pointer of the tangent (as :class:`~tissuefem.assembly.P1Assembler`'s)."""
        return self._indptr

    @property
    def indices(self) -> np.ndarray:
        """The fixed CSR column indices of the tangent; with :attr:`indptr`, what the real-time solver condenses."""
        return self._indices

    def deformation_gradient(self, u) -> np.ndarray:
        """``F = I + grad u`` at every element and quadrature point, shaped ``[2, 2, nel, nq]``."""
        u = np.asarray(u, dtype=float)
        if u.shape != (self.n_dofs,):
            raise ValueError(f"u must have shape ({self.n_dofs},), got {u.shape}")
        ue = u[self._dofs].reshape(self.n_local, 2, -1)
        F = np.einsum("aie,ajeq->ijeq", ue, self._G)
        F[0, 0] += 1.0
        F[1, 1] += 1.0
        return F

    def energy(self, u) -> float:
        """``sum Psi(F) dx`` (NaN where the material is, e.g. the log model at ``J <= 0``)."""
        return float(np.sum(self.material.energy(self.deformation_gradient(u)) * self._dx))

    def residual(self, u) -> np.ndarray:
        """The internal force vector, the gradient of :meth:`energy`."""
        P = self.material.stress(self.deformation_gradient(u))
        r = np.einsum("ijeq,ajeq->aie", P, self._GW)
        return np.bincount(self._dofs_flat, weights=r.reshape(-1), minlength=self.n_dofs)

    def tangent(self, u) -> sp.csr_matrix:
        """The tangent stiffness (Hessian of :meth:`energy`) as a CSR matrix."""
        A = self.material.tangent(self.deformation_gradient(u))
        AG = np.einsum("ijkleq,ajeq->aikleq", A, self._GW)
        K = np.einsum("aikleq,bleq->aibke", AG, self._G)
        data = np.bincount(self._scatter, weights=K.reshape(-1), minlength=self.nnz)
        return sp.csr_matrix((data, self._indices, self._indptr), shape=(self.n_dofs, self.n_dofs))


def _evaluate(basis, u, points, chunk: int = 400) -> np.ndarray:
    """Values ``(2, n)`` of the finite element field ``u`` at arbitrary points ``(2, n)``.

    scikit-fem's point location compares every point of a call with every
    candidate element of the call (memory grows like points^2), so the points
    are fed in chunks.
    """
    f = basis.interpolator(u)
    return np.concatenate([f(points[:, i:i + chunk]) for i in range(0, points.shape[1], chunk)], axis=1)


def relative_l2_error(problem: QuasistaticProblem, u, reference: QuasistaticProblem, u_reference,
                      intorder: int = 4) -> float:
    """``||u - u_ref||_L2 / ||u_ref||_L2`` over the body, by quadrature on ``problem``'s mesh.

    ``u_ref`` (on another, finer mesh) is evaluated at ``problem``'s quadrature
    points by point location; ``intorder`` is the quadrature degree (4 is ample
    for P1 and P2 differences).
    """
    basis = Basis(problem.mesh, problem.basis.elem, intorder=intorder)
    uh = np.asarray(basis.interpolate(u))  # (2, nel, nq)
    x = basis.mapping.F(basis.quadrature[0])  # quadrature points (2, nel, nq)
    ur = _evaluate(reference.basis, u_reference, x.reshape(2, -1)).reshape(uh.shape)
    err = np.sum(np.sum((uh - ur) ** 2, axis=0) * basis.dx)
    norm = np.sum(np.sum(ur**2, axis=0) * basis.dx)
    return float(np.sqrt(err / norm))


def newton_iteration_time(problem: QuasistaticProblem, u, repeats: int = 3) -> float:
    """Median time (ms) of one Newton iteration at ``u``: residual, tangent, factorization, solve.

    The linear solve is SuperLU with the ``MMD_AT_PLUS_A`` ordering, the one
    :func:`tissuefem.newton.newton_solve` uses by default. One iteration is the
    least a real-time frame can do.
    """
    fixed, _ = problem.prescribed()
    free = np.setdiff1d(np.arange(problem.basis.N), fixed)

    def iteration():
        r = problem.internal_force(u)
        K = problem.tangent(u)
        spla.splu(sp.csc_matrix(K[free][:, free]), permc_spec="MMD_AT_PLUS_A").solve(-r[free])

    return median_time(iteration, repeats)


def cost_accuracy_study(p1_sizes=(2, 4, 8, 16), p2_sizes=(1, 2, 4, 8), reference_size: int = 32,
                        repeats: int = 3, load_steps: int = 1, material: Material | None = None,
                        handle=BLOCK_HANDLE, progress=None) -> list[dict]:
    """Error and solve time of chapter 4's block, P1 against P2, over several meshes.

    Every mesh size ``n`` (cells across the height, ``h = 1/n``) is solved by
    :func:`block_problem` with ``load_steps`` load steps from rest and compared
    with a reference: P2 on ``n = reference_size`` (which should be several
    times finer than every mesh of the sweep). The error measures are

    * ``L2``: the relative ``L2`` norm of the displacement error,
      :func:`relative_l2_error`, the main measure;
    * ``energy``: the relative error of the stored energy ``int Psi dX``; with
      prescribed edges it falls like the square of the energy-norm error.

    Times are medians over ``repeats`` runs after one warm-up
    (``time.perf_counter``): ``solve_ms`` for the whole quasistatic solve
    from rest, ``iteration_ms`` for one Newton iteration at the solution
    (:func:`newton_iteration_time`). Timings depend on the machine and its
    load: read them, compare within one run, never assert them.

    Returns one dict per mesh with ``order, n, h, triangles, dofs, L2,
    energy, rate_L2`` (observed against the previous, coarser mesh of the
    same order; NaN on the first), ``newton_iterations, solve_ms,
    iteration_ms`` (print them with :func:`format_cost_accuracy`). The
    reference itself is not a row.
    """
    p1_sizes, p2_sizes = _sizes("p1_sizes", p1_sizes), _sizes("p2_sizes", p2_sizes)
    reference_size, repeats = _count("reference_size", reference_size), _count("repeats", repeats)
    load_steps = _count("load_steps", load_steps)
    if max(p1_sizes + p2_sizes, default=0) >= reference_size:
        raise ValueError(f"reference_size ({reference_size}) must exceed every size of the sweep "
                         f"(largest {max(p1_sizes + p2_sizes)})")
    if material is None:
        material = NeoHookean.from_young(1000.0, 0.3)

    reference = block_problem(reference_size, 2, material, handle)
    ref = reference.solve(load_steps=load_steps)
    if not ref.converged:
        raise RuntimeError(f"the reference solve did not converge ({ref.status})")
    ref_energy = reference.strain_energy(ref.u)
    if progress:
        progress(f"reference: P2, n = {reference_size}, {reference.basis.N} dofs")

    rows = []
    for order, sizes in ((1, p1_sizes), (2, p2_sizes)):
        previous = None
        for n in sizes:
            problem = block_problem(n, order, material, handle)
            result = problem.solve(load_steps=load_steps)
            if not result.converged:
                raise RuntimeError(f"P{order} on n = {n} did not converge ({result.status})")
            row = {
                "order": order,
                "n": n,
                "h": 1.0 / n,
                "triangles": int(problem.mesh.t.shape[1]),
                "dofs": int(problem.basis.N),
                "L2": relative_l2_error(problem, result.u, reference, ref.u),
                "energy": abs(problem.strain_energy(result.u) - ref_energy) / abs(ref_energy),
                "rate_L2": float("nan"),
                "newton_iterations": result.newton_iterations,
                "solve_ms": median_time(lambda: problem.solve(load_steps=load_steps), repeats),
                "iteration_ms": newton_iteration_time(problem, result.u, repeats),
            }
            if previous is not None:
                row["rate_L2"] = math.log(previous["L2"] / row["L2"]) / math.log(previous["h"] / row["h"])
            rows.append(row)
            previous = row
            if progress:
                progress(f"P{order}, n = {n}: L2 error {row['L2']:.2e}, solve {row['solve_ms']:.1f} ms")
    return rows


_TABLE = [
    ("order", "P", "{:d}"),
    ("n", "n", "{:d}"),
    ("triangles", "triangles", "{:d}"),
    ("dofs", "dofs", "{:d}"),
    ("L2", "L2 error", "{:.2e}"),
    ("rate_L2", "rate", "{:.2f}"),
    ("energy", "energy error", "{:.2e}"),
    ("newton_iterations", "Newton its", "{:d}"),
    ("solve_ms", "solve [ms]", "{:.1f}"),
    ("iteration_ms", "1 iteration [ms]", "{:.2f}"),
]


def format_cost_accuracy(rows) -> str:
    """The rows of :func:`cost_accuracy_study` as a plain-text table."""
    widths = [max(len(title), 9) for _, title, _ in _TABLE]
    lines = ["  ".join(f"{title:>{w}}" for (_, title, _), w in zip(_TABLE, widths))]
    for row in rows:
        cells = []
        for (key, _, fmt), w in zip(_TABLE, widths):
            value = row.get(key)
            text = "-" if value is None or (isinstance(value, float) and not math.isfinite(value)) else fmt.format(value)
            cells.append(f"{text:>{w}}")
        lines.append("  ".join(cells))
    return "\n".join(lines)


# =============================================================================
# recorded measurements (for the deterministic lecture figure)
# =============================================================================

_RECORDED_COLUMNS = ("order", "n", "triangles", "dofs", "L2", "energy", "rate_L2", "newton_iterations",
                     "solve_ms", "iteration_ms")
_NAN = float("nan")
_RECORDED = [
    # P   n  tri.  dofs  L2 error    energy err   rate its  solve ms  1 it. ms
    (1,  2,   16,   30, 2.8574e-02, 3.9018e-02,  _NAN, 3,   2.84,  0.57),
    (1,  4,   64,   90, 9.1950e-03, 1.3442e-02, 1.636, 3,   3.20,  0.72),
    (1,  8,  256,  306, 2.8753e-03, 4.4562e-03, 1.677, 3,   5.61,  1.15),
    (1, 16, 1024, 1122, 9.1687e-04, 1.4731e-03, 1.649, 3,  14.03,  2.87),
    (1, 32, 4096, 4290, 2.8921e-04, 4.8143e-04, 1.665, 3,  73.94, 14.48),
    (2,  1,    4,   30, 2.0210e-02, 1.8730e-02,  _NAN, 3,   3.47,  0.55),
    (2,  2,   16,   90, 4.8940e-03, 4.4342e-03, 2.046, 3,   4.03,  0.73),
    (2,  4,   64,  306, 1.2681e-03, 1.3299e-03, 1.948, 3,   7.80,  1.54),
    (2,  8,  256, 1122, 3.6456e-04, 4.2239e-04, 1.798, 3,  24.75,  5.29),
    (2, 16, 1024, 4290, 1.1132e-04, 1.2852e-04, 1.711, 4,  95.85, 16.96),
]
#: One run of ``cost_accuracy_study(p1_sizes=(2, 4, 8, 16, 32), p2_sizes=(1, 2, 4, 8, 16),
#: reference_size=64, repeats=5)`` (one load step) on a 2-core Linux machine (Python 3.11, numpy 2.4,
#: scipy 1.17, scikit-fem 12.0.2). The errors are reproducible to the digits shown;
#: the times are one machine's medians, to be read, not asserted.
RECORDED_COST_ACCURACY: list[dict] = [dict(zip(_RECORDED_COLUMNS, row), h=1.0 / row[1]) for row in _RECORDED]


# =============================================================================
# reference answers of the chapter 3-4 exercises
# =============================================================================

def _single_F(F) -> np.ndarray:
    F = np.asarray(F, dtype=float)
    if F.shape != (2, 2):
        raise ValueError(f"F must be a single 2x2 matrix, got shape {F.shape}")
    return F


def lame_from_young(E, nu, plane: str = "strain") -> tuple[float, float]:
    """Exercise 3.1: ``(lam, mu)`` from Young's modulus and Poisson's ratio (plane strain or stress).

    The same as :func:`tissuefem.lame_parameters`.
    """
    return lame_parameters(E, nu, plane)


def _vertices(name, V) -> np.ndarray:
    V = np.asarray(V, dtype=float)
    if V.shape != (2, 3):
        raise ValueError(f"{name} must be shaped (2, 3) (column a = vertex a), got shape {V.shape}")
    return V


def deformation_gradient_p1(X_nodes, x_nodes) -> np.ndarray:
    """Exercise 3.2: ``F`` of one linear triangle, ``F[i, j] = dx_i/dX_j``, from its vertex positions.

    ``X_nodes`` and ``x_nodes`` are ``(2, 3)``: column ``a`` is vertex ``a`` in
    the reference and in the deformed configuration. The P1 map is affine, so
    it sends each edge vector ``X_a - X_0`` to ``x_a - x_0``:
    ``F D_m = D_s`` with ``D_m = [X_1 - X_0, X_2 - X_0]`` and
    ``D_s = [x_1 - x_0, x_2 - x_0]``, hence ``F = D_s D_m^-1``.
    """
    X, x = _vertices("X_nodes", X_nodes), _vertices("x_nodes", x_nodes)
    Dm = X[:, 1:] - X[:, :1]
    Ds = x[:, 1:] - x[:, :1]
    if abs(np.linalg.det(Dm)) <= 1e-14 * max(1.0, float(np.abs(Dm).max()) ** 2):
        raise ValueError("X_nodes is a degenerate (zero-area) triangle")
    return Ds @ np.linalg.inv(Dm)


def linear_elastic_stress_2d(F, lam, mu) -> np.ndarray:
    """Exercise 3.3: ``P = 2 mu eps + lam tr(eps) I`` with ``eps = (F + F^T)/2 - I``, one 2x2 ``F``."""
    return LinearElastic(lam, mu).stress(_single_F(F))


def neo_hookean_energy_2d(F, lam, mu) -> float:
    """Exercise 4.1: ``Psi = mu/2 (F:F - 2) - mu ln J + lam/2 (ln J)^2`` for one 2x2 ``F`` (``J > 0``)."""
    return float(NeoHookean(lam, mu).energy(_single_F(F)))


def neo_hookean_stress_2d(F, lam, mu) -> np.ndarray:
    """Exercise 4.2: ``P = mu F + (lam ln J - mu) F^-T`` for one 2x2 ``F`` (``J > 0``)."""
    return NeoHookean(lam, mu).stress(_single_F(F))


def element_forces_p1(X_nodes, x_nodes, lam, mu) -> np.ndarray:
    """Exercise 4.3: the Neo-Hookean internal forces on the 3 vertices of one linear triangle.

    ``f[:, a] = d(A Psi(F)) / d x_a`` (``A`` the reference area): the
    triangle's contribution to the notes' ``int w_i,j P_ij dX`` with
    ``w = N_a e_i``, i.e. ``f_ia = A P_ij dN_a/dX_j``. Shape ``(2, 3)``, same
    vertex layout as :func:`deformation_gradient_p1`.
    """
    X = _vertices("X_nodes", X_nodes)
    F = deformation_gradient_p1(X, x_nodes)
    Dm = X[:, 1:] - X[:, :1]
    area = 0.5 * abs(np.linalg.det(Dm))
    grad12 = np.linalg.inv(Dm)  # row a-1 is grad N_a for a = 1, 2 (since N_a(X_b) = d_ab)
    grads = np.vstack([-grad12.sum(axis=0), grad12])  # (3, 2): grads[a, j] = dN_a/dX_j
    P = NeoHookean(lam, mu).stress(F)
    return area * P @ grads.T
