"""Operate on a running simulation with the mouse, in the browser: drag the tissue and cut it.

A :class:`SurgeryView` runs a :class:`~tissuefem.surgery.simulation.Simulation` and draws it in the page through a
:class:`~tissuefem.surgery.widget.TissueWidget`: the kernel sends the deformed node positions as binary arrays (the
triangles only when a cut changes them) and the browser draws them; nothing is rasterised in the kernel. In **drag**
mode (the default) a press grabs the nodes within ``radius`` of the pointer, moving drags them and letting go releases
them; in **cut** mode a stroke becomes an incision when the button is released. The page's buttons, its key ``c`` and
``view.mode = "cut"`` switch modes; its run/pause button, :meth:`~SurgeryView.start` and :meth:`~SurgeryView.stop`
run and pause the frames.

The same view runs a 3D simulation (a tetrahedral mesh): the page draws its surface with WebGL, lit, from a camera
that a right drag, a shift+drag or a drag beside the body turns and the wheel zooms; a press on the body grabs the
surface point under the pointer, which then moves in the plane through it facing the camera (the messages carry z).

The frame loop is an asyncio task in the kernel: a frame every ``interval_ms`` while something changes (input, or
the tissue still moving); at rest it waits without running or sending anything. Without a running event loop
(headless, in the tests) code calls :meth:`~SurgeryView.step`; :func:`synthetic_mouse` and :func:`synthetic_key`
send made-up input through the same message handler as the page's, so a notebook shows a drag or a cut without a
mouse. One live view per simulation and per notebook cell: a new view of the same simulation stops the old one,
and re-running a cell closes the view it made. :func:`snapshot` draws the current state as a static matplotlib
figure.
"""

from __future__ import annotations

import asyncio
import functools
import math
import threading
import time
import weakref

import numpy as np
from IPython import get_ipython
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ..engine.meshes import mean_edge_length
from ..engine.parameters import ParameterError, check_count, check_positive, check_vector, string
from .widget import TissueWidget, outline

__all__ = ["SurgeryView", "Gestures", "Pacing", "MODES", "REST_FRAMES", "take_over", "one_at_a_time",
           "synthetic_mouse", "synthetic_key", "snapshot", "shown_box", "element_j"]

#: the interaction modes of a :class:`SurgeryView`
MODES = ("drag", "cut")
#: frames in a row in which no drawn point moved more than ``rest_tolerance`` before the loop rests
REST_FRAMES = 5
READOUT_S = 0.25  #: seconds between readout lines sent while frames run (a new mode, state or message goes at once)
POINTER_KINDS = ("down", "move", "up")
_MOUSE_KINDS = {"press": "down", "move": "move", "release": "up"}
PAUSED_DRAG = "paused: the tissue follows once the view runs (the run button, or view.start())"

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
    (disconnected, saying why), one that the same cell made in an earlier run closes (its output is gone).
    :meth:`SurgeryView.disconnect` leaves the registry."""
    view._origin = _cell_origin()
    for old in [v for v in _VIEWS if not v.closed]:
        if old.sim is view.sim:
            old.disconnect()
            old._show("stopped: a newer view drives this simulation")
        elif view._origin and old._origin and old._origin[0] == view._origin[0] and old._origin != view._origin:
            old.close()  # its cell was run again: its output is gone
    _VIEWS.add(view)


def one_at_a_time(method):
    """Run ``method`` holding the view's lock: a frame and an event never interleave (a kernel may handle a
    widget's messages on another thread than the frame loop's: a cut could otherwise rebuild the mesh mid-frame)."""

    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)

    return locked


class Gestures:
    """A view's pointer input mapped to the simulation's ``grab``, ``drag``, ``release`` and ``cut``.

    :meth:`press`, :meth:`move` and :meth:`release` take points in world coordinates. ``real`` says whether the
    input came from a person (the page's pointer) or from code (:func:`synthetic_mouse`): a grab made in code is
    not carried on by the real pointer, nor a real one by made-up moves. A ``ValueError`` of the simulation becomes the
    view's message. The view provides ``radius``, ``stroke_spacing``, ``message`` and the hooks ``_changed``,
    ``_request_draw``, ``_show``, ``_follow`` and ``_tools_changed`` (the drag target or the stroke moved:
    ``target``, the point the grab follows, or ``None``; ``stroke``, the points drawn so far, or ``None``).
    """

    def __init__(self, view):
        self.view, self.sim, self._lock = view, view.sim, view._lock
        self.mode, self.handle, self.stroke, self.target = "drag", None, None, None
        self.real_press = False  # whether the grab or stroke began with a real press (a GUI event) or in code

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
        self.view._tools_changed()
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
        self.view._tools_changed()
        self.view._request_draw()

    @one_at_a_time
    def release(self, point=None) -> None:
        """The button was let go (at ``point``, or outside the view: ``None``): end the grab, or cut along the
        stroke."""
        if self.handle is not None:
            self.end_grab()
            self.view._changed()
        elif self.stroke is not None:
            stroke = np.array(self.stroke if point is None else self.stroke + [np.asarray(point, dtype=float)])
            self.drop()
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
            self.view._follow()  # the new triangles
            self.view._changed()

    def end_grab(self) -> None:
        """Release the grabbed handle, if any."""
        if self.handle is not None:
            handle, self.handle, self.target = self.handle, None, None
            self.view._tools_changed()
            try:
                self.sim.release(handle)
            except ValueError as exc:
                self.view.message = f"release failed: {exc}"

    def drop(self) -> None:
        """End a grab and drop a stroke in progress."""
        self.end_grab()
        self.stroke = None
        self.view._tools_changed()


class SurgeryView:
    """A simulation drawn in the page by a :class:`~tissuefem.surgery.widget.TissueWidget`, operated on with the
    pointer (:class:`Gestures`).

    Parameters
    ----------
    sim : tissuefem.surgery.simulation.Simulation
        Or anything with ``mesh``, ``positions``, ``picture``, ``frame``, ``grab``, ``drag``, ``release``, ``cut``.
    radius : float, optional
        A press grabs the nodes within this distance of the pointer; default twice the mean edge length.
    interval_ms : int, default 32
        Milliseconds between frames while something changes: a little more than the notes' 30 frames per second
        (at 33 ms the kernel could send at most 30.3 a second, and one late frame put it under 30).
    color : {None, "J"}
        One fill colour, or each triangle coloured by its element's ``J`` (area change; volume change in 3D: blue
        shrunk, red stretched).
    autostart : bool, default True
        Start the frame loop when the view is displayed (in a kernel with a running event loop).
    rest_tolerance : float, optional
        A frame in which no drawn point moved farther than this (world units) is quiet; after ``REST_FRAMES`` quiet
        frames without input the loop rests. Default: a thousandth of the shown box.
    width, height : int
        The canvas, CSS pixels.

    Attributes
    ----------
    widget : TissueWidget
    gestures : Gestures
    frame_times : list of float
        Milliseconds of every frame run by :meth:`step`.
    last_report : FrameReport or None
    pushes, topology_pushes : int
        Positions sent (frames the tissue moved), topologies sent (the first and one per cut).
    message : str
        The last message (a failed cut, a rejected drag, a paused view, a failed frame), or ``""``.

    Examples
    --------
    >>> from tissuefem.surgery.scene import demo_scene
    >>> from tissuefem.surgery.simulation import Simulation
    >>> view = SurgeryView(Simulation(demo_scene(n_triangles=400)), autostart=False)
    >>> synthetic_mouse(view, "press", (1.95, 0.5))   # grab the right edge
    >>> synthetic_mouse(view, "move", (2.2, 0.7))     # drag it
    >>> report = view.step()                          # one frame: the tissue follows
    >>> synthetic_mouse(view, "release", (2.2, 0.7))
    """

    def __init__(self, sim, radius=None, interval_ms=32, color=None, autostart=True, rest_tolerance=None,
                 width=700, height=450):
        missing = [m for m in ("mesh", "positions", "picture", "frame", "grab", "drag", "release", "cut")
                   if not hasattr(sim, m)]
        if missing:
            raise ParameterError("sim", "sim must be a tissuefem.surgery.simulation.Simulation; "
                                        f"{type(sim).__name__} has no {missing}")
        self.sim = sim
        self.radius = check_positive("radius", 2.0 * mean_edge_length(sim.mesh) if radius is None else radius)
        self.interval_ms = check_count("interval_ms", interval_ms)
        self.color = None if color is None else string("color", color, ("J",))
        self.autostart = bool(autostart)
        self.stroke_spacing = 0.25 * mean_edge_length(sim.mesh)
        self.dim, bounds = shown_box(sim.mesh.p)  # 2 or 3, and the box the page shows
        self.rest_tolerance = (1e-3 * float(np.max(np.diff(bounds)[::2])) if rest_tolerance is None
                               else check_positive("rest_tolerance", rest_tolerance))
        width, height = check_count("width", width), check_count("height", height)
        self._lock = threading.RLock()
        self.message, self.closed, self.last_report = "", False, None
        self.frame_times: list[float] = []
        self.pushes = self.topology_pushes = 0
        self._mesh, self._picture, self._x = None, None, None
        self._quiet, self._dirty, self._readout_at, self._text_key = 0, True, -math.inf, None
        self._tools_stale = False  # the target or the stroke changed since they were sent
        self._task, self._wake, self._loop, self._loop_thread = None, None, None, None

        self.widget = TissueWidget(bounds=bounds, width=width, height=height)
        self.gestures = Gestures(self)
        self.widget.on_msg(self._on_msg)
        self.widget.observe(self._on_mode, names="mode")
        self.widget.observe(self._on_running, names="running")
        self._follow()
        self._update_text(force=True)
        take_over(self)

    # ------------------------------------------------------------------ mode and state
    @property
    def mode(self) -> str:
        """``"drag"`` or ``"cut"`` (the page's buttons and key ``c`` set it too). Switching ends a grab or drops a
        stroke in progress."""
        return self.gestures.mode

    @mode.setter
    @one_at_a_time
    def mode(self, value):
        if string("mode", value, MODES) == self.gestures.mode:
            return
        self.gestures.drop()
        self.gestures.mode = self.widget.mode = value
        self._changed()

    def _on_mode(self, change):
        try:
            self.mode = change["new"]
        except ValueError as exc:
            self.widget.mode = self.gestures.mode
            self._show(str(exc))

    @property
    def grabbed(self):
        """The name of the grabbed handle, or ``None``."""
        return self.gestures.handle

    @property
    def stroke(self):
        """The cut stroke being drawn, ``(k, dim)``, or ``None``."""
        return None if self.gestures.stroke is None else np.array(self.gestures.stroke)

    @property
    def frames(self) -> int:
        """Frames the simulation has run."""
        return int(getattr(self.sim, "frames", 0))

    @property
    def running(self) -> bool:
        """Whether the frame loop runs (resting or not); ``False``: paused."""
        return self._task is not None and not self._task.done()

    @property
    def resting(self) -> bool:
        """Whether the loop has nothing to do: no input since the last frame and the tissue still."""
        return not self._dirty and self._quiet >= REST_FRAMES

    # ------------------------------------------------------------------ input
    def handle_message(self, content, real=True) -> None:
        """One message of the page: ``{"event": "pointer", "kind": "down" | "move" | "up", "x": .., "y": ..,
        "inside": bool}`` (world coordinates; in 3D ``"z"`` too), as the widget's message handler passes it on, or
        ``{"event": "key", "key": "c"}``. ``real=False``: made up by code (:func:`synthetic_mouse`). A disconnected
        view ignores it."""
        if not isinstance(content, dict) or content.get("event") not in ("pointer", "key"):
            raise ParameterError("content", "content (a message of the page) must be a dict with event 'pointer' "
                                            f"or 'key', got {content!r}")
        if content["event"] == "key":
            if string("key", content.get("key"), nonempty=True) == "c" and not self.closed:
                self.mode = "drag" if self.mode == "cut" else "cut"
            return
        kind = string("kind", content.get("kind"), POINTER_KINDS)
        point = check_vector("point", [content.get(k) for k in "xyz"[:self.dim]], self.dim)
        if self.closed:
            return
        if kind == "down":
            self.gestures.press(point, real=real)
            if real and self.grabbed is not None and not self.running:
                self._show(PAUSED_DRAG)  # the marker would move and the tissue not: say why
        elif kind == "move":
            self.gestures.move(point, real=real)
        else:
            self.gestures.release(point if content.get("inside", True) else None)

    def _on_msg(self, widget, content, buffers):
        try:
            self.handle_message(content)
        except ValueError as exc:
            self._show(f"message ignored: {exc}")

    # the hooks Gestures calls
    def _changed(self) -> None:
        self._update_text()
        self._request_draw()

    def _request_draw(self) -> None:
        self._dirty = True
        self._poke()

    def _show(self, message: str) -> None:
        self.message = message
        self._changed()

    def _tools_changed(self) -> None:
        self._tools_stale = True
        if not self.running:
            self._send_tools()  # no frame will come to take them along

    # ------------------------------------------------------------------ frames and what is sent
    @one_at_a_time
    def step(self):
        """Run one frame (``sim.frame()``) and send the new positions (if any point moved); returns the report."""
        self._dirty = False
        report = self.last_report = self.sim.frame()
        self.frame_times.append(1e3 * float(report.elapsed))
        quiet = self._quiet
        self._follow()
        if getattr(report, "off_frame", "") == "running":  # not counted, and no rest before the committing frame
            self._quiet = min(quiet, REST_FRAMES - 1)
        self._update_text()
        return report

    def _follow(self) -> None:
        """The simulation's positions into the widget: with new triangles after a topology change."""
        x = np.asarray(self.sim.positions(), dtype=float)
        if self.sim.mesh is not self._mesh or x.shape != self._x.shape:
            self._mesh, self._picture = self.sim.mesh, self.sim.picture
            points, loops = self._picture.points(x), None
            if self.dim == 2:  # the boundary loops, filled when there are no colours
                loops = outline(self._picture.triangles, self._picture.points(np.asarray(self._mesh.p, dtype=float)))
            self.widget.show_mesh(points.T, self._picture.triangles.T, self._picture.edges.T, self._colors(), loops)
            self._x, self._quiet = x, 0
            self.topology_pushes += 1
            self.pushes += 1
            self._send_tools()
            return
        moved = float(np.max(np.abs(x - self._x))) if x.size else 0.0
        self._quiet = self._quiet + 1 if moved <= self.rest_tolerance else 0
        if moved == 0.0 and not self._tools_stale:
            return  # the same picture: nothing to send
        self._x = x
        points = self._picture.points(x)
        with self.widget.hold_sync():
            if moved > 0.0:
                colors = self._colors()
                if colors is not None:
                    self.widget.colors = colors.astype(np.float32).tobytes()
                self.widget.positions = np.ascontiguousarray(points.T, dtype=np.float32).tobytes()
                self.pushes += 1
            self._send_tools()

    def _colors(self):
        return None if self.color is None else element_j(self.sim, self._picture)

    def _send_tools(self) -> None:
        g = self.gestures
        self.widget.target = [] if g.target is None else [float(v) for v in g.target]
        self.widget.stroke = b"" if not g.stroke else np.asarray(g.stroke, dtype=np.float32).tobytes()
        self._tools_stale = False

    def readout(self) -> str:
        """The readout: mode, running / paused / at rest / stopped, frame, the step's time and its status; under
        it the frame's accuracy (``StepReport.accuracy``: converged, the relative residual, the energy decrease,
        the smallest J, the inverted elements, what was left undone)."""
        report = self.last_report
        frame = self.frames if report is None else int(report.frame)
        step = "--" if report is None else f"{1e3 * float(report.elapsed):4.1f}"
        status = "ready" if report is None else str(report.status)
        state = ("stopped" if self.closed else "paused" if not self.running
                 else "at rest" if self.resting else "running")
        line = f"{self.gestures.mode:4s} | {state} | frame {frame:5d} | step {step} ms | {status}"
        accuracy = getattr(report, "accuracy", None)  # converged, the residual, the smallest J, the inverted ...
        return f"{line}\n{accuracy}" if accuracy else line

    def _update_text(self, force=False) -> None:
        key = (self.gestures.mode, self.message, self.running, self.closed)
        now = time.perf_counter()
        if force or key != self._text_key or now - self._readout_at >= READOUT_S:
            with self.widget.hold_sync():
                self.widget.readout = self.readout()
                self.widget.message = self.message
            self._text_key, self._readout_at = key, now

    # ------------------------------------------------------------------ the frame loop: run and pause
    def _poke(self) -> None:
        """Wake the resting loop (from any thread)."""
        wake, loop = self._wake, self._loop
        if wake is None or loop is None or loop.is_closed():
            return
        if threading.get_ident() == self._loop_thread:
            wake.set()
        else:
            loop.call_soon_threadsafe(wake.set)

    def start(self) -> None:
        """Run: start the frame loop on the running event loop (a Jupyter kernel's); it rests when nothing
        changes."""
        if self.closed:
            raise ValueError("this view is disconnected (replaced or closed): make a new SurgeryView")
        if self.running:
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            raise RuntimeError("SurgeryView.start needs a running event loop (a Jupyter kernel's); "
                               "without one, call view.step()") from None
        self._loop, self._loop_thread, self._wake = loop, threading.get_ident(), asyncio.Event()
        self._task = loop.create_task(_frame_loop(self))
        if self.message == PAUSED_DRAG:
            self.message = ""
        self._dirty = True  # a first frame, then rest if nothing changes
        self.widget.running = True
        self._update_text(force=True)

    def stop(self) -> None:
        """Pause: stop the frame loop (a frame in progress finishes); :meth:`start` runs it again."""
        task, self._task = self._task, None
        if task is not None and not task.done():
            if self._loop is not None and threading.get_ident() != self._loop_thread:
                self._loop.call_soon_threadsafe(task.cancel)
            else:
                task.cancel()
        self.widget.running = False
        self._update_text(force=True)

    def _on_running(self, change):
        """The page's run/pause button."""
        if change["new"] == self.running:
            return
        if not change["new"]:
            self.stop()
            return
        try:
            self.start()
        except (RuntimeError, ValueError) as exc:
            self.widget.running = False
            self._show(str(exc))

    @one_at_a_time
    def disconnect(self) -> None:
        """Stop the loop and let go of the grab; the widget stays on the page, its buttons off."""
        self.stop()
        self.gestures.end_grab()
        self.closed = True
        self.widget.disabled = True
        self._update_text(force=True)
        _VIEWS.discard(self)  # no longer live: a new view need not stop it

    def close(self) -> None:
        """Disconnect and close the widget."""
        self.disconnect()
        self.widget.close()

    def _repr_mimebundle_(self, include=None, exclude=None):
        if self.autostart and not self.closed:
            try:
                self.start()
            except RuntimeError:
                pass  # no event loop: code steps the view
        bundle = self.widget._repr_mimebundle_(include=include, exclude=exclude)
        data = bundle[0] if isinstance(bundle, tuple) else bundle
        data["text/plain"] = repr(self)
        return bundle

    def __repr__(self):
        state = "closed" if self.closed else ("running" if self.running else "paused")
        return f"<SurgeryView {self.mode}, {state}, frame {self.frames}>"


class Pacing:
    """When the frame loop's frames start, in seconds of a clock: one frame per ``interval`` on average while
    anything changes, so that simulated time (a step per frame) keeps to real time's pace: with the view's default
    32 ms and a step of 1/30 s it runs 33.3/32, about 4 %, ahead.

    The frames are due on a grid ``interval`` apart (:attr:`due`). Input may start a frame early, from
    :attr:`earliest` on: up to ``EARLY`` of an interval before it is due, never within ``MIN_GAP`` of an interval of
    the last one; the grid goes on from where it was (an early frame does not make the next one earlier). A frame that
    starts late is made up for in the waits after it, up to ``MADE_UP`` of an interval (beyond that the grid moves
    on: a stall is not followed by a burst). :meth:`rest`: the next frame (after input) starts a new grid.
    """

    EARLY = 0.5
    MIN_GAP = 0.5
    MADE_UP = 1.0

    def __init__(self, interval):
        self.interval = check_positive("interval", interval)
        self.due = None  # when the next frame is due (None: at once)
        self.earliest = -math.inf  # the earliest it may start, when input arrives

    def start(self, now) -> None:
        """A frame starts at ``now``: when the next is due, and how early input may start it."""
        i = self.interval
        self.due = now + i if self.due is None else max(self.due + i, now + i - self.MADE_UP * i)
        self.earliest = max(self.due - self.EARLY * i, now + self.MIN_GAP * i)

    def rest(self) -> None:
        """The loop rests: input then starts a frame at once, and a new grid."""
        self.due, self.earliest = None, -math.inf


async def _frame_loop(view) -> None:
    """The view's frame loop (a task on the kernel's event loop): while anything moves, a frame every
    ``interval_ms`` (:class:`Pacing`), then asleep until input arrives, when a frame starts at once; a refused
    frame is a message, any other error stops the loop."""
    pacing = Pacing(view.interval_ms / 1e3)
    while not view.closed:
        if view.resting and not view._tools_stale:
            view._update_text(force=True)  # the last frame's line, "at rest"
            view._wake.clear()
            await view._wake.wait()  # nothing runs until input arrives
            pacing.rest()
            continue
        pacing.start(time.perf_counter())
        view._wake.clear()  # input from now on may start the next frame early
        try:
            if view.resting:
                with view._lock:
                    view._follow()  # only the target or the stroke moved
            else:
                view.step()
        except ValueError as exc:
            view._show(f"frame failed: {exc}")
            view._quiet = REST_FRAMES  # no retry until new input
            view._dirty = False
        except Exception:
            view.stop()  # one traceback, not thirty a second
            raise
        await asyncio.sleep(max(0.0, pacing.earliest - time.perf_counter()))
        if not view._wake.is_set():
            try:  # the rest of the interval, unless input arrives first
                await asyncio.wait_for(view._wake.wait(), max(0.0, pacing.due - time.perf_counter()))
            except asyncio.TimeoutError:
                pass


def shown_box(points) -> tuple[int, list[float]]:
    """The dimension of the points ``(d, n)`` and the box a view shows, ``[xmin, xmax, ymin, ymax]`` (3D: and
    ``zmin, zmax``): the points' box grown on every side by 0.3 of its largest side."""
    X = np.asarray(points, dtype=float)
    lo, hi = X.min(axis=1), X.max(axis=1)
    margin = 0.3 * float(np.max(hi - lo))
    return X.shape[0], [float(v) for v in np.column_stack([lo - margin, hi + margin]).ravel()]


def element_j(sim, picture) -> np.ndarray:
    """``J = det F`` of the element of each drawn triangle (``picture.element``): its area change, in 3D the volume
    change of the tetrahedron a surface face bounds (P2: the mean over the element's points)."""
    J = np.asarray(sim.model.jacobian(sim.u), dtype=float)
    return J.reshape(len(J), -1).mean(axis=1)[picture.element]


# ------------------------------------------------------------------ made-up input
def synthetic_mouse(view, kind, point) -> None:
    """Send a made-up pointer event ``kind`` (``"press"``, ``"move"`` or ``"release"``) at ``point`` ``(x, y)``
    (3D: ``(x, y, z)``; world coordinates) through the view's message handler, as the page would (but marked as
    code's input)."""
    if not isinstance(view, SurgeryView):
        raise ParameterError("view", f"view must be a SurgeryView, got {type(view).__name__}")
    if kind not in _MOUSE_KINDS:
        raise ParameterError("kind", f"kind must be one of {tuple(_MOUSE_KINDS)}, got {kind!r}")
    point = check_vector("point", point, view.dim)
    view.handle_message({"event": "pointer", "kind": _MOUSE_KINDS[kind], **dict(zip("xyz", map(float, point)))},
                        real=False)


def synthetic_key(view, key) -> None:
    """Send a made-up key press (``"c"`` toggles the mode; other keys do nothing) through the view's message
    handler."""
    if not isinstance(view, SurgeryView):
        raise ParameterError("view", f"view must be a SurgeryView, got {type(view).__name__}")
    view.handle_message({"event": "key", "key": key}, real=False)


def snapshot(view, ax=None):
    """The view's current picture as a static matplotlib figure (for a page without widgets, a book, a report):
    the triangles at the positions last sent (3D: the surface, on 3D axes), the drag target and the stroke, titled
    with the readout. Draws into ``ax`` if given (3D: axes with ``projection="3d"``); returns the figure."""
    if not isinstance(view, SurgeryView):
        raise ParameterError("view", f"view must be a SurgeryView, got {type(view).__name__}")
    three = view.dim == 3
    if ax is not None and three != hasattr(ax, "zaxis"):
        raise ParameterError("ax", f"ax must be {'3D axes' if three else 'flat axes'} for a {view.dim}D view")
    fig = Figure(figsize=(7.0, 4.5), layout="constrained") if ax is None else ax.figure
    ax = fig.add_subplot(projection="3d" if three else None) if ax is None else ax
    a = view.widget.arrays()
    style = dict(facecolor="mistyrose", edgecolor="firebrick", linewidth=0.3)
    faces = a["positions"][a["triangles"]]
    if three:
        ax.add_collection3d(Poly3DCollection(faces, **style))
    else:
        ax.add_collection(PolyCollection(faces, **style))
    if len(a["stroke"]):
        ax.plot(*a["stroke"].T, "-", color="k", lw=1.2)
    if view.widget.target:
        ax.plot(*np.asarray(view.widget.target)[:, None], "o", ms=7, mfc="none", mec="tab:blue", mew=1.5)
    b = view.widget.bounds
    ax.set(**{f"{c}lim": (b[2 * k], b[2 * k + 1]) for k, c in enumerate("xyz"[:view.dim])}, aspect="equal")
    ax.set_title(view.widget.readout, fontsize=8, family="monospace", loc="left")
    return fig
