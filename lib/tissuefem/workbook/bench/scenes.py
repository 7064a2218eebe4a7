"""What each effect costs: the same scripted drag with one effect added at a time.

The standard flap runs once per :func:`variants` (no budget, the real clock); :func:`term_costs` times each
term alone, :func:`cut_costs` one cut during the drag. Compare rows of one run, not runs.
"""

from __future__ import annotations

import time

import numpy as np

from ...engine.constants import FRAME_BUDGET
from ...engine.parameters import check_count
from ...surgery.scene import Scene, flap_scene
from ...surgery.simulation import Simulation
from ..measure import median_time
from ..tables import markdown_table
from ..timestepping import flap_drag
from .common import machine_info, median_rows, recorded, write_record

__all__ = ["effects_benchmark", "variants", "format_effects_table", "term_costs", "cut_costs", "cut_frame_costs",
           "recorded_effects", "recorded_effects_table"]


def _base(n_triangles):
    """The quasistatic base: the standard flap in stable neo-Hookean, factorized in the background."""
    return flap_scene(n_triangles, model="stable-neo-hookean", dynamic=False,
                      linear_solver="reuse-background").to_dict()


PROBE = {"center": [1.0, 1.08], "radius": 0.15}
#: a slanted crack from the top edge to mid-height, cut before the first frame (its lips open as the sheet
#: is dragged)
CUT = {"path": [[0.73, 1.1], [0.96, 0.5]], "method": "elements"}
SUTURES = {"pairs": [[[0.6 + 0.1 * k, 1.0], [0.6 + 0.1 * k, 0.0]] for k in range(5)], "stiffness": 1e4,
           "tightness": 0.05}
#: a cut across the middle of the flap: the drag (the flap stretched, so narrowed) presses its lips together
PRESSED_CUT = {"path": [[0.5, 0.5], [1.5, 0.5]]}


def variants(n_triangles):
    """``[(name, scene dict, Simulation options)]``: the runs of the benchmark, base first."""
    out = []

    def add(name, effects=None, material=None, **options):
        data = _base(n_triangles)
        data["effects"].update(effects or {})
        if material:
            data["material"]["model"] = material
        out.append((name, data, options))

    add("base: stable neo-Hookean, quasistatic")
    add("linear, constant factorisation", material="linear")
    add("linear, general Newton loop", material="linear", constant_tangent=False)
    add("+ inertia", {"inertia": {}})
    add("+ inertia + gravity", {"inertia": {}, "gravity": {}})
    add("+ fibers", {"fibers": {"stiffness": 500.0, "direction": [1.0, 0.3]}})
    add("+ probe", {"probes": [PROBE]})
    add("+ sutures", {"sutures": [SUTURES]})
    add("+ inversion (projected tangent)", {"inversion": {"method": "projected"}})
    add("+ cut through elements", {"incisions": [CUT]})
    add("+ cut along edges (to compare)", {"incisions": [{**CUT, "method": "edges"}]})
    add("+ contact (nothing near)", {"contact": {}})
    add("+ incision across the middle", {"incisions": [PRESSED_CUT]})
    add("+ incision + contact (lips pressed)", {"incisions": [PRESSED_CUT], "contact": {}})
    add("everything", {"inertia": {}, "gravity": {}, "fibers": {"stiffness": 500.0, "direction": [1.0, 0.3]},
                       "probes": [PROBE], "sutures": [SUTURES], "inversion": {"method": "projected"},
                       "contact": {}})
    return out


def _cut_while_dragging(n_triangles, frames_before, method=CUT["method"], **options):
    """A new simulation of the base dragged ``frames_before`` frames, then cut along :data:`CUT`: ``(sim, the cut's
    ms, its ms of the thread's CPU time)``."""
    sim = Simulation(Scene.from_dict(_base(n_triangles)), **options)
    flap_drag(sim, frames_before)
    start, cpu = time.perf_counter(), time.thread_time()
    sim.cut(CUT["path"], method=method)
    return sim, 1e3 * (time.perf_counter() - start), 1e3 * (time.thread_time() - cpu)


def cut_costs(n_triangles, repeats=3) -> dict:
    """Median ms of one cut during the drag (the edit, new model and solver), through elements and edges."""
    return {f"through {method}": float(np.median([_cut_while_dragging(n_triangles, 3, method)[1]
                                                  for _ in range(int(repeats))])) for method in ("elements", "edges")}


def cut_frame_costs(n_triangles, repeats=5, frames_before=3) -> dict:
    """The frame in which a cut happens (the cut, then the next frame of the drag), with the old factorization kept
    as the preconditioner (``keep_factorization``) and with a fresh one made on the frame: runs of the two
    alternate. ``{"kept" | "fresh": {"cut_ms", "frame_ms", "total_ms": medians, "spread_ms": (min, max) of the
    total, "thread_ms": median CPU time of the frame's thread over the cut and the frame (what a busy machine
    adds is not in it, nor the fresh factorization on the other thread), "factorizations": on the frame, mean}}``."""
    repeats = check_count("repeats", repeats)
    runs = {"kept": [], "fresh": []}
    for _ in range(repeats):
        for name, keep in (("kept", True), ("fresh", False)):
            sim, cut, cut_cpu = _cut_while_dragging(n_triangles, frames_before, keep_factorization=keep)
            cpu = time.thread_time()
            report = flap_drag(sim, 1, start=frames_before)[0]
            cpu = cut_cpu + 1e3 * (time.thread_time() - cpu)
            runs[name].append((cut, 1e3 * report.elapsed, report.newton.factorizations, cpu))
            sim.solver.linear.close()  # the fresh factorization under way ends before the next run
    out = {}
    for name, rows in runs.items():
        cut, frame, factorizations, cpu = (np.array(column, dtype=float) for column in zip(*rows))
        total = cut + frame
        out[name] = {"cut_ms": float(np.median(cut)), "frame_ms": float(np.median(frame)),
                     "total_ms": float(np.median(total)), "spread_ms": (float(total.min()), float(total.max())),
                     "thread_ms": float(np.median(cpu)), "factorizations": float(np.mean(factorizations))}
    return out


def term_costs(sim, repeats=5) -> dict:
    """Median ms to evaluate each term's energy, force and Hessian once, at the simulation's state."""
    u, model, costs = sim.u, sim.model, {}
    for term in model.terms:
        def evaluate(term=term):
            term.energy(u)
            term.gradient(u)
            term.add_hessian(u, model.pattern.zeros())
        costs[term.name] = median_time(evaluate, repeats)  # already ms
    costs["whole Hessian"] = median_time(lambda: model.hessian(u), repeats)
    return costs


_TABLE = [("variant", "variant", "{}"), ("terms", "terms", "{}"), ("median_ms", "median ms/frame", "{:.1f}"),
          ("p95_ms", "p95 ms", "{:.1f}"), ("newton", "Newton/frame", "{:.2f}"),
          ("cost_ms", "cost vs base (ms)", "{:+.1f}")]
#: the recorded table: the last column the ratio to the base, with the rounds' range
_RECORDED = _TABLE[:-1] + [("over_base_text", "over the base (rounds' range)", "{}")]


def format_effects_table(rows) -> str:
    """The variants as a Markdown table."""
    return markdown_table([{**r, "terms": ", ".join(r["terms"])} for r in rows], _TABLE, text_columns=2)


def recorded_effects() -> tuple[list[dict], dict]:
    """The recorded run shipped with the package: its rounds joined (medians over the rounds, see
    :func:`~.common.median_rows`), each row with ``over_base`` (its median over the base's, in each round) and
    ``over_base_text`` (the median ratio and the rounds' range: the spread between rounds is the noise), and the
    record."""
    record = recorded("scenes")
    rounds = [[{**r, "over_base": r["median_ms"] / rows[0]["median_ms"]} for r in rows]
              for rows in (rd["rows"] for rd in record["rounds"])]
    rows = median_rows(rounds, "variant")
    for r in rows:
        lo, hi = r.get("over_base_range", (r["over_base"], r["over_base"]))
        r["over_base_text"] = f"{r['over_base']:.2f} ({lo:.2f}–{hi:.2f})" if hi > lo else f"{r['over_base']:.2f}"
        r["terms"] = ", ".join(r["terms"])
    return rows, record


def recorded_effects_table() -> str:
    """The recorded run as the Markdown table docs/benchmarks.md shows."""
    return markdown_table(recorded_effects()[0], _RECORDED, text_columns=2)


def effects_benchmark(n_triangles=8000, frames=30, repeats=5, out=None, progress=print) -> dict:
    """Run every variant; return ``{"rows": [...], "terms": {...}}`` and write JSON/CSV under ``out``."""
    n_triangles, frames = check_count("n_triangles", n_triangles, 50), check_count("frames", frames)
    say = progress or (lambda *a, **k: None)
    machine = machine_info()  # at the start: the load average says how quiet the machine was
    rows = []
    for name, data, options in variants(n_triangles):
        sim = Simulation(Scene.from_dict(data), **options)
        reports = flap_drag(sim, frames)
        ms, newton = np.array([1e3 * r.elapsed for r in reports]), np.array([r.newton_iterations for r in reports])
        median = float(np.median(ms))
        base = rows[0]["median_ms"] if rows else median
        rows.append({"variant": name, "terms": sim.terms, "solver": sim.solver.linear_solver_name,
                     "median_ms": median, "p95_ms": float(np.percentile(ms, 95)), "newton": float(np.mean(newton)),
                     "cost_ms": median - base, "within_budget": float(np.mean(ms <= 1e3 * FRAME_BUDGET)),
                     "ms": ms.tolist()})
        say(f"{name:40s} {median:7.1f} ms/frame  {np.mean(newton):.2f} Newton/frame  terms {sim.terms}")
    terms = term_costs(sim, repeats)  # the last variant: everything
    cuts = cut_costs(n_triangles, repeats)
    say("one cut while dragging (the edit, a new model and solver), ms: "
        + ", ".join(f"{k} {v:.1f}" for k, v in cuts.items()))
    say(format_effects_table(rows))
    say("term evaluation (energy + force + Hessian), ms: " + ", ".join(f"{k} {v:.2f}" for k, v in terms.items()))
    record = {"benchmark": "scenes", "description": __doc__.strip().splitlines()[0],
              "settings": {"n_triangles": int(n_triangles), "frames": int(frames), "repeats": int(repeats),
                           "scene": "flap_scene (stable neo-Hookean), handle on flap_path"},
              "machine": machine, "rows": rows, "term_ms": terms, "cut_ms": cuts}
    write_record(out, "scenes", record, [{**r, "terms": " + ".join(r["terms"])} for r in rows], say)
    return record
