"""Operate on a running simulation with the mouse: drag the tissue and cut it, in any matplotlib figure.

A :class:`SurgeryView` draws a :class:`~tissuefem.surgery.simulation.Simulation` in a matplotlib ``Axes`` and turns
mouse events into its input, the *input* step of the notes' frame loop (read the user, solve, render, every 1/30 s).
In **drag** mode (the default) a left-button press grabs the nodes within ``radius`` of the pointer, moving drags them
and letting go releases them; in **cut** mode a stroke becomes an incision when the button is released. The mode
buttons, the key ``c`` and ``view.mode = "cut"`` switch modes.

A timer runs one frame every ``interval_ms``, on an interactive canvas only (``%matplotlib widget``, Qt, Tk); on Agg or
inline, code calls :meth:`~SurgeryView.step` (and :meth:`~SurgeryView.draw`), so the same cells run in a browser and
headless in the tests. Events only change the state; the next frame draws it (:mod:`.view_drawing`: within the 33 ms
budget). One live view per simulation and per notebook cell: a new view of the same simulation stops the old one, and
re-running a cell closes the view it made. :func:`synthetic_mouse` and :func:`synthetic_key` send made-up events
through the canvas, as a backend would: a notebook shows a drag or a cut without a mouse, and the tests check it.
"""

from __future__ import annotations

import asyncio
import base64
import functools
import io
import math
import threading
import time
import weakref

import matplotlib.pyplot as plt
import numpy as np
from IPython import get_ipython
from matplotlib.backend_bases import KeyEvent, MouseButton, MouseEvent
from matplotlib.backends.backend_agg import FigureCanvasAgg

from ..engine.meshes import mean_edge_length
from ..engine.parameters import ParameterError, check_count, check_positive, string
from .view_drawing import KEYFRAME_S, LayeredFigure, MeshDrawing, Readout, is_gui, is_interactive, view_axes

__all__ = ["SurgeryView", "Gestures", "MouseGestures", "MODES", "take_over", "let_go", "one_at_a_time",
           "synthetic_mouse", "synthetic_key", "mean_edge_length"]

#: the interaction modes of a :class:`SurgeryView`
MODES = ("drag", "cut")

_MOUSE_EVENTS = {"press": "button_press_event", "move": "motion_notify_event", "release": "button_release_event"}

#: every view not yet disconnected, to stop the one a new view replaces
_VIEWS: weakref.WeakSet = weakref.WeakSet()


def _cell_origin():
    """Which notebook cell is running, and which run of it: ``(cell, execution count)``, or ``None``; the cell is the
    id the front-end sends with each execution (JupyterLab and nbclient do), else its source."""
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
        cell_id = ((parent or {}).get("metadata") or {}).get("cellId")
        cell = f"id:{cell_id}" if cell_id else None
    if cell is None:
        history = getattr(getattr(shell, "history_manager", None), "input_hist_raw", None)
        cell = "source:" + history[-1] if history else None
    return None if cell is None else (cell, getattr(shell, "execution_count", None))


def take_over(view) -> None:
    """Make ``view`` the live view of its simulation and of its notebook cell: a view of the same simulation stops
    (disconnected, saying why), one that the same cell made in an earlier run closes (its output is gone). Every
    kind of view registers here (``sim``, ``closed``, ``disconnect()``, ``close()``; :meth:`SurgeryView.disconnect`
    and the browser view's leave the registry themselves)."""
    view._origin = _cell_origin()
    for old in [v for v in _VIEWS if not v.closed]:
        if old.sim is view.sim:
            old.disconnect()
            old._show("stopped: a newer view drives this simulation")
        elif view._origin and old._origin and old._origin[0] == view._origin[0] and old._origin != view._origin:
            old.close()  # its cell was run again: its output is gone
    _VIEWS.add(view)


def let_go(view) -> None:
    """``view`` is no longer live (disconnected): it leaves the registry of :func:`take_over`."""
    _VIEWS.discard(view)


def one_at_a_time(method):
    """Run ``method`` holding the view's lock: a frame, an event and a draw never interleave (a kernel may handle a
    widget's messages on another thread than the timer's: a cut could otherwise rebuild the mesh mid-frame)."""

    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)

    return locked


class Gestures:
    """A view's pointer input mapped to the simulation's ``grab``, ``drag``, ``release`` and ``cut``: one home for
    every view (the matplotlib figure's :class:`MouseGestures`, the browser-drawn view of :mod:`.widget`).

    :meth:`press`, :meth:`move` and :meth:`release` take points in the view's data (world) coordinates. ``real``
    says whether the input came from a person (a browser or GUI event) or from code: a grab made in code is not
    carried on by the real pointer, nor a real one by made-up moves. A ``ValueError`` of the simulation becomes the
    view's message. The view provides ``radius``, ``stroke_spacing``, ``message`` and the hooks ``_changed``,
    ``_request_draw``, ``_show`` and ``_refresh``; :meth:`tools_changed` is told when the drag target or the stroke
    moved (``target``: the point the grab follows, or ``None``; ``stroke``: the points drawn so far, or ``None``).
    """

    def __init__(self, view):
        self.view, self.sim, self._lock = view, view.sim, view._lock
        self.mode, self.handle, self.stroke, self.target = "drag", None, None, None
        self.real_press = False  # whether the grab or stroke began with a real press (a GUI event) or in code

    def tools_changed(self) -> None:
        """The drag target or the stroke changed (a view that draws them redraws them)."""

    @one_at_a_time
    def press(self, point, real=True) -> None:
        """A press at ``point``: in drag mode grab the tissue there, in cut mode start a stroke."""
        point = np.asarray(point, dtype=float)
        self.view.message = ""
        self.real_press = bool(real)
        if self.mode == "drag":
            self.end_grab()
            try:
                self.handle = self.sim.grab(point, self.view.radius)
            except ValueError:
                return  # no tissue under the pointer: nothing to grab
            self.target = point
        else:
            self.stroke = [point]
        self.tools_changed()
        self.view._changed()

    @one_at_a_time
    def move(self, point, real=True) -> None:
        """The pointer moved to ``point``: drag the grabbed handle there, or extend the stroke."""
        if (self.handle is None and self.stroke is None) or bool(real) != self.real_press:
            return
        point = np.asarray(point, dtype=float)
        if self.handle is not None:
            try:
                self.sim.drag(self.handle, point)
            except ValueError as exc:
                self.view._show(f"drag rejected: {exc}")
                return
            self.target = point
        else:
            if np.linalg.norm(point - self.stroke[-1]) < self.view.stroke_spacing:
                return
            self.stroke.append(point)
        self.tools_changed()
        self.view._request_draw()

    @one_at_a_time
    def release(self, point=None) -> None:
        """The button was let go (at ``point``, or outside the view: ``None``): end the grab, or cut along the
        stroke."""
        if self.handle is not None:
            self.end_grab()
            self.view._changed()
        elif self.stroke is not None:
            stroke = self.stroke
            if point is not None and np.linalg.norm(np.asarray(point, dtype=float) - stroke[-1]) > 0:
                stroke.append(np.asarray(point, dtype=float))
            self.drop()
            stroke = np.array(stroke)
            distinct = stroke[np.r_[True, np.any(np.diff(stroke, axis=0) != 0, axis=1)]]
            if len(distinct) < 2:
                self.view._show("cut: draw a stroke (press, move, release)")
                return
            try:
                self.sim.cut(distinct)
            except ValueError as exc:
                self.view._show(f"cut failed: {exc}")
                return
            self.view.message = ""
            self.view._refresh()

    def end_grab(self) -> None:
        """Release the grabbed handle, if any."""
        if self.handle is not None:
            handle, self.handle, self.target = self.handle, None, None
            self.tools_changed()
            try:
                self.sim.release(handle)
            except ValueError as exc:
                self.view.message = f"release failed: {exc}"

    def drop(self) -> None:
        """End a grab and drop a stroke in progress."""
        self.end_grab()
        self.stroke = None
        self.tools_changed()


class MouseGestures(Gestures):
    """:class:`Gestures` from a matplotlib figure's mouse and keyboard, the target and stroke drawn in its axes.

    Presses and moves outside the axes, or while the toolbar pans or zooms, are ignored; a release anywhere ends the
    grab or stroke (a handle never sticks to a mouse that left). The key ``c`` toggles the mode (it is also the
    toolbar's "back" key, which matters only after zooming).
    """

    def __init__(self, view):
        super().__init__(view)
        self.ax = view.ax
        (self.stroke_artist,) = self.ax.plot([], [], "-", color="k", lw=1.2, zorder=3)
        (self.target_artist,) = self.ax.plot([], [], "o", ms=7, mfc="none", mec="tab:blue", mew=1.5, zorder=3)

    def tools_changed(self) -> None:
        target = [] if self.target is None else [self.target]
        self.target_artist.set_data([p[0] for p in target], [p[1] for p in target])
        stroke = self.stroke or []
        self.stroke_artist.set_data([p[0] for p in stroke], [p[1] for p in stroke])

    def _point(self, event):
        if event.inaxes is not self.ax or event.xdata is None or event.ydata is None:
            return None
        return np.array([event.xdata, event.ydata], dtype=float)

    @one_at_a_time
    def on_press(self, event):
        point = self._point(event)
        if point is None or event.button != MouseButton.LEFT or self.ax.get_navigate_mode() is not None:
            return
        self.press(point, real=event.guiEvent is not None)

    @one_at_a_time
    def on_motion(self, event):
        point = self._point(event)
        if point is not None:
            self.move(point, real=event.guiEvent is not None)

    @one_at_a_time
    def on_release(self, event):
        if event.button in (None, MouseButton.LEFT):
            self.release(self._point(event))

    @one_at_a_time
    def on_key(self, event):
        if event.inaxes in (None, self.ax) and event.key == "c":
            self.view.mode = "drag" if self.mode == "cut" else "cut"


class SurgeryView:
    """A simulation drawn in a matplotlib ``Axes``, operated on with the mouse (:class:`Gestures`).

    Parameters
    ----------
    sim : tissuefem.surgery.simulation.Simulation
        Or anything with ``mesh``, ``positions``, ``picture``, ``frame``, ``grab``, ``drag``, ``release``, ``cut``.
    ax : matplotlib.axes.Axes, optional
        Default: the view's own figure (:func:`~.view_drawing.view_axes`), which redraws only the moving layer per
        frame; an ``ax`` of your own figure redraws the whole figure.
    radius : float, optional
        A press grabs the nodes within this distance of the pointer; default twice the mean edge length.
    interval_ms : int, default 33
        Milliseconds between timer frames (the notes' 30 frames per second).
    autostart : bool, default True
        Start the timer once the view is on screen (a GUI window at once, Jupyter when displayed; never on Agg).

    Attributes
    ----------
    frame_times, draw_times : list of float
        Milliseconds of every frame run by :meth:`step`; of each picture drawn (on a browser canvas, until sent).
    last_report : FrameReport or None
    message : str
        The last message (a failed cut, a rejected drag, a failed frame), or ``""``; shown under the axes.
    mesh_faces, mesh_edges, stroke_artist, target_artist, status_text, message_text
        The artists: the triangles (:class:`~.view_drawing.MeshDrawing`), the stroke being drawn and the drag
        target, the readout above the axes and the message under them (:class:`~.view_drawing.Readout`).

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
            raise ParameterError("sim", "sim must be a tissuefem.surgery.simulation.Simulation; "
                                        f"{type(sim).__name__} has no {missing}")
        self.radius = check_positive("radius", 2.0 * mean_edge_length(sim.mesh) if radius is None else radius)
        self.interval_ms = check_count("interval_ms", interval_ms)
        self.sim, self.autostart, self.owns_figure = sim, bool(autostart), ax is None
        self.ax = view_axes() if ax is None else ax
        self.fig, self.canvas = self.ax.figure, self.ax.figure.canvas
        self.interactive = is_interactive(self.canvas)
        self._lock = self.fig.lock if isinstance(self.fig, LayeredFigure) else threading.RLock()
        # the loop (and its thread) that runs the timer: a start or stop asked from elsewhere goes there
        try:
            self._loop = asyncio.get_running_loop()
        except RuntimeError:
            self._loop = None
        self._loop_thread = threading.get_ident()
        self.last_report, self.message, self.closed = None, "", False
        self.stroke_spacing = 0.25 * mean_edge_length(sim.mesh)
        self._timer, self._running, self._widgets, self._box, self._keyframe_at = None, False, None, None, -math.inf

        self.drawing = MeshDrawing(self.ax, sim.mesh)
        self.mesh_faces, self.mesh_edges = self.drawing.faces, self.drawing.edges
        self.gestures = MouseGestures(self)
        self.stroke_artist, self.target_artist = self.gestures.stroke_artist, self.gestures.target_artist
        self.readout = Readout(self.ax, self.owns_figure, self._update_text)
        self.status_text, self.message_text = self.readout.status_text, self.readout.message_text
        self.frame_times, self.draw_times = self.readout.frame_times, self.readout.draw_times
        if isinstance(self.fig, LayeredFigure):
            self.fig.animate([self.mesh_faces, self.mesh_edges, self.stroke_artist, self.target_artist],
                             [self.status_text, self.message_text], self.readout)
        self._mesh = None  # the mesh drawn
        self._follow()
        self._update_text()

        g = self.gestures
        handlers = {"button_press_event": g.on_press, "motion_notify_event": g.on_motion,
                    "button_release_event": g.on_release, "key_press_event": g.on_key,
                    "close_event": lambda event: self.disconnect()}
        self._cids = [self.canvas.mpl_connect(name, handler) for name, handler in handlers.items()]
        take_over(self)
        if self.autostart and is_gui(self.canvas):
            self.start()  # a GUI window is on screen as soon as it is shown; a notebook view starts when displayed

    # ------------------------------------------------------------------ mode and state
    @property
    def mode(self) -> str:
        """``"drag"`` or ``"cut"``. Switching ends a grab (released) or drops a stroke in progress."""
        return self.gestures.mode

    @mode.setter
    @one_at_a_time
    def mode(self, value):
        if string("mode", value, MODES) == self.gestures.mode:
            return
        self.gestures.drop()
        self.gestures.mode = value
        if self._widgets is not None and self._widgets[0].value != value:
            self._widgets[0].value = value
        self._changed()

    @property
    def grabbed(self):
        """The name of the grabbed handle, or ``None``."""
        return self.gestures.handle

    @property
    def stroke(self):
        """The cut stroke being drawn, ``(k, 2)``, or ``None``."""
        return None if self.gestures.stroke is None else np.array(self.gestures.stroke)

    @property
    def drawn_positions(self) -> np.ndarray:
        """The node positions ``(2, n_nodes)`` the triangles are drawn at (set by the last frame)."""
        return self.drawing.x

    def triangles(self) -> np.ndarray:
        """The drawn triangles' corners ``(n_triangles, 3, 2)``, as the faces' path holds them."""
        return self.drawing.triangles()

    # ------------------------------------------------------------------ frames, drawing and the timer
    @one_at_a_time
    def step(self):
        """Run one frame (``sim.frame()``), record its time and request a redraw; returns the frame's report."""
        report = self.last_report = self.sim.frame()
        self.frame_times.append(1e3 * float(report.elapsed))
        self._refresh()
        return report

    def _follow(self) -> None:
        """The simulation's node positions into the drawing (new paths only for a new mesh: after a cut)."""
        x = np.asarray(self.sim.positions(), dtype=float)
        if self.sim.mesh is not self._mesh or x.shape != self.drawing.x.shape:
            self._mesh = self.sim.mesh
            self.drawing.rebuild(self.sim.picture, x)  # the triangles, or for elements cut through their material
        else:
            self.drawing.fill(x)

    def _refresh(self) -> None:
        """After a frame or a topology change: new vertex data, then a redraw."""
        self._follow()
        self._changed()

    @one_at_a_time
    def draw(self) -> float | None:
        """Render the picture now, off-screen (nothing sent or painted), for frames that code steps; returns how
        long it took (ms; timed in the view's own figure only, else ``None``)."""
        n = len(self.draw_times)
        if isinstance(self.canvas, FigureCanvasAgg):
            self.readout.offscreen = True
            try:
                FigureCanvasAgg.draw(self.canvas)
            finally:
                self.readout.offscreen = False
        else:
            self.canvas.draw()
        return self.draw_times[-1] if len(self.draw_times) > n else None

    def _update_text(self) -> None:
        """The readout: the frame's numbers, and under them its accuracy (``StepReport.accuracy``: converged, the
        relative residual, the energy decrease, the smallest J, the inverted elements, what was left undone)."""
        self.readout.update(self.gestures.mode, self.message, self.last_report, getattr(self.sim, "frames", 0))
        accuracy = getattr(self.last_report, "accuracy", None)
        if accuracy:
            numbers = self.status_text.get_text().split("\n")[0]
            self.status_text.set_text(f"{numbers}\n{accuracy}")

    def _show(self, message: str) -> None:
        self.message = message
        self._changed()

    def _changed(self) -> None:
        self._update_text()
        self._request_draw()

    def _request_draw(self, now=False) -> None:
        # while the timer runs, its next frame asks (now=True); a non-interactive canvas draws when saved or shown;
        # an interactive one coalesces requests (ipympl asks for a picture only when it has shown the last one)
        if self.interactive and (now or not self._running):
            self.canvas.draw_idle()

    def timings(self, last=None) -> dict:
        """Medians of the step and the draw (ms), their sum, and the frames drawn per second (of the ``last`` ones)."""
        return self.readout.timings(self.last_report, last)

    def frames_per_second(self, window=1.0) -> float | None:
        """Pictures drawn per second over the last ``window`` seconds (``None`` before two draws)."""
        return self.readout.frames_per_second(window)

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

    @one_at_a_time
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
        if not self.readout.sends:
            self._request_draw(now=True)
            return
        # a browser canvas: send the picture now, saving the page's round trip of asking for it; the page drops
        # difference pictures that come faster than it decodes them: every KEYFRAME_S s a whole one repairs that
        now = time.perf_counter()
        if now - self._keyframe_at >= KEYFRAME_S and hasattr(self.canvas, "_force_full"):
            self.canvas._force_full = True  # WebAgg's flag for a whole picture (as after a page refresh)
            self._keyframe_at = now
        self.canvas.draw()

    @one_at_a_time
    def disconnect(self) -> None:
        """Stop the timer and detach every event handler (the figure stays as it is)."""
        self.stop()
        self.gestures.end_grab()
        for cid in self._cids:
            self.canvas.mpl_disconnect(cid)
        self._cids = []
        self.readout.stop_listening()
        for w in (self._widgets or ())[:2]:
            w.disabled = True
        self.closed = True
        let_go(self)

    def close(self) -> None:
        """Disconnect, and close the view's own figure (its widget and its place in pyplot's list)."""
        self.disconnect()
        if self.owns_figure:
            plt.close(self.fig)

    # ------------------------------------------------------------------ showing it (Jupyter)
    def controls(self):
        """Buttons for the mode and the timer (needs ipywidgets), as one ``HBox``."""
        try:
            import ipywidgets as widgets
        except ImportError:
            raise ImportError("SurgeryView.controls needs ipywidgets (pip install 'tissuefem[interactive]'); "
                              "without it, press 'c' or set view.mode") from None
        if self._widgets is None:
            mode = widgets.ToggleButtons(options=list(MODES), value=self.mode,
                                         tooltips=["drag the tissue", "draw a stroke to cut along"],
                                         style={"button_width": "5em"})
            run = widgets.ToggleButton(value=self._running, description="run", icon="play",
                                       tooltip="run a frame every interval_ms", layout={"width": "6em"})
            mode.observe(lambda change: setattr(self, "mode", change["new"]), names="value")
            run.observe(lambda change: self.start() if change["new"] else self.stop(), names="value")
            mode.disabled = run.disabled = self.closed
            self._widgets = (mode, run, widgets.HBox([mode, run]))
        return self._widgets[2]

    def _sync_widgets(self) -> None:
        if self._widgets is not None and self._widgets[1].value != self._running:
            self._widgets[1].value = self._running

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

    def __repr__(self):
        state = "closed" if self.closed else ("running" if self._running else "stopped")
        return f"<SurgeryView {self.mode}, {state}, frame {int(getattr(self.sim, 'frames', 0))}>"


# ------------------------------------------------------------------ made-up events
def _data_to_pixels(ax, point, transform=None):
    """Pixels of ``point`` as the next draw places it: the axes box after its equal aspect is applied."""
    fig = ax.figure
    was_stale, box = fig.stale, ax.get_position().bounds
    ax.apply_aspect()
    if not was_stale and ax.get_position().bounds == box:
        fig.stale = False  # nothing moved: the figure's kept picture is still right
    return (ax.transData if transform is None else transform).transform(point)


def synthetic_mouse(view, kind, point, button=1):
    """Send a made-up mouse event ``kind`` (``"press"``, ``"move"`` or ``"release"``) at ``point`` ``(x, y)`` (data
    coordinates of ``view.ax``) through the canvas, as a backend would; ``button``: of a press or release (1 = left).
    Returns the :class:`~matplotlib.backend_bases.MouseEvent` after every handler has seen it."""
    if not isinstance(view, SurgeryView):
        raise ParameterError("view", f"view must be a SurgeryView, got {type(view).__name__}")
    if kind not in _MOUSE_EVENTS:
        raise ParameterError("kind", f"kind must be one of {tuple(_MOUSE_EVENTS)}, got {kind!r}")
    p = np.asarray(point, dtype=float)
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ParameterError("point", f"point must be a finite (x, y) pair in data coordinates, got {point!r}")
    x, y = _data_to_pixels(view.ax, p)
    name = _MOUSE_EVENTS[kind]
    event = MouseEvent(name, view.canvas, x, y, button=None if kind == "move" else MouseButton(button))
    view.canvas.callbacks.process(name, event)
    return event


def synthetic_key(view, key, point=None):
    """Send a made-up key press (e.g. ``"c"``) through the canvas, the pointer at ``point`` (default: the axes'
    centre); returns the :class:`~matplotlib.backend_bases.KeyEvent` after the handlers have seen it."""
    if not isinstance(view, SurgeryView):
        raise ParameterError("view", f"view must be a SurgeryView, got {type(view).__name__}")
    if not isinstance(key, str) or not key:
        raise ParameterError("key", f"key must be a non-empty string such as 'c', got {key!r}")
    ax = view.ax
    x, y = (_data_to_pixels(ax, (0.5, 0.5), ax.transAxes) if point is None
            else _data_to_pixels(ax, np.asarray(point, dtype=float)))
    event = KeyEvent("key_press_event", view.canvas, key, x, y)
    view.canvas.callbacks.process("key_press_event", event)
    return event
