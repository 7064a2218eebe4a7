"""What every lecture figure shares: the mark that lists a function as a figure, and deterministic saving (no
pyplot state; no timestamp or version in the PNG, so a file changes only when the figure does)."""

from __future__ import annotations

import functools
import inspect
import math
from pathlib import Path
from typing import Callable

import matplotlib
import numpy as np
from matplotlib.animation import FuncAnimation, PillowWriter
from matplotlib.figure import Figure

from ...engine.constants import TISSUE_E

__all__ = ["lecture_figure", "save", "shown", "at_least", "whole_pixels", "matplotlib_note", "ANIMATION_MIN_WIDTH",
           "animation_figure", "save_animation", "frame_axes", "stress_label", "STRESS_UNITS", "boundary_faces",
           "surface_verts", "body_axes"]

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
    size = inches
    while math.floor(size * dpi) < pixels:
        size = math.nextafter(size, math.inf)
    return size


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


def animation_figure(figsize, top: float, xlim, ylim, title_y: float, fontsize: float):
    """``(fig, ax, title)`` of an animation: fixed axes with the held left edge drawn, and an empty title."""
    fig = Figure(figsize=figsize)
    ax = fig.add_axes([0.02, 0.02, 0.96, top])
    frame_axes(ax, xlim, ylim)
    ax.plot([0.0, 0.0], [0.0, 1.0], color="k", lw=4)
    return fig, ax, fig.text(0.5, title_y, "", ha="center", va="center", fontsize=fontsize)


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
    x = shown(np.asarray(x, dtype=float)[[0, 2, 1]], digits=5)
    return x[:, faces].transpose(2, 1, 0)


def body_axes(ax, xlim, ylim, zlim, elev: float = 22.0, azim: float = -58.0, zoom: float = 1.0) -> None:
    """A 3D axes for a body of tetrahedra: the body's x, z, y limits (y up), equal scales, a fixed view, no axes;
    ``zoom`` enlarges the drawing within the axes."""
    ax.set(xlim=xlim, ylim=zlim, zlim=ylim)
    ax.set_box_aspect((xlim[1] - xlim[0], zlim[1] - zlim[0], ylim[1] - ylim[0]), zoom=zoom)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
