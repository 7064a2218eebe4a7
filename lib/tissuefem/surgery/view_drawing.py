"""What a :class:`~tissuefem.surgery.interactive.SurgeryView` draws, and how it keeps within the frame budget.

The view's own figure (:func:`view_axes`) has its axes in a fixed place (no layout engine per frame) and is a
:class:`LayeredFigure`: it keeps the picture of what does not move (axes, ticks, labels) and per frame draws only the
moving layer over it: the triangles (:class:`MeshDrawing`: two compound paths whose vertex arrays are rewritten in
place), the drag target and the cut stroke. The :class:`Readout` above the axes shows the step *and* the draw against
the 33 ms budget and the frames drawn per second, at a readable pace; messages go under the axes, cut to two lines.
"""

from __future__ import annotations

import collections
import math
import textwrap
import threading
import time

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backend_bases import DrawEvent, TimerBase
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import PathPatch
from matplotlib.path import Path
from matplotlib.textpath import TextToPath

from ..engine.constants import FRAME_BUDGET

__all__ = ["LayeredFigure", "MeshDrawing", "Readout", "view_axes", "is_interactive", "is_gui", "FIGSIZE",
           "AXES_RECT", "MESSAGE_LINES", "KEYFRAME_S"]

FIGSIZE = (7.0, 4.5)  #: the size of a view's own figure, inches
#: where its axes sit (left, bottom, width, height; figure fractions): room above for the readout, below for the tick
#: labels and the message
AXES_RECT = (0.08, 0.15, 0.9, 0.77)
TEXT_SIZE = 8  #: font size (points) of the readout and the message
MESSAGE_LINES = 2  #: lines of a message at most (its full text stays in ``view.message``)
KEEP = 600  #: drawn frames kept for the frame rate and the draw times
KEYFRAME_S = 0.5  #: seconds between whole pictures pushed to a browser canvas (the others are differences)


def is_gui(canvas) -> bool:
    """Whether ``canvas`` belongs to a GUI toolkit (Qt, Tk): one that names its framework."""
    return getattr(type(canvas), "required_interactive_framework", None) is not None


def is_interactive(canvas) -> bool:
    """Whether ``canvas``'s timers fire and it redraws on screen: a GUI toolkit, or a browser backend (ipympl,
    WebAgg) with a working timer; Agg and inline have only the base timer, which never fires."""
    return is_gui(canvas) or type(canvas.new_timer()) is not TimerBase


def view_axes():
    """The axes of a view's own figure: a :class:`LayeredFigure` of ``FIGSIZE``, made with pyplot (under ``ioff``:
    ``display(view)`` shows it once, with its buttons; a non-interactive one leaves pyplot's list, so the inline
    backend never shows a frozen copy later)."""
    was_interactive = matplotlib.is_interactive()
    with plt.ioff():
        fig = plt.figure(figsize=FIGSIZE, FigureClass=LayeredFigure)
    if not is_interactive(fig.canvas):
        plt.close(fig)  # which leaves it a bare canvas: draw it with Agg, off-screen, as inline does
        FigureCanvasAgg(fig)
    elif was_interactive and is_gui(fig.canvas):
        fig.show()  # a GUI window, as pyplot would have shown it
    if hasattr(fig.canvas, "header_visible"):  # ipympl: no "Figure 1" title over the view
        fig.canvas.header_visible = False
    return fig.add_axes(AXES_RECT)


class LayeredFigure(Figure):
    """A figure that draws what does not move once and, per frame, only its moving layer over it.

    Three levels: the *background* (axes, ticks, labels), drawn only when the figure is stale or the renderer new;
    the *slow* layer (readout, message), drawn over it and kept with it when it changed, at most every
    ``slow_interval`` s unless :meth:`refresh_slow` asks (text costs more than a frame of triangles); and the *layer*
    (triangles, target, stroke), drawn over the kept picture at every draw. ``savefig`` draws everything. Each
    :class:`Readout` in ``readouts`` is told when a draw starts and ends.
    """

    slow_interval = 0.25

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.layer = []
        self.slow = []
        self.readouts = []
        self.full_draws = self.slow_draws = self.layer_draws = 0
        self._background = None  # (renderer key, region): the figure without its animated artists
        self._kept = None  # region: the background with the slow layer over it
        self._slow_at = -math.inf
        self._slow_now = False
        #: drawing and the views' changes to what is drawn happen one at a time (see SurgeryView)
        self.lock = threading.RLock()

    def animate(self, layer, slow, readout) -> None:
        """Draw ``layer`` at every draw and ``slow`` at a readable pace, over the kept picture."""
        for artist in (*layer, *slow):
            artist.set_animated(True)
        self.layer.extend(layer)
        self.slow.extend(slow)
        self.readouts.append(readout)

    def refresh_slow(self) -> None:
        """Draw the slow layer (its changed text) at the next draw, not after ``slow_interval``."""
        self._slow_now = True

    def draw(self, renderer):
        with self.lock:
            if self.canvas.is_saving():
                super().draw(renderer)  # axes draw their animated children when saving
                return
            started = time.perf_counter()
            for readout in self.readouts:
                readout.drawing_started(started)
            announced = self._draw_kept(renderer, started)
            for artist in self.layer:
                if artist.get_visible():
                    artist.draw(renderer)
            self.layer_draws += 1
            self.stale = False
            if not announced:
                self.canvas.callbacks.process("draw_event", DrawEvent("draw_event", self.canvas, renderer))
            rendered = time.perf_counter()
            for readout in self.readouts:
                readout.drawing_rendered(started, rendered)

    def _draw_kept(self, renderer, started) -> bool:
        """The picture under the layer: kept, or drawn anew; returns whether a full draw announced itself."""
        if not (hasattr(renderer, "copy_from_bbox") and hasattr(renderer, "restore_region")):
            super().draw(renderer)  # a renderer that cannot keep a picture: everything, every time
            self.full_draws += 1
            for artist in self.slow:
                artist.draw(renderer)
            return True
        key = (id(renderer), renderer.width, renderer.height, self.dpi)
        if self.stale or self._background is None or self._background[0] != key:
            super().draw(renderer)  # announces itself (draw_event)
            self._background = (key, renderer.copy_from_bbox(self.bbox))
            self.full_draws += 1
            self._draw_slow(renderer, started)
            return True
        if (self._slow_now or started - self._slow_at >= self.slow_interval) and any(a.stale for a in self.slow):
            renderer.restore_region(self._background[1])
            self._draw_slow(renderer, started)
        else:
            renderer.restore_region(self._kept)
        return False

    def _draw_slow(self, renderer, now) -> None:
        for artist in self.slow:
            if artist.get_visible():
                artist.draw(renderer)
            artist.stale = False
        self._kept = renderer.copy_from_bbox(self.bbox)
        self._slow_at, self._slow_now = now, False
        self.slow_draws += 1


class MeshDrawing:
    """The triangles in ``ax`` as two compound paths, faces and edges, whose vertex arrays are rewritten in place;
    fixed axis limits: the reference bounding box of ``mesh`` with a margin (dragged tissue stays in view)."""

    def __init__(self, ax, mesh):
        X = np.asarray(mesh.p, dtype=float)
        lo, hi = X.min(axis=1), X.max(axis=1)
        margin = 0.3 * float(np.max(hi - lo))
        ax.set_xlim(lo[0] - margin, hi[0] + margin)
        ax.set_ylim(lo[1] - margin, hi[1] + margin)
        ax.set_aspect("equal", adjustable="box")
        ax.set_autoscale_on(False)
        self.faces = PathPatch(Path(np.zeros((1, 2))), facecolor="mistyrose", edgecolor="none", zorder=1)
        self.edges = PathPatch(Path(np.zeros((1, 2))), fill=False, edgecolor="firebrick", linewidth=0.3,
                               zorder=1.1)
        ax.add_patch(self.faces)
        ax.add_patch(self.edges)

    def rebuild(self, picture, x) -> None:
        """New paths for a new mesh: what ``picture`` (``Simulation.picture``) draws, at node positions ``x``."""
        self._picture = picture
        t = np.asarray(picture.triangles, dtype=np.intp)
        edges = np.asarray(picture.edges, dtype=np.intp)
        # each triangle as MOVETO a, LINETO b, LINETO c, CLOSEPOLY (its vertex is ignored); each edge as MOVETO, LINETO
        self._face_nodes = t[[0, 1, 2, 0]].T.ravel()
        self._edge_nodes = edges.T.ravel()
        face_codes = np.tile(np.array([Path.MOVETO, Path.LINETO, Path.LINETO, Path.CLOSEPOLY], Path.code_type),
                             t.shape[1])
        edge_codes = np.tile(np.array([Path.MOVETO, Path.LINETO], Path.code_type), edges.shape[1])
        self._face_xy = np.zeros((self._face_nodes.size, 2))
        self._edge_xy = np.zeros((self._edge_nodes.size, 2))
        faces, lines = Path(self._face_xy, face_codes), Path(self._edge_xy, edge_codes)
        lines.should_simplify = False  # every edge drawn, however short
        # the in-place update needs paths that hold the arrays themselves; if a matplotlib ever copies, copy too
        self._in_place = bool(np.shares_memory(faces.vertices, self._face_xy)
                              and np.shares_memory(lines.vertices, self._edge_xy))
        self.faces.set_path(faces)
        self.edges.set_path(lines)
        self.fill(x)

    def fill(self, x) -> None:
        """Move the drawn triangles to node positions ``x`` ``(2, n_nodes)``."""
        self.x = x
        xt = self._picture.points(x).T
        np.take(xt, self._face_nodes, axis=0, out=self._face_xy)
        np.take(xt, self._edge_nodes, axis=0, out=self._edge_xy)
        if not self._in_place:
            self.faces.set_path(Path(self._face_xy.copy(), self.faces.get_path().codes))
            self.edges.set_path(Path(self._edge_xy.copy(), self.edges.get_path().codes))
        self.faces.stale = self.edges.stale = True

    def triangles(self) -> np.ndarray:
        """The drawn triangles' corners ``(n_triangles, 3, 2)``, as the faces' path holds them."""
        return self.faces.get_path().vertices.reshape(-1, 4, 2)[:, :3, :]


def budget(report) -> float:
    """The frame budget (s) of a frame's report, or ``FRAME_BUDGET``."""
    value = FRAME_BUDGET if report is None else float(getattr(report, "budget", FRAME_BUDGET))
    return value if math.isfinite(value) and value > 0 else FRAME_BUDGET


def _ms(value) -> str:
    return "  --" if value is None else f"{value:4.1f}"


class Readout:
    """A view's two lines of text and its timings.

    The readout above the axes (mode, frame, step + draw against the budget, frames per second, the solver's status)
    and the message (at the figure's foot, or inside axes of your own); both out of any layout, so they never move
    the axes. ``on_draw`` is called when a draw starts. On a browser canvas, which sends each picture to every
    listener in ``manager.web_sockets``, the readout listens too (:meth:`send_binary`): a draw's time includes it.
    """

    def __init__(self, ax, own_figure, on_draw):
        self.ax, self.fig, self.own_figure, self._on_draw = ax, ax.figure, own_figure, on_draw
        text = dict(ha="left", fontsize=TEXT_SIZE, family="monospace", clip_on=False, in_layout=False)
        if own_figure:
            self.status_text = ax.text(0.05, 0.985, "", transform=self.fig.transFigure, va="top", **text)
            self.message_text = ax.text(0.05, 0.012, "", transform=self.fig.transFigure, va="bottom",
                                        color="firebrick", **text)
        else:
            self.status_text = ax.text(0.0, 1.02, "", transform=ax.transAxes, va="bottom", **text)
            self.message_text = ax.text(0.01, 0.01, "", transform=ax.transAxes, va="bottom", color="firebrick",
                                        **text)
        self.frame_times: list[float] = []
        self.draw_times: list[float] = []
        self.drawn_at = collections.deque(maxlen=KEEP)
        self.offscreen = False  # a draw that sends nothing (SurgeryView.draw)
        self._started = None  # when the draw in progress started
        self._key = None  # the mode and message shown
        self._sockets = getattr(getattr(self.fig.canvas, "manager", None), "web_sockets", None)
        if not (isinstance(self.fig, LayeredFigure) and isinstance(self._sockets, (list, set))):
            self._sockets = None
        elif isinstance(self._sockets, list):  # ipympl keeps a list, WebAgg a set
            self._sockets.append(self)
        else:
            self._sockets.add(self)

    @property
    def sends(self) -> bool:
        """Whether the canvas sends its pictures to a page (the readout is listening)."""
        return self._sockets is not None

    def stop_listening(self) -> None:
        if self._sockets is not None and self in self._sockets:
            self._sockets.remove(self)
        self._sockets = None

    def update(self, mode: str, message: str, report, frames: int) -> None:
        """Show ``mode``, the frame's ``report`` (``None`` before the first: ``frames`` and "ready") and ``message``."""
        if report is None:
            frame, step, status = int(frames), None, "ready"
        else:
            frame, step, status = int(report.frame), 1e3 * float(report.elapsed), str(report.status)
        draw = self.draw_times[-1] if self.draw_times else None
        fps = self.frames_per_second()
        total = None if step is None or draw is None else step + draw
        self.status_text.set_text(
            f"{mode:4s} | frame {frame:5d} | step {_ms(step)} + draw {_ms(draw)} = {_ms(total)} "
            f"/ {1e3 * budget(report):.0f} ms | {'--' if fps is None else f'{fps:.0f}':>2s} fps | {status}")
        self.message_text.set_text(self._wrapped(message))
        if isinstance(self.fig, LayeredFigure) and (mode, message) != self._key:
            self.fig.refresh_slow()  # a new mode or message shows at once; the numbers at a readable pace
        self._key = (mode, message)

    def _wrapped(self, message: str) -> str:
        """The message wrapped to the width it has, at most two lines (a longer one ends in ' ...')."""
        if not message:
            return ""
        # from 5 % into the view's own figure to 1 % before its edge, or 1 % to 98 % of axes of your own
        fraction = 0.94 if self.own_figure else 0.97 * self.ax.get_position().width
        sample = "0" * 40
        prop = self.message_text.get_fontproperties()
        get_renderer = getattr(self.fig.canvas, "get_renderer", None)
        if callable(get_renderer):  # pixels, as this renderer rounds the advance of each glyph
            char = get_renderer().get_text_width_height_descent(sample, prop, ismath=False)[0] / len(sample)
            space = fraction * self.fig.bbox.width
        else:  # points of the font's outline, with room for rounding
            char = 1.1 * TextToPath().get_text_width_height_descent(sample, prop, ismath=False)[0] / len(sample)
            space = fraction * self.fig.get_figwidth() * 72.0
        return textwrap.fill(" ".join(message.split()), width=max(20, int(space / char)), max_lines=MESSAGE_LINES,
                             placeholder=" ...")

    # ------------------------------------------------------------------ timing the draws
    def drawing_started(self, started) -> None:
        self._started = started
        self._on_draw()

    def drawing_rendered(self, started, rendered) -> None:
        if not self.sends or self.offscreen:  # nothing to send: the draw ends with the rendering
            self._record(started, rendered)

    def send_json(self, content) -> None:
        pass

    def send_binary(self, blob) -> None:
        """The canvas sent a picture to the page: the draw in progress ends now."""
        if self._started is not None:
            self._record(self._started, time.perf_counter())

    def _record(self, started, ended) -> None:
        self.draw_times.append(1e3 * (ended - started))
        if len(self.draw_times) > 2 * KEEP:
            del self.draw_times[:KEEP]
        self.drawn_at.append(ended)
        self._started = None

    def frames_per_second(self, window=1.0) -> float | None:
        """Pictures drawn per second over the last ``window`` seconds (``None`` before two draws)."""
        if len(self.drawn_at) < 2:
            return None
        now = time.perf_counter()
        recent = [t for t in self.drawn_at if t >= now - window]
        if len(recent) < 2:
            return 0.0 if now - self.drawn_at[-1] > window else None
        return (len(recent) - 1) / max(recent[-1] - recent[0], 1e-9)

    def timings(self, report, last=None) -> dict:
        """Medians of the step and the draw (ms), their sum, and the frames drawn per second (of the ``last`` ones)."""
        steps = self.frame_times[-last:] if last else self.frame_times
        draws = self.draw_times[-last:] if last else self.draw_times
        step = float(np.median(steps)) if steps else None
        draw = float(np.median(draws)) if draws else None
        return {"frames": len(self.frame_times), "draws": len(self.draw_times), "step_ms": step, "draw_ms": draw,
                "total_ms": None if step is None or draw is None else step + draw,
                "budget_ms": 1e3 * budget(report), "fps": self.frames_per_second()}
