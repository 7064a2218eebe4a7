"""Figures of chapter 7 (time stepping): explicit against implicit on the released flap
(:func:`~tissuefem.workbook.timestepping.released_flap`), and what capping a frame's Newton steps leaves."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from ...engine.constants import FRAME_BUDGET as FRAME_DT, TISSUE_E, TISSUE_NU  # FRAME_DT: one frame, 1/30 s
from ...engine.explicit import critical_time_step
from ..timestepping import (CAPPED_FRAMES, CAPS, backward_euler_run, capped_runs, cfl_study, released_flap,
                            symplectic_energies)
from .base import filmstrip, finish, lecture_figure, sheet_window, shown, write_sheet_animation
from .inversion import UPRIGHT_COLOR, draw_state

#: mesh sizes (cells along the flap's length) of the CFL figure
CFL_SIZES = (4, 8, 16, 32, 64)
#: backward-Euler steps of the energy figure
BE_STEPS = (1.0 / 30.0, 1.0 / 120.0, 1.0 / 480.0)
#: simulated time of the energy figure, in seconds (about 2.4 periods of the flap's slowest mode)
ENERGY_T_END = 2.0
#: frames of the animation (at 1/30 s each, frame 0 is the pulled flap)
ANIMATION_FRAMES = 50
#: frames shown in the filmstrip PNG
FILMSTRIP_FRAMES = (0, 3, 6, 10, 16, 25, 49)


@lecture_figure
def fig_ch07_cfl(study=None) -> Figure:
    """Chapter 7: symplectic Euler's largest stable step (bisection) and its estimate ``2 / omega_max``
    against h, fitted by ``dt = C h^p`` (CFL: ``p = 1``); right: the Courant number ``c dt / h``."""
    study = cfl_study(CFL_SIZES) if study is None else study
    h = np.array([r["h"] for r in study])
    measured = shown([r["dt_measured"] for r in study])  # bisection and ARPACK: the last digits vary
    estimate = shown([r["dt_estimate"] for r in study])
    fig = Figure(figsize=(10.5, 4.4), layout="constrained")
    ax, ax_c = fig.subplots(1, 2, width_ratios=[1.6, 1])
    constant, exponent = round(float(study.constant), 4), round(float(study.exponent), 3)  # as the label says
    # numpy's power differs in the last bit between processors (vector instructions): rounded to six
    # digits, the line cannot move by a fraction of a pixel
    h_line = shown(np.geomspace(h.min() / 1.5, 3.0, 50), digits=6)
    fit = shown(constant * h_line**exponent, digits=6)
    ax.loglog(h_line, fit, color="0.5", ls="--", lw=1,
              label=f"fit $\\Delta t = {constant:.4f}\\, h^{{{exponent:.3f}}}$")
    ax.loglog(h, estimate, "x", color="C1", ms=9, mew=2, label="estimate $2/\\omega_{max}$ (lumped $M^{-1}K$)")
    ax.loglog(h, measured, "o", color="C0", ms=6, label="measured (bisection, energy growth > 10x)")
    ax.axhline(FRAME_DT, color="C3", lw=1.2, label="one frame, 1/30 s")
    h_frame = round(float((FRAME_DT / constant) ** (1.0 / exponent)), 4)
    ax.plot([h_frame], [FRAME_DT], "s", color="C3", ms=6)
    ax.annotate(f"explicit at 1/30 s needs h ≈ {h_frame:.2f}\n(the flap is 2 x 1)", (h_frame, FRAME_DT),
                xytext=(0.55, 0.93), textcoords="axes fraction", ha="left", va="top", fontsize=8,
                arrowprops=dict(arrowstyle="->", color="0.3", lw=0.8))
    for hi, mi, r in zip(h, measured, study):
        ax.annotate(f"{r['nx']}x{r['nx'] // 2}", (hi, mi), xytext=(4, -11), textcoords="offset points", fontsize=7)
    finish(ax, legend=dict(fontsize=8, loc="lower right"), grid="both", xlabel="element size $h$ (shortest edge)",
           ylabel="largest stable $\\Delta t$ (s)", title="symplectic Euler: the step must shrink with the mesh")
    ax_c.semilogx(h, shown([r["courant"] for r in study]), "o-", color="C0", label="Courant number $c\\,\\Delta t / h$")
    ax_c.semilogx(h, shown([r["ratio"] for r in study]), "s-", color="C2", label="measured / estimate")
    ax_c.set_xticks(h, [f"{hi:g}" for hi in h])
    ax_c.xaxis.set_minor_formatter(NullFormatter())
    finish(ax_c, legend=dict(fontsize=8, loc="lower center"), grid="both", xlabel="element size $h$", ylim=(0.0, 1.2),
           title=f"$c = \\sqrt{{(\\lambda + 2\\mu)/\\rho_0}} = {study.wave_speed:.1f}$")
    fig.suptitle(f"Chapter 7, the CFL condition: $\\Delta t \\leq C h / c$ (stable neo-Hookean flap, "
                 f"E = {TISSUE_E:g}, ν = {TISSUE_NU:g}, $\\rho_0$ = 1; fitted exponent {study.exponent:.3f})",
                 fontsize=10)
    return fig


@lecture_figure
def fig_ch07_energy() -> Figure:
    """Chapter 7: the released flap's total energy: backward Euler damps it, the more the larger the step;
    symplectic Euler keeps it bounded at half its critical step and blows up at 1.1 times it."""
    problem, u0 = released_flap()
    dt_crit = critical_time_step(problem)
    fig = Figure(figsize=(13.0, 4.4), layout="constrained")
    ax, ax_z, ax_u = fig.subplots(1, 3, width_ratios=[1.5, 1, 0.9])
    for dt, color in zip(BE_STEPS, ("C0", "C1", "C2")):
        t, e = backward_euler_run(problem, u0, dt, int(round(ENERGY_T_END / dt)))
        e0 = e[0]
        ax.plot(t, e / e0, color=color, lw=1.6, label=f"backward Euler, $\\Delta t$ = 1/{1 / dt:.0f} s")
    stable_dt = 0.5 * dt_crit
    e = symplectic_energies(problem, u0, stable_dt, ENERGY_T_END)
    t = stable_dt * np.arange(e.size)
    label = f"symplectic Euler, $\\Delta t$ = 0.5 $\\Delta t_{{crit}}$ = {1000 * stable_dt:.2f} ms"
    ax.plot(t, e / e0, color="C4", lw=0.8, label=label)
    finish(ax, legend=dict(fontsize=7.5, loc="center right"), xlim=(0, ENERGY_T_END), ylim=(0.0, 1.15),
           xlabel="time $t$ (s)", ylabel="total energy $E(t) / E(0)$",
           title="backward Euler damps, symplectic Euler does not")
    ax_z.plot(t, e / e0, color="C4", lw=0.7)
    ax_z.axhline(1.0, color="k", lw=0.6, ls="--")
    ax_z.text(0.03, 0.04, f"min {e.min() / e0:.3f}, max {e.max() / e0:.3f}", transform=ax_z.transAxes, fontsize=8)
    finish(ax_z, xlim=(0, ENERGY_T_END), ylim=(0.9, 1.1), xlabel="time $t$ (s)", ylabel="$E(t) / E(0)$",
           title=f"symplectic Euler at {1000 * stable_dt:.2f} ms: bounded")
    # just above the limit
    unstable_dt = 1.1 * dt_crit
    e = symplectic_energies(problem, u0, unstable_dt, ENERGY_T_END, energy_limit=1e6 * e0)
    steps = np.arange(e.size)
    ax_u.semilogy(steps, e / e0, "o-", color="C3", ms=4, lw=1.2)
    ax_u.axhline(1.0, color="k", lw=0.6, ls="--")
    finish(ax_u, grid="both", xlabel="step", ylabel="$E / E(0)$ (log scale)",
           title="... at 1.1 $\\Delta t_{crit}$: blow-up")
    ax_u.text(0.04, 0.96, f"symplectic Euler, $\\Delta t$ = {1000 * unstable_dt:.2f} ms:\n"
              f"energy x{e[-1] / e0:.0e} after {e.size - 1} steps ({1000 * unstable_dt * (e.size - 1):.0f} ms)",
              transform=ax_u.transAxes, va="top", fontsize=8, color="C3")
    fig.suptitle(f"Chapter 7: energy of the released flap ($\\Delta t_{{crit}} = 2/\\omega_{{max}}$ = "
                 f"{1000 * dt_crit:.2f} ms at rest; 8 x 4 cells, stable neo-Hookean, E = {TISSUE_E:g}, "
                 f"ν = {TISSUE_NU:g}, $\\rho_0$ = 1)", fontsize=10)
    return fig


def write_flap_animation(gif_path, problem, states, dt: float, dpi: int = 100) -> Path:
    """Write the states as a GIF at one frame per step of ``dt``: 680 x 480 pixels, large enough to
    project (:data:`~tissuefem.workbook.figures.base.ANIMATION_MIN_WIDTH`)."""
    frames = [(problem.deformed_positions(u), problem.mesh.t, to_rgba(UPRIGHT_COLOR, 0.6)) for u in states]
    titles = [f"backward Euler, Δt = 1/{1 / dt:.0f} s:  t = {k * dt:.2f} s" for k in range(len(states))]
    return write_sheet_animation(gif_path, frames, titles, dt, dpi, figsize=(6.8, 4.8), top=0.82, fontsize=14,
                                 edgecolors="0.35", linewidths=0.5)


def release_history(ax, times, y, energy_ratio, marked, label, ylabel) -> None:
    """The lower panel of a released body's filmstrip: a displacement ``y`` over ``times`` (the ``marked`` frames
    as squares) and, on a second axis, the total energy over its initial value."""
    ax.plot(times, y, "o-", color="C0", ms=3, lw=1.2, label=label)
    ax.plot(times[list(marked)], y[list(marked)], "s", color="C3", ms=6, label="frames shown above")
    ax.axhline(0.0, color="k", lw=0.6)
    ax2 = ax.twinx()
    ax2.plot(times, energy_ratio, color="C2", lw=1.0, ls="--", label="total energy / initial")
    ax2.set(ylim=(0.0, 1.05), ylabel="$E(t)/E(0)$")
    finish(ax, xlabel="time $t$ (s), one backward-Euler step per frame", ylabel=ylabel, xlim=(0.0, times[-1]))
    (h1, l1), (h2, l2) = ax.get_legend_handles_labels(), ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper right")


@lecture_figure
def fig_ch07_released_flap(path=None) -> Figure:
    """Chapter 7: the flap let go, backward Euler at 1/30 s, as a filmstrip with the tip's displacement: the
    swing dies out by numerical damping. With a ``path``, also writes ``<path stem>.gif``."""
    problem, u0 = released_flap()
    times, energies, states = backward_euler_run(problem, u0, FRAME_DT, ANIMATION_FRAMES - 1, frames=True)
    mesh = problem.mesh
    tip = np.flatnonzero((np.abs(mesh.p[0] - 2.0) < 1e-9) & (np.abs(mesh.p[1] - 0.5) < 1e-9))[0]
    tip_dof = problem.basis.nodal_dofs[1, tip]
    window = sheet_window([problem.deformed_positions(states[k]) for k in FILMSTRIP_FRAMES])
    fig, strip, below = filmstrip(times, FILMSTRIP_FRAMES, {0: "let go"}, 1.6, 4.6, [1.0, 1.15], window)
    for ax, k in zip(strip, FILMSTRIP_FRAMES):
        ax.plot(*mesh.p[:, mesh.t[[0, 1, 2, 0]]], color="0.8", lw=0.3)  # the rest shape, faint
        draw_state(ax, mesh, problem.deformed_positions(states[k]))
        ax.plot([0.0, 0.0], [0.0, 1.0], color="k", lw=2.0)  # the held edge
    tip_y = np.array([u[tip_dof] for u in states])
    release_history(below, times, tip_y, energies / energies[0], FILMSTRIP_FRAMES,
                    "tip displacement $u_y$ (right edge, middle)", "tip $u_y$")
    fig.suptitle(f"Chapter 7: the flap let go, backward Euler at $\\Delta t$ = 1/30 s "
                 f"(stable neo-Hookean, E = {TISSUE_E:g}, ν = {TISSUE_NU:g}, $\\rho_0$ = 1, left edge held)",
                 fontsize=10)
    if path is not None:
        write_flap_animation(Path(path).with_suffix(".gif"), problem, states, FRAME_DT)
    return fig


#: a relative state error below this is round-off (its digits differ between machines)
STATE_ROUND_OFF = 1e-12


@lecture_figure
def fig_ch07_budget_residual() -> Figure:
    """Chapter 7: residual and state error left when a frame stops after 1, 2 or 3 Newton steps, by mesh size."""
    rows = capped_runs()
    fig = Figure(figsize=(9.0, 4.1), layout="constrained")
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
    finish(ax_r, grid="both", xlabel="triangles", ylabel="median of |residual| / |first residual| per frame",
           title="Residual left at the end of a frame")
    finish(ax_e, grid="both", xlabel="triangles", ylabel="max |u - u_converged| / max |u_converged|",
           title=f"State error after {CAPPED_FRAMES} frames of the drag")
    for ax in (ax_r, ax_e):
        ax.xaxis.set_minor_formatter(NullFormatter())
    # one legend for both panels, below them: inside, it would lie over the curves
    fig.legend(*ax_r.get_legend_handles_labels(), fontsize=8, loc="outside lower center", ncols=len(CAPS))
    return fig
