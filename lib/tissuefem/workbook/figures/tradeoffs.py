"""Chapter 9 figures: what accuracy costs in time, drawn from the results of
:func:`~tissuefem.workbook.bench.accuracy_cost.accuracy_study` (the lecture figures: the recorded full study);
and the plot of ``bench realtime``'s results."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from .base import lecture_figure, save
from ...engine.constants import FRAME_BUDGET
from ..verification import manufactured_convergence
from ..bench.accuracy_cost import recorded_results
from ..measure import pareto_front

#: errors that agree to this relative tolerance are not told apart (no winner by the last digits)
ERROR_RESOLUTION = 0.01
#: one colour and marker per knob, and the words a reader sees
KNOB_STYLE = {
    "mesh": ("tab:blue", "o", "mesh size (P1)"),
    "P2": ("tab:orange", "s", "mesh size (P2)"),
    "quadrature": ("tab:brown", "P", "quadrature degree (P2)"),
    "material": ("tab:green", "D", "material model"),
    "newton_tolerance": ("tab:red", "v", "Newton tolerance"),
    "newton_cap": ("tab:purple", "^", "Newton iterations cap"),
    "time_step": ("tab:pink", "<", "time step: dt = (1/30) / substeps (flap)"),
    "linear_solver": ("tab:gray", "X", "linear solver"),
}

SOLVER_LABELS = {
    "reuse": "CG + reused SuperLU (default)",
    "direct": "SuperLU, minimum degree, every iteration",
    "superlu-colamd": "SuperLU, COLAMD (SciPy's default)",
    "cg-ilu": "CG + incomplete LU",
    "cg-jacobi": "CG + Jacobi",
    "cg": "CG, no preconditioner",
    "pardiso": "PARDISO, every iteration",
    "reuse-pardiso": "CG + reused PARDISO",
}


def _short(value) -> str:
    if isinstance(value, float):
        return f"{value:.0e}"
    return {"neo-hookean": "NH", "stable-neo-hookean": "stable NH", "taylor-neo-hookean": "Taylor NH",
            "corotated": "corot.", "superlu-colamd": "COLAMD", "cg-ilu": "CG-ILU", "cg-jacobi": "CG-Jacobi",
            "pardiso": "PARDISO", "reuse-pardiso": "reuse-PARDISO"}.get(value, str(value))


def _finite(r) -> bool:
    e, c = r.get("error"), r.get("ms_median")
    return e is not None and c is not None and math.isfinite(e) and math.isfinite(c) and e > 0 and c > 0


def plot_pareto(results, path=None, annotate=True) -> Figure:
    """Error against ms per frame for every knob's settings, one panel per benchmark, with the baseline
    (star), the Pareto front (grey; resolution :data:`ERROR_RESOLUTION`) and the budget line."""
    rows = results["knobs"]
    benchmarks = list(dict.fromkeys(r["benchmark"] for r in rows))
    fig = Figure(figsize=(6.2 * len(benchmarks) + 2.6, 5.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(benchmarks)))
    budget = results.get("frame_budget_ms", 1e3 * FRAME_BUDGET)
    titles = {"flap": "Flap scene: backward Euler, dt = 1/30, the drag eased in",
              "block": "Quasistatic block: stretched and sheared in frames"}
    for ax, b in zip(axes, benchmarks):
        sel = [r for r in rows if r["benchmark"] == b and _finite(r)]
        for knob, (color, marker, label) in KNOB_STYLE.items():
            pts = [r for r in sel if r["knob"] == knob]
            if not pts:
                continue
            ax.loglog([r["ms_median"] for r in pts], [r["error"] for r in pts], marker=marker, color=color,
                      ls="-" if knob in ("mesh", "P2", "quadrature", "newton_tolerance", "newton_cap", "time_step")
                      else "none", lw=1.2, ms=6, alpha=0.9, label=label)
            if annotate and knob in ("material", "linear_solver", "newton_cap", "time_step"):
                for r in pts:
                    ax.annotate(_short(r["value"]), (r["ms_median"], r["error"]), textcoords="offset points",
                                xytext=(4, 3), fontsize=6.5, color=color)
        front = pareto_front([r["ms_median"] for r in sel], [r["error"] for r in sel], rtol=ERROR_RESOLUTION)
        if front.size:
            fc = [sel[i]["ms_median"] for i in front]
            fe = [sel[i]["error"] for i in front]
            ax.step(fc + [fc[-1] * 3], fe + [fe[-1]], where="post", color="0.6", lw=3, alpha=0.35, zorder=0,
                    label="Pareto front")
        base = [r for r in sel if r.get("baseline")]
        if base:
            ax.loglog([base[0]["ms_median"]], [base[0]["error"]], "*", color="k", ms=14, zorder=5,
                      label=f"baseline ({base[0]['triangles']} triangles, P1, NH)")
        ax.axvline(budget, color="k", ls="--", lw=1)
        ax.text(budget * 1.06, 0.97, "33 ms: 30 fps", fontsize=8, rotation=90, va="top",
                transform=ax.get_xaxis_transform())
        ax.set(xlabel="wall time per displayed frame [ms] (median)",
               ylabel="relative L2 displacement error vs reference", title=titles.get(b, b))
        ax.grid(True, which="both", alpha=0.25)
    handles = {}
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    fig.legend(list(handles.values()), list(handles), fontsize=7.5, loc="outside right upper")
    save(fig, path)
    return fig


def plot_scaling(results, path=None) -> Figure:
    """ms per frame against triangles per linear solver (log-log), with the fitted exponent in the legend."""
    sc = results["scaling"]
    rows, exps = sc["rows"], sc.get("exponents", {})
    fig = Figure(figsize=(7.0, 4.8), layout="constrained")
    ax = fig.subplots()
    markers = "osD^vP<X"
    for k, solver in enumerate(dict.fromkeys(r["solver"] for r in rows)):
        sel = [r for r in rows if r["solver"] == solver and r.get("ms_median") and math.isfinite(r["ms_median"])]
        if not sel:
            continue
        p = exps.get(solver)
        label = SOLVER_LABELS.get(solver, solver) + (f": p = {p:.2f}" if p is not None else "")
        ax.loglog([r["triangles"] for r in sel], [r["ms_median"] for r in sel], marker=markers[k % len(markers)],
                  ls="-", label=label)
    budget = results.get("frame_budget_ms", 1e3 * FRAME_BUDGET)
    ax.axhline(budget, color="k", ls="--", lw=1)
    ax.text(min(r["triangles"] for r in rows), budget * 1.1, "33 ms: 30 frames per second", fontsize=8)
    ax.set(xlabel="triangles (P1)", ylabel="ms per converged frame (median)",
           title="Flap scene: cost growth per linear solver, ms ~ triangles^p")
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=7.5)
    save(fig, path)
    return fig


def plot_budget(results, path=None) -> Figure:
    """Residual left and share of frames converged when the budgeted solver spends its 33 ms, by mesh size."""
    rows = results["budget"]
    fig = Figure(figsize=(10.0, 4.0), layout="constrained")
    ax_r, ax_c = fig.subplots(1, 2)
    for solver, marker in zip(dict.fromkeys(r["solver"] for r in rows), "osD^"):
        sel = [r for r in rows if r["solver"] == solver]
        tri = [r["triangles"] for r in sel]
        label = SOLVER_LABELS.get(solver, solver)
        ax_r.loglog(tri, [max(r["residual_median"], 1e-16) for r in sel], marker + "-", label=label + ": residual")
        ax_r.loglog(tri, [max(r["state_error"], 1e-16) for r in sel], marker + ":", alpha=0.7,
                    label=label + ": state error")
        ax_c.semilogx(tri, [100 * r["converged_share"] for r in sel], marker + "-", label=label)
    ax_r.axhline(1e-6, color="k", ls="--", lw=1)
    ax_r.text(rows[0]["triangles"], 1.6e-6, "converged: rtol = 1e-6", fontsize=8)
    ax_r.set(xlabel="triangles", ylabel="median |residual| / |first residual| at frame end;\n"
             "state error vs converged run (rel. L2)",
             title=f"What is left when {rows[0]['budget_ms']:.0f} ms are spent")
    ax_c.set(xlabel="triangles", ylabel="frames converged within the budget [%]", ylim=(-5, 105),
             title="Frames that converge in budget")
    for ax in (ax_r, ax_c):
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7.5)
    save(fig, path)
    return fig


@lecture_figure
def fig_ch09_pareto(results=None) -> Figure:
    """Chapter 9: error against ms per frame for every knob, flap and quasistatic block (recorded full study)."""
    return plot_pareto(recorded_results() if results is None else results)


@lecture_figure
def fig_ch09_scaling(results=None) -> Figure:
    """Chapter 9: ms per frame against mesh size per linear solver, with fitted growth exponents (recorded)."""
    return plot_scaling(recorded_results() if results is None else results)


@lecture_figure
def fig_ch09_budget(results=None) -> Figure:
    """Chapter 9: residual and converged share left by the 33 ms budget, by mesh size (recorded)."""
    return plot_budget(recorded_results() if results is None else results)


@lecture_figure
def fig_ch09_verification(rows=None) -> Figure:
    """Chapter 9: the reference verified -- nonlinear mesh convergence at rates 2 (P1) and 3 (P2)."""
    rows = manufactured_convergence() if rows is None else rows
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = fig.subplots()
    colors = {"neo-hookean": "tab:blue", "stable-neo-hookean": "tab:orange", "corotated": "tab:green"}
    for r in rows:
        ax.loglog(r["h"], r["errors"], "o-" if r["order"] == 1 else "s--", color=colors.get(r["model"], "k"),
                  label=f"{r['model']}, P{r['order']}: rate {r['fitted_rate']:.2f}")
    for order in (1, 2):
        sel = [r for r in rows if r["order"] == order]
        if sel:
            h = np.array(sel[0]["h"])
            e0 = sel[0]["errors"][0] * 1.6  # the slope line a little above the first curve
            ax.loglog(h, e0 * (h / h[0]) ** (order + 1), color="0.5", lw=1, ls=":")
            ax.text(h[-1], e0 * (h[-1] / h[0]) ** (order + 1), f" slope {order + 1}", fontsize=8, color="0.4")
    ax.set(xlabel="h (cell size)", ylabel="relative L2 error vs exact solution",
           title="Manufactured solution (bent arch + its body force)")
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=7.5)
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
