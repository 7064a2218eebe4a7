"""What every lecture figure shares: the mark that lists a function as a figure, deterministic saving (no pyplot
state; no timestamp or version in the PNG, so a file changes only when the figure does) and the drawing idioms
of several chapters."""

from __future__ import annotations

import functools
import inspect
import math
from pathlib import Path
from typing import Callable

import matplotlib
import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from ...engine.constants import TISSUE_E

__all__ = ["lecture_figure", "save", "shown", "at_least", "whole_pixels", "matplotlib_note", "ANIMATION_MIN_WIDTH",
           "save_animation", "frame_axes", "finish", "polygons", "stress_label", "STRESS_UNITS", "sheet_window",
           "filmstrip", "write_sheet_animation", "boundary_faces", "surface_verts", "body_axes"]

#: the resolution of every saved figure
DPI = 110
#: the least width of an animation in pixels: large enough to project in a lecture room
ANIMATION_MIN_WIDTH = 640

#: the matplotlib minor version that drew the committed PNGs: up to 3.10 it bundles FreeType 2.6.1, 3.11
#: FreeType 2.14, which rasterises every text differently. Within 3.11 the files are the same byte for byte.
FIGURES_MATPLOTLIB = "3.11"

#: significant digits of the data a figure draws: round-off (another numpy, BLAS or processor) changes a
#: later digit, which drawn unrounded could move a line by a fraction of a pixel and change the PNG's bytes.
SHOWN_DIGITS = 3


#: what a stress axis or colour bar says of its unit: the models are dimensionless, a stress is a number in
#: the units Young's modulus is given in (the tissue's E, :data:`~tissuefem.engine.constants.TISSUE_E`)
STRESS_UNITS = f"same units as E = {TISSUE_E:g}"


def stress_label(what: str, units: str = STRESS_UNITS, sep: str = " ") -> str:
    """An axis or colour-bar label for a stress: ``what``, then its unit (``sep="\\n"``: on a line of its own)."""
    return f"{what}{sep}({units})"


def lecture_figure(func: Callable) -> Callable:
    """Mark a function returning a figure as a lecture figure (:data:`~tissuefem.workbook.figures.FIGURES`),
    called as ``figure(path=None, **data)``: it also saves it to ``path`` (:func:`save`), and passes ``path``
    on to a function that takes it (to write a GIF beside)."""
    takes_path = "path" in inspect.signature(func).parameters

    @functools.wraps(func)
    def figure(path=None, **data) -> Figure:
        fig = func(path, **data) if takes_path else func(**data)
        save(fig, path)
        return fig

    figure.lecture_figure = True
    return figure


def matplotlib_note() -> str | None:
    """A warning when this matplotlib would redraw the committed figures' text differently."""
    installed = ".".join(matplotlib.__version__.split(".")[:2])
    if installed == FIGURES_MATPLOTLIB:
        return None
    return (f"note: the committed figures were drawn with matplotlib {FIGURES_MATPLOTLIB}; this is "
            f"{matplotlib.__version__}, which renders text differently, so every PNG in figures/ will "
            f"change. Commit them only if you mean to move the workbook to matplotlib {installed}.")


def whole_pixels(inches: float, dpi: float = DPI) -> float:
    """``inches``, nudged up by an ulp or two when ``inches * dpi`` falls just short of a whole number of
    pixels: 4.6 in at 110 dpi is 505.99999999999994 px, 505 px up to matplotlib 3.11.0, 506 later."""
    pixels = round(inches * dpi)
    if abs(inches * dpi - pixels) > 1e-6:
        return inches  # a fraction of a pixel: truncated alike by every version
    while math.floor(inches * dpi) < pixels:
        inches = math.nextafter(inches, math.inf)
    return inches


def shown(values, floor=None, digits=SHOWN_DIGITS) -> np.ndarray:
    """Data as a figure draws it: rounded to ``digits`` significant digits, and raised to at least ``floor``
    (a round-off level, for positive data on a log axis)."""
    a = np.array(values, dtype=float)
    if floor is not None:
        a = np.maximum(a, floor)
    flat = [float(f"{v:.{digits}g}") if math.isfinite(v) else v for v in a.ravel()]
    return np.array(flat).reshape(a.shape)


#: a label's number below this is zero to round-off or to a solver's tolerance
NEGLIGIBLE = 1e-10


def at_least(value: float, level: float = NEGLIGIBLE, spec: str = ".2g") -> str:
    """``value`` formatted for a label, or ``< level`` below it (a round-off-sized number's digits vary)."""
    if abs(value) >= level:
        return format(value, spec)
    power = math.log10(level)
    return f"< 1e{round(power)}" if power == round(power) else f"< {level:.1g}"


def save(fig: Figure, path) -> None:
    """Save deterministically: fixed DPI, a whole number of pixels, no 'Software' entry or timestamps in the PNG."""
    if path is None:
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    width, height = fig.get_size_inches()
    fig.set_size_inches(whole_pixels(width), whole_pixels(height))
    fig.savefig(path, dpi=DPI, metadata={"Software": None})


def frame_axes(ax, xlim, ylim) -> None:
    """Equal aspect, the given limits, no ticks: the axes of a drawing of the body."""
    ax.set(aspect="equal", xlim=xlim, ylim=ylim, xticks=[], yticks=[])


def save_animation(fig: Figure, update: Callable, frames: int, gif_path, dt: float, dpi: float) -> Path:
    """Write ``update(k)`` for ``k < frames`` as a GIF, one frame per ``dt`` seconds (Pillow); returns its path."""
    gif_path = Path(gif_path)
    gif_path.parent.mkdir(parents=True, exist_ok=True)
    animation = FuncAnimation(fig, update, frames=frames, interval=1000 * dt, blit=False, repeat=False)
    animation.save(gif_path, writer=PillowWriter(fps=round(1 / dt)), dpi=dpi)
    return gif_path


def finish(ax, legend: dict | None = None, grid: str | None = "major", **props) -> None:
    """The end of a plot: ``ax.set(**props)``, the figures' light grid (``grid="both"``: at the minor ticks too, for
    a log axis; ``None``: no grid) and a legend with the options ``legend`` (``None``: no legend)."""
    ax.set(**props)
    if grid is not None:
        ax.grid(True, which=grid, alpha=0.3)
    if legend is not None:
        ax.legend(**legend)


def polygons(x, cells) -> np.ndarray:
    """The cells (triangles; or edges: segments) ``cells`` ``(corners, n)`` with their nodes at ``x`` ``(dim,
    n_nodes)`` as a collection draws them: ``(n, corners, dim)``."""
    return np.asarray(x, dtype=float)[:, cells].transpose(2, 1, 0)


# --- a sheet held along its left edge x = 0, 0 <= y <= 1 (chapters 7 and 8) ------------------------------------

def sheet_window(xs, margin: float = 0.08):
    """``(xlim, ylim)``: ``margin`` beyond the held edge and every node of the states ``xs`` (each ``(2, n_nodes)``)."""
    x = np.hstack([*xs, [[0.0], [1.0]]])
    return (x[0].min() - margin, x[0].max() + margin), (x[1].min() - margin, x[1].max() + margin)


def filmstrip(times, frames, notes: dict, width: float, height: float, height_ratios, window=None,
              margin: float = 0.6, projection=None):
    """``(fig, axes, below)``: one drawing's axes per frame ``k`` in ``frames`` (``width`` inches each, ``margin``
    more in all; titled by its time, and ``notes[k]`` if given; framed by :func:`frame_axes` to the 2D ``window``
    if given), over one wide axes ``below`` for the history of the run. ``projection="3d"``: axes for a body."""
    fig = Figure(figsize=(width * len(frames) + margin, height), layout="constrained")
    grid = fig.add_gridspec(2, len(frames), height_ratios=height_ratios)
    axes = [fig.add_subplot(grid[0, col], projection=projection) for col in range(len(frames))]
    for ax, k in zip(axes, frames):
        if window is not None:
            frame_axes(ax, *window)
        ax.set_title(f"t = {times[k]:.2f} s" + (f" ({notes[k]})" if k in notes else ""), fontsize=8.5)
    return fig, axes, fig.add_subplot(grid[1, :])


def write_sheet_animation(gif_path, frames, titles, dt: float, dpi: float, *, figsize, top: float, fontsize: float,
                          **style) -> Path:
    """Write the sheet's ``frames`` as a GIF, one per ``dt`` seconds, each ``(x, t, colors)``: its nodes, triangles and
    their face colours (``style``: the triangles' edges), under the title ``titles[k]``, in fixed axes the height
    ``top`` of the figure. No anti-aliasing: few colours per frame keep the GIF small (its palette has at most 256)."""
    fig = Figure(figsize=figsize)
    ax = fig.add_axes([0.02, 0.02, 0.96, top])
    frame_axes(ax, *sheet_window([x for x, _, _ in frames]))
    ax.plot([0.0, 0.0], [0.0, 1.0], color="k", lw=4)
    title = fig.text(0.5, 0.5 * (1.02 + top), "", ha="center", va="center", fontsize=fontsize)  # above the axes
    x, t, colors = frames[0]
    body = ax.add_collection(PolyCollection(polygons(x, t), facecolors=colors, antialiaseds=False, **style))

    def update(k):
        x, t, colors = frames[k]
        body.set_verts(polygons(x, t))
        body.set_facecolors(colors)
        title.set_text(titles[k])

    return save_animation(fig, update, len(frames), gif_path, dt, dpi)


# --- bodies of tetrahedra -------------------------------------------------------------------------------------------

def boundary_faces(mesh) -> tuple[np.ndarray, np.ndarray]:
    """``(faces, elements)`` of a tetrahedron mesh: the node triples of its boundary triangles ``(3, n_faces)``
    and the tetrahedron each belongs to ``(n_faces,)``: all a drawing of the body sees."""
    facets = mesh.boundary_facets()
    return np.asarray(mesh.facets[:, facets]), np.asarray(mesh.f2t[0, facets])


def surface_verts(mesh, x, faces=None) -> np.ndarray:
    """The boundary triangles of a body with its nodes at ``x`` ``(3, n_nodes)`` as drawn: ``(n_faces, 3, 3)``,
    the body's y (up in the chapters) on the plot's vertical axis, its z across; rounded to what a figure shows."""
    faces = boundary_faces(mesh)[0] if faces is None else faces
    return polygons(shown(np.asarray(x, dtype=float)[[0, 2, 1]], digits=5), faces)


def body_axes(ax, xlim, ylim, zlim, elev: float = 22.0, azim: float = -58.0, zoom: float = 1.0) -> None:
    """A 3D axes for a body of tetrahedra: the body's x, z, y limits (y up), equal scales, a fixed view, no axes;
    ``zoom`` enlarges the drawing within the axes."""
    ax.set(xlim=xlim, ylim=zlim, zlim=ylim)
    ax.set_box_aspect((xlim[1] - xlim[0], zlim[1] - zlim[0], ylim[1] - ylim[0]), zoom=zoom)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
