"""Operate on a running simulation with the mouse: drag the tissue and cut it, in any matplotlib figure.

A :class:`SurgeryView` puts a :class:`tissuefem.surgery.simulation.Simulation` in a matplotlib ``Axes`` and
turns mouse events into the simulation's input, the *input* step of the notes' frame loop (read the user,
solve, render, every 1/30 s):

* **drag** mode (the default): a left-button press on the tissue grabs the nodes within ``radius`` of the
  pointer (:meth:`Simulation.grab`), moving the mouse with the button held drags them
  (:meth:`Simulation.drag`), and letting go releases them;
* **cut** mode: a left-button stroke draws a polyline, which becomes an incision (:meth:`Simulation.cut`)
  when the button is released; the drawing is rebuilt for the new topology.

The mode buttons, the key ``c`` (once the figure has the keyboard) and ``view.mode = "cut"`` switch modes.
A timer of the canvas runs one frame every ``interval_ms`` (:meth:`SurgeryView.step`: ``sim.frame()``, then
a redraw is requested), but only on an interactive canvas (``%matplotlib widget``, a Qt or Tk window); on
Agg or the inline backend code calls :meth:`~SurgeryView.step` and, to time the drawing too,
:meth:`~SurgeryView.draw`. So the same cells run in a browser with the mouse and headless in the tests.

**Drawing within the frame budget.** The readout above the axes shows the step *and* the draw against the
33 ms budget, and the frames drawn per second. The axes have a fixed place (no layout engine runs per
frame), and the view's own figure draws what does not move (axes, ticks, labels) once and keeps that
picture; per frame it restores it and draws only the moving layer: the triangles (one compound path for
the faces and one for the edges, whose vertex arrays are rewritten in place), the drag target and the cut
stroke. The two lines of text change at a readable pace (a new message at once); messages go to a fixed
place under the axes, cut to two lines, so they never move the axes. Mouse events only change the state:
while the timer runs, its next frame draws it. On a browser canvas (ipympl) the timer sends each frame's
picture itself, with no request from the page; Qt and Tk are asked to redraw and coalesce the requests.

**One live view per simulation and per notebook cell.** A new view of the same simulation stops the old
one; re-running the cell that made a view closes the old view (its timer would keep stepping otherwise).

:func:`synthetic_mouse` and :func:`synthetic_key` send a made-up event through the canvas's callbacks, as
a backend would, so a notebook can show a drag or a cut without a mouse (and the tests can check it).
Nothing here needs ipympl or ipywidgets; with ipywidgets the view shows buttons for the mode and the
timer (:meth:`SurgeryView.widget`).
"""

from __future__ import annotations

import asyncio
import base64
import collections
import functools
import io
import math
import textwrap
import threading
import time
import weakref

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from IPython import get_ipython
from IPython.display import display
from matplotlib.backend_bases import DrawEvent, KeyEvent, MouseButton, MouseEvent, TimerBase
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import PathPatch
from matplotlib.path import Path
from matplotlib.textpath import TextToPath

from ..engine.meshes import mean_edge_length
from ..engine.realtime import FRAME_BUDGET
from ..engine.terms import check_positive

__all__ = ["SurgeryView", "MODES", "synthetic_mouse", "synthetic_key", "mean_edge_length"]

#: the interaction modes of a :class:`SurgeryView`
MODES = ("drag", "cut")

#: the size of a view's own figure, inches
FIGSIZE = (7.0, 4.5)
#: where the axes sit in a view's own figure (left, bottom, width, height; figure fractions): room
#: above for the readout, below for the tick labels and two lines of message
AXES_RECT = (0.08, 0.15, 0.9, 0.77)
#: font size (points) of the readout and the message
TEXT_SIZE = 8
#: lines of a message at most (a longer one is cut, its full text stays in ``view.message``)
MESSAGE_LINES = 2
#: drawn frames kept for the frame rate and the draw times
_KEEP = 600
#: seconds between whole pictures pushed to a browser canvas (the others are differences)
KEYFRAME_S = 0.5

_MOUSE_EVENTS = {"press": "button_press_event", "move": "motion_notify_event", "release": "button_release_event"}

#: every view not yet disconnected, to stop the one a new view replaces
_VIEWS: weakref.WeakSet = weakref.WeakSet()


def _is_interactive(canvas) -> bool:
    """Whether ``canvas`` belongs to an interactive backend: one whose timers fire and that redraws on screen.

    A GUI toolkit (Qt, Tk) names its framework; a browser backend (ipympl, WebAgg) has a working timer;
    Agg and the inline backend have only the base timer, which never fires.
    """
    if getattr(type(canvas), "required_interactive_framework", None) is not None:
        return True
    return type(canvas.new_timer()) is not TimerBase


def _cell_origin():
    """Which notebook cell is running, and which run of it: ``(cell, execution count)``, or ``None``.

    The cell is the id the front-end sends with each execution (JupyterLab and nbclient do), else its source.
    """
    shell = get_ipython()
    if shell is None:
        return None
    cell = None
    get_parent = getattr(getattr(shell, "kernel", None), "get_parent", None)
    if callable(get_parent):
        try:
            parent = get_parent("shell")
        except TypeError:
            parent = get_parent()
        metadata = (parent or {}).get("metadata") or {}
        if metadata.get("cellId"):
            cell = "id:" + str(metadata["cellId"])
    if cell is None:
        history = getattr(getattr(shell, "history_manager", None), "input_hist_raw", None)
        if history:
            cell = "source:" + history[-1]
    return None if cell is None else (cell, getattr(shell, "execution_count", None))


class _LayeredFigure(Figure):
    """A figure that draws what does not move once and, per frame, only its moving layer over it.

    Three levels: the *background* (axes, ticks, labels), drawn in full only when the figure is stale or
    the renderer is new (size, resolution); the *slow* layer (the readout and the message), drawn over it
    and kept with it, when one of its artists changed and at most every ``slow_interval`` seconds unless
    :meth:`refresh_slow` asks for it at once (text glyph by glyph costs more than a frame of triangles);
    and the *layer* (triangles, target, stroke), drawn over the kept picture at every draw. ``savefig``
    always draws everything.
    """

    slow_interval = 0.25

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.layer = []
        self.slow = []
        self.views = []
        self.full_draws = 0
        self.slow_draws = 0
        self.layer_draws = 0
        self._background = None  # (renderer key, region): the figure without its animated artists
        self._kept = None  # region: the background with the slow layer over it
        self._slow_at = -math.inf
        self._slow_now = False
        #: drawing and the views' changes to what is drawn happen one at a time (see SurgeryView)
        self.lock = threading.RLock()

    def refresh_slow(self) -> None:
        """Draw the slow layer (its changed text) at the next draw, not after ``slow_interval``."""
        self._slow_now = True

    def draw(self, renderer):
        with self.lock:
            self._draw(renderer)

    def _draw(self, renderer):
        if self.canvas.is_saving():
            super().draw(renderer)  # axes draw their animated children when saving
            return
        started = time.perf_counter()
        for view in self.views:
            view._drawing_started(started)
        announced = False
        if hasattr(renderer, "copy_from_bbox") and hasattr(renderer, "restore_region"):
            key = (id(renderer), renderer.width, renderer.height, self.dpi)
            if self.stale or self._background is None or self._background[0] != key:
                super().draw(renderer)  # announces itself (draw_event)
                announced = True
                self._background = (key, renderer.copy_from_bbox(self.bbox))
                self.full_draws += 1
                self._draw_slow(renderer, started)
            elif (self._slow_now or started - self._slow_at >= self.slow_interval) and any(
                    a.stale for a in self.slow):
                renderer.restore_region(self._background[1])
                self._draw_slow(renderer, started)
            else:
                renderer.restore_region(self._kept)
        else:  # a renderer that cannot keep a picture: everything, every time
            super().draw(renderer)
            announced = True
            self.full_draws += 1
            for artist in self.slow:
                artist.draw(renderer)
        for artist in self.layer:
            if artist.get_visible():
                artist.draw(renderer)
        self.layer_draws += 1
        self.stale = False
        if not announced:
            self.canvas.callbacks.process("draw_event", DrawEvent("draw_event", self.canvas, renderer))
        rendered = time.perf_counter()
        for view in self.views:
            view._drawing_rendered(started, rendered)

    def _draw_slow(self, renderer, now) -> None:
        for artist in self.slow:
            if artist.get_visible():
                artist.draw(renderer)
            artist.stale = False
        self._kept = renderer.copy_from_bbox(self.bbox)
        self._slow_at, self._slow_now = now, False
        self.slow_draws += 1


class _SentImages:
    """Listens, next to the page, to what a browser canvas (ipympl, WebAgg) sends: each picture's end time.

    The canvas sends each encoded picture to every listener in ``manager.web_sockets``; this one notes the
    time, so a draw's time includes the encoding.
    """

    def __init__(self, view):
        self._view = weakref.ref(view)

    def send_json(self, content):
        pass

    def send_binary(self, blob):
        view = self._view()
        if view is not None:
            view._picture_sent(time.perf_counter(), len(blob))


def _one_at_a_time(method):
    """Run ``method`` holding the view's lock: a frame, an event and a draw never interleave.

    A kernel may handle a widget's messages on another thread than the timer's loop (ipykernel 7 routes a
    comm's messages to the subshell that last used it): a cut could otherwise rebuild the mesh mid-frame.
    """

    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)

    return locked


class SurgeryView:
    """A simulation drawn in a matplotlib ``Axes``, operated on with the mouse.

    Parameters
    ----------
    sim : tissuefem.surgery.simulation.Simulation
        The running simulation (anything with ``mesh``, ``positions``, ``frame``, ``grab``, ``drag``,
        ``release`` and ``cut``).
    ax : matplotlib.axes.Axes, optional
        Where to draw; default the view's own figure (7 x 4.5 inches, made with pyplot: under
        ``%matplotlib widget`` the interactive widget), which redraws only the moving layer per frame.
        In an ``ax`` of your own figure every redraw draws the whole figure.
    radius : float, optional
        A press grabs the nodes within this distance of the pointer; default twice the mean edge length.
    interval_ms : int, default 33
        Milliseconds between timer frames (33 ms: the notes' 30 frames per second).
    autostart : bool, default True
        Start the timer as soon as the view is on screen: at once in a GUI window (Qt, Tk), when displayed
        in Jupyter; never by itself on a non-interactive canvas (Agg, inline).

    Attributes
    ----------
    frame_times : list of float
        Milliseconds of every frame run through :meth:`step` (``report.elapsed``).
    draw_times : list of float
        Milliseconds of each drawn picture of the view's own figure (the last few hundred), until the
        picture is done: on a browser canvas, encoded and sent to the page.
    last_report : FrameReport or None
    message : str
        The last message (a failed cut, a rejected drag), or ``""``; shown under the axes, at most two lines.
    mesh_faces, mesh_edges : matplotlib.patches.PathPatch
        The triangles (one compound path each); rebuilt when the topology changes.
    stroke_artist, target_artist : matplotlib.lines.Line2D
        The cut stroke being drawn; the drag target (at the mouse).
    status_text, message_text : matplotlib.text.Text
        The readout above the axes (mode, frame, step + draw against the budget, frames drawn per
        second, the solver's status); the message, in a fixed place under the axes.

    Notes
    -----
    Press and motion events outside the axes are ignored, and clicks while the toolbar's pan or zoom tool
    is active; a release anywhere ends the current grab or stroke, so a handle never stays stuck to a mouse
    that left the axes. A grab made in code (a :func:`synthetic_mouse` press) is not carried on by the real
    mouse moving, nor a real grab by made-up moves; a real press replaces it. A ``ValueError`` raised by
    the simulation in an event handler or a timer frame is shown as the message instead of propagating.
    The key ``c`` is also the toolbar's default "back" key, which only matters after zooming.

    Examples
    --------
    >>> from tissuefem.surgery.scene import demo_scene
    >>> from tissuefem.surgery.simulation import Simulation
    >>> view = SurgeryView(Simulation(demo_scene(n_triangles=400)), autostart=False)
    >>> _ = synthetic_mouse(view, "press", (1.95, 0.5))   # grab the right edge
    >>> _ = synthetic_mouse(view, "move", (2.2, 0.7))     # drag it
    >>> report = view.step()                              # one frame: the tissue follows
    >>> _ = synthetic_mouse(view, "release", (2.2, 0.7))
    """

    def __init__(self, sim, ax=None, radius=None, interval_ms=33, autostart=True):
        missing = [m for m in ("mesh", "positions", "frame", "grab", "drag", "release", "cut") if not hasattr(sim, m)]
        if missing:
            raise ValueError("sim must be a tissuefem.surgery.simulation.Simulation; "
                             f"{type(sim).__name__} has no {missing}")
        radius = check_positive("radius", 2.0 * mean_edge_length(sim.mesh) if radius is None else radius)
        if isinstance(interval_ms, bool) or not isinstance(interval_ms, (int, np.integer)) or interval_ms < 1:
            raise ValueError(f"interval_ms must be a positive integer (milliseconds), got {interval_ms!r}")
        self.sim = sim
        self.radius = radius
        self.interval_ms = int(interval_ms)
        self.autostart = bool(autostart)

        self.owns_figure = ax is None
        if ax is None:
            ax = self._new_figure()
        self.ax = ax
        self.fig = ax.figure
        self.canvas = self.fig.canvas
        self.interactive = _is_interactive(self.canvas)
        self._layered = isinstance(self.fig, _LayeredFigure)
        self._lock = self.fig.lock if self._layered else threading.RLock()
        # the loop (and its thread) that runs the timer: a start or stop asked from elsewhere goes there
        try:
            self._loop = asyncio.get_running_loop()
        except RuntimeError:
            self._loop = None
        self._loop_thread = threading.get_ident()

        self.frame_times: list[float] = []
        self.draw_times: list[float] = []
        self._drawn_at = collections.deque(maxlen=_KEEP)
        self._draw_started = None
        self._offscreen = False
        self._keyframe_at = -math.inf
        self.last_report = None
        self.message = ""
        self._mode = "drag"
        self._handle = None  # name of the grabbed handle
        self._real_press = False  # whether the grab or stroke began with a real press (a GUI event) or in code
        self._stroke: list[np.ndarray] | None = None  # the cut polyline being drawn
        self.stroke_spacing = 0.25 * mean_edge_length(sim.mesh)
        self._timer = None
        self._running = False
        self._widgets = None
        self._box = None
        self._text_key = None
        self.closed = False

        # fixed axis limits: the reference bounding box with a margin (dragged tissue stays in view)
        X = np.asarray(sim.mesh.p, dtype=float)
        lo, hi = X.min(axis=1), X.max(axis=1)
        margin = 0.3 * float(np.max(hi - lo))
        ax.set_xlim(lo[0] - margin, hi[0] + margin)
        ax.set_ylim(lo[1] - margin, hi[1] + margin)
        ax.set_aspect("equal", adjustable="box")
        ax.set_autoscale_on(False)

        self.mesh_faces = PathPatch(Path(np.zeros((1, 2))), facecolor="mistyrose", edgecolor="none", zorder=1)
        self.mesh_edges = PathPatch(Path(np.zeros((1, 2))), fill=False, edgecolor="firebrick", linewidth=0.3,
                                    zorder=1.1)
        ax.add_patch(self.mesh_faces)
        ax.add_patch(self.mesh_edges)
        (self.stroke_artist,) = ax.plot([], [], "-", color="k", lw=1.2, zorder=3)
        (self.target_artist,) = ax.plot([], [], "o", ms=7, mfc="none", mec="tab:blue", mew=1.5, zorder=3)
        # the readout and the message in fixed places, left out of any layout (they never move the axes): above
        # the axes, and at the foot of the view's own figure (under the tick labels) or inside axes of your own
        text = dict(ha="left", fontsize=TEXT_SIZE, family="monospace", clip_on=False, in_layout=False)
        if self.owns_figure:
            self.status_text = ax.text(0.05, 0.985, "", transform=self.fig.transFigure, va="top", **text)
            self.message_text = ax.text(0.05, 0.012, "", transform=self.fig.transFigure, va="bottom",
                                        color="firebrick", **text)
        else:
            self.status_text = ax.text(0.0, 1.02, "", transform=ax.transAxes, va="bottom", **text)
            self.message_text = ax.text(0.01, 0.01, "", transform=ax.transAxes, va="bottom", color="firebrick",
                                        **text)
        self._moving = [self.mesh_faces, self.mesh_edges, self.stroke_artist, self.target_artist,
                        self.status_text, self.message_text]
        if self._layered:
            for artist in self._moving:
                artist.set_animated(True)
            self.fig.layer.extend(self._moving[:4])
            self.fig.slow.extend(self._moving[4:])
            self.fig.views.append(self)
        self._rebuild()
        self._update_text()

        self._sent_images = None
        sockets = getattr(getattr(self.canvas, "manager", None), "web_sockets", None)
        if self._layered and isinstance(sockets, (list, set)):
            self._sent_images = _SentImages(self)
            if isinstance(sockets, list):  # ipympl keeps a list, WebAgg a set
                sockets.append(self._sent_images)
            else:
                sockets.add(self._sent_images)

        handlers = {"button_press_event": self._on_press, "motion_notify_event": self._on_motion,
                    "button_release_event": self._on_release, "key_press_event": self._on_key,
                    "close_event": self._on_close}
        self._cids = [self.canvas.mpl_connect(name, handler) for name, handler in handlers.items()]
        self._origin = _cell_origin()
        self._replace_older_views()
        _VIEWS.add(self)
        if self.autostart and self.interactive and getattr(type(self.canvas), "required_interactive_framework", None):
            self.start()  # a GUI window is on screen as soon as it is shown; a notebook view starts when displayed

    def _new_figure(self):
        # under plt.ioff() pyplot does not show the figure by itself at the end of the cell: the view is
        # shown once, with its buttons, by display(view); a non-interactive figure leaves pyplot's list
        # at once, so the inline backend never shows a frozen copy of it later
        was_interactive = matplotlib.is_interactive()
        with plt.ioff():
            fig = plt.figure(figsize=FIGSIZE, FigureClass=_LayeredFigure)
        if not _is_interactive(fig.canvas):
            plt.close(fig)  # which leaves it a bare canvas: draw it with Agg, off-screen, as inline does
            FigureCanvasAgg(fig)
        elif was_interactive and getattr(type(fig.canvas), "required_interactive_framework", None):
            fig.show()  # a GUI window, as pyplot would have shown it
        if hasattr(fig.canvas, "header_visible"):  # ipympl: no "Figure 1" title over the view
            fig.canvas.header_visible = False
        return fig.add_axes(AXES_RECT)

    def _replace_older_views(self) -> None:
        for old in list(_VIEWS):
            if old is self or old.closed:
                continue
            if old.sim is self.sim:
                old.disconnect()
                old._show("stopped: a newer view drives this simulation")
            elif (self._origin is not None and old._origin is not None and old._origin[0] == self._origin[0]
                  and old._origin[1] != self._origin[1]):
                old.close()  # its cell was run again: its output is gone

    # ------------------------------------------------------------------ mode
    @property
    def mode(self) -> str:
        """``"drag"`` or ``"cut"``. Switching ends a grab (released) or drops a stroke in progress."""
        return self._mode

    @mode.setter
    @_one_at_a_time
    def mode(self, value):
        if value not in MODES:
            raise ValueError(f"mode must be one of {MODES}, got {value!r}")
        if value == self._mode:
            return
        self._end_grab()
        self._stroke = None
        self.stroke_artist.set_data([], [])
        self._mode = value
        if self._widgets is not None and self._widgets[0].value != value:
            self._widgets[0].value = value
        self._update_text()
        self._request_draw()

    @property
    def grabbed(self):
        """The name of the grabbed handle, or ``None``."""
        return self._handle

    @property
    def stroke(self):
        """The cut stroke being drawn, ``(k, 2)``, or ``None``."""
        return None if self._stroke is None else np.array(self._stroke)

    @property
    def drawn_positions(self) -> np.ndarray:
        """The node positions ``(2, n_nodes)`` the triangles are drawn at (set by the last frame)."""
        return self._x

    def triangles(self) -> np.ndarray:
        """The drawn triangles' corners ``(n_triangles, 3, 2)``, as the faces' path holds them."""
        return self.mesh_faces.get_path().vertices.reshape(-1, 4, 2)[:, :3, :]

    # ------------------------------------------------------------------ frames and the timer
    @_one_at_a_time
    def step(self):
        """Run one frame (``sim.frame()``), record its time and request a redraw; returns the frame's report."""
        report = self.sim.frame()
        self.last_report = report
        self.frame_times.append(1e3 * float(report.elapsed))
        self._refresh()
        return report

    @_one_at_a_time
    def draw(self) -> float | None:
        """Render the picture now, off-screen, and return how long it took (ms; ``None`` if not timed).

        This times the drawing of frames that code steps (the timer would have drawn each one). It renders
        into the canvas's buffer and sends or paints nothing, so unlike the live readout on a browser canvas
        it leaves out the encoding. Timed in the view's own figure only.
        """
        n = len(self.draw_times)
        if isinstance(self.canvas, FigureCanvasAgg):
            self._offscreen = True
            try:
                FigureCanvasAgg.draw(self.canvas)
            finally:
                self._offscreen = False
        else:
            self.canvas.draw()
        return self.draw_times[-1] if len(self.draw_times) > n else None

    def _elsewhere(self, method) -> bool:
        """Hand ``method`` to the timer's loop if called from another thread (a button's message, say)."""
        if self._loop is not None and threading.get_ident() != self._loop_thread and not self._loop.is_closed():
            self._loop.call_soon_threadsafe(method)
            return True
        return False

    def start(self) -> None:
        """Start the timer that calls :meth:`step` every ``interval_ms`` (on any canvas, when called)."""
        if self._elsewhere(self.start):
            return
        if self.closed:
            raise ValueError("this view is disconnected (replaced or closed): make a new SurgeryView")
        if self._timer is None:
            self._timer = self.canvas.new_timer(interval=self.interval_ms)
            self._timer.add_callback(self._on_timer)
        if not self._running:
            self._timer.start()
            self._running = True
            self._sync_widgets()

    def stop(self) -> None:
        """Stop the timer (a frame in progress finishes)."""
        if self._elsewhere(self.stop):
            return
        if self._timer is not None and self._running:
            self._timer.stop()
        self._running = False
        self._sync_widgets()

    @property
    def running(self) -> bool:
        """Whether the timer is running."""
        return self._running

    @_one_at_a_time
    def disconnect(self) -> None:
        """Stop the timer and detach every event handler (the figure stays as it is)."""
        self.stop()
        self._end_grab()
        for cid in self._cids:
            self.canvas.mpl_disconnect(cid)
        self._cids = []
        if self._sent_images is not None:
            sockets = getattr(getattr(self.canvas, "manager", None), "web_sockets", None)
            if sockets is not None and self._sent_images in sockets:
                sockets.remove(self._sent_images)
            self._sent_images = None
        if self._widgets is not None:
            for w in self._widgets[:2]:
                w.disabled = True
        self.closed = True
        _VIEWS.discard(self)

    def close(self) -> None:
        """Disconnect, and close the view's own figure (its widget and its place in pyplot's list)."""
        self.disconnect()
        if self.owns_figure:
            plt.close(self.fig)

    def _on_close(self, event):
        self.disconnect()

    @_one_at_a_time
    def _on_timer(self):
        if self.closed:  # a stop handed to the loop has not arrived yet
            return
        try:
            self.step()
        except ValueError as exc:
            self._show(f"frame failed: {exc}")
        except Exception:
            self.stop()  # one traceback, not thirty a second
            raise
        if self._sent_images is not None:
            self._push_picture()
        else:
            self._ask_canvas()

    def _push_picture(self) -> None:
        """Render and send the frame's picture to the page now (a browser canvas: ipympl, WebAgg).

        The page's protocol asks for each picture with a message to the kernel (a request and two kernel
        status changes the page redraws, per frame); pushing from the timer saves that round trip. Pictures
        are differences to the last one and the page drops those that arrive faster than it decodes, so
        every ``KEYFRAME_S`` seconds a whole picture repairs what a dropped difference left behind.
        """
        now = time.perf_counter()
        if now - self._keyframe_at >= KEYFRAME_S and hasattr(self.canvas, "_force_full"):
            self.canvas._force_full = True  # WebAgg's flag for a whole picture (as after a page refresh)
            self._keyframe_at = now
        self.canvas.draw()

    def timings(self, last=None) -> dict:
        """Medians of the step and the draw (ms), their sum, and the frames drawn per second (of the ``last`` ones)."""
        steps = self.frame_times[-last:] if last else self.frame_times
        draws = self.draw_times[-last:] if last else self.draw_times
        step = float(np.median(steps)) if steps else None
        draw = float(np.median(draws)) if draws else None
        return {
            "frames": len(self.frame_times),
            "draws": len(self.draw_times),
            "step_ms": step,
            "draw_ms": draw,
            "total_ms": None if step is None or draw is None else step + draw,
            "budget_ms": 1e3 * self._budget(),
            "fps": self.frames_per_second(),
        }

    def frames_per_second(self, window=1.0) -> float | None:
        """Pictures drawn per second over the last ``window`` seconds (``None`` before two draws)."""
        if len(self._drawn_at) < 2:
            return None
        now = time.perf_counter()
        recent = [t for t in self._drawn_at if t >= now - window]
        if len(recent) < 2:
            return 0.0 if now - self._drawn_at[-1] > window else None
        return (len(recent) - 1) / max(recent[-1] - recent[0], 1e-9)

    # ------------------------------------------------------------------ drawing
    def _rebuild(self) -> None:
        """New paths for a new mesh: the faces' and the edges' vertex arrays, rewritten in place per frame."""
        self._mesh = self.sim.mesh
        # what to draw: the triangles, or, for elements cut through, their material (Simulation.picture)
        self._picture = self.sim.picture
        t = np.asarray(self._picture.triangles, dtype=np.intp)
        edges = np.asarray(self._picture.edges, dtype=np.intp)
        # each triangle as MOVETO a, LINETO b, LINETO c, CLOSEPOLY (its vertex is ignored); each edge as MOVETO, LINETO
        self._face_nodes = t[[0, 1, 2, 0]].T.ravel()
        self._edge_nodes = edges.T.ravel()
        face_codes = np.tile(np.array([Path.MOVETO, Path.LINETO, Path.LINETO, Path.CLOSEPOLY], Path.code_type),
                             t.shape[1])
        edge_codes = np.tile(np.array([Path.MOVETO, Path.LINETO], Path.code_type), edges.shape[1])
        self._faces = np.zeros((self._face_nodes.size, 2))
        self._edges = np.zeros((self._edge_nodes.size, 2))
        faces, lines = Path(self._faces, face_codes), Path(self._edges, edge_codes)
        lines.should_simplify = False  # every edge drawn, however short
        # the in-place update needs paths that hold the arrays themselves; if a matplotlib ever copies, copy too
        self._views = bool(np.shares_memory(faces.vertices, self._faces)
                           and np.shares_memory(lines.vertices, self._edges))
        self.mesh_faces.set_path(faces)
        self.mesh_edges.set_path(lines)
        self._fill(np.asarray(self.sim.positions(), dtype=float))

    def _fill(self, x) -> None:
        self._x = x
        xt = self._picture.points(x).T
        np.take(xt, self._face_nodes, axis=0, out=self._faces)
        np.take(xt, self._edge_nodes, axis=0, out=self._edges)
        if not self._views:
            self.mesh_faces.set_path(Path(self._faces.copy(), self.mesh_faces.get_path().codes))
            self.mesh_edges.set_path(Path(self._edges.copy(), self.mesh_edges.get_path().codes))
        self.mesh_faces.stale = True
        self.mesh_edges.stale = True

    def _refresh(self) -> None:
        """After a frame or a topology change: new vertex data (new paths only after a cut), then a redraw."""
        x = np.asarray(self.sim.positions(), dtype=float)
        if self.sim.mesh is not self._mesh or x.shape != self._x.shape:
            self._rebuild()
        else:
            self._fill(x)
        self._update_text()
        self._request_draw()

    def _budget(self) -> float:
        r = self.last_report
        budget = float(getattr(r, "budget", FRAME_BUDGET)) if r is not None else FRAME_BUDGET
        return budget if math.isfinite(budget) and budget > 0 else FRAME_BUDGET

    def _update_text(self) -> None:
        r = self.last_report
        budget_ms = 1e3 * self._budget()
        if r is None:
            frame, step, status = int(getattr(self.sim, "frames", 0)), None, "ready"
        else:
            frame, step, status = int(r.frame), 1e3 * float(r.elapsed), str(r.status)
        draw = self.draw_times[-1] if self.draw_times else None
        fps = self.frames_per_second()
        total = None if step is None or draw is None else step + draw
        text = (f"{self._mode:4s} | frame {frame:5d} | step {_ms(step)} + draw {_ms(draw)} = {_ms(total)} "
                f"/ {budget_ms:.0f} ms | {'--' if fps is None else f'{fps:.0f}':>2s} fps | {status}")
        self.status_text.set_text(text)
        self.message_text.set_text(self._wrapped(self.message))
        if self._layered and (self._mode, self.message) != self._text_key:
            self.fig.refresh_slow()  # a new mode or message shows at once; the numbers at a readable pace
        self._text_key = (self._mode, self.message)

    def _wrapped(self, message: str) -> str:
        """The message wrapped to the width it has, at most two lines (a longer one ends in ' ...')."""
        if not message:
            return ""
        return textwrap.fill(" ".join(message.split()), width=self._line_length(), max_lines=MESSAGE_LINES,
                             placeholder=" ...")

    def _line_length(self) -> int:
        """How many characters of the message's monospace font fit on one line of the space it has."""
        # the message starts 5 % into the view's own figure (and may run to 1 % before its edge), or
        # 1 % into axes of your own (to 2 % before their edge)
        fraction = 0.94 if self.owns_figure else 0.97 * self.ax.get_position().width
        sample = "0" * 40
        prop = self.message_text.get_fontproperties()
        get_renderer = getattr(self.canvas, "get_renderer", None)
        if callable(get_renderer):  # pixels, as this renderer rounds the advance of each glyph
            char = get_renderer().get_text_width_height_descent(sample, prop, ismath=False)[0] / len(sample)
            space = fraction * self.fig.bbox.width
        else:  # points of the font's outline, with room for rounding
            char = 1.1 * TextToPath().get_text_width_height_descent(sample, prop, ismath=False)[0] / len(sample)
            space = fraction * self.fig.get_figwidth() * 72.0
        return max(20, int(space / char))

    def _show(self, message: str) -> None:
        self.message = message
        self._update_text()
        self._request_draw()

    def _request_draw(self) -> None:
        # while the timer runs, its next frame asks for the picture; otherwise ask the canvas now
        if not self._running:
            self._ask_canvas()

    def _ask_canvas(self) -> None:
        # a non-interactive canvas draws when it is saved or shown: drawing it here would only cost time.
        # An interactive one coalesces: Qt and Tk draw once per pass of their loop; a browser canvas
        # (ipympl) asks for a picture only when it has shown the last one.
        if self.interactive:
            self.canvas.draw_idle()

    def _drawing_started(self, started) -> None:
        self._draw_started = started
        self._update_text()  # the readout shows the last finished draw

    def _drawing_rendered(self, started, rendered) -> None:
        if self._sent_images is None or self._offscreen:  # nothing to send: the draw ends with the rendering
            self._record_draw(started, rendered)
            self._draw_started = None

    def _picture_sent(self, sent, nbytes) -> None:
        if self._draw_started is not None:
            self._record_draw(self._draw_started, sent)
            self._draw_started = None

    def _record_draw(self, started, ended) -> None:
        self.draw_times.append(1e3 * (ended - started))
        if len(self.draw_times) > 2 * _KEEP:
            del self.draw_times[:_KEEP]
        self._drawn_at.append(ended)

    # ------------------------------------------------------------------ events
    def _point(self, event):
        if event.inaxes is not self.ax or event.xdata is None or event.ydata is None:
            return None
        return np.array([event.xdata, event.ydata], dtype=float)

    def _navigating(self) -> bool:
        return self.ax.get_navigate_mode() is not None

    @_one_at_a_time
    def _on_press(self, event):
        point = self._point(event)
        if point is None or event.button != MouseButton.LEFT or self._navigating():
            return
        self.message = ""
        self._real_press = event.guiEvent is not None
        if self._mode == "drag":
            self._end_grab()
            try:
                self._handle = self.sim.grab(point, self.radius)
            except ValueError:
                self._handle = None  # no tissue under the pointer: nothing to grab
                return
            self.target_artist.set_data([point[0]], [point[1]])
        else:
            self._stroke = [point]
            self.stroke_artist.set_data([point[0]], [point[1]])
        self._update_text()
        self._request_draw()

    @_one_at_a_time
    def _on_motion(self, event):
        if self._handle is None and self._stroke is None:
            return
        if (event.guiEvent is not None) != self._real_press:
            # a real mouse moving (no button held) does not carry on a grab that code made, nor code a real one
            return
        point = self._point(event)
        if point is None:
            return
        if self._handle is not None:
            try:
                self.sim.drag(self._handle, point)
            except ValueError as exc:
                self._show(f"drag rejected: {exc}")
                return
            self.target_artist.set_data([point[0]], [point[1]])
        else:
            if np.linalg.norm(point - self._stroke[-1]) < self.stroke_spacing:
                return
            self._stroke.append(point)
            xy = np.array(self._stroke)
            self.stroke_artist.set_data(xy[:, 0], xy[:, 1])
        self._request_draw()

    @_one_at_a_time
    def _on_release(self, event):
        if event.button not in (None, MouseButton.LEFT):
            return
        if self._handle is not None:
            self._end_grab()
            self._update_text()
            self._request_draw()
        elif self._stroke is not None:
            point = self._point(event)
            stroke = self._stroke
            if point is not None and np.linalg.norm(point - stroke[-1]) > 0:
                stroke.append(point)
            self._stroke = None
            self.stroke_artist.set_data([], [])
            self._cut(np.array(stroke))

    @_one_at_a_time
    def _on_key(self, event):
        if event.inaxes not in (None, self.ax):
            return
        if event.key == "c":
            self.mode = "drag" if self._mode == "cut" else "cut"

    def _end_grab(self) -> None:
        if self._handle is not None:
            handle, self._handle = self._handle, None
            self.target_artist.set_data([], [])
            try:
                self.sim.release(handle)
            except ValueError as exc:
                self.message = f"release failed: {exc}"

    def _cut(self, polyline) -> None:
        distinct = polyline[np.r_[True, np.any(np.diff(polyline, axis=0) != 0, axis=1)]]
        if len(distinct) < 2:
            self._show("cut: draw a stroke (press, move, release)")
            return
        try:
            self.sim.cut(distinct)
        except ValueError as exc:
            self._show(f"cut failed: {exc}")
            return
        self.message = ""
        self._refresh()

    # ------------------------------------------------------------------ showing it (Jupyter)
    def controls(self):
        """Buttons for the mode and the timer (needs ipywidgets), as one ``HBox``."""
        try:
            import ipywidgets as widgets
        except ImportError:
            raise ImportError("SurgeryView.controls needs ipywidgets (pip install 'tissuefem[interactive]'); "
                              "without it, press 'c' or set view.mode") from None
        if self._widgets is None:
            mode = widgets.ToggleButtons(options=list(MODES), value=self._mode,
                                         tooltips=["drag the tissue", "draw a stroke to cut along"],
                                         style={"button_width": "5em"})
            run = widgets.ToggleButton(value=self._running, description="run", icon="play",
                                       tooltip="run a frame every interval_ms", layout={"width": "6em"})
            mode.observe(lambda change: setattr(self, "mode", change["new"]), names="value")
            run.observe(lambda change: self.start() if change["new"] else self.stop(), names="value")
            if self.closed:
                mode.disabled = run.disabled = True
            self._widgets = (mode, run, widgets.HBox([mode, run]))
        return self._widgets[2]

    def widget(self):
        """The view as one widget, its buttons above the live figure; ``None`` unless the canvas is ipympl's."""
        try:
            import ipywidgets as widgets
        except ImportError:
            return None
        if not isinstance(self.canvas, widgets.DOMWidget):
            return None
        if self._box is None:
            self._box = widgets.VBox([self.controls(), self.canvas])
        return self._box

    def _repr_mimebundle_(self, include=None, exclude=None):
        """Jupyter shows the live widget (buttons and figure) once, or on a static backend the picture."""
        box = self.widget()
        if box is not None:
            if self.autostart and not self.closed and self.interactive:
                self.start()
            return box._repr_mimebundle_(include=include, exclude=exclude)
        with io.BytesIO() as png:
            self.fig.savefig(png, format="png")
            data = base64.b64encode(png.getvalue()).decode("ascii")
        return {"image/png": data, "text/plain": repr(self)}

    def show(self) -> None:
        """Display the view (the same as ending a notebook cell with ``view``)."""
        display(self)

    def __repr__(self):
        state = "closed" if self.closed else ("running" if self._running else "stopped")
        return f"<SurgeryView {self._mode}, {state}, frame {int(getattr(self.sim, 'frames', 0))}>"

    def _sync_widgets(self) -> None:
        if self._widgets is not None and self._widgets[1].value != self._running:
            self._widgets[1].value = self._running


def _ms(value) -> str:
    return "  --" if value is None else f"{value:4.1f}"


def _check_view(view):
    if not isinstance(view, SurgeryView):
        raise ValueError(f"view must be a SurgeryView, got {type(view).__name__}")


def _data_to_pixels(ax, point, transform=None):
    """Pixels of ``point`` as the next draw places it: the axes box after its equal aspect is applied."""
    fig = ax.figure
    was_stale, box = fig.stale, ax.get_position().bounds
    ax.apply_aspect()
    if not was_stale and ax.get_position().bounds == box:
        fig.stale = False  # nothing moved: the figure's kept picture is still right
    return (ax.transData if transform is None else transform).transform(point)


def synthetic_mouse(view, kind, point, button=1):
    """Send a made-up mouse event at the data point ``point`` through the canvas, as a backend would.

    ``kind``: ``"press"``, ``"move"`` (with the button held, if it was pressed) or ``"release"``;
    ``point``: ``(x, y)`` in data coordinates of ``view.ax`` (a point outside the axes gives an event outside
    them); ``button``: of a press or release (1 = left). Returns the
    :class:`~matplotlib.backend_bases.MouseEvent` after every handler connected to the canvas has seen it.
    """
    _check_view(view)
    if kind not in _MOUSE_EVENTS:
        raise ValueError(f"kind must be one of {tuple(_MOUSE_EVENTS)}, got {kind!r}")
    p = np.asarray(point, dtype=float)
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ValueError(f"point must be a finite (x, y) pair in data coordinates, got {point!r}")
    ax = view.ax
    x, y = _data_to_pixels(ax, p)
    name = _MOUSE_EVENTS[kind]
    event = MouseEvent(name, view.canvas, x, y, button=None if kind == "move" else MouseButton(button))
    view.canvas.callbacks.process(name, event)
    return event


def synthetic_key(view, key, point=None):
    """Send a made-up key press (e.g. ``"c"``) through the canvas, the pointer at ``point`` (default: the axes' centre).

    Returns the :class:`matplotlib.backend_bases.KeyEvent` after the handlers have seen it.
    """
    _check_view(view)
    if not isinstance(key, str) or not key:
        raise ValueError(f"key must be a non-empty string such as 'c', got {key!r}")
    ax = view.ax
    if point is None:
        x, y = _data_to_pixels(ax, (0.5, 0.5), ax.transAxes)
    else:
        x, y = _data_to_pixels(ax, np.asarray(point, dtype=float))
    event = KeyEvent("key_press_event", view.canvas, key, x, y)
    view.canvas.callbacks.process("key_press_event", event)
    return event
