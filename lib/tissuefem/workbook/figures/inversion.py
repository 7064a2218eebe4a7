"""Figures of chapter 6 (inversion): ``fig06_crush_release`` and ``fig_ch06_itf_energy``, and the small
drawing helpers the chapter shares with them."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ...engine.constants import TISSUE_E, TISSUE_NU
from ...engine.inversion import diagonal
from ..hardcases import block, crush_and_release_runs, element_jacobians, inversion_models
from .base import at_least, boundary_faces, finish, frame_axes, lecture_figure, polygons, stress_label, surface_verts

#: fill colours of a triangle that keeps its orientation (J > 0) and of an inverted or flat one (J <= 0)
UPRIGHT_COLOR, INVERTED_COLOR = "#6baed6", "#d6604d"
#: the crush depths shown as columns of the crush-and-release figure (1 = flat); the released shape follows
CRUSH_COLUMNS = (0.0, 0.5, 0.9, 1.0, 1.3)
#: the titles of those columns and of the released shape's
CRUSH_TITLES = (*("rest" if d == 0 else "flat" if d == 1 else f"pushed {d:g}" for d in CRUSH_COLUMNS), "released")
#: line colour of each model (same order as :func:`tissuefem.workbook.hardcases.inversion_models`)
MODEL_COLORS = ("C0", "C2", "C1", "C3")


def draw_state(ax, mesh, x, *, J=None, alpha: float = 1.0, tol: float = 1e-12) -> int:
    """Draw the mesh with nodes at ``x``, translucent (overlaps show darker): upright triangles blue, ``J <=
    0`` red, on top (``J``: another state's, per element; ``alpha`` fades all). Returns the red count. A mesh of
    tetrahedra is drawn by its boundary faces on a 3D axes (:func:`~.base.body_axes`), opaque, a face red when its
    tetrahedron has ``J <= 0``; the count is of all tetrahedra, the hidden ones too."""
    J = element_jacobians(mesh, x) if J is None else np.asarray(J, dtype=float)
    bad = J <= tol
    if mesh.p.shape[0] == 3:
        faces, elements = boundary_faces(mesh)
        colors = np.where(bad[elements], INVERTED_COLOR, UPRIGHT_COLOR)
        ax.add_collection3d(Poly3DCollection(surface_verts(mesh, x, faces), linewidths=0.3,
                                             facecolors=[to_rgba(c, alpha) for c in colors],
                                             edgecolors=to_rgba("0.25", alpha)))
        return int(bad.sum())
    verts = polygons(x, mesh.t)
    for mask, color in ((~bad, UPRIGHT_COLOR), (bad, INVERTED_COLOR)):
        if mask.any():
            ax.add_collection(PolyCollection(verts[mask], facecolors=to_rgba(color, 0.6 * alpha),
                                             edgecolors=to_rgba("0.25", alpha), linewidths=0.45))
    return int(bad.sum())


def frame_depths(mesh, frames) -> np.ndarray:
    """How far the top edge was pushed down in each crush frame (the last frame, the released shape, excluded)."""
    rest = mesh.p[1].max()
    top = np.flatnonzero(np.abs(mesh.p[1] - rest) < 1e-9)
    return np.array([rest - np.mean(f[1, top]) for f in frames[:-1]])


@lecture_figure
def fig06_crush_release(runs=None) -> Figure:
    """Notes' Figure 6 as an experiment: a block crushed to flat and past it, then let go, one row per model
    of :func:`~tissuefem.workbook.hardcases.inversion_models` (red: ``J <= 0``)."""
    mesh = block()
    runs = crush_and_release_runs(mesh=mesh) if runs is None else runs
    xlim, ylim = (-0.38, 1.38), (-0.68, 1.12)
    ncol = len(CRUSH_COLUMNS) + 1
    fig = Figure(figsize=(1.75 * ncol + 0.9, 1.75 * len(runs) + 0.9), layout="constrained")
    axes = fig.subplots(len(runs), ncol, squeeze=False)
    bottom = mesh.p[1].min()
    for row, (name, run) in zip(axes, runs.items()):
        frames = run["frames"]
        depths = frame_depths(mesh, frames)
        for ax, target in zip(row, CRUSH_COLUMNS):
            hit = np.flatnonzero(np.abs(depths - target) < 1e-6)
            if hit.size:
                draw_state(ax, mesh, frames[hit[0]])
                y = mesh.p[1].max() - target
                ax.plot(xlim, [y, y], color="0.35", lw=0.8, ls="--")  # the top handle
            else:  # not reached: the last state the crush did reach, faded
                draw_state(ax, mesh, frames[-2], alpha=0.3)
                failed = run["crush"][-1].status if run["crush"] else "not run"
                ax.text(0.5, 0.5, f"crush stopped\nat {run['crushed']:.1f}\n(next step:\n{failed})",
                        transform=ax.transAxes, ha="center", va="center", fontsize=7.5,
                        bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="0.6", alpha=0.9))
        released = run["released"]
        ax = row[-1]
        draw_state(ax, mesh, frames[-1])
        ax.text(0.5, 0.02, f"{released.status},\nrest error {at_least(released.rest_error)}",
                transform=ax.transAxes, ha="center", va="bottom", fontsize=7,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))
        for ax in row:
            ax.plot(xlim, [bottom, bottom], color="k", lw=1.6)  # the held bottom edge
            frame_axes(ax, xlim, ylim)
        row[0].set_ylabel(name, fontsize=8.5)
    for ax, title in zip(axes[0], CRUSH_TITLES):
        ax.set_title(title, fontsize=9)
    fig.legend(handles=[Patch(fc=to_rgba(UPRIGHT_COLOR, 0.6), ec="0.25",
                              label="$J > 0$ (darker where the mesh lies over itself)"),
                        Patch(fc=to_rgba(INVERTED_COLOR, 0.6), ec="0.25", label="$J \\leq 0$ (inverted or flat)")],
               loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle("Notes' Figure 6 as an experiment: crush a block to flat and past it, then let go\n"
                 f"(E = {TISSUE_E:g}, ν = {TISSUE_NU:g}; bottom edge held; dashed: the top handle)",
                 fontsize=10)
    return fig


@lecture_figure
def fig_ch06_itf_energy() -> Figure:
    """Chapter 6: the four models' energy ``Psi(diag(1, s2))`` and its slope (the push back) along a signed
    singular value, and the energy along a shrink ``F = t I`` to 0."""
    models = inversion_models(TISSUE_E, TISSUE_NU)
    c = models["ITF-clamped neo-Hookean"].threshold
    s1 = np.linspace(-1.0, 1.6, 521)
    F_line = diagonal(np.stack([np.ones_like(s1), s1]))
    t = np.linspace(0.0, 1.4, 281)
    F_shrink = diagonal(np.stack([t, t]))
    fig = Figure(figsize=(12.0, 4.0), layout="constrained")
    ax_e, ax_p, ax_t = fig.subplots(1, 3)
    for (name, material), color in zip(models.items(), MODEL_COLORS):
        ax_e.plot(s1, material.energy(F_line), color=color, lw=2, label=name)
        ax_p.plot(s1, material.stress(F_line)[1, 1], color=color, lw=2, label=name)
        ax_t.plot(t, material.energy(F_shrink), color=color, lw=2, label=name)
    for ax in (ax_e, ax_p):
        ax.axvspan(s1[0], 0.0, color="C3", alpha=0.08, label="inverted ($s_2 < 0$)")
        ax.axvspan(0.0, c, color="C1", alpha=0.08, label=f"below the threshold $c = {c:g}$")
        ax.axvline(1.0, color="k", lw=0.6, ls="--")
        ax.axhline(0.0, color="k", lw=0.6)
        finish(ax, xlim=(s1[0], s1[-1]), xlabel="signed singular value $s_2$ (with $s_1 = 1$)")
    ax_e.set(ylim=(-500, 12000), ylabel="$\\hat\\Psi(1, s_2)$", title="energy along $s_2$")
    ax_p.set(ylim=(-20000, 6000), ylabel=stress_label("$\\partial\\hat\\Psi/\\partial s_2$"),
             title="its slope: the push back")
    ax_e.legend(fontsize=7.5, loc="upper right")
    ax_t.axvspan(0.0, c, color="C1", alpha=0.08)
    ax_t.axvline(1.0, color="k", lw=0.6, ls="--")
    finish(ax_t, xlim=(t[0], t[-1]), ylim=(-200, 10000), xlabel="$t$ in $\\mathbf{F} = t\\,\\mathbf{I}$",
           ylabel="$\\Psi(t\\,\\mathbf{I})$", title="uniform shrink to a point ($t = 0$: $\\mathbf{F} = 0$)")
    fig.suptitle(f"Inversion in diagonal space: E = {TISSUE_E:g}, ν = {TISSUE_NU:g} (plane strain)", fontsize=11)
    return fig
