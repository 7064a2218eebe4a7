"""The live view of a 3D body (the WebGL path of tissuefem.surgery.widget) in JupyterLab in headless Chromium, with
real mouse actions; the helpers of the 2D view's test (``test_browser_widget.py``) serve it.

A notebook made here shows a :class:`~tissuefem.surgery.interactive.SurgeryView` of a 2 x 1 x 1 block of tetrahedra
held on its left face. The test presses on the block's top face near its free end (the page picks the surface point
under the pointer), drags it, and checks that the grabbed nodes moved in the kernel and that the page painted
frames; then it turns the camera with a shift+drag and checks that nothing was grabbed. Without Chromium,
chromium-driver or anywidget it skips, saying what to install.

Run as a script, it is the 3D view's benchmark (nothing asserted)::

    python tests/chapters/test_browser_widget_3d.py [--cells 7 9] [--out FILE]

For each block (``2 n x n x n`` cells of six tetrahedra): frames painted per second while the wheel zooms the camera
every animation frame (events made in the page: what WebGL draws, whatever the driver's pace), while the mouse turns
the camera (the driver's pointer moves: the page alone), and while it drags the body (each picture waits for the
kernel's frame: positions received per second); the kernel's step and the page's paint (medians).
"""

from __future__ import annotations

import math
import time

import nbformat
import pytest

from browser_lab import (JupyterLab, cpu_seconds, descendants, kernel_json, open_notebook, run_all_cells,
                         start_chromium, wait_for)
from test_browser_widget import (Canvas, actions, benchmark_main, drag, median, notebook, release, reported_failure,
                                 settle, widget_missing)

pytestmark = pytest.mark.browser

#: cells across the block (2 n x n x n cells of six tetrahedra): 7 gives 4,116 tetrahedra and 960 nodes, the size
#: of chapter 11's live view
CHAPTER_CELLS = 7

VIEW_CELL = """\
from tissuefem import Scene, Simulation
from tissuefem.surgery.interactive import SurgeryView

sim = Simulation(Scene.from_dict({{
    "domain": {{"shape": "block", "lx": 2.0, "ly": 1.0, "lz": 1.0, "nx": {nx}, "ny": {n}, "nz": {n}}},
    "material": {{"model": "stable-neo-hookean", "youngs_modulus": 3000.0, "poisson_ratio": 0.3}},
    "effects": {{"inertia": {{"time_step": 1.0 / 30.0}}, "handles": [{{"name": "fixed", "region": "left"}}]}},
}}))
view = SurgeryView(sim)
view
"""

FIND_CANVAS = r"""
const c = document.querySelector('canvas.tissuefem-canvas3d');
if (!c || !c.dataset.camera || !c.tissuefem.project) return null;
c.scrollIntoView({block: 'center'});
return c;
"""

PROJECT = r"""
const c = arguments[0];
return arguments[1].map((p) => c.tissuefem.project(p[0], p[1], p[2]));
"""

#: a point on the block's top face near its free end, seen by the first camera
GRAB = (1.8, 1.0, 0.5)


class Canvas3D(Canvas):
    """World points to offsets from the canvas element's centre (selenium's), by the page's own camera."""

    def __init__(self, driver, element):
        self.driver, self.element = driver, element
        self.w, self.h = driver.execute_script("return [arguments[0].clientWidth, arguments[0].clientHeight];",
                                               element)
        self._offsets = {}

    def camera(self) -> dict:
        return self.driver.execute_script("return arguments[0].tissuefem.camera();", self.element)

    def prepare(self, points):
        """Project ``points`` in one call (the offsets of a drag, before it starts: none is asked for mid-drag)."""
        points = [tuple(float(v) for v in p) for p in points]
        pixels = self.driver.execute_script(PROJECT, self.element, [list(p) for p in points])
        self._offsets.update({p: (round(x - self.w / 2), round(y - self.h / 2)) for p, (x, y) in zip(points, pixels)})

    def offset(self, point):
        point = tuple(float(v) for v in point)
        if point not in self._offsets:
            self.prepare([point])
        return self._offsets[point]

    def received(self) -> int:
        return int(self.driver.execute_script("return Number(arguments[0].dataset.received);", self.element))


def in_view_plane(canvas, centre, offsets):
    """World points ``centre + a r + b u`` for ``(a, b)`` in ``offsets``: in the plane through ``centre`` facing the
    camera, where the page moves a grabbed point."""
    cam = canvas.camera()
    r, u = cam["r"], cam["u"]
    return [tuple(centre[i] + a * r[i] + b * u[i] for i in range(3)) for a, b in offsets]


def open_view(driver, lab, cells):
    source = VIEW_CELL.format(nx=2 * int(cells), n=int(cells))
    nbformat.write(notebook(source), lab.root / "widget3d.ipynb")
    open_notebook(driver, lab, "widget3d.ipynb")
    run_all_cells(driver)
    element = wait_for(lambda: driver.execute_script(FIND_CANVAS), 60, "the 3D view's canvas in the page")
    canvas = Canvas3D(driver, element)
    wait_for(lambda: canvas.painted() >= 1, 30, "the 3D view to paint the block")
    message = driver.execute_script("return document.querySelector('.tissuefem-message').textContent;")
    assert "WebGL" not in message, message
    wait_for(lambda: kernel_json(driver, "bool(view.running)"), 30, "the view's frame loop to run")
    return canvas


GRABBED_MOVE = ("float(__import__('numpy').abs(sim.positions()[:, sim.handles[view.grabbed].nodes]"
                " - sim.mesh.p[:, sim.handles[view.grabbed].nodes]).max())")


# --------------------------------------------------------------------------- the test
def test_the_3d_view_grabs_and_drags_a_block_in_jupyterlab(tmp_path):
    reason = widget_missing()
    if reason:
        pytest.skip(reason)
    with JupyterLab(tmp_path) as lab:
        driver = start_chromium(tmp_path)
        with reported_failure(driver, lab, tmp_path):
            canvas = open_view(driver, lab, 4)
            settle(driver)
            assert kernel_json(driver, "view.widget.dim") == 3
            painted0 = canvas.painted()
            time.sleep(0.5)
            assert canvas.painted() == painted0, "nothing is painted at rest"

            # press on the top face near the free end and pull it up and to the right, in the camera's plane
            path = in_view_plane(canvas, GRAB, [(0.03 * k, 0.02 * k) for k in range(11)])
            canvas.prepare(path)
            drag(driver, canvas, path, 0.05)
            wait_for(lambda: kernel_json(driver, "view.grabbed is not None"), 20, "a grab of the block")
            target = kernel_json(driver, "[float(v) for v in view.gestures.target]")
            assert math.dist(target, path[-1]) < 0.05, "the grab follows the pointer in the camera's plane"
            wait_for(lambda: kernel_json(driver, GRABBED_MOVE) > 0.2, 30, "the grabbed nodes to follow the mouse")
            release(driver)
            wait_for(lambda: kernel_json(driver, "view.grabbed is None"), 20, "the release to let go")
            assert canvas.painted() > painted0 + 5, "the page painted the frames of the drag"
            assert any(len(entry) == 5 for entry in canvas.log()), "the drag target was painted, in 3D"

            # a shift+drag turns the camera and grabs nothing
            from selenium.webdriver.common.keys import Keys

            settle(driver)
            before = canvas.camera()
            chain = actions(driver).move_to_element_with_offset(canvas.element, *canvas.offset(GRAB))
            chain.key_down(Keys.SHIFT).click_and_hold().move_by_offset(-80, 30).release().key_up(Keys.SHIFT)
            chain.perform()
            wait_for(lambda: canvas.camera()["eye"] != before["eye"], 10, "the camera to turn")
            assert kernel_json(driver, "view.grabbed is None and view.message == ''")
            driver.save_screenshot(str(tmp_path / "after.png"))


# --------------------------------------------------------------------------- the benchmark
#: Zooms the camera in and out with a wheel event every animation frame for ``seconds`` (in the page, no driver in
#: between); resolves to the pictures painted and the milliseconds spent.
ZOOMING = r"""
const [c, seconds, done] = [arguments[0], arguments[1], arguments[arguments.length - 1]];
const painted = Number(c.dataset.painted), started = performance.now();
let k = 0;
function step() {
  const now = performance.now();
  if (now - started > 1e3 * seconds) {
    done({painted: Number(c.dataset.painted) - painted, ms: now - started});
    return;
  }
  c.dispatchEvent(new WheelEvent('wheel', {deltaY: k++ % 40 < 20 ? 20 : -20, bubbles: true, cancelable: true}));
  requestAnimationFrame(step);
}
requestAnimationFrame(step);
"""


class Pixels:
    """A canvas for :func:`drag` whose points are already offsets from its centre (CSS pixels)."""

    def __init__(self, element):
        self.element = element

    def offset(self, point):
        return point


def measure(driver, lab, cells, seconds=4.0):
    """Painted frames per second while the camera turns (the page alone) and while dragging (positions received
    from the kernel, as many painted); the kernel's step and the page's paint."""
    canvas = open_view(driver, lab, cells)
    settle(driver)
    # a left drag beside the body turns the camera: every move is a picture drawn by the page alone
    corner = (-canvas.w // 2 + 20, -canvas.h // 2 + 20)
    n = int(seconds / 0.016)
    angles = [2 * math.pi * k / (n - 1) for k in range(n)]  # once round: the camera ends where it began
    turn = [(corner[0] + round(60 - 60 * math.cos(a)), corner[1] + round(40 * math.sin(a))) for a in angles]
    painted0, page0 = canvas.painted(), driver.execute_script("return performance.now();")
    drag(driver, Pixels(canvas.element), turn, 0.016, chunk=25)
    page1 = driver.execute_script("return performance.now();")
    release(driver)
    turning = {"seconds": round((page1 - page0) / 1e3, 2),
               "painted_per_second": round(1e3 * (canvas.painted() - painted0) / (page1 - page0), 1),
               "page_paint_median_ms": round(median([e[3] for e in canvas.log() if page0 <= e[0] <= page1]), 2)}
    zoom = driver.execute_async_script(ZOOMING, canvas.element, seconds)
    zooming = {"seconds": round(zoom["ms"] / 1e3, 2),
               "painted_per_second": round(1e3 * zoom["painted"] / zoom["ms"], 1)}
    canvas = Canvas3D(driver, canvas.element)  # projections of the camera as it is now
    kernel = descendants(kernel_json(driver, "__import__('os').getpid()"))
    circle = [(0.15 - 0.15 * math.cos(k / 20), 0.15 * math.sin(k / 20)) for k in range(n)]
    path = in_view_plane(canvas, GRAB, [(0.0, 0.0)] + circle)
    canvas.prepare(path)
    painted0, received0 = canvas.painted(), canvas.received()
    page0, cpu0 = driver.execute_script("return performance.now();"), cpu_seconds(kernel)
    drag(driver, canvas, path, 0.016, chunk=25)
    page1 = driver.execute_script("return performance.now();")
    painted1, received1, cpu1 = canvas.painted(), canvas.received(), cpu_seconds(kernel)
    release(driver)
    steps = kernel_json(driver, "[float(t) for t in view.frame_times][-200:]")
    paint_ms = [entry[3] for entry in canvas.log() if page0 <= entry[0] <= page1]
    span = (page1 - page0) / 1e3
    mesh = kernel_json(driver, "dict(nodes=int(sim.mesh.nvertices), tetrahedra=int(sim.mesh.nelements), "
                               "surface_triangles=len(view.widget.arrays()['triangles']))")
    settle(driver)
    dragging = {"seconds": round(span, 2), "painted_per_second": round((painted1 - painted0) / span, 1),
                "positions_received_per_second": round((received1 - received0) / span, 1),
                "kernel_cpu_percent_of_a_core": round(100 * (cpu1 - cpu0) / span, 1),
                "kernel_step_median_ms": None if not steps else round(median(steps), 1),
                "page_paint_median_ms": None if not paint_ms else round(median(paint_ms), 2)}
    return {"mesh": mesh, "zooming_in_the_page": zooming, "turning_the_camera": turning, "dragging": dragging}


if __name__ == "__main__":
    benchmark_main("measure the 3D view in JupyterLab + Chromium", "cells", [CHAPTER_CELLS],
                   f"cells across the block, 2 n x n x n (default: the chapter's {CHAPTER_CELLS})", measure=measure,
                   name="3D view (WebGL path of tissuefem.surgery.widget) in JupyterLab + headless Chromium",
                   prefix="n")
