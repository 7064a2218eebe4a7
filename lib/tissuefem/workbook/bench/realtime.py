"""Frame-rate benchmark of the standard scenes: the real-time solver against the scikit-fem ex43 way.

One scene per dimension (:data:`SCENES`): the 2D flap dragged along :func:`flap_path`, the 3D block
(:func:`block_simulation`) along :func:`block_path`; backward Euler with ``dt = 1/30``, every frame converged to
a relative residual of 1e-6. Per mesh size: the real-time solver unbudgeted (**fast**) and with the 1/30 s
budget (**budgeted**), scikit-fem's hyperelasticity example's way (:func:`ex43_frames`) and a frame's floor
(:func:`frame_floor`); beside the times, each way's accuracy as its frames report it
(:func:`~tissuefem.engine.stepping.accuracy_summary`). :func:`solver_comparison` runs one scene with several
linear solvers, alternating, and measures what limits each. Compare columns of one run (``docs/benchmarks.md``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, asm, condense, solve
from skfem.helpers import dot

from ...engine.constants import FRAME_BUDGET, TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from ...engine.forms import residual_form, tangent_form
from ...engine.linsolve import LinearSolver, PreconditionedCG
from ...engine.materials import NeoHookean
from ...engine.meshes import box
from ...engine.model import Handle, Model
from ...engine.parameters import ParameterError, check_count, lame_parameters
from ...engine.realtime import RealtimeSolver
from ...engine.stepping import accuracy_summary
from ...surgery.scene import flap_path, flap_scene
from ...surgery.simulation import Simulation
from ..measure import median_time
from ..tables import markdown_table
from ..timestepping import flap_drag
from .common import check_sizes, load_average, machine_info, median_rows, recorded, write_record

__all__ = ["realtime_benchmark", "ex43_frames", "format_realtime_table", "flap_simulation", "frame_floor",
           "block_simulation", "block_path", "block_drag", "BlockSimulation", "SCENES", "solver_comparison",
           "format_comparison_table", "recorded_realtime", "recorded_realtime_table"]

RTOL_FLAP = 1e-6
#: the 3D block's edges ``(L, W, H)``: a bar twice as long as it is wide and high (cells of the same shape)
BLOCK = (2.0, 1.0, 1.0)


def flap_simulation(n_triangles: int, linear_solver: str = "reuse", rtol: float = RTOL_FLAP) -> Simulation:
    """The standard flap scene, built and ready to run (no budget: every frame converges to ``rtol``)."""
    return Simulation(flap_scene(n_triangles, rtol=rtol, linear_solver=linear_solver))


def block_path(t) -> np.ndarray:
    """The 3D block's scripted drag: its ``x = L`` face's displacement at time ``t`` (a slow loop out of the
    face's plane, period 4-8 s: :func:`flap_path`'s with a third component)."""
    t = float(t)
    return np.array([0.3 * math.sin(math.pi * t / 2.0), 0.4 * math.sin(math.pi * t / 4.0),
                     0.2 * (1.0 - math.cos(math.pi * t / 4.0))])


class BlockSimulation:
    """The 3D block's ``model`` and ``solver``, read like a :class:`~tissuefem.surgery.simulation.Simulation`."""

    def __init__(self, model: Model, solver: RealtimeSolver):
        self.model, self.solver = model, solver

    mesh = property(lambda self: self.model.mesh)
    u = property(lambda self: self.solver.u)
    frames = property(lambda self: self.solver.steps)

    def frame(self, targets=None):
        """One frame: the handles to ``targets`` (``{"grab": displacement}``), solved; its report."""
        return self.solver.step(targets)


def block_simulation(n_tetrahedra: int, linear_solver=None) -> BlockSimulation:
    """The 3D block ``[0, 2] x [0, 1] x [0, 1]`` of about ``n_tetrahedra`` (Neo-Hookean, E = 1000, nu = 0.3,
    rho0 = 1): its ``x = 0`` face held (``"held"``), its ``x = 2`` face a handle (``"grab"``) that
    :func:`block_path` carries; backward Euler with ``dt = 1/30``, every frame solved to 1e-6 with no wall-clock
    budget. ``linear_solver``: the real-time solver's default for a 3D model unless given."""
    n_tetrahedra = check_count("n_tetrahedra", n_tetrahedra, 6)
    m = max(1, round((n_tetrahedra / (6.0 * BLOCK[0] / BLOCK[1])) ** (1.0 / 3.0)))  # near-cubic cells, six tets each
    mesh = box(*BLOCK, max(1, round(n_tetrahedra / (6.0 * m * m))), m, m)
    model = Model(mesh, NeoHookean(*lame_parameters(TISSUE_E, TISSUE_NU)), dt=FRAME_BUDGET, density=TISSUE_DENSITY,
                  handles=[Handle("left", name="held"), Handle("right", (0.0, 0.0, 0.0), name="grab")])
    return BlockSimulation(model, RealtimeSolver(model, budget=1e9, rtol=RTOL_FLAP, linear_solver=linear_solver))


def block_drag(sim, frames: int, start: int = 0) -> list:
    """The reports of frames ``start + 1 ... start + frames`` of the block's drag along :func:`block_path`."""
    return [sim.frame({"grab": block_path((f + 1) * FRAME_BUDGET)}) for f in range(start, start + frames)]


@dataclass(frozen=True)
class BenchScene:
    """One dimension's scene of the benchmark: how to build it (``build(n, linear_solver)``) and drag it
    (``drag(sim, frames)``), its handle's path (``path(t)``, for the ex43 way), what its size counts
    (``elements``), its default sizes, linear solver and ex43 frames, and the record's name and description."""

    elements: str
    build: object
    drag: object
    path: object
    sizes: tuple
    linear_solver: object
    baseline_frames: int
    name: str
    domain: str


SCENES = {
    2: BenchScene("triangles", flap_simulation, flap_drag, flap_path, (2000, 8000, 16000, 32000), "reuse-background",
                  10, "realtime", "[0, 2] x [0, 1], left edge fixed, right edge on flap_path"),
    3: BenchScene("tetrahedra", block_simulation, block_drag, block_path, (5000, 19000, 40000, 100000), None, 0,
                  "realtime3d", "[0, 2] x [0, 1] x [0, 1], x = 0 face fixed, x = 2 face on block_path"),
}


def ex43_frames(model, n_frames: int, rtol: float = RTOL_FLAP, path=flap_path):
    """``(ms per frame, Newton iterations per frame, u)`` of ``n_frames`` the ex43 way (``asm``, ``condense``,
    ``solve`` every iteration; the mass lumped, ``dt = 1/30``) on ``model``, its second handle on ``path``
    (:func:`flap_path`; in 3D :func:`block_path`)."""
    basis, grab, dt = model.basis, model.handles[1], FRAME_BUDGET
    K_form, r_form = tangent_form(model.material), residual_form(model.material)
    mass = BilinearForm(lambda u, v, w: TISSUE_DENSITY * dot(u, v))
    M = sp.diags(np.asarray(asm(mass, basis).sum(axis=1)).ravel()).tocsr()
    u, v = basis.zeros(), basis.zeros()
    times, iterations = [], []
    for f in range(n_frames):
        grab.move(path((f + 1) * dt))
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


def _fast_frames(scene: BenchScene, n, n_frames, linear_solver="reuse"):
    sim = scene.build(n, linear_solver)
    return sim, scene.drag(sim, n_frames)


def _paced_frames(scene: BenchScene, n, n_frames, linear_solver):
    """Budgeted frames at the display's rate: each starts one budget after the one before (a step too long for a
    frame runs off it meanwhile, see :class:`~tissuefem.engine.realtime.RealtimeSolver`); the simulation (its steps
    committed by the end) and the frames' reports."""
    sim = scene.build(n, linear_solver)
    sim.solver.budget = FRAME_BUDGET
    reports, due = [], time.perf_counter()
    for f in range(n_frames):
        reports += scene.drag(sim, 1, start=f)
        due += FRAME_BUDGET
        time.sleep(max(due - time.perf_counter(), 0.0))
    sim.solver.settle()
    return sim, reports


def frame_floor(sim, repeats: int = 9) -> dict:
    """Median ms of a tangent assembly and of one back-substitution (by the backend the simulation's solver keeps;
    CG: one application of its preconditioner) at the simulation's state: their sum ``floor_ms`` is the least a
    frame costs. Also one factorization's ms (``factorization_ms``), the stored entries of the factors
    (``factor_nnz``; multigrid: every level's matrix) and of the tangent's free block (``matrix_nnz``)."""
    model, u = sim.model, sim.u
    free = np.isin(np.arange(model.n_dofs), model.prescribed()[0], invert=True)
    rhs = -model.gradient(u)[free]
    A, factorizing = sim.solver.linear.condense(model.hessian(u), free), sim.solver.linear.factorizing
    t0 = time.perf_counter()
    factor = factorizing.factorize(A)
    factorization = 1e3 * (time.perf_counter() - t0)
    # CG's floor is one application of its preconditioner (none: the iterative solve)
    apply = (factor.precondition if isinstance(factorizing, PreconditionedCG) else None) or factor.solve
    apply(rhs)  # a first solve may check its residual: untimed
    a = median_time(lambda: model.hessian(u), repeats)
    b = median_time(lambda: apply(rhs), repeats)
    return {"assembly_ms": a, "back_substitution_ms": b, "floor_ms": a + b, "factorization_ms": factorization,
            "factor_nnz": factor.nnz, "matrix_nnz": int(A.nnz)}


_COLUMNS = [("dofs", "dofs", "{:d}"), ("fast_median_ms", "median [ms]", "{:.1f}"),
            ("fast_p95_ms", "p95 [ms]", "{:.1f}"), ("fast_p99_ms", "p99 [ms]", "{:.1f}"), ("fast_fps", "fps", "{:.0f}"),
            ("fast_newton", "Newton/frame", "{:.2f}"), ("fast_cg", "CG/frame", "{:.1f}"),
            ("fast_factorizations", "factorizations", "{:d}"), ("floor_ms", "floor [ms]", "{:.1f}"),
            ("frame_over_floor", "frame / floor", "{:.1f}x"), ("ex43_median_ms", "ex43 way [ms]", "{:.0f}"),
            ("ex43_newton", "ex43 Newton/frame", "{:.2f}"), ("fast_residual", "median rel. residual", "{:.1e}"),
            ("fast_converged", "converged", "{:.0%}"), ("fast_min_J", "min J", "{:.3f}"),
            ("fast_inverted", "inverted", "{:d}"), ("speedup", "speedup", "{:.1f}x"),
            ("budget_converged", "in budget: converged", "{:.0%}"),
            ("budget_residual", "in budget: median rel. residual", "{:.1e}"),
            ("budget_min_J", "in budget: min J", "{:.3f}"), ("budget_inverted", "in budget: inverted", "{:d}"),
            ("budget_undone", "in budget: left undone", "{}"), ("budget_p95_ms", "in budget: p95 [ms]", "{:.1f}"),
            ("budget_p99_ms", "in budget: p99 [ms]", "{:.1f}"),
            ("budget_unconverged_residual", "in budget: worst unconverged rel. residual", "{:.1e}"),
            ("budget_off_frame", "in budget: frames with a step off the frame", "{:d}"),
            ("budget_steps", "in budget: steps committed", "{:d}")]


def _accuracy_columns(prefix: str, reports) -> dict:
    """The accuracy of a run of frames as the row's ``<prefix>_...`` columns (``left undone``: how many frames of
    how many left work to later ones, and what)."""
    a = accuracy_summary(reports)
    undone = f"{a['undone']}/{a['steps']}" + (f" ({', '.join(a['undone_reasons'])})" if a["undone"] else "")
    return {f"{prefix}_residual": a["scaled_residual"], f"{prefix}_converged": a["converged"],
            f"{prefix}_min_J": a["min_J"], f"{prefix}_inverted": a["inverted"], f"{prefix}_undone": undone}


#: the recorded table's columns (docs/benchmarks.md and chapter 7 print it): times, work, accuracy, the budgeted run
_RECORDED = [("triangles", "triangles", "{:d}"), ("fast_median_ms", "median ms/frame", "{:.1f}"),
             ("fast_p95_ms", "p95 ms", "{:.1f}"), ("fast_newton", "Newton/frame", "{:.2f}"),
             ("fast_cg", "CG/frame", "{:.1f}"), ("floor_ms", "floor ms", "{:.1f}"),
             ("frame_over_floor", "frame / floor", "{:.1f}x"), ("ex43_median_ms", "ex43 way ms/frame", "{:.0f}"),
             ("fast_converged", "converged", "{:.0%}"), ("budget_converged", "budgeted: converged", "{:.0%}"),
             ("budget_p99_ms", "budgeted: p99 ms", "{:.0f}"), ("budget_first_ms", "budgeted: first frame ms", "{:.0f}"),
             ("budget_p99_after_first_ms", "budgeted: p99 ms after the first", "{:.0f}"),
             ("budget_steps", "budgeted: steps in 60 frames", "{:.0f}"),
             ("budget_residual", "budgeted: median residual", "{:.0e}")]


def format_realtime_table(rows) -> str:
    """The benchmark rows as a Markdown table (the first column: triangles or tetrahedra)."""
    elements = "tetrahedra" if rows and "tetrahedra" in rows[0] else "triangles"
    return markdown_table(rows, [(elements, elements, "{:d}"), *_COLUMNS])


def recorded_realtime() -> tuple[list[dict], dict]:
    """The recorded run shipped with the package: its rounds joined (:func:`~.common.median_rows`: medians over the
    rounds; each row with its budgeted run's first frame, ``budget_first_ms``, which learns the costs, and the 99th
    percentile of the frames after it, ``budget_p99_after_first_ms``) and the record (``rounds``: each round's
    machine, with its load average at the start, and rows)."""
    record = recorded("realtime")
    rounds = [[{**row, "budget_first_ms": row["budget_frame_ms"][0],
                "budget_p99_after_first_ms": float(np.percentile(row["budget_frame_ms"][1:], 99))}
               for row in r["rows"]] for r in record["rounds"]]
    return median_rows(rounds, "triangles"), record


def recorded_realtime_table() -> str:
    """The recorded run as the Markdown table docs/benchmarks.md and chapter 7 show (medians over the rounds)."""
    return markdown_table(recorded_realtime()[0], _RECORDED)


def _frames_row(scene: BenchScene, sim, reports) -> dict:
    """The columns of a run of unbudgeted frames (``fast_...``) with the floor at its end state."""
    ms = np.array([1e3 * r.elapsed for r in reports])
    floor = frame_floor(sim)
    return {scene.elements: int(sim.mesh.t.shape[1]), "dofs": int(sim.model.n_dofs), "frames": len(reports),
            "linear_solver": sim.solver.linear_solver_name, "fast_median_ms": float(np.median(ms)),
            "fast_p95_ms": float(np.percentile(ms, 95)), "fast_p99_ms": float(np.percentile(ms, 99)),
            "fast_fps": float(1e3 / np.median(ms)),
            "fast_newton": float(np.mean([r.newton_iterations for r in reports])),
            "fast_cg": float(np.mean([r.linear_iterations for r in reports])),
            "fast_factorizations": int(sum(r.factorizations for r in reports)),
            "fast_all_converged": bool(all(r.converged for r in reports)), "fast_ms": ms.tolist(),
            **floor, "frame_over_floor": float(np.median(ms)) / floor["floor_ms"],
            **_accuracy_columns("fast", reports)}


def realtime_benchmark(sizes=None, frames: int = 90, baseline_frames: int | None = None, budget_frames: int = 60,
                       linear_solver=None, out=None, progress=print, dim: int = 2) -> list[dict]:
    """Run the benchmark of the ``dim``-dimensional scene (:data:`SCENES`); return one dict per size (and write
    JSON and CSV into ``out``: ``realtime.*`` in 2D, ``realtime3d.*`` in 3D). ``sizes`` (triangles or tetrahedra),
    ``baseline_frames`` (``0`` skips the ex43 way) and ``linear_solver`` default to the scene's."""
    scene = SCENES[check_count("dim", dim, 2, 3)]
    sizes = check_sizes(scene.sizes if sizes is None else sizes)
    frames = check_count("frames", frames, 1)
    baseline_frames = check_count("baseline_frames", scene.baseline_frames if baseline_frames is None
                                  else baseline_frames, 0)
    budget_frames = check_count("budget_frames", budget_frames, 0)
    linear_solver = scene.linear_solver if linear_solver is None else linear_solver
    say = progress if progress is not None else (lambda *_: None)
    machine = machine_info()  # at the start: the load average says how quiet the machine was

    # one untimed pass at the largest size warms the allocator up (see the assembly benchmark)
    _fast_frames(scene, max(sizes), 3, linear_solver=linear_solver)

    rows = []
    for n in sizes:
        row = _frames_row(scene, *_fast_frames(scene, n, frames, linear_solver=linear_solver))
        say(f"realtime benchmark: {row[scene.elements]} {scene.elements}, {row['dofs']} dofs ...")
        if baseline_frames:
            base_ms, base_its, u_base = ex43_frames(scene.build(n).model, min(baseline_frames, frames),
                                                    path=scene.path)
            same = np.asarray(row["fast_ms"][: base_ms.size])  # the fast way's frames the ex43 way also ran
            fast_u = _fast_frames(scene, n, base_ms.size, linear_solver=linear_solver)[0].u
            row.update({"ex43_frames": int(base_ms.size), "ex43_median_ms": float(np.median(base_ms)),
                        "ex43_newton": float(np.mean(base_its)), "fast_median_same_frames_ms": float(np.median(same)),
                        "speedup": float(np.median(base_ms) / np.median(same)),
                        "max_state_difference": float(np.max(np.abs(fast_u - u_base))), "ex43_ms": base_ms.tolist()})
        if budget_frames:
            paced, budgeted = _paced_frames(scene, n, budget_frames, linear_solver)
            budget_ms = [1e3 * r.elapsed for r in budgeted]
            # the residuals committed unconverged (a frame showing the last state while a step runs off the frame
            # commits nothing)
            unconverged = [r.scaled_residual for r in budgeted if not r.converged and r.committed]
            row.update({"budget_ms": FRAME_BUDGET * 1e3, **_accuracy_columns("budget", budgeted),
                        "budget_p95_ms": float(np.percentile(budget_ms, 95)),
                        "budget_p99_ms": float(np.percentile(budget_ms, 99)), "budget_frame_ms": budget_ms,
                        "budget_unconverged_residual": float(max(unconverged)) if unconverged else float("nan"),
                        "budget_unconverged_residuals": unconverged,
                        "budget_off_frame": sum(r.off_frame == "running" for r in budgeted),
                        "budget_steps": int(paced.frames)})
        rows.append(row)
        say(f"  median {row['fast_median_ms']:.1f} ms/frame ({row['fast_fps']:.0f} fps), p95 {row['fast_p95_ms']:.1f}"
            f" ms, {row['fast_newton']:.2f} Newton/frame, {row['frame_over_floor']:.1f}x the floor; median rel. "
            f"residual {row['fast_residual']:.1e}, {row['fast_converged']:.0%} converged, min J "
            f"{row['fast_min_J']:.3f}, {row['fast_inverted']} inverted"
            + (f"; ex43 way {row['ex43_median_ms']:.0f} ms ({row['speedup']:.1f}x)" if baseline_frames else ""))

    say(format_realtime_table(rows))
    write_record(out, scene.name, {
        "benchmark": scene.name, "description": __doc__.strip().splitlines()[0],
        "scene": {"dim": dim, "E": TISSUE_E, "nu": TISSUE_NU, "rho0": TISSUE_DENSITY, "dt": FRAME_BUDGET,
                  "rtol": RTOL_FLAP, "domain": scene.domain},
        "settings": {"sizes": sizes, "frames": frames, "baseline_frames": baseline_frames,
                     "budget_frames": budget_frames, "linear_solver": rows[0]["linear_solver"]},
        "machine": machine, "rows": rows}, rows, say)
    return rows


# --- linear solvers compared on one scene ----------------------------------------------------------------------

#: The approaches :func:`solver_comparison` runs by default (those whose optional package is missing are left
#: out): the kept SuperLU factorization refreshed in the frame (``reuse``) and in the background, CHOLMOD and
#: PARDISO kept and refreshed in the background, and smoothed-aggregation multigrid with the rigid-body modes
#: as CG's kept preconditioner.
APPROACHES = ("reuse", "reuse-background", "reuse-background-cholmod", "reuse-background-pardiso",
              "reuse-background-cg-amg")


def _usable(name: str) -> bool:
    """Whether the approach ``name`` runs here (a known linear solver, its optional package installed)."""
    try:
        LinearSolver(name)
    except ParameterError:
        return False
    return True


_COMPARISON = [("linear_solver", "linear solver", "{}"), ("fast_median_ms", "median [ms]", "{:.1f}"),
               ("fast_p95_ms", "p95 [ms]", "{:.1f}"), ("fast_newton", "Newton/frame", "{:.2f}"),
               ("fast_cg", "CG/frame", "{:.1f}"), ("fast_factorizations", "factorizations", "{:g}"),
               ("factorization_ms", "factorization [ms]", "{:.0f}"),
               ("back_substitution_ms", "back-substitution [ms]", "{:.1f}"), ("assembly_ms", "assembly [ms]", "{:.1f}"),
               ("fill", "nnz(factors) / nnz(K)", "{:.1f}"), ("floor_ms", "floor [ms]", "{:.1f}"),
               ("frame_over_floor", "frame / floor", "{:.1f}x"), ("fast_converged", "converged", "{:.0%}")]


def format_comparison_table(rows) -> str:
    """:func:`solver_comparison`'s rows (one per approach) as a Markdown table."""
    return markdown_table(rows, _COMPARISON, text_columns=1)


def solver_comparison(n: int = 19000, approaches=APPROACHES, frames: int = 60, rounds: int = 2, dim: int = 3,
                      out=None, progress=print) -> list[dict]:
    """Run the ``dim``-dimensional scene at size ``n`` with each linear solver of ``approaches`` (those that run
    here), ``rounds`` times, alternating (so a busy machine weighs on each alike); one row per approach: the
    medians over rounds of each round's columns (as :func:`realtime_benchmark`'s, with the factorization's ms and
    the fill ``nnz(factors) / nnz(K)``), each round's median and the machine's load before each."""
    scene = SCENES[check_count("dim", dim, 2, 3)]
    n, frames, rounds = check_count("n", n), check_count("frames", frames), check_count("rounds", rounds)
    names = [a for a in approaches if _usable(a)]
    if not names:
        raise ParameterError("approaches", f"approaches: none of {list(approaches)} runs here (unknown, or their "
                                           "optional packages are missing)")
    say = progress if progress is not None else (lambda *_: None)
    runs, loads = [[] for _ in range(rounds)], []
    for r in range(rounds):
        for a in names:
            loads.append(load_average())
            sim, reports = _fast_frames(scene, n, frames, linear_solver=a)
            row = {"approach": a, **_frames_row(scene, sim, reports)}
            sim.solver.linear.close()
            runs[r].append(row)
            say(f"round {r + 1}, {a}: median {row['fast_median_ms']:.1f} ms, p95 {row['fast_p95_ms']:.1f} ms, "
                f"{row['fast_newton']:.2f} Newton and {row['fast_cg']:.1f} CG a frame, factorization "
                f"{row['factorization_ms']:.0f} ms, back-substitution {row['back_substitution_ms']:.1f} ms")
    rows = [{**row, "fill": row["factor_nnz"] / row["matrix_nnz"] if row["factor_nnz"] else None,
             "round_medians_ms": [run[i]["fast_median_ms"] for run in runs],
             "round_p95_ms": [run[i]["fast_p95_ms"] for run in runs]}
            for i, row in enumerate(median_rows(runs, "approach"))]
    say(format_comparison_table(rows))
    write_record(out, f"{scene.name}_solvers", {
        "benchmark": f"{scene.name}-solvers", "description": solver_comparison.__doc__.split(".")[0],
        "scene": {"dim": dim, "domain": scene.domain, "rtol": RTOL_FLAP, "dt": FRAME_BUDGET},
        "settings": {"n": n, "frames": frames, "rounds": rounds, "approaches": names},
        "load_before_each_run": loads, "machine": machine_info(), "rows": rows}, rows, say)
    return rows
