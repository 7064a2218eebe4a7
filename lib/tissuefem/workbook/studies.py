"""Studies of chapters 3 (kinematics: :func:`bending_map`, :func:`rotated_block`) and 4 (the block:
:func:`block_model`, :func:`cost_accuracy_study`). As everywhere, ``F[i, j] = d phi_i / d X_j``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..engine.constants import TISSUE_E, TISSUE_NU
from ..engine.linsolve import LinearSolver
from ..engine.materials import LinearElastic, Material, NeoHookean, rotation
from ..engine.meshes import rectangle
from ..engine.model import Handle, Model
from ..engine.parameters import check_count as _count, check_list, check_real
from ..engine.stepping import StaticResult, solve
from .measure import median_time, relative_l2_error
from .tables import markdown_table

__all__ = [
    "rotation", "bending_map", "bending_gradient", "displacement_from_map", "rigid_rotation_response",
    "rotated_block", "BLOCK_HANDLE", "block_model", "stretched_block", "handle_force", "newton_iteration_time",
    "cost_accuracy_study", "cost_accuracy_markdown", "RECORDED_COST_ACCURACY",
]


def _sizes(name, values) -> tuple[int, ...]:
    return tuple(_count(name, v) for v in check_list(name, values, "positive integers"))


# chapter 3's example deformation (:func:`bending_map`): the block [0, 2] x [0, 1] bent around C below it
_BEND_CENTRE = np.array([4.3, -2.3])
_BEND_ANGLE = 0.35  # a: radians of arc per unit length of X
_BEND_RADIUS = 2.6  # r0: radius of the arc Y = 0
_BEND_THICKNESS = 1.15  # b: radial length of a unit of Y (a 15 % stretch across)


def bending_map(X) -> np.ndarray:
    """Chapter 3's example ``x = phi(X)``, a block bent into an arch: ``theta = a (X - 1)``, ``r = r0 + b Y``,
    ``phi(X, Y) = C + r (sin theta, cos theta)`` (lines X = const become rays, Y = const arcs; ``J = a b r >
    0``). ``X``: ``(2, ...)``, as the result."""
    X = np.asarray(X, dtype=float)
    theta = _BEND_ANGLE * (X[0] - 1.0)
    r = _BEND_RADIUS + _BEND_THICKNESS * X[1]
    return np.stack([_BEND_CENTRE[0] + r * np.sin(theta), _BEND_CENTRE[1] + r * np.cos(theta)])


def bending_gradient(X) -> np.ndarray:
    """The exact ``F`` of :func:`bending_map`: ``[[a r cos theta, b sin theta], [-a r sin theta, b cos
    theta]]`` (``J = a b r``), shaped ``[2, 2, *X.shape[1:]]``."""
    X = np.asarray(X, dtype=float)
    a, b = _BEND_ANGLE, _BEND_THICKNESS
    r = _BEND_RADIUS + b * X[1]
    c, s = np.cos(a * (X[0] - 1.0)), np.sin(a * (X[0] - 1.0))
    return np.array([[a * r * c, b * s], [-a * r * s, b * c]])


def displacement_from_map(mesh, phi) -> np.ndarray:
    """The P1 nodal displacements ``u = phi(X) - X`` of a map ``(2, n) -> (2, n)``, in scikit-fem's dof order
    (node ``n``: dofs ``2 n`` and ``2 n + 1``)."""
    X = np.asarray(mesh.p, dtype=float)
    x = np.asarray(phi(X), dtype=float)
    if x.shape != X.shape:
        raise ValueError(f"phi must map (2, n) points to (2, n) points, got shape {x.shape} for {X.shape}")
    return (x - X).T.reshape(-1)


def rigid_rotation_response(material: Material, angles) -> dict:
    """``{"angle", "energy", "stress_norm"}`` (Frobenius) at ``F = R(theta)`` for each angle (radians): zero
    for a frame-indifferent model; linear elasticity has ``eps = (cos theta - 1) I``, ``Psi = 2 (lam + mu)(1 -
    cos theta)^2``, ``P = 2 (lam + mu)(cos theta - 1) I``."""
    angles = np.asarray(angles, dtype=float)
    R = rotation(angles.reshape(-1))
    energy = np.asarray(material.energy(R)).reshape(angles.shape)
    P = material.stress(R)
    stress_norm = np.sqrt(np.einsum("ij...,ij...->...", P, P)).reshape(angles.shape)
    return {"angle": angles, "energy": energy, "stress_norm": stress_norm}


def rotated_block(material: Material, theta, n: int = 8, width: float = 1.0, height: float = 1.0):
    """``(model, result)``: the equilibrium of a block whose left edge is clamped to a wall turned by
    ``theta`` (radians) about its midpoint, the rest free; rigid for a frame-indifferent model."""
    n, theta = _count("n", n), check_real("theta", theta)
    mesh = rectangle(width, height, max(1, round(n * width / height)), n)
    pivot = np.array([[0.0], [0.5 * height]])

    def wall(angle):  # the clamped edge's map: a turn by ``angle`` about its midpoint
        R = rotation(angle)
        return lambda X: pivot + R @ (X - pivot)

    handle = Handle("left", wall(theta))
    model = Model(mesh, material, handles=[handle])
    if isinstance(material, LinearElastic):  # linear: one Newton step, whatever the angle
        return model, solve(model)
    # ramp the angle: a linear ramp of the displacement would squeeze the edge (to zero length at 180 degrees)
    steps = max(1, math.ceil(abs(theta) / (np.pi / 12)))
    u, history = None, []
    for k in range(1, steps + 1):
        handle.move(wall(theta * k / steps))
        result = solve(model, u0=u)
        history += result.steps
        if not result.converged:
            break
        u = result.u
    handle.move(wall(theta))
    return model, StaticResult(result.u, result.converged, history)


#: The default handle motion of chapter 4's block [0, 2] x [0, 1]: the right edge moves by (0.6, 0.4).
BLOCK_HANDLE = (0.6, 0.4)


def block_model(n: int = 8, order: int = 1, material: Material | None = None, handle=BLOCK_HANDLE,
                width: float = 2.0, height: float = 1.0, assembly: str = "fast") -> Model:
    """Chapter 4's block ``[0, width] x [0, height]`` of square cells, ``n`` across the height, left edge
    fixed, right edge moved by ``handle``; Neo-Hookean (E = 1000, nu = 0.3) by default; ``assembly="forms"``:
    the readable scikit-fem forms (slow)."""
    n = _count("n", n)
    material = NeoHookean.from_young(TISSUE_E, TISSUE_NU) if material is None else material
    mesh = rectangle(width, height, max(1, round(n * width / height)), n)
    return Model(mesh, material, order=order, assembly=assembly,
                 handles=[Handle("left", name="left"), Handle("right", handle, name="right")])


def stretched_block(n: int = 12):
    """Chapter 4's block (:func:`block_model`, P1, ``n`` cells across the height) at equilibrium: ``(model, u)``."""
    model = block_model(n)
    result = solve(model)
    if not result.converged:
        raise RuntimeError(f"the stretched block did not converge ({result.status})")
    return model, result.u


def handle_force(model: Model, u, boundary: str) -> np.ndarray:
    """The force ``(f1, f2)`` the handle on ``boundary`` exerts on the body at equilibrium
    (:meth:`Model.reaction`, per unit thickness): what a haptic device would render."""
    for h in model.handles:
        if isinstance(h.region, str) and h.region == boundary:
            return model.reaction(u, h)
    raise ValueError(f"boundary {boundary!r}: no handle of the model holds it")


def newton_iteration_time(model: Model, u, repeats: int = 3) -> float:
    """Median ms of a Newton iteration at ``u`` (gradient, tangent, a fresh SuperLU factorization, solve)."""
    fixed, _ = model.prescribed()
    free = np.ones(model.n_dofs, dtype=bool)
    free[fixed] = False
    linear = LinearSolver("direct")

    def iteration():
        g = model.gradient(u)
        A = linear.matrix(lambda: model.hessian(u), free)
        linear.solve(A, -g[free])

    return median_time(iteration, repeats)


def cost_accuracy_study(p1_sizes=(2, 4, 8, 16), p2_sizes=(1, 2, 4, 8), reference_size: int = 32,
                        repeats: int = 3, load_steps: int = 1, material: Material | None = None,
                        handle=BLOCK_HANDLE, progress=None) -> list[dict]:
    """Error and solve time of chapter 4's block, P1 against P2: one dict per ``n`` (``h = 1/n``) with ``L2``,
    the relative displacement error against P2 on ``n = reference_size``, ``energy``, the relative error of
    ``int Psi dX`` (the square of the energy-norm error), ``rate_L2`` from the previous mesh (NaN on the
    first), and the median ``solve_ms`` and ``iteration_ms`` over ``repeats`` (compare within one run, never
    assert them)."""
    p1_sizes, p2_sizes = _sizes("p1_sizes", p1_sizes), _sizes("p2_sizes", p2_sizes)
    reference_size, repeats = _count("reference_size", reference_size), _count("repeats", repeats)
    load_steps = _count("load_steps", load_steps)
    if max(p1_sizes + p2_sizes, default=0) >= reference_size:
        raise ValueError(f"reference_size ({reference_size}) must exceed every size of the sweep "
                         f"(largest {max(p1_sizes + p2_sizes)})")

    reference = block_model(reference_size, 2, material, handle)
    ref = solve(reference, load_steps=load_steps)
    if not ref.converged:
        raise RuntimeError(f"the reference solve did not converge ({ref.status})")
    ref_energy = reference.stored_energy(ref.u)
    if progress:
        progress(f"reference: P2, n = {reference_size}, {reference.basis.N} dofs")

    rows = []
    for order, sizes in ((1, p1_sizes), (2, p2_sizes)):
        previous = None
        for n in sizes:
            problem = block_model(n, order, material, handle)
            result = solve(problem, load_steps=load_steps)
            if not result.converged:
                raise RuntimeError(f"P{order} on n = {n} did not converge ({result.status})")
            row = {"order": order, "n": n, "h": 1.0 / n, "triangles": int(problem.mesh.t.shape[1]),
                   "dofs": int(problem.basis.N), "L2": relative_l2_error(problem, result.u, reference, ref.u),
                   "energy": abs(problem.stored_energy(result.u) - ref_energy) / abs(ref_energy),
                   "rate_L2": float("nan"), "newton_iterations": result.newton_iterations,
                   "solve_ms": median_time(lambda: solve(problem, load_steps=load_steps), repeats),
                   "iteration_ms": newton_iteration_time(problem, result.u, repeats)}
            if previous is not None:
                row["rate_L2"] = math.log(previous["L2"] / row["L2"]) / math.log(previous["h"] / row["h"])
            rows.append(row)
            previous = row
            if progress:
                progress(f"P{order}, n = {n}: L2 error {row['L2']:.2e}, solve {row['solve_ms']:.1f} ms")
    return rows


_TABLE = [("order", "P", "{:d}"), ("n", "n", "{:d}"), ("triangles", "triangles", "{:d}"), ("dofs", "dofs", "{:d}"),
          ("L2", "L2 error", "{:.2e}"), ("rate_L2", "rate", "{:.2f}"), ("energy", "energy error", "{:.2e}"),
          ("newton_iterations", "Newton its", "{:d}"), ("solve_ms", "solve [ms]", "{:.1f}"),
          ("iteration_ms", "1 iteration [ms]", "{:.2f}")]


def cost_accuracy_markdown(rows) -> str:
    """The rows of :func:`cost_accuracy_study` as a Markdown table (for a notebook to render)."""
    return markdown_table(rows, _TABLE)


#: One recorded run of :func:`cost_accuracy_study` (``data/cost_accuracy.json``) for the deterministic lecture
#: figure: its times are one machine's medians, to be read, not asserted.
RECORDED_COST_ACCURACY: list[dict] = [
    {**row, "rate_L2": float("nan") if row["rate_L2"] is None else row["rate_L2"], "h": 1.0 / row["n"]}
    for row in json.loads((Path(__file__).parent / "data" / "cost_accuracy.json").read_text())["rows"]]
