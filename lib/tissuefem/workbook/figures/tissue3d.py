"""Figures of chapter 11 (tissue in 3D): bodies of tetrahedra drawn by their boundary faces, coloured by ``J`` or
by a stress (:func:`draw_body`): the twisted bar, the cube crushed and released with chapter 6's four models, the
slab let go under backward Euler (a filmstrip, and an animation written beside it), and the reference verified on
tetrahedra, drawn like chapter 9's verification (:func:`~tissuefem.workbook.figures.tradeoffs.plot_convergence`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize, TwoSlopeNorm
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ...engine.constants import FRAME_BUDGET as FRAME_DT, TISSUE_E, TISSUE_NU
from ..hardcases import block, crush_and_release_runs
from ..timestepping import backward_euler_run, released_flap
from ..tissue3d import twisted_bar
from ..verification import manufactured_convergence
from .base import (at_least, body_axes, boundary_faces, filmstrip, lecture_figure, save_animation, shown,
                   stress_label, surface_verts)
from .dynamics import release_history
from .inversion import CRUSH_COLUMNS, CRUSH_TITLES, INVERTED_COLOR, UPRIGHT_COLOR, draw_state, frame_depths
from .tradeoffs import plot_convergence

#: cells along each side of the crushed cube (``6 n^3`` tetrahedra)
CUBE_CELLS = 3
#: cells of the released slab (2 x 1 x 0.5, chapter 7's flap with a depth)
SLAB_CELLS = (8, 4, 2)
#: frames of the slab's animation (1/30 s each; frame 0 is the lifted slab) and those of its filmstrip
SLAB_FRAMES = 45
SLAB_FILMSTRIP = (0, 3, 6, 10, 16, 26, 44)
#: colour maps: ``J`` (diverging about 1) and the largest principal stress
J_CMAP, STRESS_CMAP = "RdBu_r", "viridis"


def cube():
    """The cube of chapter 11's crush: ``block(CUBE_CELLS, dim=3)``."""
    return block(CUBE_CELLS, dim=3)


def face_colors(mesh, values, cmap, norm) -> np.ndarray:
    """The colours of a body's boundary faces: each its tetrahedron's value in ``values`` (per element) through
    ``cmap`` and ``norm``."""
    return colormaps[cmap](norm(shown(np.asarray(values, dtype=float)[boundary_faces(mesh)[1]])))


def draw_body(ax, mesh, x, values, cmap, norm, linewidth: float = 0.25, **style):
    """Draw the boundary faces of a body of tetrahedra with nodes at ``x``, coloured by :func:`face_colors`
    (``style``: more options of the collection); returns the collection."""
    body = Poly3DCollection(surface_verts(mesh, x), facecolors=face_colors(mesh, values, cmap, norm),
                            edgecolors="0.2", linewidths=linewidth, **style)
    ax.add_collection3d(body)
    return body


def _limits(xs, margin: float = 0.05):
    """Axis limits ``(x, y, z)`` holding every state in ``xs`` (each ``(3, n)``), rounded outwards to 0.1."""
    lo = np.min([x.min(axis=1) for x in xs], axis=0) - margin
    hi = np.max([x.max(axis=1) for x in xs], axis=0) + margin
    return [(np.floor(10 * a) / 10, np.ceil(10 * b) / 10) for a, b in zip(lo, hi)]


@lecture_figure
def fig_ch11_twist(result=None) -> Figure:
    """Chapter 11: the Neo-Hookean bar held at its left face, the right face turned by 90° and pulled by 20 %
    (:func:`~tissuefem.workbook.tissue3d.twisted_bar`), its surface coloured by ``J`` and by the largest principal
    Cauchy stress."""
    result = twisted_bar() if result is None else result
    model, u = result.model, result.u
    x = model.positions(u)
    J = shown(model.jacobian(u))
    tension = shown(model.tension(u))
    limits = _limits([x, model.X])
    fig = Figure(figsize=(12.0, 4.2), layout="constrained")
    axes = [fig.add_subplot(1, 2, k + 1, projection="3d") for k in range(2)]
    spread = max(float(np.max(np.abs(J - 1.0))), 1e-3)
    J_norm = TwoSlopeNorm(vcenter=1.0, vmin=1.0 - spread, vmax=1.0 + spread)
    S_norm = Normalize(vmin=float(tension.min()), vmax=float(tension.max()))
    for ax, values, cmap, norm, label in ((axes[0], J, J_CMAP, J_norm, "$J = \\det \\mathbf{F}$ (volume ratio)"),
                                          (axes[1], tension, STRESS_CMAP, S_norm,
                                           stress_label("largest principal Cauchy stress", sep="\n"))):
        draw_body(ax, model.mesh, x, values, cmap, norm)
        body_axes(ax, *limits, elev=24.0, azim=-62.0, zoom=1.1)
        fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, shrink=0.6, pad=0.0, label=label)
    axes[0].set_title(f"coloured by J: from {J.min():.3f} to {J.max():.3f}", fontsize=9.5)
    axes[1].set_title(f"coloured by the largest principal stress: up to {tension.max():.0f}", fontsize=9.5)
    fig.suptitle(f"Chapter 11: a Neo-Hookean bar ({model.mesh.t.shape[1]} tetrahedra) held at its left face, the "
                 f"right face turned by {result.angles[-1]:g}° and pulled (E = {TISSUE_E:g}, ν = {TISSUE_NU:g})",
                 fontsize=10)
    return fig


@lecture_figure
def fig_ch11_crush_release(runs=None) -> Figure:
    """Chapter 11: chapter 6's crush and release on a cube of tetrahedra, one row per model of
    :func:`~tissuefem.workbook.hardcases.inversion_models`: the top face pushed to flat and past it (bottom face
    held), then let go (red: a face of a tetrahedron with ``J <= 0``)."""
    mesh = cube()
    runs = crush_and_release_runs(mesh=mesh) if runs is None else runs
    limits = [(-0.45, 1.45), (-0.75, 1.1), (-0.45, 1.45)]
    ncol = len(CRUSH_COLUMNS) + 1
    fig = Figure(figsize=(1.95 * ncol + 0.4, 1.8 * len(runs) + 1.0), layout="constrained")
    for r, (name, run) in enumerate(runs.items()):
        frames = run["frames"]
        depths = frame_depths(mesh, frames)
        for c in range(ncol):
            ax = fig.add_subplot(len(runs), ncol, r * ncol + c + 1, projection="3d")
            body_axes(ax, *limits, elev=14.0, azim=-60.0)
            if c == len(CRUSH_COLUMNS):
                draw_state(ax, mesh, frames[-1])
                note = f"{run['released'].status},\nrest error {at_least(run['released'].rest_error)}"
            else:
                hit = np.flatnonzero(np.abs(depths - CRUSH_COLUMNS[c]) < 1e-6)
                if hit.size:
                    inverted = draw_state(ax, mesh, frames[hit[0]])
                    note = f"J <= 0: {inverted}"
                else:
                    draw_state(ax, mesh, frames[-2], alpha=0.25)
                    failed = run["crush"][-1].status if run["crush"] else "not run"
                    note = f"stopped at {run['crushed']:.1f}\n(next: {failed})"
            ax.text2D(0.5, 0.0, note, transform=ax.transAxes, ha="center", va="bottom", fontsize=7)
            if r == 0:
                ax.set_title(CRUSH_TITLES[c], fontsize=9)
            if c == 0:
                ax.text2D(-0.05, 0.5, name, transform=ax.transAxes, rotation=90, ha="center", va="center", fontsize=8)
    fig.legend(handles=[Patch(fc=UPRIGHT_COLOR, ec="0.25", label="boundary face, $J > 0$"),
                        Patch(fc=INVERTED_COLOR, ec="0.25", label="its tetrahedron has $J \\leq 0$")],
               loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(f"Chapter 11: the crush and release of chapter 6 on a cube of {mesh.t.shape[1]} tetrahedra "
                 f"(E = {TISSUE_E:g}, ν = {TISSUE_NU:g}; bottom face held)", fontsize=10)
    return fig


def slab_run():
    """``(model, times, energies, states)``: the slab of :data:`SLAB_CELLS` lifted at its right face and let go,
    :data:`SLAB_FRAMES` frames of backward Euler at 1/30 s."""
    nx, ny, nz = SLAB_CELLS
    model, u0 = released_flap(nx=nx, ny=ny, nz=nz)
    return (model, *backward_euler_run(model, u0, FRAME_DT, SLAB_FRAMES - 1, frames=True))


def write_slab_animation(gif_path, model, states, dt: float, norm, dpi: int = 100) -> Path:
    """Write the slab's states as a GIF, one frame per step of ``dt``, faces coloured by ``J``: 680 x 480 pixels,
    large enough to project (:data:`~tissuefem.workbook.figures.base.ANIMATION_MIN_WIDTH`)."""
    fig = Figure(figsize=(6.8, 4.8))
    ax = fig.add_axes([0.0, 0.0, 1.0, 0.9], projection="3d")
    body_axes(ax, *_limits([model.positions(u) for u in states]), elev=18.0, azim=-64.0, zoom=1.2)
    body = draw_body(ax, model.mesh, model.positions(states[0]), model.jacobian(states[0]), J_CMAP, norm,
                     linewidth=0.3, antialiaseds=False)  # few colours per frame keep the GIF small
    title = fig.text(0.5, 0.94, "", ha="center", va="center", fontsize=13)

    def update(k):
        body.set_verts(surface_verts(model.mesh, model.positions(states[k])))
        body.set_facecolor(face_colors(model.mesh, model.jacobian(states[k]), J_CMAP, norm))
        title.set_text(f"backward Euler, Δt = 1/{1 / dt:.0f} s:  t = {k * dt:.2f} s  (colour: J)")

    return save_animation(fig, update, len(states), gif_path, dt, dpi)


@lecture_figure
def fig_ch11_released_slab(path=None, run=None) -> Figure:
    """Chapter 11: chapter 7's flap as a slab of tetrahedra, lifted at its right face and let go under backward
    Euler at 1/30 s: a filmstrip coloured by ``J`` and the tip's displacement. With a ``path``, also writes
    ``<path stem>.gif``."""
    model, times, energies, states = slab_run() if run is None else run
    mesh = model.mesh
    tip = np.flatnonzero(np.isclose(mesh.p[0], mesh.p[0].max()))
    tip_y = np.array([model.nodal_displacement(u)[1, tip].mean() for u in states])
    J_all = np.concatenate([model.jacobian(u) for u in states])
    spread = max(float(np.max(np.abs(J_all - 1.0))), 1e-3)
    norm = TwoSlopeNorm(vcenter=1.0, vmin=1.0 - spread, vmax=1.0 + spread)
    limits = _limits([model.positions(states[k]) for k in SLAB_FILMSTRIP])
    fig, strip, below = filmstrip(times, SLAB_FILMSTRIP, {0: "let go"}, 1.75, 5.0, [1.0, 1.1], margin=1.0,
                                  projection="3d")
    for ax, k in zip(strip, SLAB_FILMSTRIP):
        draw_body(ax, mesh, model.positions(states[k]), model.jacobian(states[k]), J_CMAP, norm, linewidth=0.2)
        body_axes(ax, *limits, elev=18.0, azim=-64.0, zoom=1.3)
    release_history(below, times, shown(tip_y), shown(energies / energies[0]), SLAB_FILMSTRIP,
                    "right face's mean displacement $u_y$", "right face $u_y$")
    fig.colorbar(ScalarMappable(norm=norm, cmap=J_CMAP), ax=strip, shrink=0.8, label="$J$")
    fig.suptitle(f"Chapter 11: the slab let go, backward Euler at $\\Delta t$ = 1/30 s ({mesh.t.shape[1]} "
                 f"tetrahedra, stable neo-Hookean, E = {TISSUE_E:g}, ν = {TISSUE_NU:g}, $\\rho_0$ = 1, left face "
                 "held)", fontsize=10)
    if path is not None:
        write_slab_animation(Path(path).with_suffix(".gif"), model, states, FRAME_DT, norm)
    return fig


@lecture_figure
def fig_ch11_convergence(rows=None) -> Figure:
    """Chapter 11: the 3D reference verified -- nonlinear mesh convergence on tetrahedra at rates 2 (P1) and 3
    (P2), three models (:func:`~tissuefem.workbook.verification.manufactured_convergence` with ``dim=3``)."""
    return plot_convergence(manufactured_convergence(dim=3) if rows is None else rows,
                            "Manufactured solution on tetrahedra (twisted arch + its body force)")
