"""BrowserView and TissueWidget headless: the page's messages drag and cut, the widget's arrays follow, nothing is
sent at rest, and the frame loop rests."""

import asyncio

import numpy as np
import pytest

pytest.importorskip("anywidget")

from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery.interactive import Gestures
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation
from tissuefem.surgery.widget import REST_FRAMES, STATIC, BrowserView, TissueWidget, outline

SHEET = {
    "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 400},
    "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
    "effects": {"inertia": {"time_step": 1.0 / 30.0}, "handles": [{"name": "fixed", "region": "left"}]},
}


class Sent:
    """The widget's synced traits that changed (what the page is sent), counted by name."""

    def __init__(self, widget):
        self.counts = {}
        widget.observe(self, names=["positions", "triangles", "edges", "target", "stroke", "readout", "message"])

    def __call__(self, change):
        self.counts[change["name"]] = self.counts.get(change["name"], 0) + 1

    def clear(self):
        self.counts = {}


def pointer(view, kind, x, y, inside=True):
    view.handle_message({"event": "pointer", "kind": kind, "x": x, "y": y, "inside": inside})


@pytest.fixture
def view():
    v = BrowserView(Simulation(Scene.from_dict(SHEET)), autostart=False)
    yield v
    v.close()


def test_the_javascript_ships_with_the_package():
    js = (STATIC / "tissue_widget.js").read_text()
    assert "export default" in js and "requestAnimationFrame" in js
    assert "import " not in js and "http" not in js, "the module imports nothing and fetches nothing"


def test_the_widget_holds_the_mesh_as_binary_arrays(view):
    a = view.widget.arrays()
    pic = view.sim.picture
    assert a["positions"].dtype == np.float32 and a["positions"].shape == (pic.triangles.max() + 1, 2)
    assert a["triangles"].dtype == np.int32 and a["triangles"].shape == (pic.triangles.shape[1], 3)
    assert a["edges"].shape == (pic.edges.shape[1], 2)
    assert 0 < np.count_nonzero(a["outline"] >= 0) < len(a["positions"]), "the boundary loops, to fill"
    assert np.allclose(a["positions"], view.sim.positions().T, atol=1e-6)
    assert view.widget.dim == 2 and isinstance(view.widget.positions, bytes)


def test_a_drag_by_messages_moves_the_tissue_and_the_positions(view):
    sent = Sent(view.widget)
    before = view.widget.arrays()["positions"].copy()
    pointer(view, "down", 1.95, 0.5)
    assert view.grabbed is not None
    assert view.widget.target == pytest.approx([1.95, 0.5])
    pointer(view, "move", 2.2, 0.3)
    for _ in range(5):
        view.step()
    after = view.widget.arrays()["positions"]
    right = before[:, 0] > 1.9
    assert after[right, 0].mean() > before[right, 0].mean() + 0.05, "the right edge followed the pointer"
    assert view.widget.target == pytest.approx([2.2, 0.3])
    assert sent.counts.get("positions", 0) >= 5
    assert "triangles" not in sent.counts, "dragging does not resend the topology"
    pointer(view, "up", 2.2, 0.3)
    assert view.grabbed is None and view.widget.target == []


def test_a_cut_by_messages_resends_the_topology_once(view):
    sent = Sent(view.widget)
    nodes = view.sim.mesh.nvertices
    view.widget.mode = "cut"  # the page's button
    assert view.mode == "cut"
    pointer(view, "down", 1.0, 1.3)
    for y in (1.1, 0.9, 0.7, 0.5):
        pointer(view, "move", 1.0, y)
    assert view.widget.arrays()["stroke"].shape[0] >= 2, "the stroke is shown while drawn"
    pointer(view, "up", 1.0, 0.4)
    assert view.sim.mesh.nvertices > nodes, "the stroke cut the tissue"
    assert sent.counts.get("triangles") == 1 and view.topology_pushes == 2
    a = view.widget.arrays()
    assert a["triangles"].max() < len(a["positions"])
    assert view.widget.stroke == b""
    view.step()
    assert sent.counts["triangles"] == 1, "a frame after the cut sends positions only"


def test_a_failed_cut_shows_its_message_in_the_page(view):
    view.mode = "cut"
    assert view.widget.mode == "cut"
    pointer(view, "down", -0.5, 1.45)
    for x in (-0.45, -0.4, -0.35):
        pointer(view, "move", x, 1.4)
    pointer(view, "up", -0.3, 1.35)
    assert view.message.startswith("cut failed") and view.widget.message == view.message


def test_nothing_is_sent_at_rest(view):
    sent = Sent(view.widget)
    frames = 0
    while not view.resting:
        view.step()
        frames += 1
        assert frames < 400, "a held sheet comes to rest"
    # a still sheet: identical positions are not resent
    x = view.sim.positions()
    view.sim.positions = lambda: x  # the state no longer changes
    sent.clear()
    view.step()
    view.step()
    assert "positions" not in sent.counts and "triangles" not in sent.counts


def test_bad_messages_are_refused_naming_the_field(view):
    with pytest.raises(ParameterError, match="kind"):
        pointer(view, "wiggle", 1.0, 0.5)
    with pytest.raises(ParameterError, match="point"):
        pointer(view, "down", float("nan"), 0.5)
    with pytest.raises(ParameterError, match="content"):
        view.handle_message(["pointer"])
    # through the widget's own message handler: shown, not raised
    view.widget._handle_custom_msg({"event": "pointer", "kind": "wiggle", "x": 0, "y": 0}, [])
    assert "kind" in view.message
    view.widget._handle_custom_msg({"event": "pointer", "kind": "down", "x": 1.95, "y": 0.5}, [])
    assert view.grabbed is not None
    with pytest.raises(ParameterError, match="mode"):
        view.mode = "pinch"
    view.widget.mode = "pinch"  # from the page: refused, the mode stays
    assert view.widget.mode == "drag" and view.mode == "drag"


def test_the_view_uses_the_shared_gestures(view):
    assert isinstance(view.gestures, Gestures)


def test_colour_by_area_change():
    v = BrowserView(Simulation(Scene.from_dict(SHEET)), autostart=False, color="J")
    try:
        c = v.widget.arrays()["colors"]
        assert c.shape == (v.widget.arrays()["triangles"].shape[0],) and np.allclose(c, 1.0, atol=1e-5)
    finally:
        v.close()
    with pytest.raises(ParameterError, match="color"):
        BrowserView(Simulation(Scene.from_dict(SHEET)), autostart=False, color="stress")


def test_a_second_view_of_the_simulation_stops_the_first(view):
    newer = BrowserView(view.sim, autostart=False)
    try:
        assert view.closed and "newer view" in view.message and not newer.closed
    finally:
        newer.close()


def test_show_mesh_checks_its_arrays():
    w = TissueWidget()
    with pytest.raises(ParameterError, match="triangles"):
        w.show_mesh(np.zeros((3, 2)), [[0, 1, 3]])
    with pytest.raises(ParameterError, match="positions"):
        w.show_mesh(np.zeros((3, 4)), [[0, 1, 2]])
    w.show_mesh(np.zeros((3, 3)), [[0, 1, 2]])  # a 3D surface: dim 3
    assert w.dim == 3 and w.arrays()["positions"].shape == (3, 3)


def test_the_loop_runs_while_things_change_and_rests_without_sending():
    async def session():
        v = BrowserView(Simulation(Scene.from_dict(SHEET)), interval_ms=5)
        sent = Sent(v.widget)
        v.start()
        assert v.running
        for _ in range(400):
            await asyncio.sleep(0.01)
            if v.resting:
                break
        assert v.resting, "the held sheet came to rest and the loop waits"
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


def test_start_needs_an_event_loop(view):
    with pytest.raises(RuntimeError, match="event loop"):
        view.start()
    assert "BrowserView" in repr(view)


def _loops_area(loops, x):
    area, loop = 0.0, []
    for i in list(loops) + [-1]:
        if i >= 0:
            loop.append(i)
            continue
        if loop:
            p = x[:, loop]
            area += 0.5 * float(np.sum(p[0] * np.roll(p[1], -1) - np.roll(p[0], -1) * p[1]))
        loop = []
    return area


@pytest.mark.parametrize("method", ["elements", "edges"])
def test_the_outline_encloses_what_the_triangles_cover(method):
    sim = Simulation(Scene.from_dict(SHEET))
    sim.cut([[1.0, 1.3], [1.0, 0.4]], method=method)
    pic = sim.picture
    x = pic.points(sim.mesh.p)
    loops = outline(pic.triangles, x)
    assert loops[-1] == -1 and loops.dtype == np.int32
    a, b, c = (x[:, pic.triangles[k]] for k in range(3))
    covered = float(np.sum(np.abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])))) / 2
    assert _loops_area(loops, x) == pytest.approx(covered, rel=1e-9)
    assert covered == pytest.approx(2.0, rel=1e-9)
    assert np.count_nonzero(loops >= 0) < pic.triangles.shape[1], "far fewer points than the triangles'"
