"""SurgeryView: mouse drags and cuts on a running simulation, driven headless by synthetic events."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from tissuefem.surgery.interactive import MODES, SurgeryView, mean_edge_length, synthetic_key, synthetic_mouse
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


def make_sim():
    return Simulation(Scene.from_dict(SHEET), clock=TickingClock())


@pytest.fixture
def view():
    sim = make_sim()
    fig = Figure(figsize=(6.0, 4.0))
    FigureCanvasAgg(fig)  # a real (non-interactive) renderer
    v = SurgeryView(sim, ax=fig.add_subplot())
    yield v
    v.disconnect()


def move_along(view, start, end, steps=4):
    """Motion events from ``start`` to ``end`` (the button held, if it was pressed)."""
    for s in np.linspace(0.0, 1.0, steps + 1)[1:]:
        synthetic_mouse(view, "move", (1 - s) * np.asarray(start) + s * np.asarray(end))


# ------------------------------------------------------------------ drawing and set-up
def test_draws_the_mesh_with_fixed_limits_and_equal_aspect(view):
    sim = view.sim
    assert len(view.mesh_artist.get_paths()) == sim.mesh.t.shape[1]
    np.testing.assert_allclose(view.drawn_positions, sim.positions())
    x0, x1 = view.ax.get_xlim()
    y0, y1 = view.ax.get_ylim()
    assert x0 < 0 < WIDTH < x1 and y0 < 0 < HEIGHT < y1
    assert view.ax.get_aspect() == 1.0
    assert view.mode == "drag" and view.grabbed is None
    assert view.radius == pytest.approx(2 * mean_edge_length(sim.mesh))
    view.fig.canvas.draw()  # renders without error


def test_timer_is_not_started_under_agg(view):
    assert not view.interactive
    assert not view.running
    assert view._timer is None
    view.start()  # an explicit start works on any canvas (Agg's timer just never fires)
    assert view.running
    view.stop()
    assert not view.running


def test_pyplot_axes_by_default_and_no_timer():
    sim = make_sim()
    v = SurgeryView(sim)
    try:
        assert v.ax.figure is v.fig and not v.running
    finally:
        v.disconnect()
        plt.close(v.fig)


# ------------------------------------------------------------------ drag mode
def test_drag_grabs_moves_the_handle_and_the_tissue_follows(view):
    sim = view.sim
    grab_at, mouse = np.array([1.9, 0.5]), np.array([2.2, 0.7])
    X = sim.positions()
    d = np.linalg.norm(X - grab_at[:, None], axis=0)
    grabbed, around = d <= view.radius, (d > 1.5 * view.radius) & (d < 3.0 * view.radius)

    synthetic_mouse(view, "press", grab_at)
    name = view.grabbed
    assert name is not None
    np.testing.assert_allclose(sim.handle_offset(name), 0.0, atol=1e-12)
    move_along(view, grab_at, mouse)
    np.testing.assert_allclose(sim.handle_offset(name), mouse - grab_at, atol=1e-9)
    assert view.target_artist.get_xdata()[0] == pytest.approx(mouse[0])  # the marker follows the mouse
    for _ in range(3):
        report = view.step()
    assert report.converged
    x = sim.positions()
    # the grabbed nodes moved rigidly with the mouse; the tissue around them followed part of the way
    np.testing.assert_allclose(x[:, grabbed] - X[:, grabbed], np.tile((mouse - grab_at)[:, None], grabbed.sum()),
                               atol=1e-9)
    before = np.linalg.norm(X[:, around] - mouse[:, None], axis=0)
    after = np.linalg.norm(x[:, around] - mouse[:, None], axis=0)
    assert after.mean() < 0.8 * before.mean()
    offset = mouse - grab_at
    assert np.mean(offset @ (x[:, around] - X[:, around])) > 0.3 * (offset @ offset)
    np.testing.assert_allclose(view.drawn_positions, x)  # the drawing follows the simulation
    np.testing.assert_allclose(view.mesh_artist.get_paths()[0].vertices[:3], x[:, sim.mesh.t[:, 0]].T)

    synthetic_mouse(view, "release", mouse)
    assert view.grabbed is None and name not in sim.handles
    assert len(view.target_artist.get_xdata()) == 0


def test_press_off_the_tissue_does_nothing(view):
    spy = Spy(view.sim, "grab", "drag", "release", "cut")
    off = (WIDTH + 0.5, HEIGHT + 0.25)  # inside the axes, far from the tissue
    event = synthetic_mouse(view, "press", off)
    assert event.inaxes is view.ax
    synthetic_mouse(view, "move", (WIDTH + 0.4, HEIGHT + 0.2))
    synthetic_mouse(view, "release", (WIDTH + 0.4, HEIGHT + 0.2))
    assert view.grabbed is None and view.message == ""
    assert spy.calls["drag"] == [] and spy.calls["release"] == [] and spy.calls["cut"] == []


def test_other_buttons_do_not_grab(view):
    synthetic_mouse(view, "press", (1.9, 0.5), button=3)
    assert view.grabbed is None


def test_events_outside_the_axes_are_ignored():
    sim = make_sim()
    fig = Figure(figsize=(9.0, 3.0))
    ax, other = fig.subplots(1, 2)
    v = SurgeryView(sim, ax=ax)
    spy = Spy(sim, "grab", "drag", "cut")
    outside = (WIDTH + 3.0, 0.5)  # to the right of the view's axes: in the other axes
    event = synthetic_mouse(v, "press", outside)
    assert event.inaxes is not ax
    assert v.grabbed is None and spy.calls["grab"] == []
    synthetic_key(v, "c", point=outside)  # a key with the pointer in the other axes
    assert v.mode == "drag"

    # a drag that leaves the axes: the motion outside is ignored, the release there still lets go
    synthetic_mouse(v, "press", (1.9, 0.5))
    name = v.grabbed
    synthetic_mouse(v, "move", (2.1, 0.6))
    synthetic_mouse(v, "move", outside)
    np.testing.assert_allclose(sim.handle_offset(name), (0.2, 0.1), atol=1e-9)
    synthetic_mouse(v, "release", outside)
    assert v.grabbed is None
    v.disconnect()


def test_disconnect_detaches_the_handlers(view):
    view.disconnect()
    synthetic_mouse(view, "press", (1.9, 0.5))
    assert view.grabbed is None


# ------------------------------------------------------------------ modes
def test_key_c_toggles_the_mode(view):
    assert view.mode == "drag"
    synthetic_key(view, "c")
    assert view.mode == "cut" and "cut" in view.status_text.get_text()
    synthetic_key(view, "x")  # other keys: nothing
    assert view.mode == "cut"
    synthetic_key(view, "c")
    assert view.mode == "drag"


def test_unknown_mode_raises(view):
    with pytest.raises(ValueError, match="mode"):
        view.mode = "scalpel"
    assert view.mode == "drag"
    assert MODES == ("drag", "cut")


def test_switching_mode_releases_a_grab(view):
    spy = Spy(view.sim, "release")
    synthetic_mouse(view, "press", (1.9, 0.5))
    assert view.grabbed is not None
    view.mode = "cut"
    assert view.grabbed is None and len(spy.calls["release"]) == 1


# ------------------------------------------------------------------ cut mode
def test_cut_stroke_changes_the_topology_and_the_drawing(view):
    sim = view.sim
    n_nodes = sim.mesh.p.shape[1]
    view.step()
    view.mode = "cut"
    stroke = [(1.0, -0.2), (1.0, 0.1), (1.0, 0.3), (1.0, 0.6)]
    synthetic_mouse(view, "press", stroke[0])
    for p in stroke[1:]:
        synthetic_mouse(view, "move", p)
    assert view.stroke.shape == (4, 2)
    assert len(view.stroke_artist.get_xdata()) == 4
    synthetic_mouse(view, "release", stroke[-1])
    assert sim.mesh.p.shape[1] > n_nodes
    assert view.drawn_positions.shape == (2, sim.mesh.p.shape[1])
    assert len(view.mesh_artist.get_paths()) == sim.mesh.t.shape[1]
    assert view.stroke is None and len(view.stroke_artist.get_xdata()) == 0
    view.step()  # frames go on with the new topology
    np.testing.assert_allclose(view.drawn_positions, sim.positions())
    view.fig.canvas.draw()


def test_a_cut_made_in_code_is_drawn_at_the_next_frame(view):
    sim = view.sim
    n_nodes = sim.mesh.p.shape[1]
    sim.cut([(0.5, 1.2), (0.5, 0.6)])  # from the top edge down, not through the view
    assert sim.mesh.p.shape[1] > n_nodes
    view.step()
    assert view.drawn_positions.shape == (2, sim.mesh.p.shape[1])
    assert len(view.mesh_artist.get_paths()) == sim.mesh.t.shape[1]


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
    assert spy.calls["cut"] == []
    assert "stroke" in view.message


def test_a_failing_cut_shows_a_message_instead_of_raising(view):
    sim = view.sim
    n_nodes = sim.mesh.p.shape[1]
    view.mode = "cut"
    synthetic_mouse(view, "press", (-0.5, HEIGHT + 0.2))  # a stroke beside the tissue, not across it
    synthetic_mouse(view, "move", (-0.5, HEIGHT + 0.05 + 0.2))
    synthetic_mouse(view, "release", (-0.4, HEIGHT + 0.25))
    assert "cut failed" in view.message
    assert "cut failed" in view.status_text.get_text()
    assert sim.mesh.p.shape[1] == n_nodes
    # the next action clears the message
    view.mode = "drag"
    synthetic_mouse(view, "press", (1.9, 0.5))
    assert view.message == ""


# ------------------------------------------------------------------ frames
def test_step_records_the_frame_time_and_updates_the_text(view):
    assert "frame     0" in view.status_text.get_text()
    report = view.step()
    assert view.last_report is report
    assert view.frame_times == [pytest.approx(1e3 * report.elapsed)]
    text = view.status_text.get_text()
    assert f"frame {report.frame:5d}" in text
    assert f"{1e3 * report.elapsed:5.1f} ms / 33 ms" in text
    assert report.status in text
    view.step()
    assert len(view.frame_times) == 2


def test_timer_callback_shows_a_value_error(view):
    def broken():
        raise ValueError("the solver gave up")

    view.sim.frame = broken
    view._on_timer()
    assert "the solver gave up" in view.status_text.get_text()


# ------------------------------------------------------------------ arguments
def test_arguments_are_checked():
    sim = make_sim()
    fig = Figure()
    ax = fig.add_subplot()
    with pytest.raises(ValueError, match="radius"):
        SurgeryView(sim, ax=ax, radius=-1.0)
    with pytest.raises(ValueError, match="interval_ms"):
        SurgeryView(sim, ax=ax, interval_ms=0)
    with pytest.raises(ValueError, match="sim"):
        SurgeryView(object(), ax=ax)
    v = SurgeryView(sim, ax=ax, radius=0.3)
    assert v.radius == 0.3
    with pytest.raises(ValueError, match="kind"):
        synthetic_mouse(v, "click", (0.0, 0.0))
    with pytest.raises(ValueError, match="point"):
        synthetic_mouse(v, "press", (np.nan, 0.0))
    with pytest.raises(ValueError, match="view"):
        synthetic_mouse(ax, "press", (0.0, 0.0))
    with pytest.raises(ValueError, match="key"):
        synthetic_key(v, "")


def test_controls_follow_the_mode(view):
    pytest.importorskip("ipywidgets")
    box = view.controls()
    mode_buttons = box.children[0]
    assert mode_buttons.value == "drag"
    synthetic_key(view, "c")
    assert mode_buttons.value == "cut"
    mode_buttons.value = "drag"
    assert view.mode == "drag"
