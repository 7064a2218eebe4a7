"""The hard cases of chapter 6: a small block put in a violent state (crushed, collapsed, mirrored, stretched,
dragged) and *released* (a few nodes held, equilibrium solved for), measured against its rest shape. Newton's
steps are capped (``max_step``) so the iterates creep downhill instead of jumping into a fold. The models:
:func:`inversion_models`. Every function takes a mesh of triangles or of tetrahedra (chapter 11's cube:
``block(dim=3)``): the moves are along y, the held nodes those of the bottom (y = 0)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..engine.inversion import ITFClamped, ProjectedTangent
from ..engine.materials import NeoHookean, StableNeoHookean, TaylorNeoHookean
from ..engine.materials import det
from ..engine.meshes import box, rectangle
from ..engine.constants import TISSUE_E, TISSUE_NU
from ..engine.parameters import lame_parameters
from ..engine.model import Handle, Model
from ..engine.realtime import RealtimeSolver
from ..engine.stepping import solve

__all__ = ["inversion_models", "block", "start_states", "ReleaseResult", "release", "crush_and_release",
           "crush_and_release_runs", "crush_in_frames", "edge_matrices", "element_jacobians", "cover_counts",
           "drag_through", "RELEASE_OPTIONS"]

#: Newton options of a release solve: absolute residual tolerance (the start residual is huge,
#: so a relative one would stop early), a step cap and room for the creeping iterations.
RELEASE_OPTIONS = {"atol": 1e-7, "rtol": 1e-12, "max_step": 0.5, "max_iterations": 400}


def inversion_models(E: float = TISSUE_E, nu: float = TISSUE_NU) -> dict:
    """Chapter 6's models (plane strain; on tetrahedra the same Lamé parameters are the 3D ones): ``ln J``
    Neo-Hookean (NaN once inverted), the notes' cubic Taylor variant and stable Neo-Hookean with the projected
    tangent (Teran et al. 2005), ITF-clamped ``ln J``."""
    lam, mu = lame_parameters(E, nu, "strain")
    return {
        "neo-Hookean (ln J)": NeoHookean(lam, mu),
        "Taylor neo-Hookean": ProjectedTangent(TaylorNeoHookean(lam, mu)),
        "stable neo-Hookean": ProjectedTangent(StableNeoHookean(lam, mu)),
        "ITF-clamped neo-Hookean": ITFClamped(NeoHookean(lam, mu)),
    }


def block(n: int = 6, dim: int = 2):
    """The unit block ``[0, 1]^2`` with ``n x n`` cells (``2 n^2`` triangles), or with ``dim=3`` the unit cube
    ``[0, 1]^3`` with ``n x n x n`` cells (``6 n^3`` tetrahedra)."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 (a square of triangles) or 3 (a cube of tetrahedra), got {dim!r}")
    return rectangle(1.0, 1.0, n, n) if dim == 2 else box(1.0, 1.0, 1.0, n, n, n)


def _down(mesh, depth: float) -> tuple:
    """The translation ``depth`` down (along -y) in the mesh's dimension."""
    return (0.0, -float(depth)) + (0.0,) * (mesh.p.shape[0] - 2)


def start_states(mesh) -> dict:
    """Deformed node positions ``(2, n_nodes)`` of the violent start states, by name."""
    X = np.asarray(mesh.p, dtype=float)
    centre = X.mean(axis=1, keepdims=True)

    def scaled(*factors):  # each coordinate times its factor
        return np.asarray(factors, dtype=float)[:, None] * X

    rest = (1.0,) * (X.shape[0] - 2)
    return {
        "mirrored": scaled(1.0, -1.0, *rest),  # every element inverted (reflected about y = 0)
        "collapsed to a point": np.broadcast_to(centre, X.shape).copy(),
        "collapsed to a line": scaled(1.0, *(0.0,) * (X.shape[0] - 1)),  # onto the x axis
        "stretched 10x": scaled(10.0, 1.0, *rest),
        "crushed past flat": scaled(1.0, -0.3, *rest),
    }


@dataclass
class ReleaseResult:
    """Outcome of a release: the final displacement and what the solve did."""

    u: np.ndarray
    converged: bool
    status: str
    iterations: int
    cuts: int  # line-search halvings
    energies: np.ndarray  # total energy after each accepted step
    start_energy: float
    rest_error: float  # ||x - X|| / ||X|| over all nodes
    finite: bool = True
    history: list = field(default_factory=list)

    @property
    def final_energy(self) -> float:
        return float(self.energies[-1]) if self.energies.size else self.start_energy


def release(mesh, material, x_start, held=None, **newton_options) -> ReleaseResult:
    """Release a body from node positions ``x_start``, the ``held`` nodes (default: the bottom edge) at rest;
    a numerical failure is in the status, never raised."""
    X = np.asarray(mesh.p, dtype=float)
    x_start = np.asarray(x_start, dtype=float)
    if x_start.shape != X.shape:
        raise ValueError(f"x_start must have shape {X.shape}, got {x_start.shape}")
    if not np.all(np.isfinite(x_start)):
        raise ValueError("x_start contains non-finite positions")
    held = np.flatnonzero(np.abs(X[1] - X[1].min()) < 1e-9) if held is None else np.asarray(held)
    model = Model(mesh, material, handles=[Handle(held)])
    u0 = model.zeros()
    u0[model.basis.nodal_dofs] = x_start - X
    u0[model.basis.nodal_dofs[:, held]] = 0.0
    options = {**RELEASE_OPTIONS, **newton_options}
    with np.errstate(all="ignore"):
        start_energy = model.stored_energy(u0)
    result = solve(model, u0=u0, **options)
    newton, u = result.steps[-1], result.u
    return ReleaseResult(
        u=u, converged=result.converged, status=result.status, iterations=result.newton_iterations,
        cuts=newton.line_search_cuts, energies=newton.energies, start_energy=float(start_energy),
        rest_error=float(np.linalg.norm(model.positions(u) - X) / np.linalg.norm(X)),
        finite=bool(np.all(np.isfinite(u))), history=newton.history)


def _push_down(model, handle, depth, steps, options, stop):
    """Move ``handle`` down by ``depth`` in ``steps`` solves, each from the last state: the results, the positions
    after each and the last state; with ``stop`` up to the first solve that fails (its state dropped)."""
    u, results, positions = model.zeros(), [], []
    for d in np.linspace(0.0, depth, steps + 1)[1:]:
        handle.move(_down(model.mesh, d))
        results.append(solve(model, u0=u, **options))
        if stop and not results[-1].converged:
            break
        u = results[-1].u
        positions.append(model.positions(u))
    return results, positions, u


def crush_and_release(material, mesh=None, depth: float = 1.3, steps: int = 13, **newton_options) -> dict:
    """Push the top edge (face) down by ``depth`` (1 = flat) in ``steps`` solves, bottom fixed, then release:
    ``frames`` (positions, the released shape last), ``crush`` (the results), ``released``, ``crushed`` (the
    depth reached), ``iterations``, ``cuts``, ``final_energy``."""
    mesh = block() if mesh is None else mesh
    top = Handle("top")
    model = Model(mesh, material, handles=[Handle("bottom"), top])
    options = {**RELEASE_OPTIONS, "rtol": 1e-8, "max_iterations": 100, **newton_options}
    crush, positions, u = _push_down(model, top, depth, steps, options, stop=True)
    released = release(mesh, material, model.positions(u), **newton_options)
    frames = [np.array(mesh.p, dtype=float)] + positions
    frames.append(model.positions(u) if not released.finite else model.positions(released.u))
    return {"frames": frames, "crush": crush, "released": released,
            "crushed": float(np.linspace(0.0, depth, steps + 1)[len(positions)]),
            "iterations": sum(r.newton_iterations for r in crush) + released.iterations,
            "cuts": sum(s.line_search_cuts for r in crush for s in r.steps) + released.cuts,
            "final_energy": released.final_energy}


def drag_through(material, mesh=None, depth: float = 1.6, steps: int = 16, **newton_options) -> dict:
    """Drag the top edge's middle (within 0.2) of a sheet held at its sides down by ``depth`` in ``steps``
    solves, then release: ``positions``, ``drag``, ``released``, ``failed_steps``, ``grab`` (the dragged nodes)."""
    mesh = block() if mesh is None else mesh
    X = np.asarray(mesh.p, dtype=float)
    sides = np.flatnonzero((np.abs(X[0] - X[0].min()) < 1e-9) | (np.abs(X[0] - X[0].max()) < 1e-9))
    grab = np.flatnonzero((np.abs(X[1] - X[1].max()) < 1e-9) & (np.abs(X[0] - X[0].mean()) < 0.2))
    handle = Handle(grab)
    model = Model(mesh, material, handles=[Handle(sides), handle])
    options = {**RELEASE_OPTIONS, "rtol": 1e-8, "max_iterations": 60, **newton_options}
    drag, positions, u = _push_down(model, handle, depth, steps, options, stop=False)
    released = release(mesh, material, model.positions(u), held=sides, **newton_options)
    return {"positions": positions, "drag": drag, "released": released,
            "failed_steps": sum(not r.converged for r in drag), "grab": grab}


def crush_in_frames(material, mesh=None, depth: float = 1.3, steps: int = 13, extra_frames: int = 50,
                    rtol: float = 1e-8, max_iterations: int = 100) -> dict:
    """The crush of :func:`crush_and_release` in real-time frames of at most ``max_iterations`` Newton steps
    (the rest carried over), then up to ``extra_frames`` more: ``x``, ``reached``, ``converged``, ``frames``,
    ``inverted`` (``J <= 0``), ``folded`` (centroids covered twice: :func:`cover_counts`), ``released``."""
    mesh = block() if mesh is None else mesh
    X = np.asarray(mesh.p, dtype=float)
    model = Model(mesh, material, handles=[Handle("bottom", name="bottom"), Handle("top", name="top")])
    solver = RealtimeSolver(model, budget=math.inf, rtol=rtol, max_iterations=max_iterations)
    for d in np.linspace(0.0, depth, steps + 1)[1:]:
        report = solver.frame({"top": _down(mesh, d)})
    frames = int(steps)
    while not report.converged and frames < steps + extra_frames:
        report = solver.frame({"top": _down(mesh, depth)})
        frames += 1
    x = model.positions(solver.u)
    top = np.flatnonzero(np.isclose(X[1], X[1].max()))
    J = element_jacobians(mesh, x)
    return {"x": x, "reached": float(X[1, top].mean() - x[1, top].mean()), "converged": bool(report.converged),
            "frames": frames, "inverted": int(np.sum(J <= 1e-12)), "folded": int(np.sum(cover_counts(mesh, x) > 1)),
            "released": release(mesh, material, x)}


def edge_matrices(mesh, x) -> np.ndarray:
    """The edge vectors ``x_k - x_0`` (``k = 1 ... d``) of every element with its nodes at ``x`` ``(d, n_nodes)``, as
    the columns of ``(d, d, n_elements)``: with ``x = X`` the rest shape's ``D_m``, and then ``F = D_s D_m^-1``."""
    corners = np.asarray(x, dtype=float)[:, mesh.t]  # (d, d + 1, n_elements)
    return corners[:, 1:] - corners[:, :1]


def element_jacobians(mesh, x) -> np.ndarray:
    """``J = det F`` of every P1 triangle (tetrahedron) with its nodes at ``x``: the ratio of signed areas (volumes),
    ``det D_s / det D_m`` (:func:`edge_matrices`)."""
    return det(edge_matrices(mesh, x)) / det(edge_matrices(mesh, mesh.p))


def cover_counts(mesh, x, tol: float = 1e-9) -> np.ndarray:
    """How many deformed triangles (tetrahedra) contain each deformed element's centroid: above 1 the mesh lies
    over itself, even with every ``J > 0``. Inside means every barycentric coordinate above ``tol`` (shared faces
    count once); they come from Cramer's rule, a ratio of signed areas (volumes). Cost ``d n_elements^2``."""
    x = np.asarray(x, dtype=float)
    D = edge_matrices(mesh, x)  # (d, d, n_elements)
    d, n = D.shape[0], D.shape[2]
    corners = x[:, mesh.t]
    offset = corners.mean(axis=1)[:, :, None] - corners[:, 0][:, None, :]  # centroid - x_0: [.., point, element]
    volume = det(D)
    ok = np.abs(volume) > 0.0
    volume = np.where(ok, volume, 1.0)
    inside = np.broadcast_to(ok, (n, n))
    rest = 1.0
    for k in range(d):  # coordinate k + 1: column k of D replaced by the offset
        Dk = np.broadcast_to(D[:, :, None, :], (d, d, n, n)).copy()
        Dk[:, k] = offset
        coordinate = det(Dk) / volume
        inside = inside & (coordinate > tol)
        rest = rest - coordinate
    return (inside & (rest > tol)).sum(axis=1)


def crush_and_release_runs(E: float = TISSUE_E, nu: float = TISSUE_NU, mesh=None) -> dict:
    """:func:`crush_and_release` (default depth 1.3) for the four models, by name."""
    mesh = block() if mesh is None else mesh
    return {name: crush_and_release(material, mesh) for name, material in inversion_models(E, nu).items()}
