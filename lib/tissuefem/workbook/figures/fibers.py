"""Figures of chapter 5 (anisotropic fibers)."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from .base import finish, frame_axes, lecture_figure, polygons, stress_label
from ...engine.meshes import fusiform_fiber_field, fusiform_muscle, fusiform_width
from ..fibers import (K_FIBER, block_pull, confined_pull, fiber_direction, muscle_pull, predicted_confined_modulus)

_FIBER_COLOR = "#b2182b"


def _segments(centers, directions, lengths) -> np.ndarray:
    """Line segments ``(n, 2, 2)`` of the given lengths, centred on ``centers`` along unit ``directions``."""
    half = 0.5 * lengths * directions
    return np.stack([(centers - half).T, (centers + half).T], axis=1)


def _outline(ax, mesh, **style):
    """Draw the boundary edges of ``mesh`` (reference positions)."""
    ax.add_collection(LineCollection(polygons(mesh.p, mesh.facets[:, mesh.boundary_facets()]), **style))


def _deformed_fibers(result, fibers, scale):
    """Deformed positions, fiber segments ``F g`` at the element centroids and fiber stretches of a pull result."""
    problem = result.model
    x = problem.positions(result.u)
    F = problem.deformation_gradient(result.u)
    a = np.einsum("ije,je->ie", F, fibers)  # F g: the deformed fiber, length = stretch
    stretch = np.hypot(a[0], a[1])
    return x, _segments(x[:, problem.mesh.t].mean(axis=1), a / stretch, scale * stretch), stretch  # at centroids


@lecture_figure
def fig03_fiber_field() -> Figure:
    """Notes' Figure 3 in 2D: the fiber field of the fusiform muscle
    (:func:`~tissuefem.engine.meshes.fusiform_fiber_field`), one segment per element."""
    mesh = fusiform_muscle(nx=32, ny=8)
    g = fusiform_fiber_field(mesh)
    c = mesh.p[:, mesh.t].mean(axis=1)  # element centroids
    fig = Figure(figsize=(9.0, 2.9), layout="constrained")
    ax = fig.subplots()
    X = np.linspace(0.0, 4.0, 201)
    w, _ = fusiform_width(X)
    ax.fill_between(X, -w / 2, w / 2, color="#f4e3d7", lw=0)
    ax.triplot(mesh.p[0], mesh.p[1], mesh.t.T, color="0.72", lw=0.4)
    _outline(ax, mesh, colors="0.3", linewidths=1.0)
    ax.add_collection(LineCollection(_segments(c, g, 0.08), colors=_FIBER_COLOR, linewidths=1.2))
    for x, label, ha in ((0.0, "left tendon\n(held)", "right"), (4.0, "right tendon\n(pulled)", "left")):
        ax.annotate(label, (x, 0.0), xytext=(x + (-0.12 if ha == "right" else 0.12), 0.0),
                    ha=ha, va="center", fontsize=9, arrowprops=dict(arrowstyle="-", color="0.4"))
    ax.annotate("belly", (2.0, 0.5), xytext=(2.0, 0.55), ha="center", fontsize=9)
    ax.plot([], [], color=_FIBER_COLOR, lw=1.2, label="fiber direction $\\mathbf{g}(\\mathbf{X})$ per element")
    ax.legend(loc="lower center", fontsize=8, frameon=False, bbox_to_anchor=(0.5, -0.02))
    ax.set(aspect="equal", xlim=(-0.9, 4.9), ylim=(-0.66, 0.7), xlabel="$X_1$", ylabel="$X_2$")
    ax.set_title("Notes' Figure 3 in 2D: a fiber field $\\mathbf{g}: B_0 \\to \\mathbb{R}^2$ "
                 "on a fusiform muscle (reference configuration)", fontsize=10)
    return fig


@lecture_figure
def fig_ch05_along_vs_across() -> Figure:
    """Chapter 5: a strip pulled along, at 45 degrees to and across its fibers, and the small-strain confined
    modulus against the fiber angle on ``lam + 2 mu + k cos^4 theta``."""
    cases = [(0.0, "fibers along the pull (0°)", "C3"), (45.0, "fibers at 45°", "C2"),
             (90.0, "fibers across the pull (90°)", "C0"), (None, "no fibers", "0.35")]
    stretches = np.linspace(1.0, 1.3, 13)
    fig = Figure(figsize=(10.0, 7.0), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.0, 1.9])
    shapes = top.subplots(1, 4)
    ax_curve, ax_mod = bottom.subplots(1, 2)
    for ax, (angle, label, color) in zip(shapes, cases):
        result = block_pull(angle, stretches)
        mesh = result.model.mesh
        _outline(ax, mesh, colors="0.55", linewidths=0.9, linestyles="dashed")
        x, segs, _ = _deformed_fibers(result, fiber_direction(0.0 if angle is None else angle)[:, None], 0.16)
        ax.triplot(x[0], x[1], mesh.t.T, color="0.7", lw=0.35)
        _outline(ax, type(mesh)(x, mesh.t, sort_t=False), colors=color, linewidths=1.4)
        if angle is not None:
            ax.add_collection(LineCollection(segs[::3], colors=_FIBER_COLOR, linewidths=1.0))
        frame_axes(ax, (-0.1, 2.7), (-0.2, 1.2))
        ax.set_title(label, fontsize=9, color=color)
        ax_curve.plot(stretches, result.nominal_stress, "o-", ms=3, color=color, label=label)
    top.suptitle("the strip at stretch 1.3 (dashed: rest shape; red: deformed fibers $\\mathbf{F}\\mathbf{g}$)",
                 fontsize=9)
    finish(ax_curve, legend=dict(fontsize=8), xlabel="stretch (pulled length / rest length)",
           ylabel=stress_label("force / rest height: mean $P_{11}$"), title="tensile test: clamped ends, free sides")

    theta = np.linspace(0.0, 90.0, 181)
    eps = 1e-4
    ax_mod.plot(theta, [predicted_confined_modulus(t) for t in theta], color="C3",
                label="prediction $\\lambda + 2\\mu + k\\cos^4\\theta$")
    angles = np.arange(0.0, 91.0, 15.0)
    measured = [float(confined_pull(a, eps).nominal_stress[0]) / eps for a in angles]
    ax_mod.plot(angles, measured, "ko", ms=5, label=f"finite elements, $\\varepsilon = {eps:g}$")
    iso = predicted_confined_modulus(90.0, stiffness=0.0)
    ax_mod.axhline(iso, color="0.35", ls="--", lw=1, label="no fibers: $\\lambda + 2\\mu$")
    ax_mod.annotate("", xy=(2.0, iso + K_FIBER), xytext=(2.0, iso),
                    arrowprops=dict(arrowstyle="<->", color="0.2", lw=1))
    ax_mod.text(5.0, iso + 0.2 * K_FIBER, f"along − across\n= $k$ = {K_FIBER:g}", fontsize=9, va="center")
    finish(ax_mod, legend=dict(fontsize=8), xlabel="fiber angle $\\theta$ to the pull (degrees)",
           ylabel=stress_label("confined modulus $P_{11}/\\varepsilon$"),
           title="small strain: $\\mathbf{F} = \\mathrm{diag}(1 + \\varepsilon, 1)$ on the boundary", xticks=angles)
    fig.suptitle(f"Pulling along versus across the fibers: neo-Hookean matrix (E = 1000, ν = 0.3) "
                 f"+ fiber term k/8 (I$_4$ − 1)², k = {K_FIBER:g}", fontsize=11)
    return fig


@lecture_figure
def fig_ch05_muscle_pull() -> Figure:
    """Chapter 5: the fusiform muscle pulled by its right tendon, with and without fibers: the shape at
    stretch 1.2 coloured by the fiber stretch ``|F g|``, and the tendon force."""
    stretches = np.linspace(1.0, 1.2, 9)
    runs = [(False, "isotropic (no fibers)", "0.35"), (True, f"with fibers, k = {K_FIBER:g}", "C3")]
    fig = Figure(figsize=(10.0, 5.0), layout="constrained")
    axes = fig.subplot_mosaic([["m0", "curve"], ["m1", "curve"]], width_ratios=[1.7, 1.0])
    results = [muscle_pull(stretches, with_fibers=with_fibers) for with_fibers, _, _ in runs]
    drawn = [_deformed_fibers(r, fusiform_fiber_field(r.model.mesh), 0.09) for r in results]
    top = float(np.ceil(10.0 * max(d[2].max() for d in drawn)) / 10.0)
    for i, ((_, label, color), result, (x, segs, stretch)) in enumerate(zip(runs, results, drawn)):
        mesh = result.model.mesh
        ax = axes[f"m{i}"]
        _outline(ax, mesh, colors="0.55", linewidths=0.8, linestyles="dashed")
        image = ax.tripcolor(x[0], x[1], mesh.t.T, facecolors=stretch, cmap="viridis", vmin=1.0, vmax=top)
        ax.add_collection(LineCollection(segs[::2], colors="w", linewidths=0.7, alpha=0.8))
        ax.axvline(stretches[-1] * 4.0, color="0.5", lw=0.6, ls=":")
        ax.set(aspect="equal", xlim=(-0.1, 4.95), ylim=(-0.6, 0.6), yticks=[])
        ax.set_title(f"{label}, stretched to {stretches[-1]:g}", fontsize=9, color=color)
        axes["curve"].plot(stretches, result.forces, "o-", ms=3, color=color, label=label)
    fig.colorbar(image, ax=[axes["m0"], axes["m1"]], location="left", shrink=0.8,
                 label="fiber stretch $\\sqrt{I_4} = |\\mathbf{F}\\mathbf{g}|$")
    ax = axes["curve"]
    finish(ax, legend=dict(fontsize=8), xlabel="muscle stretch (tendon to tendon)",
           ylabel="tendon force (per unit thickness)", title="force needed to pull the tendon")
    fig.suptitle("The fusiform muscle held at its left tendon and pulled by its right one", fontsize=11)
    return fig
