"""SurgeryView headless: the page's messages (and made-up ones) drag and cut a running simulation, the widget's
arrays follow, nothing is sent at rest, the frame loop runs and pauses, and one view lives per simulation and cell."""

import asyncio
import dataclasses
import time
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("anywidget")

import tissuefem
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery import interactive
from tissuefem.surgery.interactive import (MODES, PAUSED_DRAG, REST_FRAMES, Gestures, Pacing, SurgeryView, snapshot,
                                           synthetic_key, synthetic_mouse)
from tissuefem.engine.meshes import mean_edge_length
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation

WIDTH, HEIGHT = 2.0, 1.0
#: a small dynamic sheet held on its left edge (a few hundred triangles: every frame takes milliseconds)
SHEET = {
    "domain": {"shape": "rectangle", "width": WIDTH, "height": HEIGHT, "triangles": 400},
    "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
    "effects": {"inertia": {"time_step": 1.0 / 30.0}, "handles": [{"name": "fixed", "region": "left"}]},
}


class Spy:
    """Wrap some of a simulation's methods to record their calls."""

    def __init__(self, sim, *names):
        self.calls = {n: [] for n in names}
        for n in names:
            original = getattr(sim, n)

            def wrapped(*args, _n=n, _f=original, **kwargs):
                self.calls[_n].append(args)
                return _f(*args, **kwargs)

            setattr(sim, n, wrapped)


class TickingClock:
    """A fake clock: every read advances 0.1 ms, so frame times are deterministic and far below the budget."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        self.now += 1e-4
        return self.now


class Sent:
    """The widget's synced traits that changed (what the page is sent), counted by name."""

    def __init__(self, widget):
        self.counts = {}
        widget.observe(self, names=["positions", "triangles", "edges", "target", "stroke", "readout", "message"])

    def __call__(self, change):
        self.counts[change["name"]] = self.counts.get(change["name"], 0) + 1

    def clear(self):
        self.counts = {}


def make_sim():
    return Simulation(Scene.from_dict(SHEET), clock=TickingClock())


def pointer(view, kind, x, y, inside=True):
    """A message as the page sends it (a real pointer)."""
    view.handle_message({"event": "pointer", "kind": kind, "x": x, "y": y, "inside": inside})


@pytest.fixture
def view():
    v = SurgeryView(make_sim(), autostart=False)
    yield v
    v.close()


def drawn(view):
    return view.widget.arrays()["positions"].T  # (2, n_points)


# ------------------------------------------------------------------ a light face
def test_import_tissuefem_loads_neither_pyplot_nor_ipython():
    """The view is imported where it is used: the package loads no drawing or notebook machinery, not even once
    every name of its face has been resolved (``import tissuefem`` alone loads none of its modules: see
    ``tests/test_architecture.py``)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(tissuefem.__file__).parents[1]),
                                                       os.environ.get("PYTHONPATH", "")]))
    heavy = {'matplotlib.pyplot', 'IPython', 'anywidget', 'meshio', 'scipy.spatial', 'tomllib'}
    code = f"import sys, tissuefem; from tissuefem import *; print(sorted({heavy!r} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["[]"]
    assert "SurgeryView" not in tissuefem.__all__ and not hasattr(tissuefem, "SurgeryView")


def test_one_view_class_drawn_by_the_widget(view):
    assert not hasattr(interactive, "BrowserView") and not hasattr(interactive, "MouseGestures")
    assert isinstance(view.gestures, Gestures)
    assert view.mode == "drag" and view.grabbed is None and not view.running
    assert view.radius == pytest.approx(2 * mean_edge_length(view.sim.mesh))
    np.testing.assert_allclose(drawn(view), view.sim.positions(), atol=1e-6)
    x0, x1, y0, y1 = view.widget.bounds
    assert x0 < 0 < WIDTH < x1 and y0 < 0 < HEIGHT < y1


# ------------------------------------------------------------------ drag mode
def test_drag_grabs_moves_the_handle_and_the_tissue_follows(view):
    sim = view.sim
    grab_at, mouse = np.array([1.9, 0.5]), np.array([2.2, 0.7])
    X = sim.positions()
    d = np.linalg.norm(X - grab_at[:, None], axis=0)
    grabbed, around = d <= view.radius, (d > 1.5 * view.radius) & (d < 3.0 * view.radius)
    sent = Sent(view.widget)

    synthetic_mouse(view, "press", grab_at)
    name = view.grabbed
    assert name is not None and view.widget.target == pytest.approx(grab_at)
    for s in np.linspace(0.0, 1.0, 5)[1:]:
        synthetic_mouse(view, "move", (1 - s) * grab_at + s * mouse)
    np.testing.assert_allclose(sim.handles[name].target, mouse - grab_at, atol=1e-9)
    assert view.widget.target == pytest.approx(mouse)  # the marker follows the pointer
    for _ in range(3):
        report = view.step()
    assert report.converged
    x = sim.positions()
    np.testing.assert_allclose(x[:, grabbed] - X[:, grabbed], np.tile((mouse - grab_at)[:, None], grabbed.sum()),
                               atol=1e-9)
    before = np.linalg.norm(X[:, around] - mouse[:, None], axis=0)
    after = np.linalg.norm(x[:, around] - mouse[:, None], axis=0)
    assert after.mean() < 0.8 * before.mean()
    np.testing.assert_allclose(drawn(view), x, atol=1e-5)  # the page is sent what the simulation holds
    assert sent.counts.get("positions", 0) >= 3 and "triangles" not in sent.counts, "no topology while dragging"
    synthetic_mouse(view, "release", mouse)
    assert view.grabbed is None and name not in sim.handles and view.widget.target == []


def test_press_off_the_tissue_does_nothing(view):
    spy = Spy(view.sim, "grab", "drag", "release", "cut")
    pointer(view, "down", WIDTH + 0.5, HEIGHT + 0.25)
    pointer(view, "move", WIDTH + 0.4, HEIGHT + 0.2)
    pointer(view, "up", WIDTH + 0.4, HEIGHT + 0.2)
    assert view.grabbed is None and view.message == ""
    assert spy.calls["drag"] == [] and spy.calls["release"] == [] and spy.calls["cut"] == []


def test_a_release_outside_the_canvas_still_lets_go(view):
    pointer(view, "down", 1.9, 0.5)
    pointer(view, "move", 2.1, 0.6)
    pointer(view, "up", 9.0, 9.0, inside=False)
    assert view.grabbed is None


def test_the_real_pointer_does_not_carry_on_a_grab_made_in_code(view):
    sim = view.sim
    synthetic_mouse(view, "press", (1.9, 0.5))  # a grab made by code
    name = view.grabbed
    pointer(view, "move", 0.5, -0.4)  # a real move: not the code's grab
    np.testing.assert_allclose(sim.handles[name].target, 0.0, atol=1e-12)
    pointer(view, "down", 1.95, 0.5)  # a real press replaces it
    assert view.grabbed not in (None, name) and name not in sim.handles
    pointer(view, "move", 2.1, 0.6)
    np.testing.assert_allclose(sim.handles[view.grabbed].target, (0.15, 0.1), atol=1e-9)


# ------------------------------------------------------------------ paused: it says so (a student met a silent one)
def test_a_paused_view_says_so_and_a_drag_while_paused_says_why_the_tissue_stays(view):
    assert "paused" in view.widget.readout.splitlines()[0] and "paused" in repr(view)
    pointer(view, "down", 1.9, 0.5)
    assert view.grabbed is not None and view.message == PAUSED_DRAG and view.widget.message == PAUSED_DRAG
    pointer(view, "move", 2.1, 0.6)
    assert view.widget.target == pytest.approx([2.1, 0.6]) and view.message == PAUSED_DRAG
    pointer(view, "up", 2.1, 0.6)
    synthetic_mouse(view, "press", (1.9, 0.5))  # code that steps the view itself is not told
    assert view.message == ""


def test_the_run_button_runs_and_pauses_and_the_readout_follows():
    async def session():
        v = SurgeryView(make_sim(), interval_ms=5)
        v.widget.running = True  # the page's run button
        assert v.running and v.widget.running
        await asyncio.sleep(0.05)
        assert "paused" not in v.widget.readout
        pointer(v, "down", 1.9, 0.5)
        assert v.message == "", "a running view does not call itself paused"
        pointer(v, "up", 1.9, 0.5)
        v.widget.running = False  # the pause button
        assert not v.running and "| paused |" in v.widget.readout
        v.start()
        assert v.widget.running
        v.stop()
        assert not v.widget.running
        v.close()

    asyncio.run(session())


def test_without_an_event_loop_the_run_button_says_what_to_do(view):
    view.widget.running = True
    assert not view.running and not view.widget.running and "view.step()" in view.message
    with pytest.raises(RuntimeError, match="event loop"):
        view.start()


# ------------------------------------------------------------------ modes
def test_key_c_toggles_the_mode(view):
    synthetic_key(view, "c")
    assert view.mode == "cut" and view.widget.mode == "cut" and view.widget.readout.startswith("cut")
    synthetic_key(view, "x")  # other keys: nothing
    assert view.mode == "cut"
    synthetic_key(view, "c")
    assert view.mode == "drag"


def test_modes_from_the_page_and_from_code(view):
    view.widget.mode = "cut"  # the page's button
    assert view.mode == "cut"
    view.mode = "drag"
    assert view.widget.mode == "drag"
    with pytest.raises(ParameterError, match="mode"):
        view.mode = "scalpel"
    view.widget.mode = "pinch"  # from the page: refused, the mode stays
    assert view.widget.mode == "drag" and view.mode == "drag" and "mode" in view.message
    assert MODES == ("drag", "cut")


def test_switching_mode_releases_a_grab(view):
    spy = Spy(view.sim, "release")
    synthetic_mouse(view, "press", (1.9, 0.5))
    view.mode = "cut"
    assert view.grabbed is None and len(spy.calls["release"]) == 1


# ------------------------------------------------------------------ cut mode
def test_a_cut_resends_the_topology_once(view):
    sim, sent = view.sim, Sent(view.widget)
    nodes = sim.mesh.nvertices
    view.step()
    view.mode = "cut"
    pointer(view, "down", 1.0, 1.3)
    for y in (1.1, 0.9, 0.7, 0.5):
        pointer(view, "move", 1.0, y)
    assert view.stroke.shape == (5, 2) and view.widget.arrays()["stroke"].shape == (5, 2), "shown while drawn"
    pointer(view, "up", 1.0, 0.4)
    assert sim.mesh.nvertices > nodes and view.message == ""
    assert sent.counts.get("triangles") == 1 and view.topology_pushes == 2
    picture = sim.picture
    a = view.widget.arrays()
    assert a["triangles"].shape == (picture.triangles.shape[1], 3) and a["edges"].shape == (picture.edges.shape[1], 2)
    assert view.widget.stroke == b"" and view.stroke is None
    view.step()
    assert sent.counts["triangles"] == 1, "a frame after the cut sends positions only"
    np.testing.assert_allclose(drawn(view), picture.points(sim.positions()), atol=1e-5)


def test_a_cut_made_in_code_is_sent_at_the_next_frame(view):
    sim = view.sim
    sim.cut([(0.5, 1.2), (0.5, 0.6)])
    view.step()
    assert view.topology_pushes == 2 and drawn(view).shape == sim.picture.points(sim.positions()).shape


def test_stroke_skips_points_closer_than_the_spacing(view):
    view.mode = "cut"
    synthetic_mouse(view, "press", (1.0, -0.2))
    synthetic_mouse(view, "move", (1.0, -0.2 + 0.1 * view.stroke_spacing))
    assert len(view.stroke) == 1
    synthetic_mouse(view, "move", (1.0, 0.5))
    assert len(view.stroke) == 2


def test_a_click_without_a_stroke_does_not_cut(view):
    spy = Spy(view.sim, "cut")
    view.mode = "cut"
    synthetic_mouse(view, "press", (1.0, 0.5))
    synthetic_mouse(view, "release", (1.0, 0.5))
    assert spy.calls["cut"] == [] and "stroke" in view.message


def test_a_failed_cut_says_why_once_and_changes_nothing(view):
    nodes = view.sim.mesh.nvertices
    view.mode = "cut"
    pointer(view, "down", -0.5, 1.45)
    for x in (-0.45, -0.4, -0.35):
        pointer(view, "move", x, 1.4)
    pointer(view, "up", -0.3, 1.35)
    assert view.message.startswith("cut failed: polyline changes nothing: it meets no material")
    assert view.message.count("polyline") == 1, "the field is named once"
    assert view.widget.message == view.message and view.sim.mesh.nvertices == nodes
    view.mode = "drag"
    synthetic_mouse(view, "press", (1.9, 0.5))  # the next action clears it
    assert view.message == "" and view.widget.message == ""


# ------------------------------------------------------------------ frames and what is sent
def test_step_records_the_frame_and_the_readout_shows_it_with_its_accuracy(view):
    report = view.step()
    assert view.last_report is report and view.frame_times == [pytest.approx(1e3 * report.elapsed)]
    line, accuracy = view.readout().split("\n")
    assert f"frame {report.frame:5d}" in line and report.status in line and "paused" in line
    assert accuracy == report.accuracy and "min J" in accuracy
    assert view.frames == view.sim.frames == 1


def test_nothing_is_sent_at_rest(view):
    sent = Sent(view.widget)
    frames = 0
    while not view.resting:
        view.step()
        frames += 1
        assert frames < 400, "a held sheet comes to rest"
    x = view.sim.positions()
    view.sim.positions = lambda: x  # the state no longer changes
    sent.clear()
    view.step()
    view.step()
    assert "positions" not in sent.counts and "triangles" not in sent.counts


def test_a_frame_that_fails_shows_its_message_and_the_loop_goes_on():
    async def session():
        v = SurgeryView(make_sim(), interval_ms=5)

        def broken():
            raise ValueError("the solver gave up")

        v.sim.frame = broken
        v.start()
        await asyncio.sleep(0.05)
        assert "frame failed: the solver gave up" in v.widget.message and v.running
        v.close()

    asyncio.run(session())


def test_the_loop_runs_while_things_change_and_rests_without_sending():
    async def session():
        v = SurgeryView(make_sim(), interval_ms=5)
        sent = Sent(v.widget)
        v._repr_mimebundle_()  # displayed: autostart
        assert v.running
        for _ in range(400):
            await asyncio.sleep(0.01)
            if v.resting:
                break
        assert v.resting, "the held sheet came to rest and the loop waits"
        await asyncio.sleep(0.02)
        assert "at rest" in v.widget.readout
        frames = v.sim.frames
        sent.clear()
        await asyncio.sleep(0.3)
        assert v.sim.frames == frames and sent.counts == {}, "at rest nothing runs and nothing is sent"
        pointer(v, "down", 1.95, 0.5)
        pointer(v, "move", 2.3, 0.5)
        await asyncio.sleep(0.2)
        assert v.sim.frames > frames + 3 and sent.counts.get("positions", 0) > 3, "input wakes the loop"
        assert v.widget.arrays()["positions"][:, 0].max() > 2.05
        pointer(v, "up", 2.3, 0.5)
        v.close()
        await asyncio.sleep(0.05)
        assert not v.running

    asyncio.run(session())
    assert REST_FRAMES >= 2


def test_an_event_from_another_thread_waits_for_the_frame_in_progress(view):
    done = threading.Event()

    def press():
        synthetic_mouse(view, "press", (1.9, 0.5))
        done.set()

    with view._lock:  # a frame in progress
        worker = threading.Thread(target=press)
        worker.start()
        assert not done.wait(0.2) and view.grabbed is None
    worker.join(5)
    assert done.is_set() and view.grabbed is not None


# ------------------------------------------------------------------ arguments
def test_a_refusal_names_its_field(view):
    sim = make_sim()
    for field, call in [("radius", lambda: SurgeryView(sim, radius=np.inf)),
                        ("radius", lambda: SurgeryView(sim, radius=-1.0)),
                        ("interval_ms", lambda: SurgeryView(sim, interval_ms=33.0)),
                        ("sim", lambda: SurgeryView(object())),
                        ("color", lambda: SurgeryView(sim, color="stress")),
                        ("mode", lambda: setattr(view, "mode", "scalpel")),
                        ("kind", lambda: synthetic_mouse(view, "click", (0.0, 0.0))),
                        ("point", lambda: synthetic_mouse(view, "press", (np.nan, 0.0))),
                        ("view", lambda: synthetic_mouse(sim, "press", (0.0, 0.0))),
                        ("key", lambda: synthetic_key(view, "")),
                        ("kind", lambda: pointer(view, "wiggle", 1.0, 0.5)),
                        ("content", lambda: view.handle_message(["pointer"]))]:
        with pytest.raises(ParameterError) as refused:
            call()
        assert refused.value.field == field


def test_bad_messages_through_the_widget_are_shown_not_raised(view):
    view.widget._handle_custom_msg({"event": "pointer", "kind": "wiggle", "x": 0, "y": 0}, [])
    assert "kind" in view.message
    view.widget._handle_custom_msg({"event": "pointer", "kind": "down", "x": 1.95, "y": 0.5}, [])
    assert view.grabbed is not None


def test_colour_by_area_change():
    v = SurgeryView(make_sim(), autostart=False, color="J")
    try:
        c = v.widget.arrays()["colors"]
        assert c.shape == (v.widget.arrays()["triangles"].shape[0],) and np.allclose(c, 1.0, atol=1e-5)
    finally:
        v.close()


# ------------------------------------------------------------------ one live view
def test_a_new_view_of_the_same_simulation_stops_the_old_one(view):
    synthetic_mouse(view, "press", (1.9, 0.5))
    newer = SurgeryView(view.sim, autostart=False)
    try:
        assert view.closed and view.grabbed is None and "newer view" in view.message
        assert view.widget.disabled and "stopped" in view.widget.readout
        assert list(view.sim.handles) == ["fixed"]  # the old grab was released
        pointer(view, "down", 1.9, 0.5)  # the old one no longer listens
        assert view.grabbed is None
        with pytest.raises(ValueError, match="disconnected"):
            view.start()
        assert not newer.closed
    finally:
        newer.close()


def test_rerunning_a_cell_closes_the_view_it_made(monkeypatch):
    origin = {"value": ("id:cell-a", 3)}
    monkeypatch.setattr(interactive, "_cell_origin", lambda: origin["value"])
    first = SurgeryView(make_sim(), autostart=False)
    also_first = SurgeryView(make_sim(), autostart=False)  # two views made by one run of a cell both live
    origin["value"] = ("id:cell-b", 4)
    other = SurgeryView(make_sim(), autostart=False)
    origin["value"] = ("id:cell-a", 5)  # cell a again
    again = SurgeryView(make_sim(), autostart=False)
    assert first.closed and also_first.closed and not other.closed and not again.closed
    for v in (other, again):
        v.close()


def test_the_cell_comes_from_the_kernel_or_else_from_the_source(monkeypatch):
    class Kernel:
        parent = {"metadata": {"cellId": "c0ffee"}}

        def get_parent(self, channel=None):
            return self.parent

    class History:
        input_hist_raw = ["", "view = SurgeryView(sim)"]

    class Shell:
        kernel = Kernel()
        history_manager = History()
        execution_count = 7

    monkeypatch.setattr(interactive, "get_ipython", lambda: Shell())
    assert interactive._cell_origin() == ("id:c0ffee", 7)
    Shell.kernel.parent = {"metadata": {}}
    assert interactive._cell_origin() == ("source:view = SurgeryView(sim)", 7)
    monkeypatch.setattr(interactive, "get_ipython", lambda: None)
    assert interactive._cell_origin() is None


# ------------------------------------------------------------------ shown once; a static snapshot
def test_jupyter_shows_the_widget_once_with_the_view_as_its_text(view):
    bundle = view._repr_mimebundle_()
    data = bundle[0] if isinstance(bundle, tuple) else bundle
    assert data["application/vnd.jupyter.widget-view+json"]["model_id"] == view.widget.model_id
    assert "image/png" not in data and data["text/plain"] == repr(view)
    assert not view.running, "no event loop here: code steps the view"


def test_the_snapshot_draws_what_the_page_was_sent(view):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    synthetic_mouse(view, "press", (1.9, 0.5))
    synthetic_mouse(view, "move", (2.2, 0.6))
    view.step()
    fig = snapshot(view)
    FigureCanvasAgg(fig).draw()
    ax = fig.axes[0]
    (faces,) = ax.collections
    assert len(faces.get_paths()) == view.widget.arrays()["triangles"].shape[0]
    assert ax.get_title(loc="left") == view.widget.readout
    assert ax.lines[-1].get_xdata()[0] == pytest.approx(2.2)  # the drag target
    synthetic_mouse(view, "release", (2.2, 0.6))


def test_a_pointer_move_brings_the_next_frame_forward():
    """While the loop runs, a frame waits at most an interval, but a pointer move ends the wait (after half an
    interval): the picture follows the mouse without waiting out the interval. The interval here is 10 s; the
    frame after the move comes after half of it (5 s), long before the 10 s."""
    async def session():
        v = SurgeryView(make_sim(), interval_ms=10_000)
        pointer(v, "down", 1.95, 0.5)
        v.start()
        for _ in range(500):  # the first frame runs at once
            await asyncio.sleep(0.01)
            if v.sim.frames:
                break
        first, frames = time.perf_counter(), v.sim.frames
        pointer(v, "move", 2.2, 0.5)
        while v.sim.frames == frames and time.perf_counter() - first < 9.0:
            await asyncio.sleep(0.05)
        assert v.sim.frames > frames, "the move brought the frame forward (the interval is 10 s)"
        pointer(v, "up", 2.2, 0.5)
        v.close()

    asyncio.run(session())


def test_pacing_without_input_keeps_the_grid_and_makes_up_for_a_late_frame():
    """Frames due every interval on a grid of absolute times; one that starts late is made up for in the waits
    after it, up to an interval (beyond that the grid moves on: no burst after a stall), never two frames closer
    than half an interval."""
    pacing = Pacing(10.0)
    pacing.start(0.0)  # the first frame: the grid starts there
    assert (pacing.due, pacing.earliest) == (10.0, 5.0)
    pacing.start(13.0)  # 3 late
    assert pacing.due == 20.0, "made up for: the next frame is due on the grid"
    pacing.start(28.0)  # 8 late (after a long step, say)
    assert pacing.due == 30.0 and pacing.earliest == 33.0, "on the grid, but half an interval after this frame"
    pacing.start(33.0)
    assert pacing.due == 40.0, "made up for"
    pacing.start(65.0)  # 25 late: more than an interval
    assert (pacing.due, pacing.earliest) == (65.0, 70.0), "an interval made up for (the grid moved on by the rest)"
    pacing.start(70.0)
    assert pacing.due == 75.0
    pacing.rest()
    assert pacing.due is None and pacing.earliest == -np.inf, "after a rest input starts a frame at once"
    pacing.start(100.0)
    assert pacing.due == 110.0


def test_pacing_input_starts_a_frame_early_but_keeps_one_frame_per_interval():
    """Input may start a frame half an interval before it is due, but the grid goes on from where it was: with
    input all the time the frames still come one per interval (the simulation's time keeps pace with the clock)."""
    pacing = Pacing(10.0)
    pacing.start(0.0)
    starts = [0.0]
    for _ in range(100):  # input always waiting: every frame starts as early as allowed
        starts.append(pacing.earliest)
        pacing.start(pacing.earliest)
    assert starts[1] == 5.0, "the first frame after the one that woke the loop: half an interval on"
    assert np.min(np.diff(starts)) >= 5.0
    assert starts[-1] >= 10.0 * 100 - 5.0, "one frame per interval on average"


def test_a_refused_pacing_interval_names_it():
    with pytest.raises(ParameterError, match="interval"):
        Pacing(0.0)


def test_continuous_input_does_not_run_frames_faster_than_the_interval():
    """The page's pointer moves come far more often than frames: the loop still runs one frame per interval (a
    step per frame: faster would run the simulation ahead of the clock). Counted against an upper bound."""
    async def session():
        v = SurgeryView(make_sim(), interval_ms=50)
        pointer(v, "down", 1.95, 0.5)
        v.start()
        for _ in range(500):  # the first frame
            await asyncio.sleep(0.01)
            if v.sim.frames:
                break
        first, frames = time.perf_counter(), v.sim.frames
        k = 0
        while time.perf_counter() - first < 0.6:
            k += 1
            pointer(v, "move", 1.95 + 0.001 * (k % 50), 0.5)
            await asyncio.sleep(0.005)
        elapsed, ran = time.perf_counter() - first, v.sim.frames - frames
        pointer(v, "up", 1.95, 0.5)
        v.close()
        assert ran <= elapsed / 0.05 + 2, f"{ran} frames in {elapsed:.2f} s at one per 50 ms"

    asyncio.run(session())


def test_a_step_running_off_the_frame_keeps_the_loop_from_resting():
    """Frames that show the last committed state while a step runs off the frame (nothing moves) are not counted as
    quiet: the loop goes on to the frame that commits the step, then rests as usual."""
    view = SurgeryView(make_sim(), autostart=False)
    report = view.step()
    running = dataclasses.replace(report, off_frame="running")
    view.sim.frame = lambda: running
    for _ in range(2 * REST_FRAMES):
        view.step()
    assert not view.resting
    view.sim.frame = lambda: report
    for _ in range(REST_FRAMES):
        view.step()
    assert view.resting
    # every step off the frame (a frame shows it running, the next commits it): a still tissue rests all the same
    view = SurgeryView(make_sim(), autostart=False)
    report = view.step()
    frames = iter([dataclasses.replace(report, off_frame=kind) for kind in ("running", "finished") * 2 * REST_FRAMES])
    view.sim.frame = lambda: next(frames)
    for f in range(4 * REST_FRAMES):
        view.step()
        if view.resting:
            break
    assert view.resting and view.last_report.off_frame == "finished"

