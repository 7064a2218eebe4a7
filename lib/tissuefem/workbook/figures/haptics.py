"""Chapter 8b's figure of the tool's force at haptic rate: the force between frames from the reduced model of the
pulled edge (:func:`~tissuefem.workbook.bench.haptic.haptic_path`), against converged frames and the held force."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ..bench.haptic import haptic_path
from .base import finish, lecture_figure, shown

#: the run drawn: a reduced size of the standard flap, frames 6 to 25 of its drag, eight positions per frame
HAPTIC_RUN = dict(n_triangles=2000, frames=20, substeps=8, warmup=5)


@lecture_figure
def fig_ch08_haptic_force(run=None) -> Figure:
    """Chapter 8b: the pulled edge's force between frames from its reduced model (f0 + S dp) against converged frames
    at the same edge position, and the relative error of it and of holding the frame's force."""
    run = haptic_path(**HAPTIC_RUN) if run is None else run
    t, substeps = np.asarray(run["time"]), int(run["substeps"])
    fig = Figure(figsize=(10.0, 5.6), layout="constrained")
    ax_force, ax_error = fig.subplots(2, 1, sharex=True, height_ratios=[1.4, 1.0])
    segments = t.reshape(-1, substeps)
    starts = np.asarray(run["frame_time"])
    for i, (component, colour) in enumerate((("x", "C0"), ("y", "C1"))):
        ax_force.plot(t, shown(np.asarray(run["converged"])[:, i]), color="k", lw=0.8, marker=".", ms=3,
                      label="converged frame at the edge's position" if i == 0 else None)
        haptic = np.asarray(run["haptic"])[:, i].reshape(-1, substeps)
        frame_force = np.asarray(run["frame_force"])[:, i]
        for k, (ts, fs) in enumerate(zip(segments, haptic)):  # each frame's model, from its frame to the next
            ax_force.plot(np.r_[starts[k], ts], shown(np.r_[frame_force[k], fs]), color=colour, lw=1.6,
                          label=f"reduced model, $f_{component}$" if k == 0 else None)
            ax_force.plot([starts[k], ts[-1]], shown([frame_force[k]] * 2), color=colour, lw=0.8, ls=":",
                          label=f"frame's force held, $f_{component}$" if k == 0 else None)
    finish(ax_force, legend=dict(fontsize=7.5, ncols=3, loc="best"), ylabel="force of the edge on the body")
    ax_force.set_title(f"the pulled edge of the standard flap, {run['triangles']} triangles: {substeps} positions "
                       "between frames (1/30 s apart)\nthe reduced model is rebuilt at each frame, and steps back "
                       "there: the body moved on during the frame, which the frame before cannot know", fontsize=9)
    ax_error.semilogy(t, shown(run["haptic_error"], floor=1e-12), color="C2", lw=1.4, marker=".", ms=3,
                      label=f"reduced model (median {np.median(run['haptic_error']):.1e})")
    ax_error.semilogy(t, shown(run["hold_error"], floor=1e-12), color="0.45", lw=1.0, ls="--",
                      label=f"frame's force held (median {np.median(run['hold_error']):.1e})")
    for start in starts:
        ax_error.axvline(start, color="0.85", lw=0.6, zorder=0)
    ax_error.set(xlabel="time [s]", ylabel="relative force error")
    ax_error.legend(fontsize=8, loc="lower right")
    ax_error.grid(alpha=0.3, which="both", axis="y")
    return fig
