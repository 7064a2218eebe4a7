"""Chapter 7 figure of what the real-time budget trades: the residual and the error an unfinished frame leaves.

A frame's budget buys a number of Newton steps, how many depends on the mesh size (``bench realtime``).
To keep the figure reproducible it caps the *number of steps* per frame instead of reading a clock: the
standard flap scene run with at most 1, 2 or 3 Newton steps per frame, against it with every frame converged.
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import NullFormatter
from matplotlib.figure import Figure

from ...engine.constants import FRAME_BUDGET
from ..timestepping import CAPPED_FRAMES, CAPS, capped_runs
from .base import lecture_figure, save, shown

#: a relative state error below this is round-off (its digits differ between machines)
STATE_ROUND_OFF = 1e-12


@lecture_figure
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
             title=f"State error after {CAPPED_FRAMES} frames of the drag")
    for ax in (ax_r, ax_e):
        ax.grid(True, which="both", alpha=0.3)
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.legend(fontsize=8, loc="center right")
    save(fig, path)
    return fig


def plot_realtime(rows, path=None):
    """The realtime benchmark's results (``python -m tissuefem bench realtime``): ms per frame against mesh
    size (median and 95th percentile, ex43 way), with the 33 ms line."""
    tri = np.array([r["triangles"] for r in rows])
    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    ax = fig.subplots()
    ax.loglog(tri, [r["fast_median_ms"] for r in rows], "o-", color="tab:blue",
              label=f"real-time solver, median ({rows[0].get('linear_solver', '')})")
    ax.loglog(tri, [r["fast_p95_ms"] for r in rows], "v:", color="tab:blue", alpha=0.7, label="real-time solver, p95")
    if "ex43_median_ms" in rows[0]:
        ax.loglog(tri, [r["ex43_median_ms"] for r in rows], "s-", color="tab:red", label="scikit-fem ex43 way, median")
    ax.axhline(1e3 * FRAME_BUDGET, color="k", ls="--", lw=1)
    ax.text(tri[0], 1e3 * FRAME_BUDGET * 1.08, "33 ms: 30 frames per second", fontsize=8)
    ax.set(xlabel="triangles", ylabel="ms per converged frame",
           title="Standard flap scene, backward Euler, dt = 1/30, rtol 1e-6")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    save(fig, path)
    return fig
