"""A running simulation drawn in the browser: the kernel sends node positions, the page draws the triangles.

:class:`TissueWidget` is a Jupyter widget (anywidget) whose JavaScript ships with the package
(``static/tissue_widget.js``, nothing fetched at run time): a canvas that draws triangles (fill and edges) from
binary arrays, the drag target and the cut stroke over them, and a readout line. The positions (float32) are sent
each frame the tissue moved, the triangles (int32) only when the topology changes (a cut); the page paints with
``requestAnimationFrame`` only when something arrived. The pointer comes back as messages in world coordinates.
Positions carry their dimension (``dim``), so a 3D view can send its surface triangles the same way.

:class:`BrowserView` operates a :class:`~tissuefem.surgery.simulation.Simulation` through it. Its input goes through
the same :class:`~tissuefem.surgery.interactive.Gestures` as the matplotlib :class:`~.interactive.SurgeryView`;
its frame loop is an asyncio task in the kernel that runs a frame every ``interval_ms`` only while something
changes (input, or the tissue still moving), and at rest waits without running or sending anything. Headless,
code calls :meth:`BrowserView.step` and feeds :meth:`BrowserView.handle_message` the page's messages.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from pathlib import Path

import numpy as np

from ..engine.meshes import mean_edge_length
from ..engine.parameters import ParameterError, check_count, check_positive, check_vector, string
from .interactive import MODES, Gestures, let_go, one_at_a_time, take_over

try:
    import anywidget
    import traitlets
except ImportError as exc:  # an optional extra
    raise ImportError("tissuefem.surgery.widget needs anywidget (pip install 'tissuefem[interactive]')") from exc

__all__ = ["TissueWidget", "BrowserView", "outline", "STATIC", "REST_FRAMES"]

#: the folder of the widget's JavaScript
STATIC = Path(__file__).with_name("static")
#: frames in a row in which no drawn point moved more than ``rest_tolerance`` before the loop rests
REST_FRAMES = 5
READOUT_S = 0.25  #: seconds between readout lines sent while frames run (a new mode or message goes at once)
POINTER_KINDS = ("down", "move", "up")


class TissueWidget(anywidget.AnyWidget):
    """A triangle mesh drawn on a canvas in the page, from binary arrays (see ``static/tissue_widget.js``).

    ``positions``: float32 bytes ``(n_points, dim)``; ``triangles``: int32 bytes ``(n_triangles, 3)``; ``edges``:
    int32 bytes ``(n_edges, 2)``; ``colors``: float32 bytes, one value per triangle mapped over ``color_range``, or
    empty (one fill colour); ``bounds``: the world box shown; ``target``: ``[x, y]`` or ``[]``; ``stroke``: float32
    bytes ``(k, 2)``; ``outline``: int32 bytes, boundary loops of point indices each ended by ``-1``. The page
    sends ``{"event": "pointer", "kind": "down" | "move" | "up", "x", "y", "inside"}``.
    """

    _esm = STATIC / "tissue_widget.js"
    dim = traitlets.Int(2).tag(sync=True)
    positions = traitlets.Bytes(b"").tag(sync=True)
    triangles = traitlets.Bytes(b"").tag(sync=True)
    edges = traitlets.Bytes(b"").tag(sync=True)
    outline = traitlets.Bytes(b"").tag(sync=True)
    colors = traitlets.Bytes(b"").tag(sync=True)
    color_range = traitlets.List(traitlets.Float(), [0.5, 1.5]).tag(sync=True)
    bounds = traitlets.List(traitlets.Float(), [0.0, 1.0, 0.0, 1.0]).tag(sync=True)
    target = traitlets.List(traitlets.Float(), []).tag(sync=True)
    stroke = traitlets.Bytes(b"").tag(sync=True)
    readout = traitlets.Unicode("").tag(sync=True)
    message = traitlets.Unicode("").tag(sync=True)
    mode = traitlets.Unicode("drag").tag(sync=True)
    width = traitlets.Int(700).tag(sync=True)
    height = traitlets.Int(450).tag(sync=True)

    def show_mesh(self, positions, triangles, edges=None, colors=None, outline=None) -> None:
        """Send a new topology with its positions, in one message: ``positions`` ``(n, dim)``, ``triangles``
        ``(q, 3)``, ``edges`` ``(r, 2)``, ``colors`` ``(q,)``, ``outline``: the boundary loops (:func:`outline`),
        filled instead of the triangles when there are no colours."""
        x = np.ascontiguousarray(positions, dtype=np.float32)
        t = np.ascontiguousarray(triangles, dtype=np.int32)
        if x.ndim != 2 or x.shape[1] not in (2, 3):
            raise ParameterError("positions", f"positions must be (n, 2) or (n, 3), got shape {x.shape}")
        if t.ndim != 2 or t.shape[1] != 3 or (t.size and (t.min() < 0 or t.max() >= len(x))):
            raise ParameterError("triangles", f"triangles must be (q, 3) indices into the {len(x)} positions")
        with self.hold_sync():
            self.dim = int(x.shape[1])
            self.triangles = t.tobytes()
            self.edges = b"" if edges is None else np.ascontiguousarray(edges, dtype=np.int32).tobytes()
            self.colors = b"" if colors is None else np.ascontiguousarray(colors, dtype=np.float32).tobytes()
            self.outline = b"" if outline is None else np.ascontiguousarray(outline, dtype=np.int32).tobytes()
            self.positions = x.tobytes()

    def arrays(self) -> dict:
        """What the widget holds, as arrays: ``positions`` ``(n, dim)``, ``triangles``, ``edges``, ``colors``,
        ``stroke``."""
        return {"positions": np.frombuffer(self.positions, np.float32).reshape(-1, self.dim),
                "triangles": np.frombuffer(self.triangles, np.int32).reshape(-1, 3),
                "edges": np.frombuffer(self.edges, np.int32).reshape(-1, 2),
                "colors": np.frombuffer(self.colors, np.float32),
                "outline": np.frombuffer(self.outline, np.int32),
                "stroke": np.frombuffer(self.stroke, np.float32).reshape(-1, 2)}


def outline(triangles, reference) -> np.ndarray:
    """The boundary of the triangles ``(3, q)`` (indices into the points ``reference`` ``(2, n)``) as closed loops
    of point indices, each ended by ``-1``: the outer ones counter-clockwise, holes and cuts clockwise, so that
    filling them (nonzero rule) paints what the triangles cover. One fill of a few hundred edges replaces one of
    every triangle, which a browser without a GPU rasterises ten times slower."""
    t = np.asarray(triangles, dtype=np.int64)
    if t.size == 0:
        return np.zeros(0, np.int32)
    a, b, c = (reference[:, t[k]] for k in range(3))
    flip = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) < 0
    t = np.where(flip, t[[0, 2, 1]], t)  # every triangle counter-clockwise
    tails, heads = t.ravel(), np.roll(t, -1, axis=0).ravel()
    directed = set(zip(tails.tolist(), heads.tolist()))
    nxt: dict[int, list[int]] = {}
    for u, v in directed:
        if (v, u) not in directed:  # an edge of one triangle only: on the boundary
            nxt.setdefault(u, []).append(v)
    loops = []
    while nxt:
        start = next(iter(nxt))
        loop, u = [start], start
        while True:
            heads_u = nxt[u]
            v = heads_u.pop()
            if not heads_u:
                del nxt[u]
            if v == start or v not in nxt:
                break
            loop.append(v)
            u = v
        loops += loop + [-1]
    return np.asarray(loops, dtype=np.int32)


def _area_ratios(points, triangles, reference) -> np.ndarray:
    """Deformed over reference area of each drawn triangle (for P1: the element's ``J``)."""
    def areas(p):
        a, b, c = (p[:, triangles[k]] for k in range(3))
        return 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    ref = areas(reference)
    return areas(points) / np.where(ref == 0, 1.0, ref)


class BrowserView:
    """A simulation drawn in the page by a :class:`TissueWidget`, operated on with the pointer.

    Parameters
    ----------
    sim : tissuefem.surgery.simulation.Simulation
    radius : float, optional
        A press grabs the nodes within this distance of the pointer; default twice the mean edge length.
    interval_ms : int, default 33
        Milliseconds between frames while something changes (the notes' 30 frames per second).
    color : {None, "J"}
        One fill colour, or each triangle coloured by its area change ``J`` (blue shrunk, red stretched).
    autostart : bool, default True
        Start the frame loop when the view is displayed (in a kernel with a running event loop).
    rest_tolerance : float, optional
        A frame in which no drawn point moved farther than this (world units) is quiet; after ``REST_FRAMES`` quiet
        frames without input the loop rests. Default: a thousandth of the shown box.

    Attributes
    ----------
    widget : TissueWidget
    gestures : tissuefem.surgery.interactive.Gestures
    frame_times : list of float
        Milliseconds of every frame run by :meth:`step`.
    pushes, topology_pushes : int
        Positions sent (frames the tissue moved), topologies sent (the first and one per cut).
    message : str
    """

    def __init__(self, sim, radius=None, interval_ms=33, color=None, autostart=True, rest_tolerance=None,
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
        X = np.asarray(sim.mesh.p, dtype=float)
        lo, hi = X.min(axis=1), X.max(axis=1)
        margin = 0.3 * float(np.max(hi - lo))
        bounds = [lo[0] - margin, hi[0] + margin, lo[1] - margin, hi[1] + margin]
        self.rest_tolerance = (1e-3 * max(bounds[1] - bounds[0], bounds[3] - bounds[2]) if rest_tolerance is None
                               else check_positive("rest_tolerance", rest_tolerance))
        self._lock = threading.RLock()
        self.message, self.closed, self.last_report = "", False, None
        self.frame_times: list[float] = []
        self.pushes = self.topology_pushes = 0
        self._mesh, self._picture, self._reference, self._x = None, None, None, None
        self._quiet, self._dirty, self._readout_at, self._text_key = 0, True, -math.inf, None
        self._tools_stale = False  # the target or the stroke changed since they were sent
        self._task, self._wake, self._loop, self._loop_thread = None, None, None, None

        self.widget = TissueWidget(bounds=[float(b) for b in bounds], width=check_count("width", width),
                                   height=check_count("height", height))
        self.gestures = BrowserGestures(self)
        self.widget.on_msg(self._on_msg)
        self.widget.observe(self._on_mode, names="mode")
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
        self.gestures.mode = value
        self.widget.mode = value
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
    def running(self) -> bool:
        """Whether the frame loop runs (resting or not)."""
        return self._task is not None and not self._task.done()

    @property
    def resting(self) -> bool:
        """Whether the loop has nothing to do: no input since the last frame and the tissue still."""
        return not self._dirty and self._quiet >= REST_FRAMES

    # ------------------------------------------------------------------ input
    def handle_message(self, content) -> None:
        """One message of the page: ``{"event": "pointer", "kind": "down" | "move" | "up", "x": .., "y": ..,
        "inside": bool}`` (world coordinates), as the widget's message handler passes it on."""
        if not isinstance(content, dict) or content.get("event") != "pointer":
            raise ParameterError("content", "content (a message of the page) must be a dict with event 'pointer', "
                                            f"got {content!r}")
        kind = string("kind", content.get("kind"), POINTER_KINDS)
        point = check_vector("point", [content.get("x"), content.get("y")])
        if kind == "down":
            self.gestures.press(point, real=True)
        elif kind == "move":
            self.gestures.move(point, real=True)
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

    def _refresh(self) -> None:
        self._follow()
        self._changed()

    # ------------------------------------------------------------------ frames and what is sent
    @one_at_a_time
    def step(self):
        """Run one frame (``sim.frame()``) and send the new positions (if any point moved); returns the report."""
        self._dirty = False
        report = self.last_report = self.sim.frame()
        self.frame_times.append(1e3 * float(report.elapsed))
        self._follow()
        self._update_text()
        return report

    def _follow(self) -> None:
        """The simulation's positions into the widget: with new triangles after a topology change."""
        x = np.asarray(self.sim.positions(), dtype=float)
        if self.sim.mesh is not self._mesh or self._x is None or x.shape != self._x.shape:
            self._mesh, self._picture = self.sim.mesh, self.sim.picture
            self._reference = self._picture.points(np.asarray(self._mesh.p, dtype=float))
            points = self._picture.points(x)
            self.widget.show_mesh(points.T, self._picture.triangles.T, self._picture.edges.T, self._colors(points),
                                  outline(self._picture.triangles, self._reference))
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
                colors = self._colors(points)
                if colors is not None:
                    self.widget.colors = colors.astype(np.float32).tobytes()
                self.widget.positions = np.ascontiguousarray(points.T, dtype=np.float32).tobytes()
                self.pushes += 1
            self._send_tools()

    def _colors(self, points):
        return None if self.color is None else _area_ratios(points, self._picture.triangles, self._reference)

    def _send_tools(self) -> None:
        g = self.gestures
        self.widget.target = [] if g.target is None else [float(v) for v in g.target]
        self.widget.stroke = b"" if not g.stroke else np.asarray(g.stroke, dtype=np.float32).tobytes()
        self._tools_stale = False

    def _tools_changed(self) -> None:
        self._tools_stale = True
        if not self.running:
            self._send_tools()  # no frame will come to take them along

    def _update_text(self, force=False) -> None:
        report = self.last_report
        frame = int(getattr(self.sim, "frames", 0)) if report is None else int(report.frame)
        step = "--" if report is None else f"{1e3 * float(report.elapsed):4.1f}"
        status = "ready" if report is None else str(report.status)
        key = (self.gestures.mode, self.message)
        now = time.perf_counter()
        if force or key != self._text_key or now - self._readout_at >= READOUT_S:
            with self.widget.hold_sync():
                self.widget.readout = f"{self.gestures.mode:4s} | frame {frame:5d} | step {step} ms | {status}"
                self.widget.message = self.message
            self._text_key, self._readout_at = key, now

    # ------------------------------------------------------------------ the frame loop
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
        """Start the frame loop on the running event loop (a Jupyter kernel's); it rests when nothing changes."""
        if self.closed:
            raise ValueError("this view is disconnected (replaced or closed): make a new BrowserView")
        if self.running:
            return
        try:
            loop = asyncio.get_running_loop()
        except RuntimeError:
            raise RuntimeError("BrowserView.start needs a running event loop (a Jupyter kernel's); "
                               "without one, call view.step()") from None
        self._loop, self._loop_thread, self._wake = loop, threading.get_ident(), asyncio.Event()
        self._task = loop.create_task(self._run())

    def stop(self) -> None:
        """Stop the frame loop (a frame in progress finishes)."""
        task = self._task
        if task is not None and not task.done():
            if self._loop is not None and threading.get_ident() != self._loop_thread:
                self._loop.call_soon_threadsafe(task.cancel)
            else:
                task.cancel()

    async def _run(self) -> None:
        interval = self.interval_ms / 1e3
        while not self.closed:
            if self.resting and not self._tools_stale:
                self._wake.clear()
                await self._wake.wait()  # nothing runs until input arrives
                continue
            started = time.perf_counter()
            try:
                if self.resting:
                    with self._lock:
                        self._follow()  # only the target or the stroke moved
                else:
                    self.step()
            except ValueError as exc:
                self._show(f"frame failed: {exc}")
                self._quiet = REST_FRAMES  # no retry until new input
                self._dirty = False
            await asyncio.sleep(max(0.0, interval - (time.perf_counter() - started)))

    @one_at_a_time
    def disconnect(self) -> None:
        """Stop the loop and let go of the grab; the widget stays on the page."""
        self.stop()
        self.gestures.end_grab()
        self.closed = True
        let_go(self)

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
        return self.widget._repr_mimebundle_(include=include, exclude=exclude)

    def __repr__(self):
        state = "closed" if self.closed else ("running" if self.running else "stopped")
        return f"<BrowserView {self.mode}, {state}, frame {int(getattr(self.sim, 'frames', 0))}>"


class BrowserGestures(Gestures):
    """:class:`~tissuefem.surgery.interactive.Gestures` whose target and stroke go to the page with the next
    frame."""

    def tools_changed(self) -> None:
        self.view._tools_changed()
