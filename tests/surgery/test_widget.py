"""TissueWidget headless: the mesh as binary arrays, its checks, the boundary loops it fills, and its JavaScript
(shipped with the package, importing and fetching nothing); a 3D view: the surface of tetrahedra it sends, pointer
messages with z, its snapshot. The view that drives it: ``test_interactive.py``."""

import numpy as np
import pytest

pytest.importorskip("anywidget")

from matplotlib.figure import Figure

from tissuefem.engine.meshes import box
from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery.element_cuts import picture, surface
from tissuefem.surgery.interactive import SurgeryView, snapshot, synthetic_mouse
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation
from tissuefem.surgery.widget import STATIC, TissueWidget, outline

SHEET = {
    "domain": {"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 400},
    "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
    "effects": {"inertia": {"time_step": 1.0 / 30.0}, "handles": [{"name": "fixed", "region": "left"}]},
}


@pytest.fixture
def view():
    v = SurgeryView(Simulation(Scene.from_dict(SHEET)), autostart=False)
    yield v
    v.close()


def test_the_javascript_ships_with_the_package():
    js = (STATIC / "tissue_widget.js").read_text()
    assert "export default" in js and "requestAnimationFrame" in js
    assert "import " not in js and "http" not in js, "the module imports nothing and fetches nothing"
    # the run button names what a click does: a different symbol and word in each state
    assert '"\\u23F8 pause"' in js and '"\\u25B6 run"' in js


def test_the_widget_holds_the_mesh_as_binary_arrays(view):
    a = view.widget.arrays()
    pic = view.sim.picture
    assert a["positions"].dtype == np.float32 and a["positions"].shape == (pic.triangles.max() + 1, 2)
    assert a["triangles"].dtype == np.int32 and a["triangles"].shape == (pic.triangles.shape[1], 3)
    assert a["edges"].shape == (pic.edges.shape[1], 2)
    assert 0 < np.count_nonzero(a["outline"] >= 0) < len(a["positions"]), "the boundary loops, to fill"
    assert np.allclose(a["positions"], view.sim.positions().T, atol=1e-6)
    assert view.widget.dim == 2 and isinstance(view.widget.positions, bytes)


def test_show_mesh_checks_its_arrays():
    w = TissueWidget()
    with pytest.raises(ParameterError, match="triangles"):
        w.show_mesh(np.zeros((3, 2)), [[0, 1, 3]])
    with pytest.raises(ParameterError, match="positions"):
        w.show_mesh(np.zeros((3, 4)), [[0, 1, 2]])
    w.show_mesh(np.zeros((3, 3)), [[0, 1, 2]])  # a 3D surface: dim 3
    assert w.dim == 3 and w.arrays()["positions"].shape == (3, 3)


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


# ------------------------------------------------------------------ 3D: the surface of a block of tetrahedra
BLOCK = {
    "domain": {"shape": "block", "lx": 2.0, "ly": 1.0, "lz": 1.0, "nx": 4, "ny": 2, "nz": 2},
    "material": {"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
    "effects": {"inertia": {"time_step": 1.0 / 30.0}, "handles": [{"name": "fixed", "region": "left"}]},
}


@pytest.fixture
def view3d():
    v = SurgeryView(Simulation(Scene.from_dict(BLOCK)), autostart=False, color="J")
    yield v
    v.close()


def test_the_surface_of_tetrahedra_faces_outwards_and_closes():
    mesh = box(2.0, 1.0, 1.0, 4, 2, 2)
    pic = surface(mesh)
    assert picture(mesh).triangles.tolist() == pic.triangles.tolist(), "a tetrahedral mesh is drawn as its surface"
    assert pic.triangles.shape == (3, 2 * 2 * (4 * 2 + 2 * 2 + 4 * 2)) and pic.plain
    a, b, c = (mesh.p[:, pic.triangles[k]] for k in range(3))
    normal = np.cross(b - a, c - a, axis=0)
    centroid = mesh.p[:, mesh.t[:, pic.element]].mean(axis=1)
    assert np.all(np.einsum("ik,ik->k", normal, a - centroid) > 0), "every face turned away from its tetrahedron"
    # closed and outward: the divergence theorem gives the block's volume
    assert np.einsum("ik,ik->k", a, np.cross(b, c, axis=0)).sum() / 6 == pytest.approx(2.0, rel=1e-12)
    assert pic.edges.shape[0] == 2 and len({tuple(e) for e in pic.edges.T}) == pic.edges.shape[1]
    assert pic.points(mesh.p) is mesh.p


def test_a_3d_view_sends_its_surface_once_and_positions_each_frame(view3d):
    w, sim = view3d.widget, view3d.sim
    a = w.arrays()
    assert w.dim == 3 and view3d.dim == 3 and len(w.bounds) == 6
    assert a["positions"].shape == (sim.mesh.nvertices, 3)
    assert np.allclose(a["positions"], sim.positions().T, atol=1e-6)
    assert a["triangles"].tolist() == sim.picture.triangles.T.tolist() and len(a["outline"]) == 0
    assert a["colors"].shape == (len(a["triangles"]),) and np.allclose(a["colors"], 1.0, atol=1e-6)
    synthetic_mouse(view3d, "press", (2.0, 0.5, 0.5))  # the middle of the free face
    assert view3d.grabbed is not None
    synthetic_mouse(view3d, "move", (2.3, 0.7, 0.6))
    assert view3d.widget.target == pytest.approx([2.3, 0.7, 0.6])
    for _ in range(10):
        view3d.step()
    x = view3d.widget.arrays()["positions"]
    assert x[:, 0].max() > 2.15 and x[:, 2].max() > 1.02, "the grabbed face followed in x and z"
    assert view3d.topology_pushes == 1 and view3d.pushes > 5
    assert not np.allclose(view3d.widget.arrays()["colors"], 1.0, atol=1e-3), "the colours follow J"
    synthetic_mouse(view3d, "release", (2.3, 0.7, 0.6))
    assert view3d.grabbed is None


def test_pointer_messages_in_3d_carry_z(view3d):
    view3d.widget._handle_custom_msg({"event": "pointer", "kind": "down", "x": 2.0, "y": 0.5}, [])
    assert "point" in view3d.message and view3d.grabbed is None, "a 3D view needs z"
    view3d.widget._handle_custom_msg({"event": "pointer", "kind": "down", "x": 2.0, "y": 0.5, "z": 0.5}, [])
    assert view3d.grabbed is not None
    view3d.widget._handle_custom_msg({"event": "pointer", "kind": "up", "x": 2.0, "y": 0.5, "z": 0.5,
                                      "inside": True}, [])
    assert view3d.grabbed is None
    with pytest.raises(ParameterError) as refused:
        synthetic_mouse(view3d, "press", (2.0, 0.5))
    assert refused.value.field == "point"


def test_a_3d_snapshot_draws_the_surface_on_3d_axes(view3d):
    synthetic_mouse(view3d, "press", (2.0, 0.5, 0.5))
    fig = snapshot(view3d)
    ax = fig.axes[0]
    assert hasattr(ax, "zaxis") and ax.get_zlim() == pytest.approx(tuple(view3d.widget.bounds[4:]))
    with pytest.raises(ParameterError, match="ax"):
        snapshot(view3d, ax=Figure().add_subplot())


def test_the_javascript_draws_3d_with_webgl_of_its_own():
    js = (STATIC / "tissue_widget.js").read_text()
    assert 'getContext("webgl"' in js and "render3d" in js and "render2d" in js
    assert "THREE" not in js, "no three.js: our own WebGL"


def test_the_stroke_has_the_widget_dimension():
    w = TissueWidget()
    w.show_mesh(np.zeros((3, 3)), [[0, 1, 2]])
    w.stroke = np.arange(6, dtype=np.float32).tobytes()
    assert w.arrays()["stroke"].shape == (2, 3)


def test_a_stroke_on_a_3d_view_says_cuts_are_2d_only(view3d):
    view3d.mode = "cut"
    for kind, point in [("press", (1.0, 1.0, 0.5)), ("move", (1.0, 0.5, 0.5)), ("release", (1.0, 0.0, 0.5))]:
        synthetic_mouse(view3d, kind, point)
    assert view3d.message.startswith("cut failed") and "2D" in view3d.message
    assert view3d.sim.mesh.nelements == 6 * 4 * 2 * 2 and view3d.stroke is None
