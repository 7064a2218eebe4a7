"""Frame-rate benchmark of the standard scene: the real-time solver against the scikit-fem ex43 way.

The standard flap scene, per mesh size: its real-time solver unbudgeted (**fast**) and with the 1/30 s budget
(**budgeted**), scikit-fem's hyperelasticity example's way (:func:`ex43_frames`) and a frame's floor
(:func:`frame_floor`). Beside the times, each way's accuracy as its frames report it
(:func:`~tissuefem.engine.stepping.accuracy_summary`): the median relative residual, the share converged, the
smallest ``J`` and the most inverted elements, and for budgeted frames their 95th and 99th percentile times, what
they left undone and the largest residual an unconverged one committed. Compare columns of one run
(``docs/benchmarks.md``).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, asm, condense, solve

from ...engine.constants import FRAME_BUDGET, TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from ...engine.forms import residual_form, tangent_form
from ...engine.linsolve import LinearSolver
from ...engine.parameters import check_count
from ...engine.stepping import accuracy_summary
from ...surgery.scene import flap_path, flap_scene
from ...surgery.simulation import Simulation
from ..measure import median_time
from ..tables import markdown_table
from ..timestepping import flap_drag
from .common import check_sizes, machine_info, median_rows, recorded, write_csv, write_json

__all__ = ["realtime_benchmark", "ex43_frames", "format_realtime_table", "flap_simulation", "frame_floor",
           "recorded_realtime", "recorded_realtime_table"]

RTOL_FLAP = 1e-6


def flap_simulation(n_triangles: int, linear_solver: str = "reuse") -> Simulation:
    """The standard flap scene, built and ready to run (no budget: every frame converges)."""
    return Simulation(flap_scene(n_triangles, rtol=RTOL_FLAP, linear_solver=linear_solver))


def ex43_frames(model, n_frames: int, dt: float = FRAME_BUDGET, rtol: float = RTOL_FLAP, density=TISSUE_DENSITY,
                lumped: bool = True):
    """``(ms per frame, Newton iterations per frame, u)`` of ``n_frames`` the ex43 way (``asm``, ``condense``,
    ``solve`` every iteration; the mass lumped by default) on ``model``, its second handle on
    :func:`flap_path`."""
    basis = model.basis
    grab = model.handles[1]
    K_form, r_form = tangent_form(model.material), residual_form(model.material)

    @BilinearForm
    def mass(u, v, w):
        return density * (u[0] * v[0] + u[1] * v[1])

    M = asm(mass, basis)
    if lumped:
        M = sp.diags(np.asarray(M.sum(axis=1)).ravel()).tocsr()
    u, v = basis.zeros(), basis.zeros()
    times, iterations = [], []
    for f in range(n_frames):
        grab.move(flap_path((f + 1) * dt))
        t0 = time.perf_counter()
        fixed, values = model.prescribed()
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


def _fast_frames(n_triangles, n_frames, budget=None, linear_solver="reuse"):
    sim = flap_simulation(n_triangles, linear_solver)
    if budget is not None:
        sim.solver.budget = budget
    return sim, flap_drag(sim, n_frames)


def frame_floor(sim, repeats: int = 9) -> dict:
    """Median ms of a tangent assembly and of one back-substitution at the simulation's state: their sum, the
    least a frame costs (``floor_ms``)."""
    model, u = sim.model, sim.u
    fixed, _ = model.prescribed()
    free = np.ones(model.n_dofs, dtype=bool)
    free[fixed] = False
    linear = LinearSolver("constant")
    rhs = -model.gradient(u)[free]
    linear.solve(linear.matrix(lambda: model.hessian(u), free), rhs)  # factorize once, untimed
    a = median_time(lambda: model.hessian(u), repeats)
    b = median_time(lambda: linear.solve(None, rhs), repeats)
    return {"assembly_ms": a, "back_substitution_ms": b, "floor_ms": a + b}


_TABLE = [
    ("triangles", "triangles", "{:d}"), ("dofs", "dofs", "{:d}"), ("fast_median_ms", "median [ms]", "{:.1f}"),
    ("fast_p95_ms", "p95 [ms]", "{:.1f}"), ("fast_fps", "fps", "{:.0f}"), ("fast_newton", "Newton/frame", "{:.2f}"),
    ("fast_cg", "CG/frame", "{:.1f}"), ("fast_factorizations", "factorizations", "{:d}"),
    ("floor_ms", "floor [ms]", "{:.1f}"), ("frame_over_floor", "frame / floor", "{:.1f}x"),
    ("ex43_median_ms", "ex43 way [ms]", "{:.0f}"), ("ex43_newton", "ex43 Newton/frame", "{:.2f}"),
    ("fast_residual", "median rel. residual", "{:.1e}"), ("fast_converged", "converged", "{:.0%}"),
    ("fast_min_J", "min J", "{:.3f}"), ("fast_inverted", "inverted", "{:d}"),
    ("speedup", "speedup", "{:.1f}x"), ("budget_converged", "in budget: converged", "{:.0%}"),
    ("budget_residual", "in budget: median rel. residual", "{:.1e}"), ("budget_min_J", "in budget: min J", "{:.3f}"),
    ("budget_inverted", "in budget: inverted", "{:d}"), ("budget_undone", "in budget: left undone", "{}"),
    ("budget_p95_ms", "in budget: p95 [ms]", "{:.1f}"), ("budget_p99_ms", "in budget: p99 [ms]", "{:.1f}"),
    ("budget_unconverged_residual", "in budget: worst unconverged rel. residual", "{:.1e}"),
]


def _accuracy_columns(prefix: str, reports) -> dict:
    """The accuracy of a run of frames as the row's ``<prefix>_...`` columns (``left undone``: how many frames of
    how many left work to later ones, and what)."""
    a = accuracy_summary(reports)
    undone = f"{a['undone']}/{a['steps']}" + (f" ({', '.join(a['undone_reasons'])})" if a["undone"] else "")
    return {f"{prefix}_residual": a["scaled_residual"], f"{prefix}_converged": a["converged"],
            f"{prefix}_min_J": a["min_J"], f"{prefix}_inverted": a["inverted"], f"{prefix}_undone": undone}


#: the recorded table's columns (docs/benchmarks.md and chapter 7 print it): times, work, accuracy, the budgeted run
_RECORDED = [
    ("triangles", "triangles", "{:d}"), ("fast_median_ms", "median ms/frame", "{:.1f}"), ("fast_p95_ms", "p95 ms", "{:.1f}"),
    ("fast_newton", "Newton/frame", "{:.2f}"), ("fast_cg", "CG/frame", "{:.1f}"), ("floor_ms", "floor ms", "{:.1f}"),
    ("frame_over_floor", "frame / floor", "{:.1f}x"), ("ex43_median_ms", "ex43 way ms/frame", "{:.0f}"),
    ("fast_converged", "converged", "{:.0%}"), ("budget_converged", "budgeted: converged", "{:.0%}"),
    ("budget_p95_ms", "budgeted: p95 ms", "{:.0f}"), ("budget_p99_ms", "budgeted: p99 ms", "{:.0f}"),
    ("budget_residual", "budgeted: median residual", "{:.0e}"),
]


def format_realtime_table(rows) -> str:
    """The benchmark rows as a Markdown table."""
    return markdown_table(rows, _TABLE)


def recorded_realtime() -> tuple[list[dict], dict]:
    """The recorded run shipped with the package: its rounds joined (:func:`~.common.median_rows`: medians over the
    rounds) and the record (``rounds``: each round's machine, with its load average at the start, and rows)."""
    record = recorded("realtime")
    return median_rows([r["rows"] for r in record["rounds"]], "triangles"), record


def recorded_realtime_table() -> str:
    """The recorded run as the Markdown table docs/benchmarks.md and chapter 7 show (medians over the rounds)."""
    return markdown_table(recorded_realtime()[0], _RECORDED)


def realtime_benchmark(sizes=(2000, 8000, 16000, 32000), frames: int = 90, baseline_frames: int = 10,
                       budget_frames: int = 60, linear_solver: str = "reuse-background", out=None,
                       progress=print) -> list[dict]:
    """Run the benchmark; return one dict per size (and write JSON and CSV into ``out``); ``baseline_frames =
    0`` skips the ex43 way."""
    sizes = check_sizes(sizes)
    frames = check_count("frames", frames, 1)
    baseline_frames = check_count("baseline_frames", baseline_frames, 0)
    budget_frames = check_count("budget_frames", budget_frames, 0)
    say = progress if progress is not None else (lambda *_: None)
    machine = machine_info()  # at the start: the load average says how quiet the machine was

    # one untimed pass at the largest size warms the allocator up (see the assembly benchmark)
    _fast_frames(max(sizes), 3, linear_solver=linear_solver)

    rows = []
    for n in sizes:
        sim, reports = _fast_frames(n, frames, linear_solver=linear_solver)
        nel = sim.mesh.t.shape[1]
        say(f"realtime benchmark: {nel} triangles, {sim.model.n_dofs} dofs ...")
        ms = np.array([1e3 * r.elapsed for r in reports])
        floor = frame_floor(sim)
        row = {"triangles": int(nel), "dofs": int(sim.model.n_dofs), "frames": frames,
               "linear_solver": sim.solver.linear_solver_name, "fast_median_ms": float(np.median(ms)),
               "fast_p95_ms": float(np.percentile(ms, 95)), "fast_fps": float(1e3 / np.median(ms)),
               "fast_newton": float(np.mean([r.newton_iterations for r in reports])),
               "fast_cg": float(np.mean([r.linear_iterations for r in reports])),
               "fast_factorizations": int(sum(r.factorizations for r in reports)),
               "fast_all_converged": bool(all(r.converged for r in reports)), "fast_ms": ms.tolist(),
               **floor, "frame_over_floor": float(np.median(ms)) / floor["floor_ms"],
               **_accuracy_columns("fast", reports)}
        if baseline_frames:
            base_ms, base_its, u_base = ex43_frames(flap_simulation(n).model, min(baseline_frames, frames))
            same = ms[: base_ms.size]
            fast_u = _fast_frames(n, base_ms.size, linear_solver=linear_solver)[0].u
            row.update({"ex43_frames": int(base_ms.size), "ex43_median_ms": float(np.median(base_ms)),
                        "ex43_newton": float(np.mean(base_its)), "fast_median_same_frames_ms": float(np.median(same)),
                        "speedup": float(np.median(base_ms) / np.median(same)),
                        "max_state_difference": float(np.max(np.abs(fast_u - u_base))), "ex43_ms": base_ms.tolist()})
        if budget_frames:
            _, budgeted = _fast_frames(n, budget_frames, budget=FRAME_BUDGET, linear_solver=linear_solver)
            budget_ms = [1e3 * r.elapsed for r in budgeted]
            unconverged = [r.scaled_residual for r in budgeted if not r.converged]
            row.update({"budget_ms": FRAME_BUDGET * 1e3, **_accuracy_columns("budget", budgeted),
                        "budget_p95_ms": float(np.percentile(budget_ms, 95)),
                        "budget_p99_ms": float(np.percentile(budget_ms, 99)), "budget_frame_ms": budget_ms,
                        "budget_unconverged_residual": float(max(unconverged)) if unconverged else float("nan"),
                        "budget_unconverged_residuals": unconverged})
        rows.append(row)
        say(f"  median {row['fast_median_ms']:.1f} ms/frame ({row['fast_fps']:.0f} fps), "
            f"{row['fast_newton']:.2f} Newton/frame, {row['frame_over_floor']:.1f}x the floor; median rel. residual "
            f"{row['fast_residual']:.1e}, {row['fast_converged']:.0%} converged, min J {row['fast_min_J']:.3f}, "
            f"{row['fast_inverted']} inverted"
            + (f"; ex43 way {row['ex43_median_ms']:.0f} ms ({row['speedup']:.1f}x)" if baseline_frames else ""))

    say(format_realtime_table(rows))
    if out is not None:
        record = {"benchmark": "realtime", "description": __doc__.strip().splitlines()[0],
                  "scene": {"E": TISSUE_E, "nu": TISSUE_NU, "rho0": TISSUE_DENSITY, "dt": FRAME_BUDGET,
                            "rtol": RTOL_FLAP, "domain": "[0, 2] x [0, 1], left edge fixed, right edge on flap_path"},
                  "settings": {"sizes": sizes, "frames": frames, "baseline_frames": baseline_frames,
                               "budget_frames": budget_frames, "linear_solver": linear_solver},
                  "machine": machine, "rows": rows}
        written = [write_json(Path(out) / "realtime.json", record), write_csv(Path(out) / "realtime.csv", rows)]
        say("wrote " + ", ".join(str(w) for w in written))
    return rows
