"""Operate on a running simulation with the mouse: drag the tissue and cut it, in any matplotlib figure.

A :class:`SurgeryView` puts a :class:`tissuefem.surgery.simulation.Simulation` in a
matplotlib ``Axes`` and turns mouse events into the simulation's input, which
is the *input* step of the notes' frame loop (read the user, solve, render,
every 1/30 s):

* **drag** mode (the default): a left-button press on the tissue grabs the
  nodes within ``radius`` of the pointer (:meth:`Simulation.grab`), moving the
  mouse with the button held drags them (:meth:`Simulation.drag`), and letting
  go releases them;
* **cut** mode: a left-button stroke draws a polyline, which becomes an
  incision (:meth:`Simulation.cut`) when the button is released; the drawing
  is rebuilt for the new topology.

The key ``c`` toggles the two modes (``view.mode = "cut"`` does the same from
code). A timer of the figure's canvas runs one frame every ``interval_ms``
(:meth:`SurgeryView.step`: ``sim.frame()`` and a redraw). The timer starts
only on an interactive canvas (``%matplotlib widget`` in Jupyter, a Qt or Tk
window); on a non-interactive one (Agg, the inline backend) nothing runs by
itself and code calls :meth:`~SurgeryView.step`. So the same cells run in a
browser with the mouse and headless in the test suite.

:func:`synthetic_mouse` and :func:`synthetic_key` send a made-up event through
the canvas's callbacks, exactly as a backend would, so a notebook can show what
a drag or a cut does without a mouse (and the tests can check it).

Nothing here needs ipympl or ipywidgets; with ipywidgets installed,
:meth:`SurgeryView.controls` adds buttons for the mode and the timer.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.backend_bases import KeyEvent, MouseButton, MouseEvent, TimerBase
from matplotlib.collections import PathCollection
from matplotlib.path import Path

from ..engine.realtime import FRAME_BUDGET

__all__ = ["SurgeryView", "MODES", "synthetic_mouse", "synthetic_key", "mean_edge_length"]

#: the interaction modes of a :class:`SurgeryView`
MODES = ("drag", "cut")

_MOUSE_EVENTS = {
    "press": "button_press_event",
    "move": "motion_notify_event",
    "release": "button_release_event",
}

_SIM_METHODS = ("positions", "frame", "grab", "drag", "release", "cut")


def mean_edge_length(mesh) -> float:
    """Mean length of the edges of a triangle mesh (reference coordinates)."""
    p, f = mesh.p, mesh.facets
    return float(np.mean(np.linalg.norm(p[:, f[0]] - p[:, f[1]], axis=0)))


def _is_interactive(canvas) -> bool:
    """Whether ``canvas`` belongs to an interactive backend: one whose timers fire and that redraws on screen.

    A GUI toolkit (Qt, Tk, ...) names its framework; a browser backend (ipympl, WebAgg) names none but
    has a working timer. Agg and the inline backend have only the base timer, which never fires.
    """
    if getattr(type(canvas), "required_interactive_framework", None) is not None:
        return True
    return type(canvas.new_timer()) is not TimerBase


class SurgeryView:
    """A simulation drawn in a matplotlib ``Axes``, operated on with the mouse.

    Parameters
    ----------
    sim : tissuefem.surgery.simulation.Simulation
        The running simulation (anything with its ``mesh``, ``positions``,
        ``frame``, ``grab``, ``drag``, ``release`` and ``cut``).
    ax : matplotlib.axes.Axes, optional
        Where to draw; default a new pyplot figure (under ``%matplotlib widget``
        that is the interactive widget).
    radius : float, optional
        A press grabs the nodes within this distance of the pointer; default
        twice the mean edge length of the mesh.
    interval_ms : int, default 33
        Milliseconds between timer frames (33 ms: the notes' 30 frames per second).
    autostart : bool, default True
        Start the timer at once, but only on an interactive canvas; on a
        non-interactive one (Agg, inline) the timer never starts by itself.

    Attributes
    ----------
    frame_times : list of float
        Wall-clock milliseconds of every frame run through :meth:`step`.
    last_report : FrameReport or None
        The last frame's report.
    message : str
        The last message shown under the status (a failed cut, a rejected drag), or ``""``.
    mesh_artist : matplotlib.collections.PathCollection
        The triangles; rebuilt (new paths) when the topology changes.
    stroke_artist : matplotlib.lines.Line2D
        The cut stroke being drawn.
    status_text : matplotlib.text.Text
        The title line: mode, frame, frame time against the budget, status.

    Notes
    -----
    Press and motion events outside the axes are ignored; a release anywhere
    ends the current grab or stroke, so a handle never stays stuck to a mouse
    that left the axes with the button held. Clicks are also ignored while the
    toolbar's pan or zoom tool is active. A ``ValueError`` raised by the
    simulation inside an event handler or a timer frame is shown in the
    status text instead of propagating. The key ``c`` is also matplotlib's
    default "back" key of the navigation toolbar, which only matters after
    zooming.

    The triangles are drawn as one collection whose paths are views of one
    vertex buffer: a frame writes the new positions into that buffer, so a
    redraw costs no Python loop over the elements.

    Examples
    --------
    >>> from tissuefem.scene import Simulation, demo_scene
    >>> view = SurgeryView(Simulation(demo_scene(n_triangles=400)), autostart=False)
    >>> _ = synthetic_mouse(view, "press", (1.95, 0.5))   # grab the right edge
    >>> _ = synthetic_mouse(view, "move", (2.2, 0.7))     # drag it
    >>> report = view.step()                              # one frame: the tissue follows
    >>> _ = synthetic_mouse(view, "release", (2.2, 0.7))
    """

    def __init__(self, sim, ax=None, radius=None, interval_ms=33, autostart=True):
        missing = [m for m in ("mesh", *_SIM_METHODS) if not hasattr(sim, m)]
        if missing:
            raise ValueError(f"sim must be a tissuefem.surgery.simulation.Simulation; {type(sim).__name__} has no {missing}")
        self.sim = sim
        if radius is None:
            radius = 2.0 * mean_edge_length(sim.mesh)
        self.radius = _positive("radius", radius)
        if isinstance(interval_ms, bool) or not isinstance(interval_ms, (int, np.integer)) or interval_ms < 1:
            raise ValueError(f"interval_ms must be a positive integer (milliseconds), got {interval_ms!r}")
        self.interval_ms = int(interval_ms)

        if ax is None:
            import matplotlib.pyplot as plt

            _, ax = plt.subplots(figsize=(7.0, 4.5), layout="constrained")
        self.ax = ax
        self.fig = ax.figure
        self.canvas = self.fig.canvas
        self.interactive = _is_interactive(self.canvas)

        self.frame_times: list[float] = []
        self.last_report = None
        self.message = ""
        self._mode = "drag"
        self._handle = None  # name of the grabbed handle
        self._grab_point = None
        self._stroke: list[np.ndarray] | None = None  # the cut polyline being drawn
        self.stroke_spacing = 0.25 * mean_edge_length(sim.mesh)
        self._timer = None
        self._running = False
        self._widgets = None

        # fixed axis limits: the reference bounding box with a margin (dragged tissue stays in view)
        X = np.asarray(sim.mesh.p, dtype=float)
        lo, hi = X.min(axis=1), X.max(axis=1)
        margin = 0.3 * float(np.max(hi - lo))
        ax.set_xlim(lo[0] - margin, hi[0] + margin)
        ax.set_ylim(lo[1] - margin, hi[1] + margin)
        ax.set_aspect("equal", adjustable="box")
        ax.set_autoscale_on(False)

        self.mesh_artist = PathCollection([], facecolors="mistyrose", edgecolors="firebrick", linewidths=0.3,
                                          zorder=1)
        ax.add_collection(self.mesh_artist, autolim=False)
        (self.stroke_artist,) = ax.plot([], [], "-", color="k", lw=1.2, zorder=3)
        (self.target_artist,) = ax.plot([], [], "o", ms=7, mfc="none", mec="tab:blue", mew=1.5, zorder=3)
        self.status_text = ax.set_title("", fontsize=9, loc="left", family="monospace")
        self._mesh = None
        self._rebuild()
        self._update_status()

        self._cids = [
            self.canvas.mpl_connect("button_press_event", self._on_press),
            self.canvas.mpl_connect("motion_notify_event", self._on_motion),
            self.canvas.mpl_connect("button_release_event", self._on_release),
            self.canvas.mpl_connect("key_press_event", self._on_key),
        ]
        if autostart and self.interactive:
            self.start()

    # ------------------------------------------------------------------ mode
    @property
    def mode(self) -> str:
        """``"drag"`` or ``"cut"``. Switching ends a grab (released) or drops a stroke in progress."""
        return self._mode

    @mode.setter
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
        self._update_status()
        self._redraw()

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
        """The node positions ``(2, n_nodes)`` of the last redraw."""
        return self._x

    # ------------------------------------------------------------------ frames and the timer
    def step(self):
        """Run one frame of the simulation (``sim.frame()``), record its time, redraw; returns its report."""
        report = self.sim.frame()
        self.last_report = report
        self.frame_times.append(1e3 * float(report.elapsed))
        self._refresh()
        return report

    def start(self) -> None:
        """Start the timer that calls :meth:`step` every ``interval_ms`` (on any canvas, when called)."""
        if self._timer is None:
            self._timer = self.canvas.new_timer(interval=self.interval_ms)
            self._timer.add_callback(self._on_timer)
        if not self._running:
            self._timer.start()
            self._running = True
            self._sync_widgets()

    def stop(self) -> None:
        """Stop the timer (a frame in progress finishes)."""
        if self._timer is not None and self._running:
            self._timer.stop()
        self._running = False
        self._sync_widgets()

    @property
    def running(self) -> bool:
        """Whether the timer is running."""
        return self._running

    def disconnect(self) -> None:
        """Stop the timer and detach every event handler (the figure stays as it is)."""
        self.stop()
        self._end_grab()
        for cid in self._cids:
            self.canvas.mpl_disconnect(cid)
        self._cids = []

    def _on_timer(self):
        try:
            self.step()
        except ValueError as exc:
            self._show(f"frame failed: {exc}")
        except Exception:
            self.stop()  # one traceback, not thirty a second
            raise

    # ------------------------------------------------------------------ drawing
    def _rebuild(self) -> None:
        """New paths for a new mesh: one vertex buffer (n_triangles, 4, 2) the paths are views of."""
        mesh = self.sim.mesh
        self._mesh = mesh
        self._t = np.asarray(mesh.t, dtype=np.intp)
        nt = self._t.shape[1]
        self._buffer = np.zeros((nt, 4, 2))
        self._fill_buffer(np.asarray(self.sim.positions(), dtype=float))
        codes = np.array([Path.MOVETO, Path.LINETO, Path.LINETO, Path.CLOSEPOLY], dtype=Path.code_type)
        paths = [Path(self._buffer[k], codes) for k in range(nt)]
        # the in-place update needs paths that are views of the buffer; if a matplotlib ever copies, copy too
        self._views = bool(nt == 0 or np.shares_memory(paths[0].vertices, self._buffer))
        self.mesh_artist.set_paths(paths)

    def _fill_buffer(self, x) -> None:
        self._x = x
        self._buffer[:, :3, :] = x[:, self._t].T
        self._buffer[:, 3, :] = self._buffer[:, 0, :]

    def _refresh(self) -> None:
        """Redraw after a frame or a topology change: new vertex data (new paths only after a cut)."""
        if self.sim.mesh is not self._mesh:
            self._rebuild()
        else:
            x = np.asarray(self.sim.positions(), dtype=float)
            if x.shape != self._x.shape:
                self._rebuild()
            else:
                self._fill_buffer(x)
                if self._views:
                    self.mesh_artist.stale = True
                else:
                    self._rebuild()
        self._update_status()
        self._redraw()

    def _update_status(self) -> None:
        r = self.last_report
        budget_ms = 1e3 * float(getattr(r, "budget", FRAME_BUDGET) if r is not None else FRAME_BUDGET)
        if not math.isfinite(budget_ms):
            budget_ms = 1e3 * FRAME_BUDGET
        if r is None:
            frame, timing, status = int(getattr(self.sim, "frames", 0)), "   -- ms", "ready"
        else:
            frame, timing, status = int(r.frame), f"{1e3 * float(r.elapsed):5.1f} ms", str(r.status)
        text = f"{self._mode:4s} | frame {frame:5d} | {timing} / {budget_ms:.0f} ms | {status}"
        if self.message:
            text += f"\n{self.message}"
        self.status_text.set_text(text)

    def _show(self, message: str) -> None:
        self.message = message
        self._update_status()
        self._redraw()

    def _redraw(self) -> None:
        # a non-interactive canvas draws when it is saved or shown; drawing it here would only cost time
        if self.interactive:
            self.canvas.draw_idle()

    # ------------------------------------------------------------------ events
    def _point(self, event):
        if event.inaxes is not self.ax or event.xdata is None or event.ydata is None:
            return None
        return np.array([event.xdata, event.ydata], dtype=float)

    def _navigating(self) -> bool:
        return self.ax.get_navigate_mode() is not None

    def _on_press(self, event):
        point = self._point(event)
        if point is None or event.button != MouseButton.LEFT or self._navigating():
            return
        self.message = ""
        if self._mode == "drag":
            self._end_grab()
            try:
                self._handle = self.sim.grab(point, self.radius)
            except ValueError:
                self._handle = None  # no tissue under the pointer: nothing to grab
                return
            self._grab_point = point
            self.target_artist.set_data([point[0]], [point[1]])
        else:
            self._stroke = [point]
            self.stroke_artist.set_data([point[0]], [point[1]])
        self._update_status()
        self._redraw()

    def _on_motion(self, event):
        if self._handle is None and self._stroke is None:
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
        self._redraw()

    def _on_release(self, event):
        if event.button not in (None, MouseButton.LEFT):
            return
        if self._handle is not None:
            self._end_grab()
            self._redraw()
        elif self._stroke is not None:
            point = self._point(event)
            stroke = self._stroke
            if point is not None and np.linalg.norm(point - stroke[-1]) > 0:
                stroke.append(point)
            self._stroke = None
            self.stroke_artist.set_data([], [])
            self._cut(np.array(stroke))

    def _on_key(self, event):
        if event.inaxes not in (None, self.ax):
            return
        if event.key == "c":
            self.mode = "drag" if self._mode == "cut" else "cut"

    def _end_grab(self) -> None:
        if self._handle is not None:
            handle, self._handle = self._handle, None
            self._grab_point = None
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

    # ------------------------------------------------------------------ optional ipywidgets controls
    def controls(self):
        """Buttons for the mode and the timer (needs ipywidgets); show them with ``display(view.controls())``."""
        try:
            import ipywidgets as widgets
        except ImportError:
            raise ImportError(
                "SurgeryView.controls needs ipywidgets (pip install 'tissuefem[interactive]'); "
                "without it, press 'c' or set view.mode"
            ) from None
        if self._widgets is None:
            mode = widgets.ToggleButtons(options=list(MODES), value=self._mode, description="mode")
            run = widgets.ToggleButton(value=self._running, description="run", icon="play")
            mode.observe(lambda change: setattr(self, "mode", change["new"]), names="value")
            run.observe(lambda change: self.start() if change["new"] else self.stop(), names="value")
            self._widgets = (mode, run, widgets.HBox([mode, run]))
        return self._widgets[2]

    def _sync_widgets(self) -> None:
        if self._widgets is not None and self._widgets[1].value != self._running:
            self._widgets[1].value = self._running


def _positive(name, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def _check_view(view):
    if not isinstance(view, SurgeryView):
        raise ValueError(f"view must be a SurgeryView, got {type(view).__name__}")


def synthetic_mouse(view, kind, point, button=1):
    """Send a made-up mouse event at the data point ``point`` through the canvas, as a backend would.

    Parameters
    ----------
    view : SurgeryView
    kind : {"press", "move", "release"}
        Button press, motion (with the button held, if it was pressed) or button release.
    point : (2,) array_like
        Where, in data coordinates of ``view.ax`` (converted to pixels with
        ``ax.transData``; a point outside the axes gives an event outside them).
    button : int, default 1
        The mouse button of a press or release (1 = left).

    Returns
    -------
    matplotlib.backend_bases.MouseEvent
        The event, after every handler connected to the canvas has seen it.
    """
    _check_view(view)
    if kind not in _MOUSE_EVENTS:
        raise ValueError(f"kind must be one of {tuple(_MOUSE_EVENTS)}, got {kind!r}")
    p = np.asarray(point, dtype=float)
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ValueError(f"point must be a finite (x, y) pair in data coordinates, got {point!r}")
    ax = view.ax
    ax.apply_aspect()  # the pixel transform the next draw would use (equal aspect moves the axes box)
    x, y = ax.transData.transform(p)
    name = _MOUSE_EVENTS[kind]
    event = MouseEvent(name, view.canvas, x, y, button=None if kind == "move" else MouseButton(button))
    view.canvas.callbacks.process(name, event)
    return event


def synthetic_key(view, key, point=None):
    """Send a made-up key press (e.g. ``"c"``) through the canvas, with the pointer at ``point`` (default: the axes' centre).

    Returns the :class:`matplotlib.backend_bases.KeyEvent` after the handlers have seen it.
    """
    _check_view(view)
    if not isinstance(key, str) or not key:
        raise ValueError(f"key must be a non-empty string such as 'c', got {key!r}")
    ax = view.ax
    ax.apply_aspect()
    if point is None:
        x, y = ax.transAxes.transform((0.5, 0.5))
    else:
        x, y = ax.transData.transform(np.asarray(point, dtype=float))
    event = KeyEvent("key_press_event", view.canvas, key, x, y)
    view.canvas.callbacks.process("key_press_event", event)
    return event
