"""Chapter 10's figures: cutting through elements (the virtual node algorithm), a crack on two meshes, the
flaps redone with it, and self-contact."""

from __future__ import annotations

import numpy as np
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure

from ...engine.constants import TISSUE_E, TISSUE_NU
from ...engine.contact import ContactSurface
from ...surgery.element_cuts import picture as element_picture
from ...surgery.surfaces import contact_surface
from ..procedures import (CRACK, CRACK_MESHES, FLAP_MESHES, VIRTUAL_NODES_STROKE, crack_opening, crack_runs,
                          flap_comparison, fold_run, overlap_area, pressed_cut_run, virtual_nodes_run)
from .base import frame_axes, lecture_figure, polygons, shown, stress_label
from .surgery import TENSION_CMAP, tension_colorbar, tension_norm

__all__ = ["fig_ch10_virtual_nodes", "fig_ch10_cut_through", "fig_ch10_flaps", "fig_ch10_contact", "draw_picture",
           "cut_pieces", "content_window"]


def draw_picture(ax, sim, values=None, norm=None, *, color="0.88", lw=0.2, outline=True):
    """Draw the tissue of ``sim`` as it is now: every element's material (``Simulation.picture``)."""
    picture = sim.picture
    x = picture.points(sim.positions())
    if values is None:
        colors = dict(facecolors=color)
    else:
        colors = dict(array=np.asarray(values, dtype=float)[picture.element], cmap=TENSION_CMAP, norm=norm)
    coll = ax.add_collection(PolyCollection(polygons(x, picture.triangles), edgecolors="none", **colors))
    if outline:
        ax.add_collection(LineCollection(polygons(x, picture.edges), colors=[(0.0, 0.0, 0.0, 0.3)], linewidths=lw))
    return coll


def cut_pieces(cut) -> tuple[int, int]:
    """``(copies, whole)``: of the elements a cut through elements touches (``cut.regions``), the copies that
    hold part of a triangle (weight < 1) and the triangles left whole (the crack tip's, where the stroke ends)."""
    touched = np.array(sorted(cut.regions), dtype=int)
    partial = cut.weights[touched] < 1
    return int(partial.sum()), int((~partial).sum())


@lecture_figure
def fig_ch10_virtual_nodes() -> Figure:
    """Chapter 10: the virtual node algorithm (Molino, Bao and Fedkiw 2004) on 16 triangles: each one the
    stroke separates is duplicated, each copy holding its side's material; rings: virtual nodes."""
    sim, edit, n_old = virtual_nodes_run()
    stroke = np.array(VIRTUAL_NODES_STROKE)
    fig = Figure(figsize=(10.0, 3.9), layout="constrained")
    axes = fig.subplots(1, 2)
    ax = axes[0]
    P = edit.mesh.p[:, :n_old]
    t_old = np.unique(np.sort(edit.parent[edit.mesh.t], axis=0), axis=1)
    ax.add_collection(PolyCollection(polygons(P, t_old), facecolors="0.9", edgecolors="0.4", linewidths=0.6))
    ax.plot(*P, "o", color="k", ms=3)
    ax.plot(*stroke.T, "-", color="C3", lw=2)
    frame_axes(ax, (-0.1, 2.25), (-0.12, 1.15))
    ax.set_title(f"(a) the stroke on the mesh: {t_old.shape[1]} triangles, {n_old} nodes", fontsize=9)
    ax = axes[1]
    x = sim.positions()
    cut = np.array(sorted(edit.regions))
    draw_picture(ax, sim, color="0.85", lw=0.5)
    ax.add_collection(PolyCollection(polygons(shown(x), sim.mesh.t[:, cut]), facecolors="none", edgecolors="C0",
                                     linewidths=0.8, linestyles="--"))
    real = np.arange(sim.mesh.nvertices) < n_old
    ax.plot(*shown(x[:, real]), "o", color="k", ms=3, label="nodes of the mesh")
    ax.plot(*shown(x[:, ~real]), "o", mfc="white", mec="C0", ms=6, mew=1.3,
            label=f"virtual nodes ({int((~real).sum())})")
    frame_axes(ax, (-0.1, 2.25), (-0.12, 1.15))
    # below the axes: inside, the legend would hide a node
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, 0.0), ncols=2, frameon=False)
    copies, whole = cut_pieces(edit)
    split = len(np.unique(edit.elements[cut[edit.weights[cut] < 1]]))
    ax.set_title(f"(b) cut, pulled open: {split} triangles split into {copies} copies that each hold part "
                 f"of one;\n{whole} whole triangle{'s' if whole != 1 else ''} at the crack tip", fontsize=9)
    fig.suptitle("Chapter 10: the virtual node algorithm, up close", fontsize=10)
    return fig


@lecture_figure
def fig_ch10_cut_through(runs=None) -> Figure:
    """Chapter 10: a slanted crack snapped to mesh edges (a staircase that changes with the mesh) or cut
    through the elements (the drawn line on both meshes), coloured by tension."""
    runs = crack_runs() if runs is None else runs
    norm = tension_norm(*[r[0].tension() for r in runs.values()])
    fig = Figure(figsize=(11.0, 6.4), layout="constrained")
    axes = fig.subplots(2, 2)
    crack = np.asarray(CRACK)
    for i, method in enumerate(("edges", "elements")):
        for j, n in enumerate(CRACK_MESHES):
            sim, edit = runs[(method, n)]
            ax = axes[i, j]
            draw_picture(ax, sim, sim.tension(), norm, lw=0.12)
            ax.plot(*crack.T, color="C3", lw=0.6, alpha=0.8)
            frame_axes(ax, (0.55, 1.55), (0.3, 1.12))
            kind = "snapped to mesh edges" if method == "edges" else "through the elements"
            ax.set_title(f"({'abcd'[2 * i + j]}) {kind}, {sim.mesh.nelements} elements: opening "
                         f"{crack_opening(sim, edit):.4f}", fontsize=9)
    tension_colorbar(fig, norm, list(axes.ravel()), shrink=0.8)
    fig.suptitle(f"Chapter 10: a crack drawn on a pulled sheet (stable neo-Hookean, E = {TISSUE_E:g}, "
                 f"ν = {TISSUE_NU:g}), on {CRACK_MESHES[0]} and {CRACK_MESHES[1]} triangles", fontsize=10)
    return fig


@lecture_figure
def fig_ch10_flaps(runs=None) -> Figure:
    """Chapter 10: the advancement and a rotation flap, snapped to edges and cut through elements, with the
    tension report on two meshes: cut through the elements, it stays put."""
    runs = flap_comparison() if runs is None else runs
    fine = FLAP_MESHES[-1]
    fig = Figure(figsize=(13.5, 7.2), layout="constrained")
    axes = fig.subplots(2, 3, width_ratios=[1, 1, 0.7])
    shown_runs = [runs[(name, m, fine)] for name in ("advancement", "rotation") for m in ("edges", "elements")]
    norm = tension_norm(*[r.tension for r in shown_runs])
    windows = {"advancement": ((0.7, 3.8), (0.3, 1.7)), "rotation": ((0.6, 2.9), (0.3, 2.7))}
    for i, name in enumerate(("advancement", "rotation")):
        for j, method in enumerate(("edges", "elements")):
            result = runs[(name, method, fine)]
            sim = result.simulation
            ax = axes[i, j]
            draw_picture(ax, sim, result.tension, norm, lw=0.1)
            ends = sim.model.sutures.ends(sim.u)
            ax.plot(*shown(ends[0]), "o", ms=1.8, color="C0", zorder=5)
            frame_axes(ax, *windows[name])
            kind = "snapped to edges" if method == "edges" else "through elements"
            ax.set_title(f"({'abcdef'[3 * i + j]}) {name}, {kind}: {result.stitches} stitches,\n"
                         f"gap {result.initial_gap:.2f} → {result.max_gap:.0e}", fontsize=8.5)
        ax = axes[i, 2]
        width = 0.35
        for k, method in enumerate(("edges", "elements")):
            flap = [runs[(name, method, n)].flap_tension for n in FLAP_MESHES]
            p95 = [runs[(name, method, n)].p95_tension for n in FLAP_MESHES]
            pos = np.arange(len(FLAP_MESHES)) + (k - 0.5) * width
            ax.bar(pos, shown(flap), width, color=f"C{k}", label=f"{method}: mean in the flap")
            ax.plot(pos, shown(p95), "k_", ms=14, mew=2)
        ax.plot([], [], "k_", ms=10, mew=2, label="95th percentile, patch")
        ax.set_xticks(np.arange(len(FLAP_MESHES)), [f"{n} triangles" for n in FLAP_MESHES], fontsize=8)
        ax.set_ylabel(stress_label("tension"), fontsize=8)
        ax.tick_params(labelsize=7.5)
        top = max(max(r.flap_tension, r.p95_tension) for (f, _, _), r in runs.items() if f == name)
        ax.set_ylim(0.0, 1.45 * top)
        ax.legend(fontsize=7, loc="upper left", ncols=1)
        ax.set_title(f"({'cf'[i]}) {name} flap: the report on two meshes", fontsize=8.5)
        ax.grid(alpha=0.3, axis="y")
    tension_colorbar(fig, norm, [axes[0, 0], axes[0, 1], axes[1, 0], axes[1, 1]], shrink=0.7)
    fig.suptitle(f"Chapter 10: two local flaps cut through the elements beside the edge-snapped versions "
                 f"(stable neo-Hookean, E = {TISSUE_E:g}, ν = {TISSUE_NU:g}; after Sifakis et al. 2009)",
                 fontsize=10)
    return fig


def content_window(positions, margin=0.04):
    """``(xlim, ylim)`` around every node of ``positions`` (a list of ``[2, nodes]`` arrays), with a ``margin``
    of the larger side, rounded outwards to 0.01 (a round-off in the positions moves no limit)."""
    x = np.concatenate([np.asarray(p, dtype=float) for p in positions], axis=1)
    pad = margin * float(np.max(np.ptp(x, axis=1)))
    return tuple((float(np.floor((x[d].min() - pad) * 100) / 100), float(np.ceil((x[d].max() + pad) * 100) / 100))
                 for d in range(2))


@lecture_figure
def fig_ch10_contact() -> Figure:
    """Chapter 10: self-contact: a strip folded onto itself (:func:`~tissuefem.workbook.procedures.fold_run`)
    and a crack pressed shut (:func:`~tissuefem.workbook.procedures.pressed_cut_run`), without and with
    contact."""
    runs = [[run(contact) for contact in (False, True)] for run in (fold_run, pressed_cut_run)]
    # one window a row, around the whole body in both its panels: nothing leaves the axes
    windows = [content_window([model.positions(u) for _, _, model, u in row]) for row in runs]
    fig = Figure(figsize=(12.0, 6.6), layout="constrained")
    axes = fig.subplots(2, 2, height_ratios=[max(0.4, (y[1] - y[0]) / (x[1] - x[0])) for x, y in windows])
    for i, row in enumerate(runs):
        window = windows[i]
        for j, (mesh, regions, model, u) in enumerate(row):
            contact = j == 1
            x = model.positions(u)
            picture = element_picture(mesh, regions)
            points = shown(picture.points(x))
            ax = axes[i, j]
            ax.add_collection(PolyCollection(polygons(points, picture.triangles), facecolors=(0.27, 0.51, 0.71, 0.45),
                                             edgecolors="none"))
            surface = model.contact.surface if contact else (contact_surface(mesh, None, regions) if regions
                                                             else ContactSurface.from_mesh(mesh))
            segments = polygons(shown(surface.positions(x)), np.asarray(surface.segments))
            ax.add_collection(LineCollection(segments, colors="k", linewidths=0.6))
            frame_axes(ax, *window)
            overlap = overlap_area(picture, x)
            what = ("a strip folded onto itself", "a crack pressed shut, sheared")[i]
            state = "with contact" if contact else "no contact"
            extra = (f"; deepest press {model.contact.overlap(u) / model.contact.distance:.2f} skin"
                     if contact else "")
            ax.set_title(f"({'abcd'[2 * i + j]}) {what}, {state}:\narea overlapping itself {overlap:.2g}{extra}",
                         fontsize=8.5)
    fig.suptitle("Chapter 10: self-contact of the surface (outer boundary and wound lips)", fontsize=10)
    return fig
