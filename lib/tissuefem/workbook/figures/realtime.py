"""Chapter 7 figure of what the real-time budget trades: the residual and the error an unfinished frame leaves.

A frame's budget buys a number of Newton steps, and how many fit in 33 ms
depends on the mesh size (the ``bench realtime`` table says how many). To
keep the figure reproducible it caps the *number of steps* per frame instead
of reading a clock: the standard flap scene (:mod:`tissuefem.bench_realtime`)
run with at most 1, 2 or 3 Newton steps per frame, against the same scene
with every frame converged.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from .registry import register, save, shown

SIZES = (500, 2000, 8000)
CAPS = (1, 2, 3)
FRAMES = 40


def capped_runs(sizes=SIZES, caps=CAPS, frames=FRAMES) -> list[dict]:
    """For each size and cap: median relative residual per frame and the final state error against converged frames."""
    from ..bench.realtime import DT_FLAP, flap_path, flap_scene
    from ...engine.realtime import RealtimeSolver

    rows = []
    for n in sizes:
        reference = RealtimeSolver(flap_scene(n)[0], dt=DT_FLAP, budget=math.inf, rtol=1e-10)
        for f in range(frames):
            reference.frame({1: flap_path((f + 1) * DT_FLAP)})
        scale = float(np.max(np.abs(reference.u)))
        for cap in caps:
            solver = RealtimeSolver(flap_scene(n)[0], dt=DT_FLAP, budget=math.inf, rtol=1e-12, max_iterations=cap)
            relative = []
            for f in range(frames):
                report = solver.frame({1: flap_path((f + 1) * DT_FLAP)})
                relative.append(report.relative_residual)
            rows.append({
                "triangles": int(solver.problem.mesh.t.shape[1]),
                "cap": cap,
                "median_relative_residual": float(np.median(relative)),
                "state_error": float(np.max(np.abs(solver.u - reference.u)) / scale),
            })
    return rows


#: a relative state error below this is round-off (its digits differ between machines)
STATE_ROUND_OFF = 1e-12


@register
def fig_ch07_budget_residual(path=None, rows=None) -> Figure:
    """Chapter 7: residual and state error left when a frame stops after 1, 2 or 3 Newton steps, by mesh size."""
    rows = capped_runs() if rows is None else rows
    fig = Figure(figsize=(9.0, 3.8), layout="constrained")
    ax_r, ax_e = fig.subplots(1, 2)
    for cap, marker in zip(CAPS, "os^"):
        sel = [r for r in rows if r["cap"] == cap]
        tri = [r["triangles"] for r in sel]
        label = f"{cap} Newton step{'s' if cap > 1 else ''} per frame"
        # a residual of 1e-9 of the first one carries round-off at 1e-4 of itself: two digits
        ax_r.loglog(tri, shown([r["median_relative_residual"] for r in sel], digits=2), marker + "-", label=label)
        ax_e.loglog(tri, shown([r["state_error"] for r in sel], floor=STATE_ROUND_OFF), marker + "-", label=label)
    ax_e.axhspan(STATE_ROUND_OFF / 20, STATE_ROUND_OFF, color="0.9", lw=0, zorder=0)
    ax_e.text(0.02, STATE_ROUND_OFF / 5, f"round-off (drawn at {STATE_ROUND_OFF:.0e})",
              transform=ax_e.get_yaxis_transform(), fontsize=7.5, color="0.35", va="center")
    ax_r.axhline(1e-6, color="k", ls="--", lw=1)
    ax_r.text(rows[0]["triangles"], 1.5e-6, "converged: rtol = 1e-6", fontsize=8)
    ax_r.set(xlabel="triangles", ylabel="median of |residual| / |first residual| per frame",
             title="Residual left at the end of a frame")
    ax_e.set(xlabel="triangles", ylabel="max |u - u_converged| / max |u_converged|",
             title=f"State error after {FRAMES} frames of the drag")
    from matplotlib.ticker import NullFormatter

    for ax in (ax_r, ax_e):
        ax.grid(True, which="both", alpha=0.3)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.legend(fontsize=8, loc="center right")
    save(fig, path)
    return fig
