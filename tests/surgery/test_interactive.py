"""SurgeryView: mouse drags and cuts on a running simulation, driven headless by synthetic events."""

import os
import subprocess
import sys
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.backend_bases import MouseButton
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

import tissuefem
from tissuefem.surgery import interactive, view_drawing
from tissuefem.engine.parameters import ParameterError
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


# ------------------------------------------------------------------ a light face
def test_import_tissuefem_loads_neither_pyplot_nor_ipython():
    """The view is imported where it is used: the package loads no drawing or notebook machinery, not even once
    every name of its face has been resolved (``import tissuefem`` alone loads none of its modules: see
    ``tests/test_architecture.py``)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(tissuefem.__file__).parents[1]),
                                                       os.environ.get("PYTHONPATH", "")]))
    heavy = {'matplotlib.pyplot', 'IPython', 'meshio', 'scipy.spatial', 'tomllib'}  # loaded where they are used
    code = f"import sys, tissuefem; from tissuefem import *; print(sorted({heavy!r} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["[]"]
    assert "SurgeryView" not in tissuefem.__all__ and not hasattr(tissuefem, "SurgeryView")


# ------------------------------------------------------------------ drawing and set-up
def drawn_edges(view):
    """The drawn edges, (n_edges, 2, 2)."""
    return view.mesh_edges.get_path().vertices.reshape(-1, 2, 2)


def test_draws_the_mesh_with_fixed_limits_and_equal_aspect(view):
    sim = view.sim
    x, t, f = sim.positions(), sim.mesh.t, sim.mesh.facets
    assert view.triangles().shape == (t.shape[1], 3, 2)
    np.testing.assert_allclose(view.triangles(), x[:, t].transpose(2, 1, 0))
    np.testing.assert_allclose(drawn_edges(view), x[:, f].transpose(2, 1, 0))
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
    np.testing.assert_allclose(view.triangles()[0], x[:, sim.mesh.t[:, 0]].T)
    np.testing.assert_allclose(drawn_edges(view)[5], x[:, sim.mesh.facets[:, 5]].T)

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
    # the cut crosses elements: each copy is drawn as the material it carries (Simulation.picture)
    picture = sim.picture
    assert not picture.plain and picture.element.max() == sim.mesh.t.shape[1] - 1
    assert view.triangles().shape[0] == picture.triangles.shape[1]
    assert drawn_edges(view).shape[0] == picture.edges.shape[1]
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
    picture = sim.picture
    np.testing.assert_allclose(view.triangles(), picture.points(sim.positions())[:, picture.triangles].transpose(2, 1, 0))
    # the drawn material covers the tissue once: the drawn area is the material's area (no copy drawn whole)
    x = picture.points(sim.model.X)
    a, b, c = (x[:, picture.triangles[k]] for k in range(3))
    drawn = 0.5 * np.abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).sum()
    assert drawn == pytest.approx(sim.model.element_areas().sum(), rel=1e-12)


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
    assert view.message_text.get_text().startswith("cut failed")
    assert "cut failed" not in view.status_text.get_text()  # the readout keeps its one line
    assert sim.mesh.p.shape[1] == n_nodes
    # the next action clears the message
    view.mode = "drag"
    synthetic_mouse(view, "press", (1.9, 0.5))
    assert view.message == "" and view.message_text.get_text() == ""


# ------------------------------------------------------------------ frames
def test_step_records_the_frame_time_and_updates_the_text(view):
    assert "frame     0" in view.status_text.get_text()
    report = view.step()
    assert view.last_report is report
    assert view.frame_times == [pytest.approx(1e3 * report.elapsed)]
    text = view.status_text.get_text()
    assert f"frame {report.frame:5d}" in text
    # the step and the draw against the budget; nothing drawn yet (a non-interactive canvas draws on demand)
    assert f"step {1e3 * report.elapsed:4.1f} + draw   -- =   -- / 33 ms" in text
    assert report.status in text
    view.step()
    assert len(view.frame_times) == 2
    assert view.draw_times == []


def test_timer_callback_shows_a_value_error(view):
    def broken():
        raise ValueError("the solver gave up")

    view.sim.frame = broken
    view._on_timer()
    assert "the solver gave up" in view.message_text.get_text()


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


def test_a_refusal_names_its_field():
    sim, ax = make_sim(), Figure().add_subplot()
    view = SurgeryView(sim, ax=ax)
    for field, call in [("radius", lambda: SurgeryView(sim, ax=ax, radius=np.inf)),
                        ("interval_ms", lambda: SurgeryView(sim, ax=ax, interval_ms=33.0)),
                        ("sim", lambda: SurgeryView(object(), ax=ax)),
                        ("mode", lambda: setattr(view, "mode", "scalpel")),
                        ("kind", lambda: synthetic_mouse(view, "click", (0.0, 0.0)))]:
        with pytest.raises(ParameterError) as refused:
            call()
        assert refused.value.field == field


def test_controls_follow_the_mode(view):
    pytest.importorskip("ipywidgets")
    box = view.controls()
    mode_buttons = box.children[0]
    assert mode_buttons.value == "drag"
    synthetic_key(view, "c")
    assert mode_buttons.value == "cut"
    mode_buttons.value = "drag"
    assert view.mode == "drag"


# ------------------------------------------------------------------ the view's own figure: drawing in layers
@pytest.fixture
def own():
    """A view in its own figure (Agg here: the same layered drawing as on an interactive canvas)."""
    v = SurgeryView(make_sim(), autostart=False)
    yield v
    v.close()


def buffer(view):
    return np.asarray(view.canvas.buffer_rgba()).copy()


def test_own_figure_has_fixed_axes_and_no_layout_engine(own):
    fig = own.fig
    assert fig.get_layout_engine() is None
    assert tuple(own.ax.get_position(original=True).bounds) == pytest.approx(view_drawing.AXES_RECT)
    assert tuple(fig.get_size_inches()) == pytest.approx(view_drawing.FIGSIZE)
    # not left in pyplot's list on a non-interactive backend: the inline backend cannot show a copy of it later
    assert all(plt.figure(n) is not fig for n in plt.get_fignums())


def test_layered_draw_restores_the_background_and_draws_only_the_moving_layer(own):
    fig = own.fig
    own.draw()
    assert (fig.full_draws, fig.layer_draws) == (1, 1)
    synthetic_mouse(own, "press", (1.9, 0.5))
    synthetic_mouse(own, "move", (2.1, 0.6))
    for _ in range(3):
        own.step()
        assert isinstance(own.draw(), float)
    assert fig.full_draws == 1 and fig.layer_draws == 4  # made-up mouse events do not force a full draw
    assert len(own.draw_times) == 4 and all(t > 0 for t in own.draw_times)
    # the layered picture is the whole picture: equal to a full draw of the same state (the readout's
    # numbers included, which otherwise show at a readable pace)
    fig.slow_interval = 0.0
    own.draw()
    own.readout.update = lambda *args: None  # the same readout in both pictures (it shows the last draw's time)
    own.step()
    own.draw()
    fast = buffer(own)
    fig.stale = True
    own.draw()
    assert fig.full_draws == 2
    np.testing.assert_array_equal(buffer(own), fast)
    del own.readout.update
    # something that does not move changes (the limits): the next draw is a full one
    own.ax.set_xlim(-1.0, 3.0)
    own.draw()
    assert fig.full_draws == 3


def test_text_is_redrawn_at_a_readable_pace_but_a_message_at_once(own):
    fig = own.fig
    fig.slow_interval = 1e9  # a pace no busy machine can reach: the test does not depend on the clock
    own.draw()
    slow = fig.slow_draws
    for _ in range(3):
        own.step()  # new numbers in the readout ...
        own.draw()
    assert fig.slow_draws == slow  # ... shown after slow_interval (0.25 s by default), not at every frame
    own._show("something went wrong")
    own.draw()
    assert fig.slow_draws == slow + 1  # a new message shows at the next draw
    fig.slow_interval = 0.0
    own.step()
    own.draw()
    assert fig.slow_draws == slow + 2


def test_saving_draws_everything(own, tmp_path):
    own.step()
    own.fig.savefig(tmp_path / "view.png")
    import matplotlib.image as mpimg

    picture = mpimg.imread(tmp_path / "view.png")
    # the triangles' fill (mistyrose) is in the saved picture although they are animated artists
    misty = np.array(matplotlib.colors.to_rgb("mistyrose"))
    assert np.any(np.all(np.abs(picture[..., :3] - misty) < 0.02, axis=-1))


def test_timings_and_the_readout_show_step_and_draw(own):
    own.draw()
    for _ in range(3):
        own.step()
        own.draw()
    t = own.timings()
    assert t["frames"] == 3 and t["draws"] == 4
    assert t["step_ms"] == pytest.approx(np.median(own.frame_times))
    assert t["total_ms"] == pytest.approx(t["step_ms"] + t["draw_ms"])
    assert t["budget_ms"] == pytest.approx(1e3 / 30, rel=1e-3)
    own._update_text()
    text = own.status_text.get_text()
    assert f"draw {own.draw_times[-1]:4.1f}" in text and "/ 33 ms" in text and "fps" in text
    # two lines: the frame's numbers, then its own accuracy
    numbers, accuracy = text.split("\n")
    assert "fps" in numbers and accuracy == own.last_report.accuracy
    assert accuracy.startswith("converged | rel. residual") and "min J" in accuracy and "inverted" in accuracy


def test_the_readout_has_one_line_until_the_first_frame(view):
    assert "\n" not in view.status_text.get_text()
    report = view.step()
    assert view.status_text.get_text().splitlines()[1] == report.accuracy


def test_draw_in_axes_of_your_own_is_not_timed(view):
    assert view.draw() is None and view.draw_times == []
    assert not view.mesh_faces.get_animated()  # a normal figure draws every artist itself


# ------------------------------------------------------------------ a message never moves the axes (defect 3)
def test_a_long_message_is_wrapped_inside_the_figure_and_the_axes_stay(own):
    own.draw()
    box = own.ax.get_position().bounds
    own._show("cut failed: " + "a very long explanation of what went wrong with the stroke " * 6)
    own.draw()
    text = own.message_text.get_text()
    assert 1 < len(text.splitlines()) <= view_drawing.MESSAGE_LINES and text.endswith("...")
    renderer = own.canvas.get_renderer()
    extent = own.message_text.get_window_extent(renderer)
    assert 0 <= extent.x0 and extent.x1 <= own.fig.bbox.width and 0 <= extent.y0
    assert extent.y1 < own.ax.get_window_extent(renderer).y0  # under the axes, clear of them
    assert own.ax.get_position().bounds == box
    status = own.status_text.get_window_extent(renderer)
    assert status.x1 <= own.fig.bbox.width and status.y0 > own.ax.get_window_extent(renderer).y1
    own.mode = "cut"
    synthetic_mouse(own, "press", (1.0, 0.5))
    assert own.message == "" and own.ax.get_position().bounds == box


# ------------------------------------------------------------------ one live view (defect 1)
def test_a_new_view_of_the_same_simulation_stops_the_old_one():
    sim = make_sim()
    old = SurgeryView(sim, ax=Figure().add_subplot())
    old.start()
    synthetic_mouse(old, "press", (1.9, 0.5))
    assert old.running and old.grabbed is not None
    new = SurgeryView(sim, ax=Figure().add_subplot())
    assert not old.running and old.closed and old.grabbed is None
    assert "newer view" in old.message
    assert list(sim.handles) == ["fixed"]  # the old grab was released
    synthetic_mouse(old, "press", (1.9, 0.5))  # the old one no longer listens
    assert old.grabbed is None
    with pytest.raises(ValueError, match="disconnected"):
        old.start()
    assert not new.closed
    new.disconnect()


def test_rerunning_a_cell_closes_the_view_it_made(monkeypatch):
    origin = {"value": ("id:cell-a", 3)}
    monkeypatch.setattr(interactive, "_cell_origin", lambda: origin["value"])
    first = SurgeryView(make_sim())
    also_first = SurgeryView(make_sim())  # two views made by one run of a cell both live
    origin["value"] = ("id:cell-b", 4)
    other = SurgeryView(make_sim())  # another cell
    assert not first.closed and not also_first.closed
    origin["value"] = ("id:cell-a", 5)  # cell a again
    again = SurgeryView(make_sim())
    assert first.closed and also_first.closed and not first.running
    assert not other.closed and not again.closed
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


def test_closing_the_figure_stops_the_view():
    v = SurgeryView(make_sim(), ax=Figure().add_subplot())
    v.start()
    v.canvas.callbacks.process("close_event", matplotlib.backend_bases.CloseEvent("close_event", v.canvas))
    assert not v.running and v.closed


# ------------------------------------------------------------------ shown once, with its mode buttons (defects 2, 4)
def test_on_a_static_backend_the_view_shows_one_picture(own):
    bundle = own._repr_mimebundle_()
    assert set(bundle) == {"image/png", "text/plain"}
    assert own.widget() is None  # no live widget on Agg


@pytest.fixture
def browser_view():
    """A view on an ipympl canvas (the widget of %matplotlib widget), with no page attached."""
    pytest.importorskip("ipywidgets")
    nbagg = pytest.importorskip("ipympl.backend_nbagg")
    fig = view_drawing.LayeredFigure(figsize=view_drawing.FIGSIZE)
    canvas = nbagg.Canvas(fig)
    with warnings.catch_warnings():  # ipympl's toolbar passes traitlets an argument it deprecates
        warnings.simplefilter("ignore", DeprecationWarning)
        nbagg.FigureManager(canvas, 9999)
    canvas.syncing_data_url = False  # as once a page has the widget
    v = SurgeryView(make_sim(), ax=fig.add_axes(view_drawing.AXES_RECT), autostart=False)
    yield v
    v.disconnect()
    canvas.close()


def test_in_jupyter_the_view_is_one_widget_with_mode_buttons(browser_view):
    import ipywidgets

    v = browser_view
    assert v.interactive
    box = v.widget()
    assert isinstance(box, ipywidgets.VBox) and box.children[1] is v.canvas
    mode, run = box.children[0].children
    assert isinstance(mode, ipywidgets.ToggleButtons) and mode.options == MODES
    mode.value = "cut"  # a click on the button: no click into the figure needed first
    assert v.mode == "cut"
    synthetic_key(v, "c")  # the key still works, and the buttons follow
    assert v.mode == "drag" and mode.value == "drag"
    bundle = v._repr_mimebundle_()
    assert "application/vnd.jupyter.widget-view+json" in bundle
    assert "image/png" not in bundle  # no frozen copy beside the live one
    assert bundle["application/vnd.jupyter.widget-view+json"]["model_id"] == box.model_id


def test_a_picture_sent_to_the_page_is_timed_with_its_encoding(browser_view):
    v = browser_view
    v.step()
    v.canvas.draw()  # what the page's request for a picture does: render, encode as PNG, send
    assert len(v.draw_times) == 1
    v.canvas.draw()
    assert len(v.draw_times) == 2 and v.fig.full_draws == 1
    assert v.frames_per_second() is not None
    v.disconnect()
    assert not v.readout.sends and v.readout not in v.canvas.manager.web_sockets


def test_the_timer_sends_each_frame_to_the_page_and_events_only_change_the_state(browser_view, monkeypatch):
    v = browser_view
    asked = []
    monkeypatch.setattr(v.canvas, "draw_idle", lambda: asked.append(1))
    v._running = True  # as if the timer ran: mouse events change the state, the next frame draws it
    synthetic_mouse(v, "press", (1.9, 0.5))
    for k in range(5):
        synthetic_mouse(v, "move", (1.9 + 0.02 * k, 0.5))
    assert asked == [] and v.draw_times == []
    v._on_timer()
    # the frame's picture went to the page at once (no request from the page): a whole one first
    assert len(v.draw_times) == 1 and asked == [] and v.canvas._current_image_mode == "full"
    v._on_timer()
    assert len(v.draw_times) == 2 and v.canvas._current_image_mode == "diff"  # then differences ...
    v._keyframe_at -= view_drawing.KEYFRAME_S
    v._on_timer()
    assert v.canvas._current_image_mode == "full"  # ... and a whole picture every KEYFRAME_S
    v._running = False
    synthetic_mouse(v, "move", (2.1, 0.5))  # stopped: an event asks the page for a picture
    assert asked == [1]


# ------------------------------------------------------------------ events from another thread
def test_an_event_from_another_thread_waits_for_the_frame_in_progress(view):
    import threading

    done = threading.Event()

    def press():
        synthetic_mouse(view, "press", (1.9, 0.5))
        done.set()

    with view._lock:  # a frame (or a draw) in progress
        worker = threading.Thread(target=press)
        worker.start()
        assert not done.wait(0.2) and view.grabbed is None
    worker.join(5)
    assert done.is_set() and view.grabbed is not None


def test_start_and_stop_from_another_thread_go_to_the_timers_loop():
    import asyncio
    import threading

    async def main():
        v = SurgeryView(make_sim(), ax=Figure().add_subplot())
        worker = threading.Thread(target=v.start)
        worker.start()
        worker.join(5)
        assert not v.running  # handed to the loop, not started on the wrong thread
        await asyncio.sleep(0.01)
        assert v.running
        worker = threading.Thread(target=v.stop)
        worker.start()
        worker.join(5)
        await asyncio.sleep(0.01)
        assert not v.running
        v.disconnect()

    asyncio.run(main())


def test_the_real_mouse_moving_does_not_carry_on_a_grab_made_in_code(view):
    from matplotlib.backend_bases import MouseEvent

    sim = view.sim
    synthetic_mouse(view, "press", (1.9, 0.5))  # as chapter 8 leaves its view: the edge held by code
    name = view.grabbed
    x, y = view.ax.transData.transform((0.5, -0.4))
    hover = MouseEvent("motion_notify_event", view.canvas, x, y, guiEvent="a real move, no button held")
    view.canvas.callbacks.process("motion_notify_event", hover)
    np.testing.assert_allclose(sim.handle_offset(name), 0.0, atol=1e-12)  # the tissue did not follow
    x, y = view.ax.transData.transform((1.95, 0.5))
    press = MouseEvent("button_press_event", view.canvas, x, y, MouseButton.LEFT, guiEvent="a real press")
    view.canvas.callbacks.process("button_press_event", press)
    assert view.grabbed is not None and view.grabbed != name and name not in sim.handles  # replaced
    x, y = view.ax.transData.transform((2.1, 0.6))
    drag = MouseEvent("motion_notify_event", view.canvas, x, y, guiEvent="a real move, button held")
    view.canvas.callbacks.process("motion_notify_event", drag)
    np.testing.assert_allclose(sim.handle_offset(view.grabbed), (0.15, 0.1), atol=1e-9)
