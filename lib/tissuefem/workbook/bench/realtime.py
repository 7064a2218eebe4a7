"""Frame-rate benchmark of the standard scene: the real-time solver against the scikit-fem ex43 way.

The standard scene (:func:`flap_scene`): a Neo-Hookean tissue flap
``[0, 2] x [0, 1]`` (E = 1000, nu = 0.3, plane strain, rho0 = 1), its left
edge fixed, its right edge carried along a scripted loop (:func:`flap_path`)
by a handle; backward Euler with ``dt = 1/30``; every frame's Newton solve
converged to a relative residual of ``1e-6``.

For each mesh size the benchmark runs, in one process and on the same frames:

* **fast**: :class:`~tissuefem.realtime.RealtimeSolver` with no budget (every
  frame converges), so a frame's time is what a converged frame costs: the
  P1 assembler, warm starts, and the reused factorization as the CG
  preconditioner;
* **ex43 way**: the same backward-Euler Newton iteration written as
  scikit-fem's hyperelasticity example writes a Newton step: ``BilinearForm``
  and ``LinearForm`` assembled with ``asm`` every iteration (here the forms
  of :mod:`tissuefem.forms` plus the mass matrix), ``condense`` on the fixed
  degrees of freedom, and ``skfem.solve`` (SciPy's ``spsolve``), with one
  safeguard added: a step whose residual is not finite is halved (plain
  Newton ends in NaN in the first frame at 32k triangles). Slow, so
  only the first ``baseline_frames`` frames; the ratio compares medians over
  those same frames;
* **budgeted**: the real-time solver with its default 1/30 s budget and the
  real clock: the share of frames that converge in budget and the residual
  left when the budget runs out.

Timings are medians and 95th percentiles of ``time.perf_counter`` per frame.
This is a benchmark to read, not a test: compare columns of one run.
"""

from __future__ import annotations

import csv
import json
import math
import os
import time
from pathlib import Path

import numpy as np

from .common import _check_sizes, machine_info, markdown_table
from ...engine.realtime import FRAME_BUDGET, RealtimeSolver

__all__ = ["flap_scene", "flap_path", "realtime_benchmark", "ex43_frames", "format_realtime_table", "plot_realtime"]

E_FLAP, NU_FLAP, RHO_FLAP, DT_FLAP, RTOL_FLAP = 1000.0, 0.3, 1.0, 1.0 / 30.0, 1e-6


def flap_path(t) -> np.ndarray:
    """The scripted handle path: displacement of the right edge at time ``t`` (a slow loop, period 4-8 s)."""
    t = float(t)
    return np.array([0.3 * math.sin(math.pi * t / 2.0), 0.4 * math.sin(math.pi * t / 4.0)])


def flap_scene(n_triangles: int = 8000, material=None):
    """``(problem, grab)``: the standard flap with the left edge fixed and a handle on the right edge."""
    from ...engine.materials import NeoHookean
    from ...engine.meshes import flap
    from ...engine.quasistatic import Handle, QuasistaticProblem

    mesh = flap(n_triangles=n_triangles)
    grab = Handle("handle")
    material = material or NeoHookean.from_young(E_FLAP, NU_FLAP)
    return QuasistaticProblem(mesh, material, handles=[Handle("fixed"), grab]), grab


def ex43_frames(problem, grab, n_frames: int, dt: float = DT_FLAP, rtol: float = RTOL_FLAP, density=RHO_FLAP,
                lumped: bool = True):
    """Run ``n_frames`` of the scene the ex43 way; return ``(ms per frame, Newton iterations per frame, u)``.

    The mass matrix is built once (lumped by default, as the real-time solver's default, so both solve the
    same equations); the stiffness and the residual are assembled every Newton iteration.
    """
    from skfem import BilinearForm, asm, condense, solve

    from ...engine.forms import residual_form, tangent_form

    basis = problem.basis
    K_form, r_form = tangent_form(problem.material), residual_form(problem.material)

    @BilinearForm
    def mass(u, v, w):
        return density * (u[0] * v[0] + u[1] * v[1])

    M = asm(mass, basis)
    if lumped:
        import scipy.sparse as sp

        M = sp.diags(np.asarray(M.sum(axis=1)).ravel()).tocsr()
    u, v = basis.zeros(), basis.zeros()
    times, iterations = [], []
    for f in range(n_frames):
        grab.move(flap_path((f + 1) * dt))
        t0 = time.perf_counter()
        fixed, values = problem.prescribed()
        u_tilde = u + dt * v
        x = u_tilde.copy()
        x[fixed] = values
        free = np.setdiff1d(np.arange(basis.N), fixed)
        def residual(x):
            with np.errstate(all="ignore"):
                return M @ (x - u_tilde) + dt**2 * asm(r_form, basis, u=basis.interpolate(x))

        r = residual(x)
        r0 = np.linalg.norm(r[free])
        for k in range(50):
            if np.linalg.norm(r[free]) <= rtol * r0:
                break
            A = M + dt**2 * asm(K_form, basis, u=basis.interpolate(x))
            dx = solve(*condense(A, -r, D=fixed))
            # the one safeguard added to plain Newton: halve a step whose residual is not finite
            # (without it the first frame at 32k triangles inverts elements and ends in NaN)
            for _ in range(30):
                r_new = residual(x + dx)
                if np.all(np.isfinite(r_new)):
                    break
                dx = 0.5 * dx
            x, r = x + dx, r_new
        times.append(1e3 * (time.perf_counter() - t0))
        iterations.append(k)
        v = (x - u) / dt
        u = x
    return np.array(times), np.array(iterations), u


def _fast_frames(problem, grab, n_frames, budget=math.inf, linear_solver="reuse"):
    solver = RealtimeSolver(problem, dt=DT_FLAP, density=RHO_FLAP, budget=budget, rtol=RTOL_FLAP,
                            linear_solver=linear_solver)
    reports = []
    for f in range(n_frames):
        reports.append(solver.frame({1: flap_path((f + 1) * DT_FLAP)}))
    return solver, reports


_TABLE = [
    ("triangles", "triangles", "{:d}"),
    ("dofs", "dofs", "{:d}"),
    ("fast_median_ms", "median [ms]", "{:.1f}"),
    ("fast_p95_ms", "p95 [ms]", "{:.1f}"),
    ("fast_fps", "fps", "{:.0f}"),
    ("fast_newton", "Newton/frame", "{:.2f}"),
    ("fast_cg", "CG/frame", "{:.1f}"),
    ("fast_factorizations", "factorizations", "{:d}"),
    ("ex43_median_ms", "ex43 way [ms]", "{:.0f}"),
    ("ex43_newton", "ex43 Newton/frame", "{:.2f}"),
    ("speedup", "speedup", "{:.1f}x"),
    ("budget_converged", "in budget: converged", "{:.0%}"),
    ("budget_residual", "in budget: median rel. residual", "{:.1e}"),
]


def format_realtime_table(rows) -> str:
    """The benchmark rows as a Markdown table."""
    return markdown_table(rows, _TABLE)


def realtime_benchmark(sizes=(2000, 8000, 16000, 32000), frames: int = 90, baseline_frames: int = 10,
                       budget_frames: int = 60, linear_solver: str = "reuse", out=None, progress=print) -> list[dict]:
    """Run the frame-rate benchmark; return one dict per size (and write JSON, CSV and a figure to ``out``).

    ``out`` is a folder: ``realtime.json``, ``realtime.csv`` and ``realtime.png`` go there.
    ``baseline_frames = 0`` skips the ex43-way run.
    """
    sizes = _check_sizes(sizes)
    for name, value in (("frames", frames), ("baseline_frames", baseline_frames), ("budget_frames", budget_frames)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ValueError(f"{name} must be a non-negative integer, got {value!r}")
    if frames < 1:
        raise ValueError(f"frames must be at least 1, got {frames!r}")
    say = progress if progress is not None else (lambda *_: None)

    # one untimed pass at the largest size warms the allocator up (see tissuefem.bench)
    problem, grab = flap_scene(max(sizes))
    _fast_frames(problem, grab, 3, linear_solver=linear_solver)

    rows = []
    for n in sizes:
        problem, grab = flap_scene(n)
        nel = problem.mesh.t.shape[1]
        say(f"realtime benchmark: {nel} triangles, {problem.basis.N} dofs ...")
        solver, reports = _fast_frames(problem, grab, frames, linear_solver=linear_solver)
        ms = np.array([1e3 * r.elapsed for r in reports])
        row = {
            "triangles": int(nel),
            "dofs": int(problem.basis.N),
            "frames": frames,
            "linear_solver": solver.linear_solver_name,
            "fast_median_ms": float(np.median(ms)),
            "fast_p95_ms": float(np.percentile(ms, 95)),
            "fast_fps": float(1e3 / np.median(ms)),
            "fast_newton": float(np.mean([r.newton_iterations for r in reports])),
            "fast_cg": float(np.mean([r.linear_iterations for r in reports])),
            "fast_factorizations": int(sum(r.factorizations for r in reports)),
            "fast_all_converged": bool(all(r.converged for r in reports)),
            "fast_ms": ms.tolist(),
        }
        if baseline_frames:
            base_problem, base_grab = flap_scene(n)
            base_ms, base_its, u_base = ex43_frames(base_problem, base_grab, min(baseline_frames, frames))
            same = ms[: base_ms.size]
            fast_u = _fast_frames(*flap_scene(n), base_ms.size, linear_solver=linear_solver)[0].u
            row.update({
                "ex43_frames": int(base_ms.size),
                "ex43_median_ms": float(np.median(base_ms)),
                "ex43_newton": float(np.mean(base_its)),
                "fast_median_same_frames_ms": float(np.median(same)),
                "speedup": float(np.median(base_ms) / np.median(same)),
                "max_state_difference": float(np.max(np.abs(fast_u - u_base))),
                "ex43_ms": base_ms.tolist(),
            })
        if budget_frames:
            _, budgeted = _fast_frames(*flap_scene(n), budget_frames, budget=FRAME_BUDGET, linear_solver=linear_solver)
            row.update({
                "budget_ms": FRAME_BUDGET * 1e3,
                "budget_converged": float(np.mean([r.converged for r in budgeted])),
                "budget_residual": float(np.median([r.relative_residual for r in budgeted])),
                "budget_p95_ms": float(np.percentile([1e3 * r.elapsed for r in budgeted], 95)),
            })
        rows.append(row)
        say(f"  median {row['fast_median_ms']:.1f} ms/frame ({row['fast_fps']:.0f} fps), "
            f"{row['fast_newton']:.2f} Newton/frame"
            + (f"; ex43 way {row['ex43_median_ms']:.0f} ms ({row['speedup']:.1f}x)" if baseline_frames else ""))

    say(format_realtime_table(rows))
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        record = {
            "benchmark": "realtime",
            "description": __doc__.strip().splitlines()[0],
            "scene": {"E": E_FLAP, "nu": NU_FLAP, "rho0": RHO_FLAP, "dt": DT_FLAP, "rtol": RTOL_FLAP,
                      "domain": "[0, 2] x [0, 1], left edge fixed, right edge on flap_path"},
            "settings": {"sizes": sizes, "frames": frames, "baseline_frames": baseline_frames,
                         "budget_frames": budget_frames, "linear_solver": linear_solver},
            "machine": machine_info(),
            "rows": rows,
        }
        with open(out / "realtime.json", "w", encoding="utf-8") as fh:
            json.dump(record, fh, indent=2)
            fh.write("\n")
        keys = [k for k in rows[0] if not isinstance(rows[0][k], list)]  # per-frame lists stay in the JSON
        with open(out / "realtime.csv", "w", encoding="utf-8", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
        plot_realtime(rows, out / "realtime.png")
        say(f"wrote {out / 'realtime.json'}, {out / 'realtime.csv'}, {out / 'realtime.png'}")
    return rows


def plot_realtime(rows, path=None):
    """ms per frame against mesh size (median and 95th percentile, ex43 way), with the 33 ms line."""
    from matplotlib.figure import Figure

    from ..figures.registry import save

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
