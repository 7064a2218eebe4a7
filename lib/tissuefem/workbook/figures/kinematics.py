"""Figures of chapters 3 and 4 (2D kinematics, linear elasticity, Neo-Hookean quasistatics): the notes'
Figure 2, a rigid rotation's stress, the stretched block and what accuracy costs."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure
from matplotlib.patches import FancyArrowPatch
from matplotlib.tri import Triangulation

from ...engine.constants import FRAME_BUDGET, TISSUE_E, TISSUE_NU
from ...engine.materials import LinearElastic, NeoHookean, det
from ...engine.meshes import rectangle
from ..hardcases import edge_matrices
from ..studies import (BLOCK_HANDLE, RECORDED_COST_ACCURACY, bending_gradient, bending_map, rigid_rotation_response,
                       rotated_block, rotation, stretched_block)
from .base import at_least, finish, frame_axes, lecture_figure, shown, stress_label

#: one frame at 30 frames per second, in milliseconds
FRAME_BUDGET_MS = 1e3 * FRAME_BUDGET
_LABEL_BOX = dict(boxstyle="round,pad=0.12", fc="white", ec="none", alpha=0.8)


def _arrow(ax, start, vec, color, text, offset) -> None:
    """An arrow ``vec`` from ``start``, labelled with ``text`` at ``offset`` from its head."""
    ax.annotate("", xy=start + vec, xytext=start, zorder=5,
                arrowprops=dict(arrowstyle="-|>", color=color, lw=2.0, shrinkA=0, shrinkB=0))
    ax.text(*(start + vec + offset), text, color=color, fontsize=10, ha="center", va="center", bbox=_LABEL_BOX,
            zorder=6)


def _mapped_edges(mesh, phi, samples: int = 12) -> np.ndarray:
    """Every mesh edge sampled at ``samples`` points and mapped by ``phi``: segments (n_edges, samples, 2)."""
    s = np.linspace(0.0, 1.0, samples)
    a, b = mesh.p[:, mesh.facets[0]], mesh.p[:, mesh.facets[1]]  # (2, n_edges)
    pts = a[:, :, None] + (b - a)[:, :, None] * s  # (2, n_edges, samples)
    x = phi(pts.reshape(2, -1)).reshape(pts.shape)
    return np.moveaxis(x, 0, -1)


def _boundary_loop(nx: int, ny: int) -> np.ndarray:
    """Node indices around the boundary of a structured :func:`~tissuefem.engine.meshes.rectangle`, closed."""
    row = nx + 1
    return np.concatenate([np.arange(row), nx + row * np.arange(1, ny + 1),  # bottom, right
                           ny * row + np.arange(nx - 1, -1, -1), row * np.arange(ny - 1, -1, -1)])  # top, left


def _outline(width, height, samples: int = 60) -> np.ndarray:
    """The boundary of ``[0, width] x [0, height]`` as a closed polyline (2, m), counter-clockwise."""
    s = np.linspace(0.0, 1.0, samples, endpoint=False)
    return np.hstack([
        np.stack([s * width, 0 * s]), np.stack([width + 0 * s, s * height]),
        np.stack([width * (1 - s), height + 0 * s]), np.stack([0 * s, height * (1 - s)]), [[0.0], [0.0]],
    ])


@lecture_figure
def fig02_kinematics() -> Figure:
    """Notes' Figure 2: the bent block (:func:`~tissuefem.workbook.studies.bending_map`), X carried to x =
    phi(X), dX to F dX; right: a cut's normal N and the force across it, P N dA = sigma n da."""
    mesh = rectangle(2.0, 1.0, 8, 4)
    fig = Figure(figsize=(13.2, 3.9), layout="constrained")
    ax, ax_s = fig.subplots(1, 2, width_ratios=[9.0, 3.9])
    identity = lambda X: X  # noqa: E731
    for phi, color, fill in ((identity, "C0", "#dbe8f5"), (bending_map, "C1", "#fbe3cc")):
        edges = _mapped_edges(mesh, phi)
        boundary = phi(_outline(2.0, 1.0))
        ax.fill(boundary[0], boundary[1], color=fill, zorder=0)
        ax.add_collection(LineCollection(edges, colors=color, linewidths=0.8, zorder=1))
        ax.plot(boundary[0], boundary[1], color=color, lw=1.6, zorder=1)

    X0 = np.array([1.25, 0.3])
    x0 = bending_map(X0)
    F0 = bending_gradient(X0)
    ax.annotate("", xy=x0, xytext=X0, zorder=4,
                arrowprops=dict(arrowstyle="-|>", color="0.35", lw=1.3, ls="--", shrinkA=4, shrinkB=4))
    mid = 0.5 * (X0 + x0)
    ax.text(mid[0] + 0.1, mid[1] - 0.1, "$\\mathbf{u}(\\mathbf{X}) = \\phi(\\mathbf{X}) - \\mathbf{X}$",
            ha="center", va="top", fontsize=10, color="0.25", bbox=_LABEL_BOX)
    # the map itself, from body to body
    ax.add_patch(FancyArrowPatch((1.5, 1.2), (3.3, 1.55), connectionstyle="arc3,rad=-0.3",
                                 arrowstyle="-|>", mutation_scale=18, lw=1.6, color="k", zorder=4))
    ax.text(2.35, 1.72, "$\\phi(\\cdot, t)$", ha="center", fontsize=13)

    scale = 0.45
    offsets = {0: (np.array([0.08, -0.1]), np.array([0.12, -0.1])),
               1: (np.array([-0.2, 0.02]), np.array([-0.25, 0.02]))}
    for j, (color, name) in enumerate((("C3", "1"), ("C2", "2"))):
        e = np.eye(2)[:, j]
        _arrow(ax, X0, scale * e, color, f"$d\\mathbf{{X}}_{name}$", offsets[j][0])
        _arrow(ax, x0, scale * F0 @ e, color, f"$\\mathbf{{F}}\\,d\\mathbf{{X}}_{name}$", offsets[j][1])
    ax.plot(*X0, "ko", ms=5, zorder=6)
    ax.plot(*x0, "ko", ms=5, zorder=6)
    ax.text(X0[0] - 0.06, X0[1] - 0.05, "$\\mathbf{X}$", ha="right", va="top", fontsize=12, zorder=6,
            bbox=_LABEL_BOX)
    ax.text(x0[0] - 0.06, x0[1] - 0.06, "$\\mathbf{x} = \\phi(\\mathbf{X})$", ha="right", va="top",
            fontsize=12, zorder=6, bbox=_LABEL_BOX)
    ax.text(1.0, -0.1, "reference (material) configuration $B_0 = \\{\\mathbf{X}\\}$", ha="center", va="top",
            fontsize=10, color="C0")
    low = bending_map(np.array([[0.0, 1.0], [0.0, 0.0]]))  # a bottom corner and the bottom middle
    ax.text(low[0, 1], low[1, 0] - 0.08, "deformed (current) configuration $B_t = \\{\\mathbf{x}\\}$", ha="center",
            va="top", fontsize=10, color="C1")
    ax.set(aspect="equal", xlim=(-0.25, 6.0), ylim=(-0.3, 1.9), xlabel="$X_1$, $x_1$", ylabel="$X_2$, $x_2$")
    ax.set_title("Notes' Figure 2: $\\phi$ carries $\\mathbf{X}$ to $\\mathbf{x}$; "
                 "$F_{ij} = \\partial\\phi_i/\\partial X_j$ carries $d\\mathbf{X}$ "
                 "to $d\\mathbf{x} = \\mathbf{F}\\,d\\mathbf{X}$")
    _stress_half(ax_s, F0)
    return fig


def _stress_half(ax, F0) -> None:
    """The stress half of Figure 2 at one material point (see :func:`fig02_kinematics`)."""
    P0 = NeoHookean.from_young(TISSUE_E, TISSUE_NU).stress(F0)
    J0 = float(np.linalg.det(F0))
    N = np.array([1.0, 1.0]) / np.sqrt(2.0)     # the normal of a diagonal material cut
    force = P0 @ N                               # per unit reference length of the cut
    n_da = J0 * np.linalg.inv(F0).T @ N          # Nanson: n da = J F^-T N dA
    sigma = P0 @ F0.T / J0
    assert np.allclose(sigma @ n_da, force)      # the same force, per deformed length
    # directions rounded as drawn (the last bits of a stress vary between processors)
    n_dir = shown(n_da / np.linalg.norm(n_da))
    f_dir = shown(force / np.linalg.norm(force))
    F_shown = shown(F0)
    a, shift = 0.32, np.array([1.45, 0.0])
    square = np.array([[-a, a, a, -a, -a], [-a, -a, a, a, -a]])
    cut = np.array([[a, -a], [-a, a]])
    for offset, M, color, fill in ((np.zeros(2), np.eye(2), "C0", "#dbe8f5"), (shift, F_shown, "C1", "#fbe3cc")):
        patch = offset[:, None] + M @ square
        ax.fill(patch[0], patch[1], color=fill, ec=color, lw=1.2, zorder=1)
        line = offset[:, None] + M @ cut
        ax.plot(line[0], line[1], color="k", lw=1.6, ls="--", zorder=2)
    _arrow(ax, np.zeros(2), 0.32 * N, "k", "$\\mathbf{N}$", np.array([0.08, 0.04]))
    _arrow(ax, shift, 0.32 * n_dir, "k", "$\\mathbf{n}$", np.array([0.09, 0.0]))
    _arrow(ax, shift, 0.5 * f_dir, "C3", "$\\mathbf{P}\\mathbf{N}\\,dA = \\boldsymbol{\\sigma}\\mathbf{n}\\,da$",
           np.array([0.05, 0.1]))
    ax.add_patch(FancyArrowPatch((0.25, 0.48), (1.2, 0.48), connectionstyle="arc3,rad=-0.25",
                                 arrowstyle="-|>", mutation_scale=14, lw=1.2, color="k", zorder=4))
    ax.text(0.72, 0.66, "$\\mathbf{F}$", ha="center", fontsize=12)
    ax.text(0.0, -a - 0.1, "a cut at $\\mathbf{X}$\nwith normal $\\mathbf{N}$", ha="center", va="top",
            fontsize=9, color="C0")
    ax.text(shift[0], -a - 0.1, "its image at $\\mathbf{x}$", ha="center", va="top", fontsize=9, color="C1")
    frame_axes(ax, (-0.55, 2.2), (-0.75, 0.85))
    ax.set_title("the stress half: $\\mathbf{P}$ maps the normal $\\mathbf{N}$ of a cut\n"
                 "to the force across it per unit reference area", fontsize=10)


@lecture_figure
def fig_ch03_rotation_stress() -> Figure:
    """Chapter 3: a rigid rotation stresses linear elasticity, not Neo-Hookean (energy and |P| at F =
    R(theta)); right: a block clamped to a wall turned by 60 degrees."""
    linear = LinearElastic.from_young(TISSUE_E, TISSUE_NU)
    neo = NeoHookean.from_young(TISSUE_E, TISSUE_NU)
    deg = np.linspace(0.0, 180.0, 181)
    fig = Figure(figsize=(12.0, 4.3), layout="constrained")
    ax_e, ax_p, ax_b = fig.subplots(1, 3, width_ratios=[1, 1, 1.15])
    for material, color, label in ((linear, "C3", "linear elasticity"), (neo, "C0", "Neo-Hookean")):
        resp = rigid_rotation_response(material, np.radians(deg))
        ax_e.plot(deg, resp["energy"], color=color, lw=2, label=label)
        ax_p.plot(deg, resp["stress_norm"], color=color, lw=2, label=label)
    lam, mu = linear.lam, linear.mu
    ax_e.plot(deg[::15], 2 * (lam + mu) * (1 - np.cos(np.radians(deg[::15]))) ** 2, "k.", ms=5,
              label="$2(\\lambda+\\mu)(1-\\cos\\theta)^2$")
    for ax, what, ylabel in ((ax_e, "energy", "energy density $\\Psi(\\mathbf{R}_\\theta)$"),
                             (ax_p, "stress", stress_label("$|\\mathbf{P}(\\mathbf{R}_\\theta)|$"))):
        finish(ax, legend=dict(fontsize=8, loc="upper left"), xlabel="rotation angle $\\theta$ [degrees]",
               ylabel=ylabel, title=f"{what} of a rigid rotation", xticks=np.arange(0, 181, 30))

    theta = np.radians(60.0)
    outline = _outline(1.0, 1.0)
    ax_b.plot(outline[0], outline[1], color="0.5", ls="--", lw=1, label="reference block")
    for material, color, name in ((linear, "C3", "linear"), (neo, "C0", "Neo-Hookean")):
        problem, result = rotated_block(material, theta, n=8)
        x = np.round(problem.deformed_positions(result.u), 4)  # drawn to 1e-4: round-off moves no line
        loop = x[:, _boundary_loop(8, 8)]
        tri = Triangulation(x[0], x[1], problem.mesh.t.T)
        ratio = float(0.5 * np.sum(det(edge_matrices(problem.mesh, problem.deformed_positions(result.u)))))
        energy = abs(problem.stored_energy(result.u))
        ax_b.fill(loop[0], loop[1], color=color, alpha=0.15, lw=0)
        ax_b.triplot(tri, color=color, lw=0.3, alpha=0.6)
        ax_b.plot(loop[0], loop[1], color=color, lw=1.8,
                  label=f"{name}: area $\\times${ratio:.2f}, energy {at_least(energy)}")
    wall = np.array([[0.0, 0.0], [-0.6, 0.6]])
    w = rotation(theta) @ wall + [[0.0], [0.5]]
    ax_b.plot(w[0], w[1], color="k", lw=3.5, solid_capstyle="butt", label="clamped edge, turned by 60°")
    finish(ax_b, legend=dict(fontsize=7.5, loc="upper left"), grid=None, aspect="equal", xlim=(-0.7, 1.6),
           ylim=(-0.1, 2.6), xlabel="$x_1$", ylabel="$x_2$", title="equilibrium of a block turned at its left edge")
    fig.suptitle(f"Linear elasticity is not frame indifferent (E = {TISSUE_E:g}, $\\nu$ = {TISSUE_NU:g})")
    return fig


@lecture_figure
def fig_ch04_block() -> Figure:
    """Chapter 4: the Neo-Hookean block (24 x 12 cells, P1) stretched and sheared by its handles, coloured by
    J = det F and by Psi."""
    problem, u = stretched_block()
    F = problem.deformation_gradient(u)
    J = det(F)
    psi = problem.material.energy(F)
    x = problem.deformed_positions(u)
    tri = Triangulation(x[0], x[1], problem.mesh.t.T)
    outline = _outline(2.0, 1.0)
    fig = Figure(figsize=(11.0, 3.9), layout="constrained")
    axes = fig.subplots(1, 2)
    spread = max(abs(J.max() - 1.0), abs(1.0 - J.min()))
    panels = [
        (J, "RdBu_r", TwoSlopeNorm(1.0, 1.0 - spread, 1.0 + spread), "$J = \\det \\mathbf{F}$ (area ratio)"),
        (psi, "viridis", None, "energy density $\\Psi$"),
    ]
    for ax, (values, cmap, norm, label) in zip(axes, panels):
        art = ax.tripcolor(tri, facecolors=values, cmap=cmap, norm=norm, edgecolors="face", lw=0.1)
        ax.triplot(tri, color="k", lw=0.15, alpha=0.5)
        ax.plot(outline[0], outline[1], color="0.4", ls="--", lw=1)
        ax.plot([0.0, 0.0], [0.0, 1.0], color="k", lw=4, solid_capstyle="butt")
        ax.plot([2.0 + BLOCK_HANDLE[0]] * 2, [BLOCK_HANDLE[1], 1.0 + BLOCK_HANDLE[1]], color="C1", lw=4,
                solid_capstyle="butt")
        ax.text(-0.06, 0.5, "fixed", rotation=90, ha="right", va="center", fontsize=9)
        ax.annotate("", xy=(2.0 + BLOCK_HANDLE[0], 0.5 + BLOCK_HANDLE[1]), xytext=(2.0, 0.5),
                    arrowprops=dict(arrowstyle="-|>", color="k", lw=1.5))
        ax.text(2.0 + 0.5 * BLOCK_HANDLE[0] + 0.05, 0.5 + 0.5 * BLOCK_HANDLE[1] - 0.05,
                f"handle\n{tuple(BLOCK_HANDLE)}", fontsize=8, va="top", bbox=_LABEL_BOX)
        ax.set(aspect="equal", xlim=(-0.25, 2.9), ylim=(-0.15, 1.55), xlabel="$x_1$", ylabel="$x_2$", title=label)
        fig.colorbar(art, ax=ax, shrink=0.8)
    fig.suptitle(f"Neo-Hookean block (E = {TISSUE_E:g}, $\\nu$ = {TISSUE_NU:g}), {problem.mesh.t.shape[1]} P1 "
                 f"triangles, left edge fixed, right edge moved by {tuple(BLOCK_HANDLE)}")
    return fig


@lecture_figure
def fig_ch04_cost_accuracy(rows=None) -> Figure:
    """Chapter 4: L2 error against time (the whole solve; one Newton iteration), P1 against P2, with the 33 ms
    budget; ``rows`` default to the recorded run (:data:`~tissuefem.workbook.studies.RECORDED_COST_ACCURACY`).
    """
    source = "recorded run" if rows is None else "this run"
    rows = RECORDED_COST_ACCURACY if rows is None else list(rows)
    fig = Figure(figsize=(11.0, 4.4), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    for ax, key, title in ((axes[0], "solve_ms", "whole solve from rest"),
                           (axes[1], "iteration_ms", "one Newton iteration")):
        for order, color, marker in ((1, "C0", "o"), (2, "C1", "s")):
            sel = [r for r in rows if r["order"] == order]
            if not sel:
                continue
            t, e = [r[key] for r in sel], [r["L2"] for r in sel]
            ax.loglog(t, e, marker=marker, color=color, lw=1.5, label=f"P{order}")
            for r, ti, ei in zip(sel, t, e):
                ax.annotate(f"{r['dofs']}", (ti, ei), textcoords="offset points",
                            xytext=(5, 4 if order == 1 else -10), fontsize=7, color=color)
        times = [r[key] for r in rows] + [FRAME_BUDGET_MS]
        lo, hi = 0.5 * min(times), 3.0 * max(times)
        ax.axvline(FRAME_BUDGET_MS, color="C3", lw=1.5, ls="--", label="33 ms: one frame at 30 Hz")
        ax.axvspan(FRAME_BUDGET_MS, hi, color="C3", alpha=0.06)
        finish(ax, legend=dict(fontsize=8, loc="lower left"), grid="both", xlabel="wall time [ms]", title=title,
               xlim=(lo, hi))
    axes[0].set_ylabel("relative $L^2$ error of the displacement")
    fig.suptitle(f"What accuracy costs: Neo-Hookean block, error against time ({source}; labels: dofs)")
    return fig
