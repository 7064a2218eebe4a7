"""Figures of chapter 8 (virtual surgery) from :mod:`tissuefem.workbook.procedures`' runs: an incision, a cut
through two pieces, a probe and a flap. Colour: the tension
(:meth:`~tissuefem.surgery.simulation.Simulation.tension`), red pulled apart, blue pressed together."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import Normalize, to_rgba
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from ...engine.constants import FRAME_BUDGET as FRAME_DT, TISSUE_E, TISSUE_NU  # FRAME_DT: one frame, 1/30 s
from ..procedures import INCISION_PULL, flap_runs, incision_run, probe_run, two_pieces_run
from .base import (at_least, filmstrip, finish, frame_axes, lecture_figure, polygons, sheet_window, stress_label,
                   write_sheet_animation)

#: the colour map of the tension (largest principal Cauchy stress); centred at zero
TENSION_CMAP = "RdBu_r"
#: the held piece and the free piece of the two-pieces figure
HELD_COLOR, FREE_COLOR = "#6baed6", "#fd8d3c"
WOUND_COLOR = "#67000d"
#: the frames in the two-pieces filmstrip, the probe's depths drawn and the flap length drawn
FILMSTRIP, PROBE_SHOWN, FLAP_SHOWN = (0, 6, 12, 15, 18, 22, 26), (0.1, 0.25), 1.2


def tension_norm(*values, percentile=98.0) -> Normalize:
    """A symmetric colour scale ``[-s, s]`` with ``s`` the given percentile of ``|tension|`` (tips excluded)."""
    s = float(np.percentile(np.abs(np.concatenate([np.ravel(v) for v in values])), percentile))
    return Normalize(-s, s)


def draw_mesh(ax, x, t, values=None, norm=None, *, color="0.88", lw=0.25, alpha=1.0):
    """The triangles ``t`` with their nodes at ``x``; coloured by ``values`` (one per element) if given."""
    if values is None:
        colors = dict(facecolors=to_rgba(color, alpha), edgecolors=to_rgba("0.35", alpha))
    else:
        colors = dict(array=np.asarray(values, dtype=float), cmap=TENSION_CMAP, norm=norm, edgecolors=(0, 0, 0, 0.22))
    return ax.add_collection(PolyCollection(polygons(x, t), linewidths=lw, **colors))


def draw_wound(ax, mesh, x, **style) -> None:
    """The wound's edges (the boundary facets a cut or an excision made) as dark lines; none on an uncut mesh."""
    wound = [mesh.boundaries[n] for n in ("cut", "defect") if n in (mesh.boundaries or {})]
    if wound:
        segments = polygons(x, mesh.facets[:, np.concatenate(wound)])
        ax.add_collection(LineCollection(segments, **(dict(colors=WOUND_COLOR, linewidths=1.4, zorder=3) | style)))


def tension_colorbar(fig, norm, axes, **kwargs):
    """A colour bar of the tension beside ``axes``, its unit on a line of its own."""
    bar = fig.colorbar(ScalarMappable(norm=norm, cmap=TENSION_CMAP), ax=axes, extend="both", **kwargs)
    bar.set_label(stress_label("tension: largest principal Cauchy stress", sep="\n"), fontsize=8)
    bar.ax.tick_params(labelsize=7)
    return bar


@lecture_figure
def fig_ch08_incision() -> Figure:
    """Chapter 8: an incision in a pulled sheet before and after the cut, coloured by tension: the nodes along
    the stroke are duplicated and the tension moves to the tip."""
    run = incision_run()
    before, after = run["before"], run["after"]
    norm = tension_norm(before["tension"], after["tension"])
    fig = Figure(figsize=(11.0, 3.7), layout="constrained")
    axes = fig.subplots(1, 2)
    xlim, ylim = (-0.12, 2.0 + INCISION_PULL + 0.12), (-0.15, 1.22)
    titles = (f"(a) pulled by {INCISION_PULL:g}: {before['nodes']} nodes",
              f"(b) cut from the top edge to mid-height: {after['nodes']} nodes "
              f"(+{after['nodes'] - before['nodes']} copies)")
    for ax, state, title in zip(axes, (before, after), titles):
        ax.plot([0, 2, 2, 0, 0], [0, 0, 1, 1, 0], color="0.6", lw=0.8, ls="--")  # the sheet at rest
        draw_mesh(ax, state["x"], state["t"], state["tension"], norm)
        ax.plot([0.0, 0.0], [0.0, 1.0], color="k", lw=3)  # the held edge
        ax.annotate("", xy=(2.0 + INCISION_PULL + 0.1, 0.5), xytext=(2.0 + INCISION_PULL - 0.02, 0.5),
                    arrowprops=dict(arrowstyle="-|>", color="k", lw=1.2))
        frame_axes(ax, xlim, ylim)
        ax.set_title(title, fontsize=9)
    draw_wound(axes[1], after["mesh"], after["x"])
    cut_nodes = np.unique(after["mesh"].facets[:, after["mesh"].boundaries["cut"]])
    tip = cut_nodes[np.argmin(after["mesh"].p[1, cut_nodes])]
    xt = after["x"][:, tip]
    axes[1].annotate(f"tip: max tension {after['tension'].max():.0f}\n(it grows as the mesh is refined)",
                     xy=xt, xytext=(xt[0] + 0.35, xt[1] - 0.45), fontsize=7.5,
                     bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="none", alpha=0.85),
                     arrowprops=dict(arrowstyle="->", color="0.2", lw=0.8))
    axes[1].text(0.02, 0.02, f"the lips open by {after['opening']:.3f} at the top edge; "
                 f"{'still one piece' if after['pieces'] == 1 else str(after['pieces']) + ' pieces'}",
                 transform=axes[1].transAxes, fontsize=7.5)
    axes[0].text(0.02, 0.02, f"max tension {before['tension'].max():.0f} (at the corners of the pulled edge)",
                 transform=axes[0].transAxes, fontsize=7.5)
    tension_colorbar(fig, norm, axes, shrink=0.85)
    fig.suptitle(f"Chapter 8: an incision in a pulled sheet (quasistatic, stable neo-Hookean, E = {TISSUE_E:g}, "
                 f"ν = {TISSUE_NU:g}; left edge held, right edge pulled)", fontsize=10)
    return fig


def _piece_colors(free_elements, alpha=0.75):
    return np.where(np.asarray(free_elements)[:, None], to_rgba(FREE_COLOR, alpha), to_rgba(HELD_COLOR, alpha))


def write_two_pieces_animation(gif_path, run, dpi=120) -> Path:
    """Every frame of the run as a GIF at 30 frames per second: 648 x 864 pixels, large enough to project
    (:data:`~tissuefem.workbook.figures.base.ANIMATION_MIN_WIDTH`); no mesh edges: at this size they would
    cover the colours."""
    frames, times, cut = run["frames"], run["times"], run["cut_frame"]
    stages = ["hanging" if k < cut else ("cut!" if k == cut else "falling") for k in range(len(frames))]
    return write_sheet_animation(gif_path, [(x, t, _piece_colors(free, 1.0)) for x, t, free in frames],
                                 [f"t = {time:.2f} s  ({stage})" for time, stage in zip(times, stages)], FRAME_DT,
                                 dpi, figsize=(5.4, 7.2), top=0.86, fontsize=13, edgecolors="face", linewidths=0.5)


@lecture_figure
def fig_ch08_two_pieces(path=None) -> Figure:
    """Chapter 8: a hanging sheet cut in two, the free piece on backward Euler's discrete free fall ``y_k =
    y_c + k dt v_c - g dt^2 k (k + 1) / 2``. With a ``path``, also writes ``<path stem>.gif``."""
    run = two_pieces_run()
    frames, times, cut = run["frames"], run["times"], run["cut_frame"]
    window = sheet_window([frames[k][0] for k in FILMSTRIP])
    fig, strip, below = filmstrip(times, FILMSTRIP, {cut: "cut"}, 1.45, 5.3, [1.55, 1.0], window)
    for ax, k in zip(strip, FILMSTRIP):
        x, t, free = frames[k]
        ax.plot([0, 2, 2, 0, 0], [0, 0, 1, 1, 0], color="0.7", lw=0.6, ls="--")  # the sheet at rest
        ax.add_collection(PolyCollection(polygons(x, t), facecolors=_piece_colors(free), edgecolors="0.35",
                                         linewidths=0.3))
        ax.plot([0.0, 0.0], [0.0, 1.0], color="k", lw=2.0)  # the held edge
        if k == cut:
            ax.plot([1.0, 1.0], [1.25, -0.25], color="k", lw=0.9, ls=":")
    ax = below
    com = run["com"]
    ax.plot(times, com[:, 0], "o-", color=HELD_COLOR, ms=3, lw=1.2, label="left part (held piece after the cut)")
    ax.plot(times, com[:, 1], "o-", color=FREE_COLOR, ms=3, lw=1.2, label="right part (free piece after the cut)")
    ax.plot(times[cut:], run["free_fall"], color="k", lw=0.9, ls="--",
            label="discrete free fall from the state at the cut")
    ax.axvline(times[cut], color="0.4", lw=0.8, ls=":")
    ax.text(times[cut], 0.98, " cut", transform=ax.get_xaxis_transform(), va="top", fontsize=8)
    ax.plot(times[list(FILMSTRIP)], com[list(FILMSTRIP), 1], "s", color="C3", ms=5, label="frames shown above")
    err = float(np.max(np.abs(com[cut:, 1] - run["free_fall"])))
    finish(ax, legend=dict(fontsize=7.5, loc="lower left"), xlabel="time (s), one backward-Euler step per frame",
           ylabel="centre of mass height $y$", xlim=(0.0, times[-1]))
    ax.set_title(f"free piece against free fall: largest difference {at_least(err, spec='.1e')}", fontsize=9)
    fig.suptitle(f"Chapter 8: a cut through the body makes two pieces (stable neo-Hookean, E = {TISSUE_E:g}, "
                 f"ν = {TISSUE_NU:g}, $\\rho_0$ = 1, g = 9.81, $\\Delta t$ = 1/30 s)", fontsize=10)
    if path is not None:
        write_two_pieces_animation(Path(path).with_suffix(".gif"), run)
    return fig


@lecture_figure
def fig_ch08_probe() -> Figure:
    """Chapter 8: a rigid disc pressed into a block, at two depths, with the penalty's nodal forces
    (:class:`~tissuefem.engine.terms.Probe`); right: the force on the tool and the penetration."""
    run = probe_run()
    states, R = run["states"], run["radius"]
    sel = [i for i, s in enumerate(states) if any(np.isclose(s["depth"], d) for d in PROBE_SHOWN)]
    shown = [states[i] for i in sel]
    norm = tension_norm(*[s["tension"] for s in shown])
    fig = Figure(figsize=(12.5, 3.6), layout="constrained")
    axes = fig.subplots(1, 3, width_ratios=[1, 1, 0.75])
    scale = max(float(np.abs(s["contact"]).max()) for s in shown)
    for ax, s, letter in zip(axes[:2], shown, "ab"):
        draw_mesh(ax, s["x"], s["t"], s["tension"], norm)
        ax.plot([0, 2], [0, 0], color="k", lw=3)
        ax.add_patch(Circle(s["center"], R, facecolor="0.55", edgecolor="k", lw=0.8, alpha=0.85, zorder=4))
        active = np.flatnonzero(np.hypot(*s["contact"]) > 0)
        ax.quiver(s["x"][0, active], s["x"][1, active], s["contact"][0, active] / scale,
                  s["contact"][1, active] / scale, angles="xy", scale_units="xy", scale=4.0, color="k",
                  width=0.004, zorder=5)
        frame_axes(ax, (-0.08, 2.08), (-0.1, 1.0 + R + 0.1))
        ax.set_title(f"({letter}) depth {s['depth']:g}: {active.size} nodes in contact, "
                     f"penetration {s['penetration']:.1e}", fontsize=9)
    tension_colorbar(fig, norm, list(axes[:2]), shrink=0.85)
    ax = axes[2]
    depth = np.array([s["depth"] for s in states])
    force = np.array([-s["force"][1] for s in states])
    ax.plot(depth, force, "o-", color="C0", ms=4, label="force on the tool (vertical)")
    ax.plot(depth[sel], force[sel], "s", color="C3", ms=6, label="(a), (b)")
    finish(ax, xlabel="depth of the disc below the top edge", ylabel="force (per unit thickness)")
    ax.set_title("the tissue pushes back", fontsize=9)
    ax2 = ax.twinx()
    ax2.plot(depth, [s["penetration"] for s in states], "^--", color="C2", ms=4, lw=0.9, label="penetration left")
    ax2.set_ylabel("deepest node inside the disc", fontsize=8)
    ax2.tick_params(labelsize=7)
    (h1, l1), (h2, l2) = ax.get_legend_handles_labels(), ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=7.5, loc="upper left")
    fig.suptitle(f"Chapter 8: a probe pressed into the tissue, a surface penalty $E = \\sum_a k\\, l_a\\, h(R - d_a)$, "
                 f"$h(g) \\approx g^2/2$ (R = {R:g}, k = {states[0]['stiffness']:.2g}; block held on its bottom edge)",
                 fontsize=10)
    return fig


def stitch_arcs(a, b, bulge=0.18, n=12) -> np.ndarray:
    """Curved segments ``(k, n, 2)`` from the points ``a`` to ``b`` (each ``(2, k)``), bent to the right of
    ``a -> b``: a stitch along an incision stays visible."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    s = np.linspace(0.0, 1.0, n)[:, None, None]
    d = b - a
    normal = np.array([d[1], -d[0]])
    curve = a[None] + s * d[None] + bulge * 4.0 * s * (1.0 - s) * normal[None]  # (n, 2, k)
    return curve.transpose(2, 0, 1)  # (k, n, 2)


@lecture_figure
def fig_ch08_flap() -> Figure:
    """Chapter 8: an advancement flap closes a 0.6 x 0.6 defect (after Sifakis et al. 2009): (a) cut, stitches
    planned, (b) sutured, coloured by tension, (c) the mean tension for three flap lengths."""
    runs = flap_runs()
    result = runs[FLAP_SHOWN]
    sim = result.simulation
    mesh = sim.mesh
    ends_cut = sim.model.sutures.ends(np.zeros_like(sim.u))  # (flap end / wound end, xy, stitch)
    ends_sut = sim.model.sutures.ends(sim.u)
    x_cut, t_cut, _ = result.snapshots["cut"]
    x_sut, t_sut, e_sut = result.snapshots["sutured"]
    norm = tension_norm(result.tension)
    fig = Figure(figsize=(13.5, 3.6), layout="constrained")
    axes = fig.subplots(1, 3, width_ratios=[1, 1, 0.62])
    xlim, ylim = (-0.05, 4.05), (-0.05, 2.05)
    ax = axes[0]
    draw_mesh(ax, x_cut, t_cut, color="0.9", lw=0.2)
    draw_wound(ax, mesh, x_cut)
    ax.add_collection(LineCollection(stitch_arcs(ends_cut[0], ends_cut[1]), colors="C0", linewidths=0.7, zorder=4))
    ax.plot(*ends_cut[0], "o", ms=2.0, color="C0", zorder=5)
    frame_axes(ax, xlim, ylim)
    ax.set_title(f"(a) defect excised, flap cut ({FLAP_SHOWN:g} long); {result.stitches} stitches planned",
                 fontsize=9)
    ax = axes[1]
    draw_mesh(ax, x_sut, t_sut, result.tension[e_sut], norm, lw=0.15)
    draw_wound(ax, mesh, x_sut, linewidths=0.8)
    ax.plot(*ends_sut[0], "o", ms=2.2, color="C0", zorder=5)
    frame_axes(ax, xlim, ylim)
    ax.set_title(f"(b) sutured: gap {result.initial_gap:.2f} → {result.max_gap:.0e}, "
                 f"mean tension in the flap {result.flap_tension:.0f}", fontsize=9)
    tension_colorbar(fig, norm, list(axes[:2]), shrink=0.85)
    ax = axes[2]
    lengths = np.array(sorted(runs))
    ax.plot(lengths, [runs[L].flap_tension for L in lengths], "o-", color="C3", label="mean tension in the flap")
    ax.plot(lengths, [runs[L].mean_tension for L in lengths], "s--", color="C0", label="mean tension, whole patch")
    for L in lengths:
        ax.annotate(f"{runs[L].stitches} stitches", (L, runs[L].flap_tension), xytext=(0, 8),
                    textcoords="offset points", ha="center", fontsize=7)
    finish(ax, legend=dict(fontsize=7.5, loc="lower left"), xlabel="flap length", ylabel=stress_label("tension"),
           xticks=lengths, xlim=(lengths[0] - 0.25, lengths[-1] + 0.25),
           ylim=(0.0, 1.25 * max(runs[L].flap_tension for L in lengths)))
    ax.set_title("(c) longer flap, less tension", fontsize=9)
    fig.suptitle(f"Chapter 8: an advancement flap closes a 0.6 x 0.6 defect (stable neo-Hookean, E = {TISSUE_E:g}, "
                 f"ν = {TISSUE_NU:g}, patch held on its outer edges; after Sifakis et al. 2009)", fontsize=10)
    return fig
