"""Chapter 8's interactive section in a real browser: JupyterLab, Debian's Chromium, real mouse actions.

The test builds a notebook of exactly the chapter's cells for the section
"With the mouse" (and the chapter's set-up cell before them), opens it in
JupyterLab in headless Chromium through chromium-driver, runs it with
*Run All Cells* as a student would, then with the mouse on the figure's
canvas: drags the tissue, measures how fast the picture follows, switches to
cut mode with the mode buttons, and cuts. It asserts what must hold (the
picture changed, frames were drawn, the cut happened, nothing failed); the
frame rate and the latency it measured are a benchmark, written to
``bench-results/interactive_browser.json`` and printed, never asserted.

Run it alone with ``python -m pytest -m browser -s``, or as a script
(``python tests/chapters/test_browser.py``) to print the measurement. Without Chromium
and chromium-driver it skips, saying how to install them.

How the numbers are measured (in the page, with ``performance.now()``):

* **frames drawn per second**: paints of the view's canvas (ipympl draws each
  frame it receives onto its visible canvas with one ``drawImage``) per second,
  while the mouse drags the tissue continuously, and while it rests;
* **latency**: with the button held, the mouse jumps to a new point and waits;
  the latency is the time from that mouse event to the first paint in which the
  drag target's marker (drawn at the mouse) appears at the new point. Each
  probe waits a different time before its jump, so the jumps fall at every
  phase of the view's frame timer.
"""

from __future__ import annotations

import json
import os
import platform
import random
import sys
import tempfile
import time
from pathlib import Path

import nbformat
import pytest

from browser_lab import (PROBE_SHOWN, JupyterLab, browser_missing, cpu_seconds, descendants, kernel_execute,
                         kernel_json, open_notebook, run_all_cells, start_chromium, wait_for)

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
CHAPTER = ROOT / "chapters" / "ch08b_virtual_surgery.ipynb"
SECTION = "With the mouse"
BENCH_OUT = ROOT / "bench-results" / "interactive_browser.json"
#: matplotlib's "tab:blue", the colour of the drag target's marker
MARKER_RGB = (31, 119, 180)


def interactive_section(chapter=CHAPTER):
    """A notebook of the chapter's set-up cell and every cell of its section "With the mouse", unchanged."""
    nb = nbformat.read(chapter, as_version=4)
    cells = nb.cells
    setup = next(c for c in cells if c.cell_type == "code")
    start = next(i for i, c in enumerate(cells)
                 if c.cell_type == "markdown" and c.source.startswith("## ") and SECTION in c.source.splitlines()[0])
    end = next((i for i in range(start + 1, len(cells))
                if cells[i].cell_type == "markdown" and cells[i].source.startswith("## ")), len(cells))
    section = nbformat.v4.new_notebook(metadata=nb.metadata)
    section.cells = [setup, *cells[start:end]]
    for cell in section.cells:
        if cell.cell_type == "code":
            cell.outputs, cell.execution_count = [], None
    return section


# --------------------------------------------------------------------------- the page
FIND_VIEW = r"""
const [w, h] = [arguments[0], arguments[1]];
for (const div of document.querySelectorAll('.jupyter-matplotlib-canvas-div')) {
  const canvases = div.querySelectorAll('canvas');
  if (canvases.length >= 2 && canvases[0].width === w && canvases[0].height === h) {
    div.scrollIntoView({block: 'center'});
    window.__tf.canvas = canvases[0];
    window.__tf.paints = [];
    return canvases[canvases.length - 1];
  }
}
return null;
"""

SNAPSHOT = r"""
const c = window.__tf.canvas;
window.__tf.snapshot = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
"""

CHANGED = r"""
const c = window.__tf.canvas, a = window.__tf.snapshot;
const b = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
let n = 0;
for (let i = 0; i < a.length; i += 4) {
  if (a[i] !== b[i] || a[i + 1] !== b[i + 1] || a[i + 2] !== b[i + 2]) n++;
}
return n / (a.length / 4);
"""


def paint_times(driver):
    return driver.execute_script("return window.__tf.paints.slice();")


def rate(times, t0, t1):
    """Paints per second between t0 and t1 (ms, page clock)."""
    inside = [t for t in times if t0 <= t <= t1]
    return 1e3 * len(inside) / (t1 - t0) if t1 > t0 else 0.0


def page_metrics(driver):
    """Seconds the page's main thread spent so far: in tasks, scripts, layout, style (Chromium's own counters)."""
    driver.execute_cdp_cmd("Performance.enable", {})
    metrics = {m["name"]: m["value"] for m in driver.execute_cdp_cmd("Performance.getMetrics", {})["metrics"]}
    return {k: metrics.get(k, 0.0) for k in ("TaskDuration", "ScriptDuration", "LayoutDuration",
                                              "RecalcStyleDuration")}


def per_frame(before, after, frames):
    """Milliseconds per frame of each counter (seconds) between two readings."""
    if before is None or after is None or not frames:
        return None
    return {name: round(1e3 * (after[name] - before[name]) / frames, 1) for name in before}


def page_now(driver):
    return driver.execute_script("return performance.now();")


class Canvas:
    """Data coordinates of the view's axes to offsets from the canvas element's centre (what selenium takes)."""

    def __init__(self, driver, element):
        self.driver, self.element = driver, element
        info = kernel_json(driver, "dict(w=view.fig.bbox.width, h=view.fig.bbox.height, "
                                   "ratio=float(getattr(view.canvas, 'device_pixel_ratio', 1.0)))")
        self.ratio = info["ratio"]
        self.height = info["h"]
        size = element.size
        self.cx, self.cy = size["width"] / 2.0, size["height"] / 2.0

    def pixels(self, points):
        """Canvas pixels (x right, y down) of data points."""
        code = ("print(_json.dumps(view.ax.transData.transform(" + json.dumps([list(map(float, p)) for p in points])
                + ").tolist()))")
        out = kernel_execute(self.driver, "import json as _json; view.ax.apply_aspect(); " + code)
        display = json.loads(out.strip().splitlines()[-1])
        return [(x / self.ratio, (self.height - y) / self.ratio) for x, y in display]

    def offsets(self, points):
        return [(round(x - self.cx), round(y - self.cy)) for x, y in self.pixels(points)]


def actions(driver):
    from selenium.webdriver.common.action_chains import ActionChains

    return ActionChains(driver, duration=0)


def press_at(driver, canvas, offset):
    actions(driver).move_to_element_with_offset(canvas.element, *offset).click_and_hold().perform()


def move_to(driver, canvas, offset):
    actions(driver).move_to_element_with_offset(canvas.element, *offset).perform()


def release(driver):
    actions(driver).release().perform()


class CpuMeter:
    """CPU seconds of the kernel, the Jupyter server and Chromium (every process of each) over a stretch."""

    def __init__(self, driver, lab):
        kernel_pid = kernel_json(driver, "__import__('os').getpid()")
        server = [p for p in descendants(lab.process.pid) if p != kernel_pid and p not in descendants(kernel_pid)]
        self.groups = {"kernel": descendants(kernel_pid), "server": server,
                       "chromium": descendants(driver.service.process.pid)}

    def read(self):
        return {name: cpu_seconds(pids) for name, pids in self.groups.items()}


def drag_session(driver, lab=None, seed=8):
    """Everything a student does with the mouse; returns the measurements and what the kernel saw."""
    rng = random.Random(seed)
    fig = kernel_json(driver, "dict(w=int(round(view.fig.bbox.width)), h=int(round(view.fig.bbox.height)))")
    element = wait_for(lambda: driver.execute_script(FIND_VIEW, fig["w"], fig["h"]), 30,
                       f"the view's canvas ({fig['w']} x {fig['h']} px) in the page")
    canvas = Canvas(driver, element)
    # the timer runs: frames arrive without any input
    wait_for(lambda: len(paint_times(driver)) >= 5, 30, "the running view to paint frames")
    meter = CpuMeter(driver, lab) if lab is not None else None
    cpu0, page0 = (meter.read() if meter else None), page_metrics(driver)
    t_rest0 = page_now(driver)
    time.sleep(2.0)
    t_rest1 = page_now(driver)
    cpu1, page1 = (meter.read() if meter else None), page_metrics(driver)
    rest_fps = rate(paint_times(driver), t_rest0, t_rest1)
    rest_paints = len([t for t in paint_times(driver) if t_rest0 <= t <= t_rest1])
    rest_cpu = per_frame(cpu0, cpu1, rest_paints)
    rest_page = per_frame(page0, page1, rest_paints)
    before = kernel_json(driver, "dict(frames=int(sim.frames), nodes=int(sim.mesh.nvertices))")
    driver.execute_script(SNAPSHOT)

    # grab the tissue at its rightmost node, wherever the chapter's run left it
    grab = kernel_json(driver, "sim.positions()[:, int(sim.positions()[0].argmax())].tolist()")
    grab = (grab[0] - 0.02, grab[1])
    press_at(driver, canvas, canvas.offsets([grab])[0])
    wait_for(lambda: kernel_json(driver, "view.grabbed is not None"), 20, "the press to grab the tissue")

    # a continuous drag: a slow loop around a point to the lower right, a move every ~20 ms
    import math
    (x0, x1), (y0, y1) = kernel_json(driver, "[view.ax.get_xlim(), view.ax.get_ylim()]")
    centre = (min(grab[0] + 0.15, x1 - 0.45), max(min(grab[1] - 0.1, y1 - 0.45), y0 + 0.45))
    loop = [(centre[0] + 0.2 * math.cos(a), centre[1] + 0.2 * math.sin(a))
            for a in [2 * math.pi * k / 150 for k in range(151)]]
    offsets = canvas.offsets(loop)
    chain = actions(driver)
    for off in offsets:
        chain.move_to_element_with_offset(canvas.element, *off).pause(0.02)
    cpu0, page0 = (meter.read() if meter else None), page_metrics(driver)
    t_drag0 = page_now(driver)
    chain.perform()
    t_drag1 = page_now(driver)
    cpu1, page1 = (meter.read() if meter else None), page_metrics(driver)
    drag_paints = len([t for t in paint_times(driver) if t_drag0 <= t <= t_drag1])
    drag_fps = rate(paint_times(driver), t_drag0, t_drag1)
    cpu_per_frame = per_frame(cpu0, cpu1, drag_paints)
    page_per_frame = per_frame(page0, page1, drag_paints)

    # latency probes: jump, wait until the marker shows the jump, rest a random while
    probe_points = [(centre[0] + (0.18 if k % 2 else -0.18), centre[1] + 0.05 * ((k % 3) - 1)) for k in range(16)]
    probe_offsets = canvas.offsets(probe_points)
    probe_pixels = canvas.pixels(probe_points)
    latencies, missed = [], 0
    for off, (px, py) in zip(probe_offsets, probe_pixels):
        time.sleep(rng.uniform(0.12, 0.4))
        driver.execute_script(
            "window.__tf.probe = {x: Math.round(arguments[0]), y: Math.round(arguments[1]), r: 8, min: 6, "
            "rgb: arguments[2], shown: null};", px * canvas.ratio, py * canvas.ratio, list(MARKER_RGB))
        move_to(driver, canvas, off)
        moved = driver.execute_script("return window.__tf.moves[window.__tf.moves.length - 1][0];")
        shown = driver.execute_async_script(PROBE_SHOWN, 3000)  # waits in the page: no polling
        if shown is None:
            missed += 1
        else:
            latencies.append(shown - moved)
    driver.execute_script("window.__tf.probe = null;")
    release(driver)
    wait_for(lambda: kernel_json(driver, "view.grabbed is None"), 20, "the release to let go")
    changed_by_drag = driver.execute_script(CHANGED)

    # cut mode with the mode buttons above the figure (no click into the figure first), then a stroke
    mode_button = driver.execute_script(
        "for (const b of document.querySelectorAll('.widget-toggle-button')) {"
        "  if (b.textContent.trim() === 'cut') return b; } return null;")
    if mode_button is not None:
        mode_button.click()
    else:  # a view without mode buttons: click into the figure (off the tissue), then the key
        from selenium.webdriver.common.keys import Keys  # noqa: F401

        move_to(driver, canvas, canvas.offsets([(-0.45, -0.45)])[0])
        actions(driver).click().send_keys("c").perform()
    wait_for(lambda: kernel_json(driver, "view.mode") == "cut", 20, "cut mode")
    # a stroke from above the sheet down to below its middle, near the held edge (where the sheet moves least)
    x_cut = 0.5
    top = kernel_json(driver, f"float(sim.positions()[1][abs(sim.positions()[0] - {x_cut}) < 0.1].max())")
    stroke = [(x_cut, top + 0.3 - 0.1 * k) for k in range(int((top + 0.3 - 0.45) / 0.1) + 1)]
    stroke_offsets = canvas.offsets(stroke)
    chain = actions(driver).move_to_element_with_offset(canvas.element, *stroke_offsets[0]).click_and_hold()
    for off in stroke_offsets[1:]:
        chain.move_to_element_with_offset(canvas.element, *off).pause(0.05)
    chain.release().perform()

    def cut_or_message():
        state = kernel_json(driver, "dict(nodes=int(sim.mesh.nvertices), message=view.message)")
        if state["message"]:
            raise AssertionError(f"the stroke did not cut: {state['message']}")
        return state["nodes"] > before["nodes"]

    wait_for(cut_or_message, 30, "the stroke to cut the tissue")
    time.sleep(0.5)  # a few frames after the cut
    after = kernel_json(
        driver,
        "dict(frames=int(sim.frames), nodes=int(sim.mesh.nvertices), message=view.message, mode=view.mode, "
        "running=bool(view.running), steps_ms=[float(t) for t in view.frame_times][-300:], "
        "draws_ms=[float(t) for t in getattr(view, 'draw_times', [])][-300:], "
        "status=view.status_text.get_text(), "
        "full_draws=getattr(view.fig, 'full_draws', None), slow_draws=getattr(view.fig, 'slow_draws', None), "
        "layer_draws=getattr(view.fig, 'layer_draws', None))")
    checks = defect_checks(driver, canvas, fig)
    return dict(
        checks=checks,
        figure_px=[fig["w"], fig["h"]],
        rest_fps=rest_fps,
        drag_fps=drag_fps,
        drag_seconds=(t_drag1 - t_drag0) / 1e3,
        cpu_ms_per_frame_while_dragging=cpu_per_frame,
        page_main_thread_ms_per_frame_while_dragging=page_per_frame,
        cpu_ms_per_frame_at_rest=rest_cpu,
        page_main_thread_ms_per_frame_at_rest=rest_page,
        latency_ms=latencies,
        latency_missed=missed,
        changed_by_drag=changed_by_drag,
        changed_total=driver.execute_script(CHANGED),
        paints=len(paint_times(driver)),
        page_encode_ms=driver.execute_script("return window.__tf.encode_ms.slice(-300);"),
        mode_buttons=mode_button is not None,
        before=before,
        after=after,
    )


VIEW_IN_PAGE = r"""
const [w, h] = [arguments[0], arguments[1]];
let canvases = 0, images = 0;
for (const div of document.querySelectorAll('.jupyter-matplotlib-canvas-div')) {
  const c = div.querySelector('canvas');
  if (c && c.width === w && c.height === h) canvases++;
}
for (const img of document.querySelectorAll('.jp-OutputArea img')) {
  if (img.naturalWidth === w && img.naturalHeight === h) images++;
}
return {canvases: canvases, images: images};
"""

RUN_CELL = r"""
const [needle, done] = [arguments[0], arguments[arguments.length - 1]];
const panel = window.jupyterapp.shell.currentWidget;
const cells = panel.content.widgets;
const i = cells.findIndex((c) => c.model.type === 'code' && c.model.sharedModel.getSource().includes(needle));
const before = cells[i].model.executionCount;
panel.content.activeCellIndex = i;
window.jupyterapp.commands.execute('notebook:run-cell').then(() => done([i, before]), (e) => done([i, String(e)]));
"""


def run_cell(driver, needle, timeout=60):
    """Run the notebook's code cell whose source contains ``needle`` (as Shift+Enter would) and wait for it."""
    index, before = driver.execute_async_script(RUN_CELL, needle)
    count = "return window.jupyterapp.shell.currentWidget.content.widgets[arguments[0]].model.executionCount;"
    wait_for(lambda: driver.execute_script(count, index) not in (None, before), timeout,
             f"the cell with {needle!r} to run")


def defect_checks(driver, canvas, fig):
    """The defects, checked in the page: one live view and no frozen copy of it; a failed cut's message in a
    fixed place that leaves the axes where they are; re-running the cell that made the view stops the old one."""
    checks = {"view_in_page": driver.execute_script(VIEW_IN_PAGE, fig["w"], fig["h"])}
    # a stroke beside the tissue, not across it: the cut fails and says why
    box = kernel_json(driver, "list(view.ax.get_position().bounds)")
    beside = [(-0.5, 1.45), (-0.45, 1.4), (-0.4, 1.35), (-0.35, 1.3)]
    offsets = canvas.offsets(beside)
    chain = actions(driver).move_to_element_with_offset(canvas.element, *offsets[0]).click_and_hold()
    for off in offsets[1:]:
        chain.move_to_element_with_offset(canvas.element, *off).pause(0.05)
    chain.release().perform()
    try:
        wait_for(lambda: kernel_json(driver, "view.message"), 20, "the failed cut's message")
    except TimeoutError:
        pass
    checks["failed_cut"] = kernel_json(
        driver,
        "(lambda r: dict(message=view.message, box=list(view.ax.get_position().bounds), "
        "shown=getattr(view, 'message_text', view.status_text).get_text(), "
        "extent=list(getattr(view, 'message_text', view.status_text).get_window_extent(r).extents), "
        "axes=list(view.ax.get_window_extent(r).extents), figure=list(view.fig.bbox.extents)))"
        "(view.canvas.get_renderer())")
    checks["failed_cut"]["box_before"] = box
    # the student runs the view's cell again: the old view must stop
    kernel_execute(driver, "_old_view = view")
    run_cell(driver, "view = SurgeryView(sim")
    rerun = kernel_json(driver, "dict(closed=getattr(_old_view, 'closed', None), running=bool(_old_view.running), "
                                "frames=int(_old_view.sim.frames), replaced=view is not _old_view)")
    time.sleep(0.5)
    rerun["frames_later"] = kernel_json(driver, "int(_old_view.sim.frames)")
    checks["rerun"] = rerun
    return checks


def median(values):
    v = sorted(values)
    if not v:
        return None
    m = len(v) // 2
    return v[m] if len(v) % 2 else 0.5 * (v[m - 1] + v[m])


def summary(result):
    lat = result["latency_ms"]
    steps, draws = result["after"]["steps_ms"], result["after"]["draws_ms"]
    return {
        "frames drawn per second while dragging": round(result["drag_fps"], 1),
        "frames drawn per second at rest (timer running)": round(result["rest_fps"], 1),
        "latency mouse move -> picture, median ms": None if not lat else round(median(lat), 1),
        "latency max ms": None if not lat else round(max(lat), 1),
        "latency probes shown / missed": [len(lat), result["latency_missed"]],
        "kernel step median ms": None if not steps else round(median(steps), 1),
        "kernel draw median ms": None if not draws else round(median(draws), 1),
        "CPU ms per frame drawn while dragging (kernel, server, chromium)": result["cpu_ms_per_frame_while_dragging"],
        "page main thread ms per frame while dragging": result["page_main_thread_ms_per_frame_while_dragging"],
        "CPU ms per frame drawn at rest": result["cpu_ms_per_frame_at_rest"],
        "page main thread ms per frame at rest": result["page_main_thread_ms_per_frame_at_rest"],
        "page re-encoding per picture (ipympl's toDataURL), median ms":
            None if not result["page_encode_ms"] else round(median(result["page_encode_ms"]), 1),
    }


def write_benchmark(result, path=BENCH_OUT):
    import matplotlib

    try:
        import ipympl
        ipympl_version = ipympl.__version__
    except ImportError:
        ipympl_version = None
    record = {
        "benchmark": "chapter 8 interactive view in JupyterLab + headless Chromium",
        "summary": summary(result),
        "measured": {k: v for k, v in result.items() if k not in ("after",)},
        "kernel": result["after"],
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "processor": platform.machine(), "cpus": os.cpu_count(),
                    # other work on the machine takes CPU from the kernel, the server and the browser alike
                    "load_average_1_5_15_min": list(os.getloadavg()) if hasattr(os, "getloadavg") else None},
        "versions": {"matplotlib": matplotlib.__version__, "ipympl": ipympl_version},
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=2))
    return record


def run_session(workdir, chapter=CHAPTER):
    workdir = Path(workdir)
    with JupyterLab(workdir) as lab:
        nbformat.write(interactive_section(chapter), lab.root / "interactive.ipynb")
        driver = start_chromium(workdir)
        try:
            open_notebook(driver, lab, "interactive.ipynb")
            run_all_cells(driver)
            assert kernel_json(driver, "bool(INTERACTIVE and view.interactive and view.running)"), \
                "the chapter's last cell should leave the view running on the ipympl canvas"
            result = drag_session(driver, lab)
            driver.save_screenshot(str(workdir / "after.png"))
            return result
        except BaseException:
            try:
                driver.save_screenshot(str(workdir / "failure.png"))
            except Exception:
                pass
            print("JupyterLab log:\n" + lab.log_tail(), file=sys.stderr)
            raise
        finally:
            driver.quit()


# --------------------------------------------------------------------------- the test
def test_chapter_8_view_in_jupyterlab_with_chromium(tmp_path):
    reason = browser_missing()
    if reason:
        pytest.skip(reason)
    result = run_session(tmp_path)
    record = write_benchmark(result)
    print(f"\nbrowser benchmark ({BENCH_OUT.relative_to(ROOT)}):")
    print(json.dumps(record["summary"], indent=2))

    assert result["mode_buttons"], "the view shows buttons for its mode"
    assert result["paints"] > 20, "the running view painted frames"
    assert result["rest_fps"] > 0 and result["drag_fps"] > 0
    assert result["changed_by_drag"] > 0.01, "dragging changed the picture"
    assert result["after"]["nodes"] > result["before"]["nodes"], "the stroke cut the tissue"
    assert result["after"]["frames"] > result["before"]["frames"]
    assert result["after"]["mode"] == "cut" and result["after"]["running"]
    assert len(result["latency_ms"]) > 0, "the marker followed the mouse"
    checks = result["checks"]
    assert checks["view_in_page"] == {"canvases": 1, "images": 0}, "one live view, no frozen copy beside it"
    failed = checks["failed_cut"]
    assert failed["message"].startswith("cut failed") and failed["shown"].startswith("cut failed")
    assert failed["box"] == failed["box_before"], "the message did not move the axes"
    x0, y0, x1, y1 = failed["extent"]
    assert failed["figure"][0] <= x0 and x1 <= failed["figure"][2] and y0 >= 0, "the message is not clipped"
    assert y1 < failed["axes"][1], "the message sits under the axes"
    rerun = checks["rerun"]
    assert rerun["replaced"] and rerun["closed"] and not rerun["running"], "re-running the cell stopped the old view"
    assert rerun["frames_later"] == rerun["frames"], "the old view's simulation no longer steps"


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description="measure chapter 8's interactive view in JupyterLab + Chromium")
    parser.add_argument("--chapter", type=Path, default=CHAPTER, help="the chapter notebook (default: chapter 8)")
    parser.add_argument("--keep", type=Path, help="a folder to keep the session's files in (logs, screenshot)")
    parser.add_argument("--out", type=Path, default=BENCH_OUT, help=f"the JSON to write (default {BENCH_OUT.name})")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        workdir = args.keep or Path(folder)
        out = run_session(workdir, args.chapter)
    rec = write_benchmark(out, args.out)
    print(json.dumps(rec["summary"], indent=2))
