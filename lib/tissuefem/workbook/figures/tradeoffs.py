"""Chapter 9 figures: what accuracy costs in time, drawn from the results of
:func:`~tissuefem.workbook.bench.accuracy_cost.accuracy_study` (the lecture figures: the recorded full study);
the verified reference's mesh convergence (:func:`plot_convergence`, also chapter 11's on tetrahedra); and the plot of
``bench realtime``'s results."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from .base import lecture_figure, save, shown
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

#: the colours of P1 and P2 in the verification figure
ORDER_COLORS = ("tab:blue", "tab:red")

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
    return all(v is not None and math.isfinite(v) and v > 0 for v in (r.get("error"), r.get("ms_median")))


def plot_pareto(results, path=None) -> Figure:
    """Error against ms per frame for every knob's settings, one panel per benchmark, with the baseline
    (star), the Pareto front (grey; resolution :data:`ERROR_RESOLUTION`) and the budget line."""
    rows = results["knobs"]
    benchmarks = list(dict.fromkeys(r["benchmark"] for r in rows))
    fig = Figure(figsize=(6.2 * len(benchmarks) + 2.6, 5.0), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(benchmarks)))
    budget = results.get("frame_budget_ms", 1e3 * FRAME_BUDGET)
    titles = {"flap": "Flap scene: backward Euler, dt = 1/30, the drag eased in",
              "block": "Quasistatic block: stretched and sheared in frames"}
    labels = {ax: [] for ax in axes}
    marked = {}
    for ax, b in zip(axes, benchmarks):
        sel = [r for r in rows if r["benchmark"] == b and _finite(r)]
        marked[ax] = [(r["ms_median"], r["error"]) for r in sel]
        for knob, (color, marker, label) in KNOB_STYLE.items():
            pts = [r for r in sel if r["knob"] == knob]
            if not pts:
                continue
            ax.loglog([r["ms_median"] for r in pts], [r["error"] for r in pts], marker=marker, color=color,
                      ls="none" if knob in ("material", "linear_solver") else "-", lw=1.2, ms=6, alpha=0.9, label=label)
            if knob in ("material", "linear_solver", "newton_cap", "time_step"):
                labels[ax] += [(r["ms_median"], r["error"], _short(r["value"]), color) for r in pts]
        front = pareto_front([r["ms_median"] for r in sel], [r["error"] for r in sel], rtol=ERROR_RESOLUTION)
        if front.size:
            fc, fe = [sel[i]["ms_median"] for i in front], [sel[i]["error"] for i in front]
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
    for ax in axes:
        if labels[ax]:
            place_labels(ax, labels[ax], marked[ax])
    save(fig, path)
    return fig


#: the gap between a point and its label, and between labels [points]
LABEL_GAP = 3.0


def place_labels(ax, labels, points=(), fontsize=6.5) -> list:
    """Write each ``(x, y, text, colour)`` of ``labels`` beside its point where it overlaps no other label,
    no point of ``points`` and no text already in the axes, and stays inside them: right of the point first,
    then further up or down (joined to its point by a thin line), then on the left. Call it when everything
    else is drawn: it lays the figure out to know where the points land. Returns the annotations."""
    fig = ax.get_figure()
    fig.draw_without_rendering()
    to_points = 72.0 / fig.dpi
    x0, y0, x1, y1 = (v * to_points for v in ax.get_window_extent().extents)
    taken = [tuple(v * to_points for v in t.get_window_extent().extents) for t in ax.texts]
    marker = 4.0
    for px, py in ax.transData.transform(np.asarray(points, dtype=float).reshape(-1, 2)) * to_points:
        taken.append((px - marker, py - marker, px + marker, py + marker))
    height = 1.15 * fontsize
    steps = [LABEL_GAP] + [s * (height + LABEL_GAP) for k in range(1, 9) for s in (k, -k)]
    drawn = []
    for x, y, text, color in sorted(labels, key=lambda item: (item[0], item[1])):
        px, py = ax.transData.transform((x, y)) * to_points
        width = 0.7 * fontsize * len(text)  # a generous average letter: capitals are wide
        choice = None
        for dx in (marker, -marker - width):
            for dy in steps:
                lo_y = py + dy if dy > 0 else py + dy - height
                box = (px + dx, lo_y, px + dx + width, lo_y + height)
                inside = box[0] >= x0 and box[2] <= x1 and box[1] >= y0 and box[3] <= y1
                padded = (box[0] - LABEL_GAP, box[1] - 1.0, box[2] + LABEL_GAP, box[3] + 1.0)
                if inside and not any(_overlap(padded, other) for other in taken):
                    choice = (box, dx, lo_y - py, abs(dy) > LABEL_GAP)
                    break
            if choice:
                break
        if choice is None:  # nowhere free: beside the point, as before
            choice = ((px + marker, py, px + marker + width, py + height), marker, LABEL_GAP, False)
        box, dx, dy, far = choice
        taken.append(box)
        leader = dict(arrowstyle="-", lw=0.5, color=color, alpha=0.8, shrinkA=0.5, shrinkB=2.5) if far else None
        drawn.append(ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points", fontsize=fontsize,
                                 color=color, ha="left", va="bottom", arrowprops=leader))
    return drawn


def _overlap(a, b) -> bool:
    """Whether two boxes ``(x0, y0, x1, y1)`` overlap."""
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


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
    """Residual left, share of frames converged and the frames' times when the budgeted solver spends its 33 ms,
    by mesh size."""
    rows = results["budget"]
    fig = Figure(figsize=(14.0, 4.0), layout="constrained")
    ax_r, ax_c, ax_t = fig.subplots(1, 3)
    for solver, marker in zip(dict.fromkeys(r["solver"] for r in rows), "osD^"):
        sel = [r for r in rows if r["solver"] == solver]
        tri = [r["triangles"] for r in sel]
        label = SOLVER_LABELS.get(solver, solver)
        ax_r.loglog(tri, [max(r["residual_median"], 1e-16) for r in sel], marker + "-", label=label + ": residual")
        ax_r.loglog(tri, [max(r["state_error"], 1e-16) for r in sel], marker + ":", alpha=0.7,
                    label=label + ": state error")
        ax_c.semilogx(tri, [100 * r["converged_share"] for r in sel], marker + "-", label=label)
        ax_t.loglog(tri, [r["ms_median"] for r in sel], marker + "-", label=label + ": median")
        ax_t.loglog(tri, [r["ms_p95"] for r in sel], marker + ":", label=label + ": 95th percentile")
    ax_r.axhline(1e-6, color="k", ls="--", lw=1)
    ax_r.text(rows[0]["triangles"], 1.6e-6, "converged: rtol = 1e-6", fontsize=8)
    ax_r.set(xlabel="triangles", ylabel="median |residual| / |first residual| at frame end;\n"
             "state error vs converged run (rel. L2)",
             title=f"What is left when {rows[0]['budget_ms']:.0f} ms are spent")
    ax_c.set(xlabel="triangles", ylabel="frames converged within the budget [%]", ylim=(-5, 105),
             title="Frames that converge in budget")
    ax_t.axhline(rows[0]["budget_ms"], color="C3", ls="--", lw=1, label=f"budget {rows[0]['budget_ms']:.0f} ms")
    ax_t.set(xlabel="triangles", ylabel="ms per budgeted frame (real clock)", title="What the frames took")
    for ax in (ax_r, ax_c, ax_t):
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=7.5)
    save(fig, path)
    return fig


@lecture_figure
def fig_ch09_pareto() -> Figure:
    """Chapter 9: error against ms per frame for every knob, flap and quasistatic block (recorded full study)."""
    return plot_pareto(recorded_results())


@lecture_figure
def fig_ch09_scaling() -> Figure:
    """Chapter 9: ms per frame against mesh size per linear solver, with fitted growth exponents (recorded)."""
    return plot_scaling(recorded_results())


@lecture_figure
def fig_ch09_budget() -> Figure:
    """Chapter 9: residual and converged share left by the 33 ms budget, by mesh size (recorded)."""
    return plot_budget(recorded_results())


@lecture_figure
def fig_ch09_verification(rows=None) -> Figure:
    """Chapter 9: the reference verified -- nonlinear mesh convergence at rates 2 (P1) and 3 (P2)."""
    return plot_convergence(manufactured_convergence() if rows is None else rows,
                            "Manufactured solution (bent arch + its body force)")


def plot_convergence(rows, title) -> Figure:
    """Relative L2 errors against the cell size ``h`` of :func:`~tissuefem.workbook.verification.
    manufactured_convergence`'s rows: one colour per order, one marker per model, the slopes ``order + 1``."""
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = fig.subplots()
    models = list(dict.fromkeys(r["model"] for r in rows))
    orders = sorted({r["order"] for r in rows})
    # the models' errors agree to about 1 %: one colour per order, one marker per model, drawn from large and
    # open to small and filled so that every model stays visible on the others
    marks = [("o", 10, "none"), ("s", 6.5, "none"), ("^", 4, None)]
    for r in rows:
        k = models.index(r["model"])
        marker, size, face = marks[k % len(marks)]
        color = ORDER_COLORS[orders.index(r["order"]) % len(ORDER_COLORS)]
        ax.loglog(r["h"], shown(r["errors"]), marker=marker, ms=size, mfc=face if face else color, mec=color,
                  mew=1.2, color=color, ls="-" if k == 0 else "none", lw=1.2, zorder=3)
    for i, order in enumerate(orders):
        sel = [r for r in rows if r["order"] == order]
        color = ORDER_COLORS[i % len(ORDER_COLORS)]
        h = np.array(sel[0]["h"])
        e0 = sel[0]["errors"][0] * 2.0  # the slope line above the curve, ending at its coarsest mesh
        ax.loglog(h, shown(e0 * (h / h[0]) ** (order + 1)), color="0.5", lw=1, ls=":")
        ax.text(h[0], e0, f"slope {order + 1}  ", fontsize=8, color="0.4", ha="right", va="bottom")
    for k, model in enumerate(models):
        marker, size, face = marks[k % len(marks)]
        ax.plot([], [], marker=marker, ms=size, mfc=face if face else "0.3", mec="0.3", mew=1.2, ls="none",
                label=model)
    for i, order in enumerate(orders):
        rates = ", ".join(f"{r['fitted_rate']:.2f}" for r in rows if r["order"] == order)
        ax.plot([], [], color=ORDER_COLORS[i % len(ORDER_COLORS)], lw=1.2, label=f"P{order}: rates {rates}")
    ticks = sorted({h for r in rows for h in r["h"]})
    ax.set_xticks(ticks, [f"1/{round(1 / h)}" if h < 1 else f"{h:g}" for h in ticks])
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlim(ticks[0] / 1.6, ticks[-1] * 1.6)
    ax.set(xlabel="h (cell size)", ylabel="relative L2 error vs exact solution", title=title)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=7.5, loc="lower right", title="models; rates in their order", title_fontsize=7.5)
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
