"""TissueWidget headless: the mesh as binary arrays, its checks, the boundary loops it fills, and its JavaScript
(shipped with the package, importing and fetching nothing). The view that drives it: ``test_interactive.py``."""

import numpy as np
import pytest

pytest.importorskip("anywidget")

from tissuefem.engine.parameters import ParameterError
from tissuefem.surgery.interactive import SurgeryView
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
