"""The tool's force at haptic rate on the standard flap scene: a 1 kHz force loop beside the frames.

After each frame the grabbed edge's reduced model (:func:`~tissuefem.engine.haptics.tool_model`: its force and its
stiffness seen through the body) is built; between frames a second thread updates the force from it at ``rate``
updates per second, as a haptic device's loop would, while the frames go on at their normal (unbudgeted) rate.
:func:`haptic_benchmark` times it: updates per second, the time per update, how late the ticks ran, and each frame's
time with and without the loop, paired (two copies of the scene stepped alternately, the loop beside the second).
:func:`haptic_path` measures the force's error along the scripted drag (:func:`~tissuefem.surgery.scene.flap_path`)
at tool positions between frames, against the converged frame at the same tool position (the frame taken again from
its start, with the edge there), and against holding the frame's force until the next one.
"""

from __future__ import annotations

import sys
import threading
import time

import numpy as np

from ...engine.constants import FRAME_BUDGET
from ...engine.haptics import tool_model
from ...engine.parameters import check_count, check_real
from ...surgery.scene import flap_path
from ..tables import markdown_table
from .common import check_sizes, machine_info, write_record
from .realtime import flap_simulation

__all__ = ["haptic_benchmark", "haptic_path", "HapticLoop", "format_haptic_table"]

#: the tool: the standard flap's pulled edge
TOOL = "handle"
#: the tolerance of the reference frames (converged far below the force errors measured)
REFERENCE_RTOL = 1e-10
#: the interpreter's thread switch interval while the loop runs (its default, 5 ms, would let the frames' Python
#: code hold the haptic thread off for several of its 1 ms periods)
SWITCH_INTERVAL = 1e-4


def _norms(a) -> np.ndarray:
    return np.linalg.norm(np.asarray(a, dtype=float), axis=-1)


def haptic_path(n_triangles: int = 8000, frames: int = 30, substeps: int = 4, warmup: int = 5,
                linear_solver: str = "reuse") -> dict:
    """The force along the scripted drag between frames ``warmup + 1 ... warmup + frames``: after frame ``k`` the tool
    moves on through ``substeps`` positions to frame ``k + 1``'s, and at each the reduced model's force is compared
    with the converged frame ``k`` taken again from its start with the edge there (``reference``), and with the
    frame's force held (``hold``). Also the jump at each frame: frame ``k + 1``'s force against the reduced model's at
    the same position (what the body's own motion over the frame adds). Forces: what the edge exerts on the body."""
    frames = check_count("frames", frames, 1)
    substeps = check_count("substeps", substeps, 1)
    warmup = check_count("warmup", warmup, 0)
    sim = flap_simulation(n_triangles, linear_solver)
    reference = flap_simulation(n_triangles, linear_solver, REFERENCE_RTOL)
    for k in range(1, warmup + 1):
        sim.frame({TOOL: flap_path(k * FRAME_BUDGET)})
    times, positions, haptic, converged, jumps, frame_forces = [], [], [], [], [], []
    model, solver = None, sim.solver
    for k in range(warmup + 1, warmup + frames + 1):
        start = dict(u=solver.u.copy(), v=solver.v.copy(), v_previous=solver.v_previous, time_=solver.time,
                     steps=solver.steps)  # to take frame k again from its start (set_state)
        sim.frame({TOOL: flap_path(k * FRAME_BUDGET)})
        frame_force = sim.model.reaction(sim.u, TOOL)
        if model is not None:  # the previous model at this frame's position, against this frame's force
            jumps.append(float(np.linalg.norm(frame_force - model.force(flap_path(k * FRAME_BUDGET)))))
        model = tool_model(sim.solver, TOOL)
        frame_forces.append(frame_force)
        for s in range(1, substeps + 1):
            t = (k + s / substeps) * FRAME_BUDGET
            p = flap_path(t)
            reference.solver.set_state(**start)
            report = reference.frame({TOOL: p})
            if not report.converged:
                raise RuntimeError(f"haptic_path: the reference frame at t = {t:.3f} s did not converge")
            times.append(t)
            positions.append(p)
            haptic.append(model.force(p))
            converged.append(reference.model.reaction(reference.u, TOOL))
    haptic, converged = np.array(haptic), np.array(converged)
    hold = np.repeat(frame_forces, substeps, axis=0)  # each frame's force, held over its substeps
    size = np.maximum(_norms(converged), np.finfo(float).tiny)
    return {"triangles": int(sim.mesh.nelements), "dofs": int(sim.model.n_dofs), "frames": frames,
            "substeps": substeps, "warmup": warmup, "time": np.array(times), "position": np.array(positions),
            "haptic": haptic, "converged": converged, "hold": hold,
            "frame_time": (np.arange(warmup + 1, warmup + frames + 1)) * FRAME_BUDGET,
            "frame_force": np.array(frame_forces),
            "haptic_error": _norms(haptic - converged) / size, "hold_error": _norms(hold - converged) / size,
            "jump": np.array(jumps), "jump_relative": np.array(jumps) / np.median(size)}


class HapticLoop:
    """A thread that evaluates ``model()``'s force at ``position()`` ``rate`` times a second between :meth:`resume`
    and :meth:`pause` (a device's loop), its ticks due at ``resumed + k / rate`` (nothing drifts): it sleeps until
    ``SPIN`` s before a tick (a sleep overshoots by about 0.1 ms), then yields until the tick is due; a late tick runs
    at once, none is dropped. Each update's seconds in ``update_seconds``, each tick's start less its due time in
    ``lateness``, the seconds from resume to pause in ``active_seconds``; a position the model refuses keeps the last
    force (counted in ``refused``)."""

    #: seconds before a tick at which the loop stops sleeping and yields until the tick is due
    SPIN = 2e-4

    def __init__(self, model, position, rate: float = 1000.0, clock=time.perf_counter, sleep=time.sleep):
        self.model, self.position, self.clock, self.sleep = model, position, clock, sleep
        self.period = 1.0 / check_real("rate", rate, 1.0, 1e6)
        self.active, self.stop = threading.Event(), threading.Event()
        self.update_seconds, self.lateness, self.active_seconds, self.refused = [], [], 0.0, 0
        self.last_force, self.resumed_at, self.paused_at = None, 0.0, 0.0
        self.thread = threading.Thread(target=self._run, name="tissuefem-haptic", daemon=True)

    def resume(self) -> None:
        """Tick from now on: the first tick is due at once."""
        self.resumed_at = self.clock()
        self.active.set()

    def pause(self) -> None:
        """No tick due from now on runs (those due before, late, still do)."""
        if self.active.is_set():
            self.paused_at = self.clock()
            self.active.clear()

    def _run(self):
        while not self.stop.is_set():
            if self.active.wait(0.01):
                self.ticking()

    def ticking(self) -> None:
        """Run the ticks due from :meth:`resume` until :meth:`pause` (on the loop's thread)."""
        began = tick = self.resumed_at
        ticks = 0
        while True:
            wait = tick - self.clock() - self.SPIN
            if wait > 0:
                self.sleep(wait)
            while self.clock() < tick:
                self.sleep(0)  # lets the frames' thread run until the tick is due
            if self.stop.is_set() or self.resumed_at != began or (not self.active.is_set() and
                                                                   tick >= self.paused_at):
                break  # (a tick due before the pause still runs)
            t0 = self.clock()
            self.lateness.append(t0 - tick)
            try:
                self.last_force = self.model().force(self.position())
            except ValueError:  # a refused position (a glitch of the device): the last force stays
                self.refused += 1
            self.update_seconds.append(self.clock() - t0)
            ticks += 1
            tick = began + ticks * self.period
        self.active_seconds += max(self.paused_at - began, 0.0)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.pause()
        self.stop.set()
        self.thread.join()


def _timed_frames(n_triangles, frames, rate, linear_solver, say):
    """Two copies of the scene stepped alternately along the drag, the loop running beside the second only."""
    plain, haptic = flap_simulation(n_triangles, linear_solver), flap_simulation(n_triangles, linear_solver)
    for sim in (plain, haptic):  # the first frame (from rest, no cost learned yet) is not timed
        sim.frame({TOOL: flap_path(FRAME_BUDGET)})
    current = {"model": tool_model(haptic.solver, TOOL), "t": FRAME_BUDGET, "start": time.perf_counter()}

    def position():  # the device's position: the drag, on between the last frame and the next
        elapsed = min(time.perf_counter() - current["start"], FRAME_BUDGET)
        return flap_path(current["t"] + elapsed)

    plain_ms, haptic_ms, build_ms = [], [], []
    switch = sys.getswitchinterval()
    sys.setswitchinterval(SWITCH_INTERVAL)
    try:
        with HapticLoop(lambda: current["model"], position, rate) as loop:
            for k in range(2, frames + 2):
                target = {TOOL: flap_path(k * FRAME_BUDGET)}
                t0 = time.perf_counter()
                plain.frame(target)
                plain_ms.append(1e3 * (time.perf_counter() - t0))
                loop.resume()
                t0 = time.perf_counter()
                haptic.frame(target)
                t1 = time.perf_counter()
                current["model"] = tool_model(haptic.solver, TOOL)  # swapped whole: the loop sees old or new
                current["t"], current["start"] = k * FRAME_BUDGET, time.perf_counter()
                haptic_ms.append(1e3 * (t1 - t0))
                build_ms.append(1e3 * (current["start"] - t1))
                loop.pause()
    finally:
        sys.setswitchinterval(switch)
    say(f"  {len(loop.update_seconds)} force updates in {loop.active_seconds:.2f} s beside {frames} frames")
    return plain, np.array(plain_ms), np.array(haptic_ms), np.array(build_ms), loop


_TABLE = [
    ("triangles", "triangles", "{:d}"), ("updates_per_second", "updates/s", "{:.0f}"),
    ("update_median_us", "update median [µs]", "{:.1f}"), ("update_p95_us", "update p95 [µs]", "{:.1f}"),
    ("late_median_us", "tick late median [µs]", "{:.0f}"), ("late_p95_us", "tick late p95 [µs]", "{:.0f}"),
    ("missed_ticks", "ticks late by a period or more", "{:d}"), ("frame_plain_median_ms", "frame alone [ms]", "{:.1f}"),
    ("frame_haptic_median_ms", "frame beside the loop [ms]", "{:.1f}"),
    ("build_median_ms", "reduced model [ms]", "{:.1f}"), ("haptic_error_median", "force error median", "{:.1e}"),
    ("haptic_error_max", "force error max", "{:.1e}"), ("hold_error_median", "held force error median", "{:.1e}"),
    ("hold_error_max", "held force error max", "{:.1e}")]


def format_haptic_table(rows) -> str:
    """The benchmark's rows as a Markdown table."""
    return markdown_table(rows, _TABLE)


def haptic_benchmark(n_triangles: int = 8000, frames: int = 60, rate: float = 1000.0, path_frames: int = 30,
                     substeps: int = 4, linear_solver: str = "reuse-background", out=None, progress=print) -> dict:
    """Run the benchmark at about ``n_triangles``: ``frames`` timed frame pairs with the loop at ``rate``, and the
    force error over ``path_frames`` frames of ``substeps`` positions each (:func:`haptic_path`); one row (and JSON
    and CSV in ``out``)."""
    n_triangles = check_sizes([n_triangles])[0]
    frames = check_count("frames", frames, 1)
    say = progress if progress is not None else (lambda *_: None)
    say(f"haptic benchmark: about {n_triangles} triangles, the force loop at {rate:g} updates/s ...")
    sim, plain_ms, haptic_ms, build_ms, loop = _timed_frames(n_triangles, frames, rate, linear_solver, say)
    update_us, late_us = 1e6 * np.array(loop.update_seconds), 1e6 * np.array(loop.lateness)
    path = haptic_path(n_triangles, path_frames, substeps, linear_solver=linear_solver.removesuffix("-background"))
    ratio = (haptic_ms + build_ms) / plain_ms
    row = {"triangles": int(sim.mesh.nelements), "dofs": int(sim.model.n_dofs), "frames": frames, "rate": rate,
           "updates": len(update_us),
           "updates_per_second": len(update_us) / loop.active_seconds if loop.active_seconds > 0 else float("nan"),
           "update_median_us": float(np.median(update_us)), "update_p95_us": float(np.percentile(update_us, 95)),
           "update_max_us": float(np.max(update_us)), "missed_ticks": int(np.sum(late_us >= 1e6 * loop.period)),
           **{f"late_{name}_us": float(np.percentile(late_us, q)) for name, q in (("median", 50), ("p95", 95),
                                                                                   ("max", 100))},
           "frame_plain_median_ms": float(np.median(plain_ms)), "frame_haptic_median_ms": float(np.median(haptic_ms)),
           "build_median_ms": float(np.median(build_ms)), "paired_ratio_median": float(np.median(ratio)),
           "path_frames": path["frames"], "substeps": path["substeps"],
           "haptic_error_median": float(np.median(path["haptic_error"])),
           "haptic_error_max": float(np.max(path["haptic_error"])),
           "hold_error_median": float(np.median(path["hold_error"])),
           "hold_error_max": float(np.max(path["hold_error"])),
           "jump_relative_median": float(np.median(path["jump_relative"])) if path["jump"].size else float("nan"),
           "frame_plain_ms": plain_ms.tolist(), "frame_haptic_ms": haptic_ms.tolist(), "build_ms": build_ms.tolist()}
    say(f"  {row['updates_per_second']:.0f} updates/s, median {row['update_median_us']:.1f} µs per update; ticks "
        f"late by {row['late_median_us']:.0f} µs median, {row['late_p95_us']:.0f} p95, {row['late_max_us']:.0f} max "
        f"({row['missed_ticks']} by a period or more, run late, none dropped); frames "
        f"{row['frame_plain_median_ms']:.1f} ms alone, {row['frame_haptic_median_ms']:.1f} ms beside the loop "
        f"+ {row['build_median_ms']:.1f} ms for the reduced model; force error median "
        f"{row['haptic_error_median']:.1e}, max {row['haptic_error_max']:.1e} (held: {row['hold_error_median']:.1e}, "
        f"{row['hold_error_max']:.1e})")
    say(format_haptic_table([row]))
    record = {"benchmark": "haptic", "description": __doc__.strip().splitlines()[0],
              "settings": {"n_triangles": n_triangles, "frames": frames, "rate": rate, "path_frames": path_frames,
                           "substeps": substeps, "linear_solver": linear_solver, "switch_interval": SWITCH_INTERVAL},
              "machine": machine_info(), "rows": [row],
              "path": {k: v for k, v in path.items() if isinstance(v, np.ndarray)}}
    write_record(out, "haptic", record, [row], say)
    return record
