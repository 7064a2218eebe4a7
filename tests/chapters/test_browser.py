"""Chapter 8's interactive section in a real browser: JupyterLab, Debian's Chromium, real pointer input.

The test builds a notebook of exactly the chapter's cells for the section
"With the mouse" (and the chapter's set-up cell before them), opens it in
JupyterLab in headless Chromium through chromium-driver, runs it with
*Run All Cells* as a student would, then with the mouse on the view's canvas
(the browser-drawn widget of ``tissuefem.surgery.widget``): drags the tissue,
measures how fast the picture follows, pauses and runs the view with its
button, switches to cut mode with the mode button, and cuts. It asserts what
must hold (opening changed nothing, no scripted grab holds the sheet, the
tissue followed the pointer, the page painted frames, a paused view says so,
the cut happened, a failed cut says why once); the frame rate and the latency
it measured are a benchmark, written to ``bench-results/interactive_browser.json``
and printed, never asserted.

Run it alone with ``python -m pytest -m browser -s``, or as a script
(``python tests/chapters/test_browser.py``) to print the measurement. Without Chromium,
chromium-driver or anywidget it skips, saying what to install.

How the numbers are measured (in the page, with ``performance.now()``):

* **frames painted per second**: the view's canvas counts its paints (``data-painted``); per second while the
  mouse drags the tissue continuously, and while it rests (none: nothing is sent at rest);
* **latency**: with the button held, the pointer jumps to a new point and waits; the latency is the time from
  that pointer event to the first paint that shows the drag target at the new point (the canvas logs each
  paint's target). Each probe waits a different time before its jump, so the jumps fall at every phase of the
  view's frame loop.
"""

from __future__ import annotations

import json
import math
import os
import platform
import random
import tempfile
import time
from pathlib import Path

import nbformat
import pytest

from browser_lab import PANEL, JupyterLab, kernel_execute, kernel_json, notebook_state, open_notebook, run_all_cells, \
    start_chromium, wait_for
from test_browser_widget import (FIND_CANVAS, POINTER_TIMES, Canvas, actions, drag, median, release, reported_failure,
                                 widget_missing)

pytestmark = pytest.mark.browser

ROOT = Path(__file__).resolve().parents[2]
CHAPTER = ROOT / "chapters" / "ch08b_virtual_surgery.ipynb"
SECTION = "With the mouse"
BENCH_OUT = ROOT / "bench-results" / "interactive_browser.json"


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
PAGE_TEXT = r"""
const root = arguments[0].closest('.tissuefem-view');
const run = root.querySelector('button.tissuefem-run');
return {readout: root.querySelector('.tissuefem-readout').textContent,
        message: root.querySelector('.tissuefem-message').textContent,
        run: run.textContent, running: run.dataset.running,
        canvases: document.querySelectorAll('canvas.tissuefem-canvas').length};
"""

RUN_CELL = r"""
const [needle, done] = [arguments[0], arguments[arguments.length - 1]];
const panel = PANEL;
const cells = panel.content.widgets;
const i = cells.findIndex((c) => c.model.type === 'code' && c.model.sharedModel.getSource().includes(needle));
const before = cells[i].model.executionCount;
panel.content.activeCellIndex = i;
window.jupyterapp.commands.execute('notebook:run-cell').then(() => done([i, before]), (e) => done([i, String(e)]));
""".replace("PANEL", PANEL)


METADATA = f"return {PANEL}.context.model.toJSON().metadata;"


def page_text(driver, canvas):
    return driver.execute_script(PAGE_TEXT, canvas.element)


def run_cell(driver, needle, timeout=60):
    """Run the notebook's code cell whose source contains ``needle`` (as Shift+Enter would) and wait for it."""
    index, before = driver.execute_async_script(RUN_CELL, needle)
    count = f"return {PANEL}.content.widgets[arguments[0]].model.executionCount;"
    wait_for(lambda: driver.execute_script(count, index) not in (None, before), timeout,
             f"the cell with {needle!r} to run")


def rightmost(driver):
    return kernel_json(driver, "sim.positions()[:, int(sim.positions()[0].argmax())].tolist()")


def stroke_path(driver, x):
    top = kernel_json(driver, f"float(sim.positions()[1][abs(sim.positions()[0] - {x}) < 0.1].max())")
    return [(x, top + 0.3 - 0.1 * k) for k in range(int((top + 0.3 - 0.45) / 0.1) + 1)]


def drag_session(driver, seed=8):
    """Everything a student does with the mouse; returns the measurements and what the kernel and page saw."""
    rng = random.Random(seed)
    out = {"after_run_all": kernel_json(driver, "dict(running=bool(view.running), grabbed=view.grabbed, "
                                                "handles=list(sim.handles))")}
    element = wait_for(lambda: driver.execute_script(FIND_CANVAS), 60, "the view's canvas in the page")
    canvas = Canvas(driver, element)
    wait_for(lambda: canvas.painted() >= 1, 30, "the view to paint the tissue")
    wait_for(lambda: kernel_json(driver, "bool(view.resting)"), 90, "the released sheet to come to rest")
    out["canvases"] = page_text(driver, canvas)["canvases"]

    # at rest: nothing painted
    painted0, t0 = canvas.painted(), time.monotonic()
    time.sleep(2.0)
    out["rest_painted_per_second"] = (canvas.painted() - painted0) / (time.monotonic() - t0)

    # a continuous drag from the rightmost node: a loop to the lower right, a move every ~20 ms
    x_before = kernel_json(driver, "sim.positions().tolist()")
    grab = rightmost(driver)
    grab = (grab[0] - 0.02, grab[1])
    centre = (grab[0] + 0.15, grab[1] - 0.1)
    loop = [grab] + [(centre[0] + 0.2 * math.cos(a), centre[1] + 0.2 * math.sin(a))
                     for a in [2 * math.pi * k / 150 for k in range(151)]]
    painted0, page0 = canvas.painted(), driver.execute_script("return performance.now();")
    drag(driver, canvas, loop, 0.02, chunk=30)
    page1 = driver.execute_script("return performance.now();")
    out["drag_painted_per_second"] = 1e3 * (canvas.painted() - painted0) / (page1 - page0)
    out["grabbed_while_dragging"] = kernel_json(driver, "view.grabbed is not None")
    x_after = kernel_json(driver, "sim.positions().tolist()")
    out["tissue_moved"] = max(abs(a - b) for ra, rb in zip(x_before, x_after) for a, b in zip(ra, rb))

    # latency probes: the button held, jump to a new point after a random wait, find the first paint showing it
    driver.execute_script(POINTER_TIMES)
    latencies, missed = [], 0
    for k in range(12):
        time.sleep(rng.uniform(0.1, 0.3))
        point = (centre[0] + (0.18 if k % 2 else -0.18), centre[1] + 0.05 * ((k % 3) - 1))
        actions(driver).move_to_element_with_offset(canvas.element, *canvas.offset(point)).perform()
        moved = driver.execute_script("return window.__tf_pointer[window.__tf_pointer.length - 1];")
        shown, deadline = None, time.monotonic() + 3.0
        while shown is None and time.monotonic() < deadline:
            time.sleep(0.02)
            shown = next((t for t, x, y, _ in canvas.log()
                          if t >= moved and x is not None and abs(x - point[0]) < 0.01 and abs(y - point[1]) < 0.01),
                         None)
        if shown is None:
            missed += 1
        else:
            latencies.append(shown - moved)
    release(driver)
    wait_for(lambda: kernel_json(driver, "view.grabbed is None"), 20, "the release to let go")
    out["latency_ms"], out["latency_missed"] = latencies, missed
    out["paint_ms"] = [entry[3] for entry in canvas.log()][-300:]

    # pause with the run button: the readout says so, a drag moves the marker and says why the tissue stays
    running_label = page_text(driver, canvas)["run"]
    driver.find_element("css selector", "button.tissuefem-run").click()
    wait_for(lambda: not kernel_json(driver, "view.running"), 20, "the pause button to pause the view")
    wait_for(lambda: "paused" in page_text(driver, canvas)["readout"], 20, "the readout to say paused")
    paused = page_text(driver, canvas)
    x0 = kernel_json(driver, "sim.positions().tolist()")
    grab = rightmost(driver)
    drag(driver, canvas, [(grab[0] - 0.02, grab[1]), (grab[0] + 0.1, grab[1] - 0.1)], 0.05)
    wait_for(lambda: "paused" in page_text(driver, canvas)["message"], 20, "the paused view to say why")
    paused_drag = page_text(driver, canvas)
    release(driver)
    x1 = kernel_json(driver, "sim.positions().tolist()")
    out["pause"] = {"running_label": running_label, "paused_label": paused["run"], "readout": paused["readout"],
                    "message": paused_drag["message"], "frames_while_paused": int(x0 != x1)}
    driver.find_element("css selector", "button.tissuefem-run").click()
    wait_for(lambda: kernel_json(driver, "view.running"), 20, "the run button to run the view")
    out["pause"]["label_again"] = page_text(driver, canvas)["run"]

    # cut mode with the mode button, then a stroke across the sheet
    nodes = kernel_json(driver, "int(sim.mesh.nvertices)")
    driver.find_element("css selector", "button.tissuefem-mode[data-mode='cut']").click()
    wait_for(lambda: kernel_json(driver, "view.mode") == "cut", 20, "cut mode")
    drag(driver, canvas, stroke_path(driver, 0.5), 0.05)
    release(driver)

    def cut():
        state = kernel_json(driver, "dict(nodes=int(sim.mesh.nvertices), message=view.message)")
        if state["message"]:
            raise AssertionError(f"the stroke did not cut: {state['message']}")
        return state["nodes"] > nodes

    wait_for(cut, 30, "the stroke to cut the tissue")
    out["cut"] = kernel_json(driver, "dict(nodes=int(sim.mesh.nvertices), topology=view.topology_pushes)")
    out["cut"]["nodes_before"] = nodes

    # a stroke beside the tissue: the cut fails and says why, once
    drag(driver, canvas, [(-0.5, 1.45), (-0.45, 1.4), (-0.4, 1.35), (-0.35, 1.3)], 0.05)
    release(driver)
    wait_for(lambda: page_text(driver, canvas)["message"], 20, "the failed cut's message")
    out["failed_cut"] = page_text(driver, canvas)["message"]

    # the student runs the view's cell again: the old view stops
    kernel_execute(driver, "_old_view = view")
    run_cell(driver, "view = SurgeryView(sim")
    rerun = kernel_json(driver, "dict(closed=_old_view.closed, running=bool(_old_view.running), "
                                "frames=int(_old_view.sim.frames), replaced=view is not _old_view)")
    time.sleep(0.5)
    rerun["frames_later"] = kernel_json(driver, "int(_old_view.sim.frames)")
    out["rerun"] = rerun
    out["kernel_steps_ms"] = kernel_json(driver, "[float(t) for t in _old_view.frame_times][-300:]")
    return out


def summary(result):
    lat, steps, paints = result["latency_ms"], result["kernel_steps_ms"], result["paint_ms"]
    return {
        "frames painted per second while dragging": round(result["drag_painted_per_second"], 1),
        "frames painted per second at rest": round(result["rest_painted_per_second"], 1),
        "latency pointer move -> picture, median ms": None if not lat else round(median(lat), 1),
        "latency max ms": None if not lat else round(max(lat), 1),
        "latency probes shown / missed": [len(lat), result["latency_missed"]],
        "kernel step median ms": None if not steps else round(median(steps), 1),
        "page paint median ms": None if not paints else round(median(paints), 1),
    }


def write_benchmark(result, path=BENCH_OUT):
    import anywidget

    record = {
        "benchmark": "chapter 8 interactive view (browser-drawn widget) in JupyterLab + headless Chromium",
        "summary": summary(result),
        "measured": result,
        "machine": {"python": platform.python_version(), "platform": platform.platform(),
                    "processor": platform.machine(), "cpus": os.cpu_count(),
                    # other work on the machine takes CPU from the kernel, the server and the browser alike
                    "load_average_1_5_15_min": list(os.getloadavg()) if hasattr(os, "getloadavg") else None},
        "versions": {"anywidget": getattr(anywidget, "__version__", None)},
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record, indent=2))
    return record


def run_session(workdir, chapter=CHAPTER):
    workdir = Path(workdir)
    with JupyterLab(workdir) as lab:
        nbformat.write(interactive_section(chapter), lab.root / "interactive.ipynb")
        driver = start_chromium(workdir)
        with reported_failure(driver, lab, workdir):
            open_notebook(driver, lab, "interactive.ipynb")
            time.sleep(1.0)  # anything JupyterLab rewrites on opening has happened by now
            opened = {"dirty": notebook_state(driver)["dirty"], "metadata": driver.execute_script(METADATA),
                      "committed": dict(nbformat.read(chapter, as_version=4).metadata)}
            run_all_cells(driver)
            result = drag_session(driver)
            result["opened"] = opened
            driver.save_screenshot(str(workdir / "after.png"))
            return result


# --------------------------------------------------------------------------- the test
def test_chapter_8_view_in_jupyterlab_with_chromium(tmp_path):
    reason = widget_missing()
    if reason:
        pytest.skip(reason)
    result = run_session(tmp_path)
    record = write_benchmark(result)
    print(f"\nbrowser benchmark ({BENCH_OUT.relative_to(ROOT)}):")
    print(json.dumps(record["summary"], indent=2))

    opened = result["opened"]
    assert opened["metadata"]["kernelspec"] == opened["committed"]["kernelspec"], \
        "JupyterLab keeps the chapter's kernelspec (its display name) as committed"
    if opened["metadata"].get("language_info") == opened["committed"].get("language_info"):  # the same Python
        assert opened["dirty"] is False, "opening the chapter does not mark it modified"
    ran = result["after_run_all"]
    assert ran["running"] and ran["grabbed"] is None and ran["handles"] == ["fixed"], \
        "after Run All the view runs and no scripted grab holds the sheet"
    assert result["canvases"] == 1, "one live view"
    assert result["grabbed_while_dragging"] and result["tissue_moved"] > 0.05, "the tissue followed the pointer"
    assert result["drag_painted_per_second"] > 0 and result["rest_painted_per_second"] == 0
    assert len(result["latency_ms"]) > 0, "the marker followed the pointer"
    pause = result["pause"]
    assert pause["running_label"] != pause["paused_label"] and pause["label_again"] == pause["running_label"], \
        "the run button shows what it does in each state"
    assert "paused" in pause["readout"] and "paused" in pause["message"] and not pause["frames_while_paused"]
    assert result["cut"]["nodes"] > result["cut"]["nodes_before"] and result["cut"]["topology"] >= 2
    failed = result["failed_cut"]
    assert failed.startswith("cut failed: polyline changes nothing") and failed.count("polyline") == 1
    rerun = result["rerun"]
    assert rerun["replaced"] and rerun["closed"] and not rerun["running"], "re-running the cell stopped the old view"
    assert rerun["frames_later"] == rerun["frames"], "the old view's simulation no longer steps"


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description="measure chapter 8's interactive view in JupyterLab + Chromium")
    parser.add_argument("--chapter", type=Path, default=CHAPTER, help="the chapter notebook (default: chapter 8)")
    parser.add_argument("--keep", type=Path, help="a folder to keep the session's files in (logs, screenshot)")
    parser.add_argument("--out", type=Path, default=BENCH_OUT, help=f"the JSON to write (default {BENCH_OUT.name})")
    args = parser.parse_args()
    reason = widget_missing()
    if reason:
        raise SystemExit(reason)
    with tempfile.TemporaryDirectory() as folder:
        workdir = args.keep or Path(folder)
        out = run_session(workdir, args.chapter)
    rec = write_benchmark(out, args.out)
    print(json.dumps(rec["summary"], indent=2))
