"""The live view (tissuefem.surgery.interactive, drawn by tissuefem.surgery.widget) in JupyterLab in headless
Chromium, with real mouse actions; its helpers serve ``test_browser.py`` (chapter 8's own cells) too.

A notebook made here shows a :class:`~tissuefem.surgery.interactive.SurgeryView` of chapter 8's sheet; the test drags
the tissue on the widget's canvas and checks that it moved (the positions in the kernel) and that the page painted
frames (the canvas's own counter), then cuts it with a stroke. Without Chromium, chromium-driver or anywidget it
skips, saying what to install.

Run as a script, it is the view's benchmark (nothing asserted)::

    python tests/chapters/test_browser_widget.py [--triangles 2000 8000] [--out FILE]

For each mesh: frames painted per second while the mouse drags continuously (over the whole drag, and from its first
picture on: the time before it is the driver's and the press's), the latency from a mouse move to the
first paint that shows it (the drag target at the new point, which the kernel sends with the positions of the frame
that took the move), and the CPU the kernel uses at rest (after the tissue settled and the mouse let go). With the
drag and the latency: the view's frames and the steps committed in them (fewer when steps ran off the frame: the
target then moves ahead of the tissue, and the latency is the target's).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import random
import sys
import tempfile
import time
from pathlib import Path

import nbformat
import pytest

from browser_lab import (JupyterLab, browser_missing, cpu_seconds, descendants, kernel_execute, kernel_json,
                         open_notebook, run_all_cells, start_chromium, wait_for)

pytestmark = pytest.mark.browser

#: chapter 8's sheet (about 1,100 nodes)
CHAPTER_TRIANGLES = 2000

VIEW_CELL = """\
from tissuefem import Simulation, demo_scene
from tissuefem.surgery.interactive import SurgeryView

sim = Simulation(demo_scene(n_triangles={triangles}))
view = SurgeryView(sim)
view
"""

FIND_CANVAS = r"""
const c = document.querySelector('canvas.tissuefem-canvas');
if (!c || !c.dataset.view) return null;
c.scrollIntoView({block: 'center'});
return c;
"""

CANVAS_INFO = r"""
const c = arguments[0];
return {view: JSON.parse(c.dataset.view), w: c.clientWidth, h: c.clientHeight, painted: Number(c.dataset.painted)};
"""


POINTER_TIMES = r"""
if (!window.__tf_pointer) {
  window.__tf_pointer = [];
  window.addEventListener('pointermove', () => {
    window.__tf_pointer.push(performance.now());
    if (window.__tf_pointer.length > 5000) window.__tf_pointer.splice(0, 2500);
  }, true);
}
"""


#: the view's frames and the steps the simulation committed: fewer steps than frames when steps ran off the frame
#: (a frame then shows the last committed state, and the drag target moves ahead of the tissue)
FRAME_COUNTS = "[len(view.frame_times), int(sim.frames)]"


def frames_and_steps(before, after) -> dict:
    return {"frames": after[0] - before[0], "steps_committed": after[1] - before[1]}


def imported_from(driver) -> str:
    """Where the notebook's kernel imported tissuefem from: relative to the tree holding this test if inside it
    (measured code is this tree's), else the full path (another copy, e.g. an installed one)."""
    path = Path(kernel_json(driver, "__import__('tissuefem').__file__")).resolve()
    tree = Path(__file__).resolve().parents[2]
    return str(path.relative_to(tree)) if path.is_relative_to(tree) else str(path)


def widget_missing() -> str | None:
    reason = browser_missing()
    if reason:
        return reason
    try:
        import anywidget  # noqa: F401
    except ImportError:
        return "anywidget is not installed: pip install anywidget"
    return None


def notebook(source):
    """A notebook of one code cell, ``source``, with a Python 3 kernel."""
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(source)]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3 (ipykernel)", "language": "python"}
    return nb


class Canvas:
    """World coordinates to offsets from the canvas element's centre (selenium's), by the page's own map."""

    def __init__(self, driver, element):
        self.driver, self.element = driver, element
        info = driver.execute_script(CANVAS_INFO, element)
        self.scale, self.ox, self.oy = info["view"]
        self.w, self.h = info["w"], info["h"]

    def offset(self, point):
        x, y = point
        return round(self.ox + self.scale * x - self.w / 2), round(self.oy - self.scale * y - self.h / 2)

    def painted(self) -> int:
        return int(self.driver.execute_script("return Number(arguments[0].dataset.painted);", self.element))

    def log(self, since=None):
        """The page's log of paints (``[time, target x, target y, ms]``), those from ``since`` on (page ms) if
        given: a poll copies only the few new ones (copying the whole log each time loads the page it measures)."""
        if since is None:
            return self.driver.execute_script("return arguments[0].tissuefem.log.slice();", self.element)
        return self.driver.execute_script("return arguments[0].tissuefem.log.filter((e) => e[0] >= arguments[1]);",
                                          self.element, since)


def actions(driver):
    from selenium.webdriver.common.action_chains import ActionChains

    return ActionChains(driver, duration=0)


def open_view(driver, lab, triangles):
    nbformat.write(notebook(VIEW_CELL.format(triangles=int(triangles))), lab.root / "widget.ipynb")
    open_notebook(driver, lab, "widget.ipynb")
    run_all_cells(driver)
    element = wait_for(lambda: driver.execute_script(FIND_CANVAS), 60, "the widget's canvas in the page")
    canvas = Canvas(driver, element)
    wait_for(lambda: canvas.painted() >= 1, 30, "the widget to paint the tissue")
    wait_for(lambda: kernel_json(driver, "bool(view.running)"), 30, "the view's frame loop to run")
    return canvas


def settle(driver, timeout=60):
    wait_for(lambda: kernel_json(driver, "bool(view.resting)"), timeout, "the tissue to come to rest")


def drag(driver, canvas, points, pause, chunk=None):
    """Press at the first point, move through the others (``pause`` s apart), keep the button held. ``chunk``: send
    the moves in chains of that many (the button stays held; short chains keep chromedriver's calls short)."""
    chunk = chunk or len(points)
    chain = actions(driver).move_to_element_with_offset(canvas.element, *canvas.offset(points[0])).click_and_hold()
    for k, p in enumerate(points[1:], start=1):
        if k % chunk == 0:
            chain.perform()
            chain = actions(driver)
        chain.move_to_element_with_offset(canvas.element, *canvas.offset(p)).pause(pause)
    chain.perform()


@contextlib.contextmanager
def reported_failure(driver, lab, folder):
    """On any failure: a screenshot into ``folder`` and the JupyterLab log on stderr; the browser quits either way."""
    try:
        yield
    except BaseException:
        try:
            driver.save_screenshot(str(Path(folder) / "failure.png"))
        except Exception:
            pass
        print("JupyterLab log:\n" + lab.log_tail(), file=sys.stderr)
        raise
    finally:
        driver.quit()


def release(driver):
    actions(driver).release().perform()


def median(values):
    v = sorted(values)
    if not v:
        return None
    m = len(v) // 2
    return v[m] if len(v) % 2 else 0.5 * (v[m - 1] + v[m])


def percentile(values, q):
    v = sorted(values)
    return None if not v else v[min(len(v) - 1, int(round(q / 100 * (len(v) - 1))))]


# --------------------------------------------------------------------------- the test
def test_the_browser_view_drags_and_cuts_in_jupyterlab(tmp_path):
    reason = widget_missing()
    if reason:
        pytest.skip(reason)
    with JupyterLab(tmp_path) as lab:
        driver = start_chromium(tmp_path)
        with reported_failure(driver, lab, tmp_path):
            canvas = open_view(driver, lab, 800)
            settle(driver)
            before = kernel_json(driver, "dict(x=float(sim.positions()[0].max()), frames=int(sim.frames), "
                                         "nodes=int(sim.mesh.nvertices), pushes=view.pushes)")
            painted0 = canvas.painted()
            log = (tmp_path / "jupyterlab.log").read_text(errors="replace")
            assert "without Nagle's delay" in log, "the installed package enables tissuefem.surgery.nodelay"
            # at rest nothing is sent and nothing painted
            time.sleep(0.5)
            assert kernel_json(driver, "view.pushes") == before["pushes"]
            assert canvas.painted() == painted0, "nothing is painted at rest"
            # two frames sent back to back: each is painted (the newer does not replace the older unpainted)
            kernel_execute(driver, "_x = view.widget.positions\nview.widget.positions = bytes(len(_x))\n"
                                   "view.widget.positions = _x")
            wait_for(lambda: canvas.painted() >= painted0 + 2, 20, "the page to paint both frames")
            time.sleep(0.3)
            assert canvas.painted() == painted0 + 2, "one picture a frame"
            painted0 = canvas.painted()
            path = [(1.95 + 0.03 * k, 0.5 - 0.02 * k) for k in range(11)]
            drag(driver, canvas, path, 0.05)
            wait_for(lambda: kernel_json(driver, "float(sim.positions()[0].max())") > before["x"] + 0.1, 30,
                     "the dragged tissue to follow the mouse")
            assert kernel_json(driver, "view.grabbed is not None")
            release(driver)
            wait_for(lambda: kernel_json(driver, "view.grabbed is None"), 20, "the release to let go")
            assert canvas.painted() > painted0 + 5, "the page painted the frames of the drag"
            target_paints = [entry for entry in canvas.log() if entry[1] is not None]
            assert target_paints, "the drag target was painted"

            # cut mode with the widget's button, then a stroke across the sheet
            button = driver.find_element("css selector", "button.tissuefem-mode[data-mode='cut']")
            button.click()
            wait_for(lambda: kernel_json(driver, "view.mode") == "cut", 20, "cut mode")
            top = kernel_json(driver, "float(sim.positions()[1][abs(sim.positions()[0] - 0.5) < 0.1].max())")
            stroke = [(0.5, top + 0.3 - 0.1 * k) for k in range(int((top + 0.3 - 0.45) / 0.1) + 1)]
            drag(driver, canvas, stroke, 0.05)
            release(driver)

            def cut():
                state = kernel_json(driver, "dict(nodes=int(sim.mesh.nvertices), message=view.message)")
                if state["message"]:
                    raise AssertionError(f"the stroke did not cut: {state['message']}")
                return state["nodes"] > before["nodes"]

            wait_for(cut, 30, "the stroke to cut the tissue")
            after = kernel_json(driver, "dict(topology=view.topology_pushes, frames=int(sim.frames))")
            assert after["topology"] == 2, "the topology was sent twice: at the start and after the cut"
            assert after["frames"] > before["frames"]
            driver.save_screenshot(str(tmp_path / "after.png"))


# --------------------------------------------------------------------------- the benchmark
def measure(driver, lab, triangles, seconds=3.0, probes=30, seed=8):
    """Painted frames per second while dragging, mouse-to-picture latency and the kernel's CPU at rest."""
    rng = random.Random(seed)
    canvas = open_view(driver, lab, triangles)
    settle(driver)
    kernel_pid = kernel_json(driver, "__import__('os').getpid()")
    kernel = descendants(kernel_pid)

    # at rest: nothing sent, nothing painted, the kernel's CPU
    painted0, cpu0, t0 = canvas.painted(), cpu_seconds(kernel), time.monotonic()
    time.sleep(3.0)
    rest = {"cpu_percent_of_a_core": round(100 * (cpu_seconds(kernel) - cpu0) / (time.monotonic() - t0), 2),
            "painted": canvas.painted() - painted0}

    # dragging continuously: a circle around the grab, a move every 16 ms
    n = int(seconds / 0.016)
    centre = (1.95, 0.5)
    path = [centre] + [(centre[0] + 0.15 - 0.15 * math.cos(k / 20), centre[1] + 0.15 * math.sin(k / 20))
                       for k in range(n)]
    painted0, page0 = canvas.painted(), driver.execute_script("return performance.now();")
    cpu0, counts0 = cpu_seconds(kernel), kernel_json(driver, FRAME_COUNTS)
    drag(driver, canvas, path, 0.016, chunk=25)
    page1 = driver.execute_script("return performance.now();")
    painted1, cpu1, counts1 = canvas.painted(), cpu_seconds(kernel), kernel_json(driver, FRAME_COUNTS)
    steps = kernel_json(driver, "[float(t) for t in view.frame_times][-200:]")
    paints = [entry for entry in canvas.log() if page0 <= entry[0] <= page1]
    paint_ms = [entry[3] for entry in paints]
    first = paints[0][0] if paints else page1  # the drag's first picture (the press reached the page before it)
    dragging = {"painted_per_second": round(1e3 * (painted1 - painted0) / (page1 - page0), 1),
                "painted_per_second_from_the_first_picture": None if len(paints) < 2 else
                round(1e3 * (len(paints) - 1) / (page1 - first), 1),
                "first_picture_ms": round(first - page0, 1),
                "seconds": round((page1 - page0) / 1e3, 2),
                "kernel_cpu_percent_of_a_core": round(100 * (cpu1 - cpu0) / ((page1 - page0) / 1e3), 1),
                "kernel_step_median_ms": None if not steps else round(median(steps), 1),
                "page_paint_median_ms": None if not paint_ms else round(median(paint_ms), 1),
                **frames_and_steps(counts0, counts1)}

    # latency probes: the button held, jump to a new point after a random wait, find the first paint showing it;
    # pointer moves are timed as they reach the page (the widget prevents the mouse events that would follow them)
    driver.execute_script(POINTER_TIMES)
    latencies, missed, counts0 = [], 0, kernel_json(driver, FRAME_COUNTS)
    for k in range(probes):
        time.sleep(rng.uniform(0.1, 0.3))
        point = (centre[0] + (0.2 if k % 2 else 0.05), centre[1] + 0.04 * ((k % 3) - 1))
        actions(driver).move_to_element_with_offset(canvas.element, *canvas.offset(point)).perform()
        moved = driver.execute_script("return window.__tf_pointer[window.__tf_pointer.length - 1];")
        shown = None
        deadline = time.monotonic() + 3.0
        while shown is None and time.monotonic() < deadline:
            time.sleep(0.02)
            for t, x, y, *_ in canvas.log(since=moved):
                if t >= moved and x is not None and abs(x - point[0]) < 0.01 and abs(y - point[1]) < 0.01:
                    shown = t
                    break
        if shown is None:
            missed += 1
        else:
            latencies.append(shown - moved)
    release(driver)
    latency = {"median_ms": None if not latencies else round(median(latencies), 1),
               "p95_ms": None if not latencies else round(percentile(latencies, 95), 1),
               "shown": len(latencies), "missed": missed, "each_ms": [round(t, 1) for t in latencies],
               **frames_and_steps(counts0, kernel_json(driver, FRAME_COUNTS))}

    # after the drag: the tissue settles, then rests again
    settle(driver)
    painted0, cpu0, t0 = canvas.painted(), cpu_seconds(kernel), time.monotonic()
    time.sleep(3.0)
    rest_after = {"cpu_percent_of_a_core": round(100 * (cpu_seconds(kernel) - cpu0) / (time.monotonic() - t0), 2),
                  "painted": canvas.painted() - painted0}
    nodes = kernel_json(driver, "dict(nodes=int(sim.mesh.nvertices), triangles=int(sim.mesh.nelements))")
    return {"mesh": nodes, "tissuefem": imported_from(driver), "at_rest": rest, "dragging": dragging, "latency": latency,
            "at_rest_after_drag": rest_after}


def run_benchmark(workdir, sizes, measure=measure, name="browser-drawn view (tissuefem.surgery.widget) in JupyterLab "
                  "+ headless Chromium", prefix="t", nagle=False) -> dict:
    """``measure(driver, lab, size)`` for each size, each in its own JupyterLab and browser; the record with the
    machine's load, and whether the server sent without Nagle's delay (:mod:`tissuefem.surgery.nodelay` loaded;
    ``nagle=True`` disables it)."""
    results = []
    for size in sizes:
        folder = Path(workdir) / f"{prefix}{size}"
        folder.mkdir(parents=True, exist_ok=True)
        with JupyterLab(folder, nagle=nagle) as lab:
            driver = start_chromium(folder)
            with reported_failure(driver, lab, folder):
                results.append(measure(driver, lab, size))
            nodelay = "without Nagle's delay" in (folder / "jupyterlab.log").read_text(errors="replace")
    return {"benchmark": name, "load_average_1_5_15_min": list(os.getloadavg()), "cpus": os.cpu_count(),
            "kernel_websockets": "without Nagle's delay" if nodelay else "Jupyter Server's default (Nagle on)",
            "results": results}


def benchmark_main(description, option, default, help, **run) -> None:
    """The command line of a browser benchmark: the sizes ``--<option>``, ``--out`` a JSON file; prints the record."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument(f"--{option}", type=int, nargs="+", default=default, help=help)
    parser.add_argument("--out", type=Path, help="a JSON file to write")
    parser.add_argument("--nagle", action="store_true",
                        help="disable tissuefem's Jupyter Server extension (kernel websockets with Nagle's algorithm)")
    args = parser.parse_args()
    reason = widget_missing()
    if reason:
        raise SystemExit(reason)
    with tempfile.TemporaryDirectory() as folder:
        record = run_benchmark(folder, getattr(args, option), nagle=args.nagle, **run)
    text = json.dumps(record, indent=2)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
    print(text)


if __name__ == "__main__":
    benchmark_main("measure the browser-drawn view in JupyterLab + Chromium", "triangles", [CHAPTER_TRIANGLES, 8000],
                   "mesh sizes (default: chapter 8's 2000 and 8000)")
