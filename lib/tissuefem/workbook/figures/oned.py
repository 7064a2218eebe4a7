"""Figures of the 1D chapters (1 and 2) and of the notes' Figures 5 and 7."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ...engine.constants import TISSUE_E, TISSUE_NU
from ...engine.materials1d import Linear1D, NeoHookean1D, TaylorNeoHookean1D
from ..oned import convergence_study, newton_histories
from .base import finish, lecture_figure, shown, stress_label


@lecture_figure
def fig05_admissible_maps() -> Figure:
    """Notes' Figure 5: phi(X) = X^2 (admissible) beside phi(X) = sin(2 pi X) (inverting), shaded where
    phi'(X) <= 0, and material points joined to their images."""
    X = np.linspace(0.0, 1.0, 401)
    maps = [
        ("admissible: $\\phi(X) = X^2$", X**2, 2.0 * X),
        ("inverting: $\\phi(X) = \\sin(2\\pi X)$", np.sin(2 * np.pi * X), 2 * np.pi * np.cos(2 * np.pi * X)),
    ]
    fig = Figure(figsize=(9.0, 5.6), layout="constrained")
    axes = fig.subplots(2, 2, height_ratios=[3, 2])
    Xs = np.linspace(0.0, 1.0, 21)
    for col, (title, phi, dphi) in enumerate(maps):
        ax = axes[0, col]
        ax.plot(X, phi, color="C0", lw=2, label="$\\phi(X)$")
        bad = dphi <= 1e-12
        ax.fill_between(X, -1.1, 1.1, where=bad, color="C3", alpha=0.18, step="mid",
                        label="$\\phi'(X) \\leq 0$")
        if bad[0] and not bad[1]:
            ax.plot([0], [phi[0]], "o", color="C3", ms=7)
        ax.axhline(0, color="0.6", lw=0.8)
        ax.set(title=title, xlabel="$X$ (material)", ylabel="$x = \\phi(X)$", xlim=(0, 1), ylim=(-1.1, 1.1))
        ax.legend(loc="lower left", fontsize=8)
        # material points carried to their images
        ax = axes[1, col]
        phis = np.interp(Xs, X, phi)
        for Xi, xi, di in zip(Xs, phis, np.interp(Xs, X, dphi)):
            ax.plot([Xi, xi], [0, 1], color="C3" if di <= 1e-12 else "C0", lw=1)
        ax.plot(Xs, np.zeros_like(Xs), "k.", ms=4)
        ax.plot(phis, np.ones_like(Xs), "k.", ms=4)
        ax.set(yticks=[0, 1], yticklabels=["$X$", "$x$"], xlim=(-1.1, 1.1), xlabel="position")
    fig.suptitle("Notes' Figure 5: a deformation must keep $\\phi' > 0$ to stay a bijection")
    return fig


@lecture_figure
def fig07_neo_hookean_1d() -> Figure:
    """Notes' Figure 7: 1D Neo-Hookean energy and stress against J = F: ln J (undefined for J <= 0), the
    cubic-Taylor r(J) model (finite through inversion) and linear."""
    models = [
        (NeoHookean1D.from_young(TISSUE_E, TISSUE_NU), "C0", "-", "ln J (notes' model)"),
        (TaylorNeoHookean1D.from_young(TISSUE_E, TISSUE_NU), "C2", "-", "cubic Taylor r(J)"),
        (Linear1D.from_young(TISSUE_E, TISSUE_NU), "0.5", ":", "linear"),
    ]
    J = np.linspace(-0.4, 2.2, 1301)
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    ax_e, ax_s = fig.subplots(1, 2)
    for mat, color, ls, label in models:
        ax_e.plot(J, mat.energy(J), color=color, ls=ls, lw=2, label=label)
        ax_s.plot(J, mat.stress(J), color=color, ls=ls, lw=2, label=label)
    for ax in (ax_e, ax_s):
        ax.axvspan(J[0], 0.0, color="C3", alpha=0.08, label="inverted ($J \\leq 0$)")
        ax.axvline(1.0, color="k", lw=0.6, ls="--")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set(xlabel="$J = F$", xlim=(J[0], J[-1]))
    ax_e.set(ylim=(-200, 4500), ylabel="energy density $\\Psi$", title="energy")
    ax_s.set(ylim=(-11000, 3000), ylabel=stress_label("stress $P = d\\Psi/dF$"), title="first Piola-Kirchhoff stress")
    ax_e.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"Notes' Figure 7: 1D Neo-Hookean, E = {TISSUE_E:g}, nu = {TISSUE_NU:g}")
    return fig


@lecture_figure
def fig_ch01_convergence() -> Figure:
    """Chapter 1: L2 and H1 errors of the 1D linear bar against h, P1 and P2, with observed rates."""
    rows = convergence_study()
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = fig.subplots()
    for order, marker in ((1, "o"), (2, "s")):
        sel = [r for r in rows if r["order"] == order]
        h = np.array([r["h"] for r in sel])
        for key, ls in (("L2", "-"), ("H1", "--")):
            ax.loglog(h, np.array([r[key] for r in sel]), marker=marker, ls=ls,
                      label=f"P{order}, {key} error (rate {sel[-1][f'rate_{key}']:.2f})")
    finish(ax, legend=dict(fontsize=8), grid="both", xlabel="element size $h$", ylabel="error",
           title="1D linear bar: error against mesh size")
    return fig


@lecture_figure
def fig_ch02_newton() -> Figure:
    """Chapter 2: Newton residual histories for the 1D Neo-Hookean bar under several end tractions."""
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = fig.subplots()
    round_off = 1e-11  # the residual of this bar cannot fall below about 1e-12 (chapter 2, section 3)
    for T, (norms, status) in newton_histories().items():
        ax.semilogy(np.arange(norms.size), shown(norms, floor=round_off), "o-", label=f"T = {T:g} ({status})")
    ax.axhspan(round_off / 20, round_off, color="0.9", lw=0, zorder=0)
    ax.text(0.02, round_off / 5, f"round-off (drawn at {round_off:.0e})", transform=ax.get_yaxis_transform(),
            fontsize=7.5, color="0.35", va="center")
    finish(ax, legend=dict(fontsize=8), grid="both", xlabel="Newton iteration $k$", ylabel="$\\|q(u^k)\\|$",
           title="Newton on the 1D Neo-Hookean bar: quadratic convergence")
    return fig
