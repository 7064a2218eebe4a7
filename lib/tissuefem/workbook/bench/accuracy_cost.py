"""What accuracy costs in time: chapter 9's measured study (``python -m tissuefem bench accuracy``).

Each knob of :data:`KNOBS` is turned one at a time away from a baseline :class:`Setting` on two benchmarks:
``flap``, the standard flap scene (backward Euler, 1/30 s a frame) with its drag eased in
(:func:`eased_flap_path`: after a jump backward Euler converges like ``dt^0.4``, too slowly to check any
reference), and ``block``, chapter 4's block carried quasistatically to :data:`BLOCK_TARGET`. *Cost*: the
median wall time per displayed frame; *error*: the relative ``L2`` displacement error against
:func:`reference_run` (P2 on :func:`graded_flap`, Newton to ``1e-10``, Richardson in time for the flap), whose
own estimated error (:func:`_estimate`) must lie ten times below every setting's. Timings are one machine's
medians: compare within a run, never assert them; the errors are deterministic (``docs/benchmarks.md``).
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ...engine.constants import FRAME_BUDGET, TISSUE_DENSITY, TISSUE_E, TISSUE_NU
from ...engine.linsolve import LinearSolver, available
from ...engine.materials import MATERIALS, material as make_material
from ...engine.meshes import flap
from ...engine.model import Handle, Model
from ...engine.parameters import check_count, check_real, require, string
from ...engine.realtime import RealtimeSolver
from ...engine.stepping import accuracy_summary, solve
from ...surgery.scene import Scene, flap_path, flap_scene
from ...surgery.simulation import Simulation
from ..verification import beam_problem_tip, manufactured_convergence
from ..measure import fitted_exponent, pareto_front, relative_l2_error
from ..tables import markdown_table
from .common import DATA, load_results, machine_info, write_csv, write_json

__all__ = [
    "Setting", "KNOBS", "PLANS", "BLOCK_TARGET", "EASE_IN", "REFERENCE_GRADING", "eased_flap_path", "graded_flap",
    "make_simulation", "run_setting", "reference_run", "knob_sweep", "solver_scaling", "budget_residual",
    "capped_newton_experiment", "time_convergence", "accuracy_study", "write_results", "read_results",
    "recorded_results", "format_knob_table",
]

#: Where the quasistatic benchmark's handle ends: the right edge moved by (0.6, 0.4), as in chapter 4.
BLOCK_TARGET = (0.6, 0.4)
BENCHMARKS = ("flap", "block")
#: Seconds over which the flap benchmark eases its drag in (:func:`eased_flap_path`).
EASE_IN = 0.5
#: How strongly the reference meshes are graded towards the rectangle's edges (:func:`graded_flap`).
REFERENCE_GRADING = 1.5


def eased_flap_path(t) -> np.ndarray:
    """:func:`~tissuefem.surgery.scene.flap_path` times the smooth step ``10 tau^3 - 15 tau^4 + 6 tau^5``,
    ``tau = t / EASE_IN``: the edge starts at rest with zero acceleration."""
    tau = min(max(float(t) / EASE_IN, 0.0), 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2) * flap_path(t)


def _graded(xi, grading: float) -> np.ndarray:
    """``[0, 1] -> [0, 1]``, symmetric, with slope ``~ (distance to the nearer end)^(grading - 1)`` at the ends."""
    xi = np.asarray(xi, dtype=float)
    return np.where(xi <= 0.5, 0.5 * (2.0 * xi) ** grading, 1.0 - 0.5 * (2.0 * (1.0 - xi)) ** grading)


def graded_flap(n_triangles: int, grading: float = REFERENCE_GRADING):
    """:func:`~tissuefem.engine.meshes.flap` (same topology and boundaries) with each coordinate mapped by ``x
    -> 0.5 (2 x)^grading`` on its lower half, symmetrically above: cells shrink towards the corners, where the
    solution is singular (``grading = 1``: uniform)."""
    mesh = flap(n_triangles=int(n_triangles))
    width, height = mesh.p[0].max(), mesh.p[1].max()
    p = np.vstack([width * _graded(mesh.p[0] / width, grading), height * _graded(mesh.p[1] / height, grading)])
    return replace(mesh, doflocs=p)


@dataclass(frozen=True)
class Setting:
    """One setting of every knob. The defaults are the study's baseline (each plan sets the mesh size)."""

    triangles: int = 8000
    order: int = 1
    intorder: int | None = None  # quadrature degree; None: 2 * order
    material: str = "neo-hookean"
    rtol: float = 1e-6  # Newton: converged when |grad E| <= rtol |grad E(x0)| (per frame)
    max_iterations: int = 50  # Newton iterations per frame at most
    substeps: int = 1  # backward-Euler steps per displayed frame (dt = 1/30 / substeps)
    linear_solver: str = "reuse"

    def check(self) -> "Setting":
        for name in ("triangles", "max_iterations", "substeps"):
            check_count(f"setting {name}", getattr(self, name))
        check_count("setting order", self.order, 1, 2)
        string("setting material", self.material, sorted(MATERIALS))
        check_real("setting rtol", self.rtol, 0.0, 1.0, lo_open=True, hi_open=True)
        string("setting linear_solver", self.linear_solver)
        try:
            LinearSolver(self.linear_solver) if _runnable(self.linear_solver) else None
        except ValueError as err:
            raise ValueError(f"setting linear_solver: {err}") from None
        return self


#: The knobs and what each ``value`` changes in the baseline (the plan gives the values, and the quadrature
#: knob's mesh).
_CHANGES = {
    "mesh": lambda value, plan: {"triangles": int(value)},
    "P2": lambda value, plan: {"triangles": int(value), "order": 2},
    "quadrature": lambda value, plan: {"triangles": int(plan["knobs"]["quadrature_triangles"]), "order": 2,
                                       "intorder": int(value)},
    "material": lambda value, plan: {"material": value},
    "newton_tolerance": lambda value, plan: {"rtol": float(value)},
    "newton_cap": lambda value, plan: {"max_iterations": int(value), "rtol": 1e-12},
    "time_step": lambda value, plan: {"substeps": int(value)},
    "linear_solver": lambda value, plan: {"linear_solver": value},
}
KNOBS = tuple(_CHANGES)

_MATERIALS = ("linear", "corotated", "neo-hookean", "stable-neo-hookean", "taylor-neo-hookean")
_SOLVERS = ("reuse", "direct", "superlu-colamd", "cg-ilu", "cg-jacobi", "pardiso", "reuse-pardiso")

#: Sweep plans: ``full`` for the CLI, ``reduced`` for chapter 9's notebook, ``tiny`` for the tests.
PLANS = {
    "full": {
        "base_triangles": 8000, "frames": 30,
        "checkpoints": 5,  # the flap's error is the largest over every 5th frame
        "block_frames": 10,
        # the flap's reference: P2 on 8000 graded triangles, 16 and 32 substeps; the block's on 32000
        "reference": {"triangles": 8000, "substeps": 16, "block_triangles": 32000, "grading": REFERENCE_GRADING},
        "knobs": {"mesh": (500, 1000, 2000, 4000, 8000, 16000, 32000), "P2": (250, 500, 1000, 2000, 4000),
                  "quadrature": (2, 3, 4, 6), "quadrature_triangles": 2000, "material": _MATERIALS,
                  "newton_tolerance": (1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 1e-8), "newton_cap": (1, 2, 3),
                  "time_step": (1, 2, 4), "linear_solver": _SOLVERS},
        # the slow solvers stop at 8k triangles (at 32k one CG-ILU frame takes minutes)
        "scaling": {"sizes": (500, 1000, 2000, 4000, 8000, 16000, 32000), "frames": 8,
                    "solvers": ("reuse", "direct", "superlu-colamd", "cg-ilu", "cg-jacobi", "pardiso"),
                    "largest": {"cg-ilu": 8000, "cg-jacobi": 8000, "pardiso": 8000}},
        "budget": {"sizes": (1000, 2000, 4000, 8000, 16000, 32000), "frames": 30, "solvers": ("reuse",)},
    },
    "reduced": {
        "base_triangles": 1000, "frames": 15, "checkpoints": 5, "block_frames": 5,
        "reference": {"triangles": 2000, "substeps": 4},
        "knobs": {"mesh": (250, 500, 1000, 2000), "P2": (250, 500), "quadrature": (2, 4), "quadrature_triangles": 250,
                  "material": ("linear", "corotated", "neo-hookean", "stable-neo-hookean"),
                  "newton_tolerance": (1e-1, 1e-3, 1e-6), "newton_cap": (1, 2), "time_step": (1, 2, 4),
                  "linear_solver": ("reuse", "direct", "cg-ilu", "cg-jacobi")},
        "scaling": {"sizes": (500, 1000, 2000, 4000), "frames": 5, "solvers": ("reuse", "direct", "cg-jacobi")},
        "budget": {"sizes": (1000, 4000), "frames": 10, "solvers": ("reuse",)},
    },
    "tiny": {
        "base_triangles": 200, "frames": 4, "checkpoints": 2, "block_frames": 2,
        "reference": {"triangles": 400, "substeps": 2},
        "knobs": {"mesh": (100, 200), "P2": (100,), "quadrature": (2, 4), "quadrature_triangles": 100,
                  "material": ("linear", "neo-hookean"), "newton_tolerance": (1e-2, 1e-6), "newton_cap": (1,),
                  "time_step": (1, 2), "linear_solver": ("reuse", "direct", "cg-jacobi", "cg-ilu", "superlu-colamd")},
        "scaling": {"sizes": (100, 200), "frames": 2, "solvers": ("reuse", "cg-jacobi")},
        "budget": {"sizes": (100, 200), "frames": 2, "solvers": ("reuse",)},
    },
}


# --- one run ---------------------------------------------------------------------------------------

def _runnable(linear_solver: str) -> bool:
    """Whether this machine has the solver (PARDISO needs the optional pypardiso)."""
    return "pardiso" not in linear_solver or available("pardiso")


def make_simulation(setting: Setting, benchmark: str = "flap", budget=math.inf, clock=time.perf_counter) -> Simulation:
    """The standard flap scene with ``setting``: ``"flap"`` backward Euler at ``dt = 1/30 / substeps`` (P2
    with the consistent mass: lumping gives its vertices none), ``"block"`` quasistatic. A linear material
    runs on its constant factorization, hence its cheap row. Under a ``budget`` every step stays on its frame
    (``off_frame = False``): the study measures what an unfinished frame leaves, frame by frame, not a step that
    runs off the frame (chapter 7's benchmark shows that)."""
    setting.check()
    scene = flap_scene(setting.triangles, model=setting.material, dynamic=benchmark == "flap",
                       rtol=setting.rtol, linear_solver=setting.linear_solver).to_dict()
    scene["solver"]["max_iterations"] = setting.max_iterations
    if benchmark == "flap":
        scene["effects"]["inertia"] = {"time_step": FRAME_BUDGET / setting.substeps,
                                       "mass": "consistent" if setting.order == 2 else "lumped"}
    sim = Simulation(Scene.from_dict(scene), order=setting.order, intorder=setting.intorder, clock=clock)
    sim.solver.budget = budget
    sim.solver.off_frame = False
    return sim


def _checkpoints(benchmark: str, frames: int, every: int) -> tuple[int, ...]:
    """The frames whose state is kept: every ``every``-th and the last (the block: its last)."""
    return tuple(f for f in range(1, frames + 1) if f == frames or (benchmark == "flap" and f % every == 0))


def run_setting(benchmark: str, setting: Setting, frames: int, checkpoints=(), budget=math.inf,
                clock=time.perf_counter, drag=None):
    """Run ``frames`` displayed frames of ``benchmark`` with ``setting`` (``drag(t)``: the flap's path,
    default :func:`eased_flap_path`): ``(model, states, stats)``, ``states`` a copy of ``u`` at each
    checkpoint frame, ``stats`` the ms per frame (over substeps), iterations, convergence, residuals."""
    if string("benchmark", benchmark, BENCHMARKS) == "block" and setting.substeps != 1:
        raise ValueError("the quasistatic block has no time step: substeps must be 1")
    sim = make_simulation(setting, benchmark, budget=budget, clock=clock)
    states, stats = _drive(sim.solver, benchmark, frames, setting.substeps, checkpoints, drag)
    return sim.model, states, stats


#: what a run keeps of each frame's report (not the report: it holds the state, and a run has thousands)
_KEPT = ("newton_iterations", "linear_iterations", "factorizations", "converged", "relative_residual",
         "handle_fraction", "scaled_residual", "min_J", "inverted", "undone")


def _drive(solver, benchmark: str, frames: int, substeps: int, checkpoints=(), drag=None):
    """``frames`` displayed frames of ``substeps`` solver frames each: ``(states, stats)`` (:func:`run_setting`)."""
    states, ms, kept = {}, [], []
    for f in range(1, frames + 1):
        spent = 0.0
        for s in range(1, substeps + 1):
            target = ((drag or eased_flap_path)((f - 1 + s / substeps) * FRAME_BUDGET) if benchmark == "flap"
                      else np.array(BLOCK_TARGET) * f / frames)
            report = solver.frame({"handle": target})
            spent += report.elapsed
            kept.append(SimpleNamespace(**{k: getattr(report, k) for k in _KEPT}))
        ms.append(1e3 * spent)
        if f in checkpoints:
            states[f] = solver.u.copy()
    each = {k: [getattr(r, k) for r in kept] for k in _KEPT}
    # each frame's own accuracy: the smallest J, the most inverted elements, the frames that left work undone
    summary = accuracy_summary(kept)
    return states, {
        "ms": ms, "ms_median": float(np.median(ms)), "ms_p95": float(np.percentile(ms, 95)),
        # per displayed frame (all substeps)
        "newton": float(np.sum(each["newton_iterations"]) / frames),
        "linear_iterations": float(np.sum(each["linear_iterations"]) / frames),
        "factorizations": int(np.sum(each["factorizations"])), "converged_share": float(np.mean(each["converged"])),
        # Newton's own ratio ||g|| / ||g(start)||: a frame whose start is already good shows it large (up to 1)
        # and still converged, judged on the residual over the larger load scale (scaled_residual)
        "residual_median": float(np.median(each["relative_residual"])),
        # the smallest share of its motion a handle made in one frame (< 1: a frame could not move it all the
        # way without inverting elements, and the real-time solver kept the state valid instead)
        "handle_fraction_min": float(np.min(each["handle_fraction"])),
        "finite": bool(np.all(np.isfinite(solver.u))), "scaled_residual_median": summary["scaled_residual"],
        "min_J": summary["min_J"], "inverted": summary["inverted"], "undone_frames": summary["undone"],
        "undone_reasons": summary["undone_reasons"],
    }


def _reference_model(benchmark: str, triangles: int, grading: float, substeps: int = 1) -> Model:
    """The reference's model: P2 on :func:`graded_flap`, the benchmark's material, handles and (flap) inertia."""
    mesh = graded_flap(triangles, grading)
    dt = FRAME_BUDGET / substeps if benchmark == "flap" else None
    return Model(mesh, make_material("neo-hookean", TISSUE_E, TISSUE_NU), order=2, density=TISSUE_DENSITY,
                 dt=dt, mass="consistent", handles=[Handle("fixed", name="fixed"), Handle("handle", name="handle")])


def _reference_states(benchmark: str, triangles: int, grading: float, frames: int, checkpoints, substeps=None):
    """One reference solution at the checkpoints, ``(model, {frame: u})``: the block's final equilibrium by
    load stepping (finer until no step inverts the graded mesh's thinnest cells), the flap by backward Euler
    with ``substeps`` steps per frame; Newton to ``1e-10``."""
    if benchmark == "block":
        for load_steps in (20, 60, 180):
            model = _reference_model("block", triangles, grading)
            model.handle("handle").move(np.array(BLOCK_TARGET))
            result = solve(model, load_steps=max(load_steps, 2 * frames), rtol=1e-10)
            if result.converged:
                break
        if not result.converged:
            raise RuntimeError(f"the block reference on {triangles} triangles did not converge ({result.status})")
        return model, {frames: result.u}
    model = _reference_model("flap", triangles, grading, substeps)
    solver = RealtimeSolver(model, budget=math.inf, rtol=1e-10)
    states, stats = _drive(solver, "flap", frames, substeps, checkpoints)
    if stats["converged_share"] < 1.0:
        raise RuntimeError(f"a flap reference run ({triangles} triangles, {substeps} substeps) did not converge")
    return model, states


def _extrapolated(run, triangles, substeps):
    """Richardson in time: ``2 u(dt / 2s) - u(dt / s)`` at the checkpoints, from ``run(triangles, s)``'s ``(model,
    states)`` with ``s`` substeps per frame (the block, ``substeps = None``: its one solution)."""
    if substeps is None:
        return run(triangles, None)
    model, coarse = run(triangles, substeps)
    _, fine = run(triangles, 2 * substeps)
    return model, {f: 2.0 * fine[f] - coarse[f] for f in fine}


def _estimate(d_coarse, d_fine, ratio: float = 2.0):
    """``(rate, estimate)`` of the finest of three solutions, each ``ratio`` times finer, from the distances
    between the finer (``d_fine``) and the coarser two: an error ``~ ratio^-p`` leaves ``d_fine / (ratio^p -
    1)``; with no clear rate (two levels, ``p < 1``) it is ``d_fine``, a bound for any rate >= 1."""
    if d_coarse is None or not (d_fine > 0 and d_coarse > d_fine):
        return None, float(d_fine)
    p = math.log(d_coarse / d_fine) / math.log(ratio)
    return float(p), float(d_fine if p < 1.0 else d_fine / (ratio**p - 1.0))


def reference_run(benchmark: str, plan: dict, progress=None, check: bool = True):
    """``(problem, states, info)``: P2, Newton to ``1e-10``, on ``plan["reference"]``'s ``triangles`` (block:
    ``block_triangles``) and ``grading``, the flap as ``2 u(dt/2s) - u(dt/s)`` (``s = substeps``). With
    ``check``, ``info`` holds its error estimate (:func:`_estimate`) in space from 1/4 and 1/16 of the
    triangles (``space_*``), for the flap in time from 2 and 4 times larger steps (``time_*``), and their sum."""
    ref = plan["reference"]
    frames = plan["frames"] if benchmark == "flap" else plan["block_frames"]
    checkpoints = _checkpoints(benchmark, frames, plan["checkpoints"])
    grading = float(ref.get("grading", REFERENCE_GRADING))
    n = int(ref.get("block_triangles", ref["triangles"])) if benchmark == "block" else int(ref["triangles"])
    s = int(ref["substeps"]) if benchmark == "flap" else None
    t0 = time.perf_counter()
    # each (triangles, substeps) reference run once: the estimates below reuse them
    run = functools.cache(lambda m, k: _reference_states(benchmark, m, grading, frames, checkpoints, k))
    problem, states = _extrapolated(run, n, s)
    info = {"triangles": int(problem.mesh.t.shape[1]), "dofs": int(problem.basis.N), "order": 2,
            "grading": grading, "substeps": None if s is None else [s, 2 * s]}
    if check:
        def from_coarser(coarser):
            """``(distance, rate, estimate)`` from coarser versions of the reference, finest first."""
            d_fine = max(_errors(*coarser[0], (problem, states))) if coarser else float("nan")
            d_coarse = max(_errors(*coarser[1], coarser[0])) if len(coarser) > 1 else None
            return (d_fine, *_estimate(d_coarse, d_fine))

        # space: the same reference on coarser meshes (each a quarter of the triangles: h doubles)
        siblings = [_extrapolated(run, m, s) for m in (n // 4, n // 16) if m >= 50]
        d_fine, rate, space = from_coarser(siblings)
        info.update({"space_distance": d_fine, "space_rate": rate, "space_error_estimate": space,
                     "coarser_sibling_triangles": [int(sib[0].mesh.t.shape[1]) for sib in siblings]})
        time_estimate = 0.0
        if benchmark == "flap":
            # time: the extrapolations from steps 2 and 4 times larger, on the reference's mesh
            t_fine, t_rate, time_estimate = from_coarser([_extrapolated(run, n, s // k) for k in (2, 4)
                                                          if s // k >= 1 and s % k == 0])
            info.update({"time_distance": t_fine, "time_rate": t_rate, "time_error_estimate": time_estimate})
        info["error_estimate"] = space + time_estimate
    info["seconds"] = time.perf_counter() - t0
    if progress:
        extra = f", error estimate {info['error_estimate']:.1e}" if check else ""
        progress(f"{benchmark}: reference P2, {info['triangles']} triangles (graded), {info['dofs']} dofs"
                 f"{extra} ({info['seconds']:.0f} s)")
    return problem, states, info


def _l2_gram(model):
    """The consistent ``L2`` mass matrix of the model's basis (for norms of differences on one mesh)."""
    return model.assembler.csr(model.assembler.mass(1.0, lumped=False))


def _relative_same_mesh(M, u, u_ref) -> float:
    d = u - u_ref
    return float(np.sqrt((d @ (M @ d)) / (u_ref @ (M @ u_ref))))


def _errors(problem, states, reference) -> list[float]:
    """Relative ``L2`` errors at the reference's checkpoints, in order (``problem`` on its own mesh)."""
    return [relative_l2_error(problem, states[f], reference[0], reference[1][f]) for f in sorted(reference[1])]


# --- the sweeps ------------------------------------------------------------------------------------

def knob_sweep(benchmark: str, plan: dict, reference, progress=None) -> list[dict]:
    """One row per (knob, value) of ``plan``: the setting, its cost, its error and ``from_baseline``; a
    setting this machine cannot run is skipped, a failed one has ``error = nan``."""
    frames = plan["frames"] if benchmark == "flap" else plan["block_frames"]
    checkpoints = _checkpoints(benchmark, frames, plan["checkpoints"])
    base = Setting(triangles=int(plan["base_triangles"]))
    # the baseline once more, to measure how far each setting moves the answer from it
    baseline = run_setting(benchmark, base, frames, checkpoints)
    rows = []
    for knob in KNOBS:
        if knob == "time_step" and benchmark == "block":
            continue
        for value in plan["knobs"].get(knob, ()):
            setting = replace(base, **_CHANGES[knob](value, plan))
            if not _runnable(setting.linear_solver):
                continue
            row = {"benchmark": benchmark, "knob": knob, "value": value, **asdict(setting),
                   "baseline": setting == base}
            try:
                problem, states, stats = run_setting(benchmark, setting, frames, checkpoints)
                errors = _errors(problem, states, reference) if stats["finite"] else [float("nan")]
                moved = _errors(problem, states, baseline) if stats["finite"] else [float("nan")]
                row.update({"triangles": int(problem.mesh.t.shape[1]), "dofs": int(problem.basis.N),
                            "error": max(errors), "error_final": errors[-1], "errors": errors,
                            "from_baseline": max(moved), "checkpoints": sorted(states), "failed": ""})
                row.update({k: v for k, v in stats.items() if k not in ("ms", "finite")})
            except (ValueError, RuntimeError) as err:
                row.update({"error": float("nan"), "ms_median": float("nan"), "failed": str(err)})
            rows.append(row)
            if progress:
                progress(f"  {benchmark:5s} {knob:16s} {str(value):18s} "
                         f"{row.get('ms_median', float('nan')):8.1f} ms/frame  error {row['error']:.2e}"
                         + (f"  FAILED: {row['failed']}" if row["failed"] else f"  {_accuracy_text(row)}"))
    return rows


def _solver_settings(solvers, sizes, largest=None) -> list[tuple[str, Setting]]:
    """``(solver, Setting)`` for each linear solver that runs here and each size up to its ``largest``."""
    return [(solver, Setting(triangles=int(n), linear_solver=solver)) for solver in solvers if _runnable(solver)
            for n in sizes if n <= (largest or {}).get(solver, math.inf)]


def solver_scaling(sizes, solvers, frames: int, largest=None, progress=None) -> dict:
    """Time per frame of the flap against mesh size per linear solver (``largest``: a slow solver's largest
    size): ``{"rows", "exponents"}`` with ``ms ~ C triangles^p`` fitted where the solver ran."""
    rows = []
    for solver, setting in _solver_settings(solvers, sizes, largest):
        try:
            model, _, stats = run_setting("flap", setting, frames)
        except (ValueError, RuntimeError) as err:
            rows.append({"solver": solver, "triangles": setting.triangles, "ms_median": float("nan"),
                         "failed": str(err)})
            continue
        kept = ("ms_median", "ms_p95", "newton", "linear_iterations", "factorizations")
        rows.append({"solver": solver, "triangles": int(model.mesh.t.shape[1]), "dofs": int(model.n_dofs),
                     **{k: stats[k] for k in kept}, "failed": ""})
        if progress:
            progress(f"  scaling {solver:15s} {rows[-1]['triangles']:6d} triangles  {stats['ms_median']:8.1f} ms/frame")
    exponents = {}
    for solver in dict.fromkeys(r["solver"] for r in rows):
        sel = [r for r in rows if r["solver"] == solver and np.isfinite(r["ms_median"]) and r["ms_median"] > 0]
        if len(sel) >= 2:
            exponents[solver] = fitted_exponent([r["triangles"] for r in sel], [r["ms_median"] for r in sel])
    return {"rows": rows, "exponents": exponents}


def budget_residual(sizes, frames: int, solvers=("reuse",), budget: float = FRAME_BUDGET, clock=time.perf_counter,
                    progress=None) -> list[dict]:
    """What the budgeted solver leaves on the flap by mesh size and solver: frames converged, median
    end-of-frame residual, final state's distance from a converged run."""
    rows = []
    for solver, setting in _solver_settings(solvers, sizes):
        model, states, stats = run_setting("flap", setting, frames, (frames,), budget=budget, clock=clock)
        _, converged_states, _ = run_setting("flap", setting, frames, (frames,))
        kept = ("converged_share", "residual_median", "min_J", "inverted", "undone_frames", "ms_median", "ms_p95")
        rows.append({"solver": solver, "triangles": int(model.mesh.t.shape[1]), "dofs": int(model.n_dofs),
                     "budget_ms": 1e3 * budget, **{k: stats[k] for k in kept},
                     "state_error": _relative_same_mesh(_l2_gram(model), states[frames], converged_states[frames])})
        if progress:
            r = rows[-1]
            progress(f"  budget {solver:8s} {r['triangles']:6d} triangles  {r['ms_median']:8.1f} ms/frame  "
                     f"{_accuracy_text(r)}  state error {r['state_error']:.1e}")
    return rows


def _drag_path(drag: str):
    return flap_path if string("drag", drag, ("jump", "eased")) == "jump" else eased_flap_path


def time_convergence(drag: str = "jump", triangles: int = 500, substeps=(1, 2, 4, 8, 16), frames: int = 5) -> dict:
    """Backward Euler's convergence in time on the flap: ``distances[k]``, the largest relative ``L2``
    distance between ``substeps[k]`` and ``substeps[k + 1]``, and their ``ratios`` (0.5: first order)."""
    path = _drag_path(drag)
    checkpoints = _checkpoints("flap", frames, 5)
    runs = [run_setting("flap", Setting(triangles=triangles, rtol=1e-10, substeps=int(s)), frames, checkpoints,
                        drag=path) for s in substeps]
    M = _l2_gram(runs[0][0])
    distances = [max(_relative_same_mesh(M, a[1][f], b[1][f]) for f in checkpoints) for a, b in zip(runs, runs[1:])]
    return {"drag": drag, "substeps": [int(s) for s in substeps], "distances": distances,
            "ratios": [b / a for a, b in zip(distances, distances[1:])]}


def capped_newton_experiment(triangles: int = 500, frames: int = 5, drag: str = "jump",
                              reference_substeps: int = 8) -> dict:
    """Why one Newton step per frame can *lower* the flap's error: the flap converged and capped, against ``2
    u(dt/2s) - u(dt/s)`` on the same mesh (``s = reference_substeps``). At the last frame: both errors, how
    far the cap moved the state (``capped_moved``) and the ``L2`` ``cosine`` of that move with the converged
    run's error (positive: towards the reference)."""
    runs = {name: run_setting("flap", Setting(triangles=triangles, **options), frames, (frames,), drag=_drag_path(drag))
            for name, options in (("converged", {"rtol": 1e-10}), ("capped", {"max_iterations": 1, "rtol": 1e-12}),
                                  ("coarse", {"rtol": 1e-10, "substeps": reference_substeps}),
                                  ("fine", {"rtol": 1e-10, "substeps": 2 * reference_substeps}))}
    model, M = runs["fine"][0], _l2_gram(runs["fine"][0])
    converged, capped, coarse, fine = (runs[name][1][frames] for name in runs)
    reference = 2.0 * fine - coarse
    moved, error = capped - converged, reference - converged
    return {"drag": drag, "triangles": int(model.mesh.t.shape[1]), "frames": frames,
            "error_converged": _relative_same_mesh(M, converged, reference),
            "error_capped": _relative_same_mesh(M, capped, reference),
            "capped_moved": float(math.sqrt((moved @ (M @ moved)) / (reference @ (M @ reference)))),
            "cosine": float(moved @ (M @ error) / math.sqrt((moved @ (M @ moved)) * (error @ (M @ error))))}


# --- the whole study -------------------------------------------------------------------------------

def _plan(plan) -> tuple[str, dict]:
    """``(name, plan)`` of a plan given by its name in :data:`PLANS` or as a dict."""
    if isinstance(plan, dict):
        require("plan", plan, ("base_triangles", "frames", "checkpoints", "block_frames", "reference", "knobs"))
        return "custom", plan
    return string("plan", plan, PLANS), PLANS[plan]


def accuracy_study(plan="full", benchmarks=BENCHMARKS, scaling: bool = True, budget: bool = True,
                   verification: bool = True, out=None, progress=print) -> dict:
    """Run the study and return (and write into the folder ``out``) its results: ``machine``, ``plan``,
    ``references``, ``knobs``, ``pareto`` (per benchmark, the front's rows), ``scaling``, ``budget``,
    ``verification``. ``plan``: ``"full"`` (minutes), ``"reduced"`` (chapter 9's), ``"tiny"`` (tests') or a
    dict."""
    name, plan = _plan(plan)
    for b in benchmarks:
        string("benchmarks", b, BENCHMARKS)
    say = progress or (lambda *_: None)
    started = time.perf_counter()
    # one untimed run first: imports, caches and the allocator warm up before anything is timed
    run_setting("flap", Setting(triangles=int(plan["base_triangles"])), 2)
    results = {"study": "accuracy", "plan_name": name, "plan": plan, "machine": machine_info(),
               "frame_budget_ms": 1e3 * FRAME_BUDGET, "references": {}, "knobs": [], "pareto": {}}
    for b in benchmarks:
        reference = reference_run(b, plan, progress=say, check=verification)
        results["references"][b] = reference[2]
        say(f"{b}: sweeping the knobs")
        rows = knob_sweep(b, plan, reference, progress=say)
        offset = len(results["knobs"])
        results["knobs"] += rows
        front = pareto_front([r.get("ms_median", float("nan")) for r in rows], [r["error"] for r in rows])
        results["pareto"][b] = [int(offset + i) for i in front]
    if scaling and "scaling" in plan:
        say("flap: time per frame against mesh size, per linear solver")
        results["scaling"] = solver_scaling(**plan["scaling"], progress=say)  # sizes, solvers, frames, largest
    if budget and "budget" in plan:
        say(f"flap: the budgeted solver ({1e3 * FRAME_BUDGET:.0f} ms per frame, real clock)")
        results["budget"] = budget_residual(**plan["budget"], progress=say)  # sizes, frames, solvers
    if verification:
        computed, exact = beam_problem_tip(32, 8, 2)
        results["verification"] = {
            "cantilever_P2_32x8": {"tip": computed, "exact": exact,
                                   "relative_error": abs(computed - exact) / abs(exact)},
            "manufactured": manufactured_convergence(sizes={1: (4, 8, 16), 2: (2, 4, 8)} if name != "full" else None),
        }
    results["seconds"] = time.perf_counter() - started
    say(format_knob_table(results["knobs"]))
    if out is not None:
        paths = write_results(results, out)
        say("wrote " + ", ".join(str(p) for p in paths))
    return results


# --- results files ---------------------------------------------------------------------------------

def write_results(results: dict, out) -> list[Path]:
    """Write ``accuracy.json`` and one CSV per table (knobs, scaling, budget; library versions in every row)
    into the folder ``out``; return the paths. (The figures of the study draw from these results.)"""
    out = Path(out)
    paths = [write_json(out / "accuracy.json", results)]
    machine = results.get("machine", {})
    versions = {c: machine.get(c, "") for c in ("python", "numpy", "scipy", "scikit-fem", "platform")}
    tables = {"knobs": results.get("knobs", []), "scaling": results.get("scaling", {}).get("rows", []),
              "budget": results.get("budget", [])}
    return paths + [write_csv(out / f"accuracy_{table}.csv", rows, versions) for table, rows in tables.items() if rows]


def read_results(path) -> dict:
    """Read an ``accuracy.json`` written by :func:`write_results` (JSON nulls become NaN in number fields)."""
    results = load_results(path)
    for row in results.get("knobs", []) + results.get("scaling", {}).get("rows", []) + results.get("budget", []):
        row.update({k: float("nan") for k, v in row.items() if v is None and k != "intorder"})
    return results


def recorded_results() -> dict:
    """The full study as recorded on the reference machine (shipped with the package; chapter 9 reads it)."""
    return read_results(DATA / "accuracy_study.json")


#: what the knob tables' residual column means, for the pages that print them (chapter 9, its appendix)
RESIDUAL_COLUMN_NOTE = (
    "*median residual / start residual* is the median over the frames of Newton's own ratio: the residual a "
    "frame ended with over the residual it started from. It is not what convergence is judged on. A frame has "
    "converged when its residual is at most the tolerance times the larger of its start residual and, for a "
    "quasistatic frame, the load its linearised start balances. The block's frames start from that linearised "
    "step, whose residual is already small against the load, so a converged block frame shows a ratio near "
    "$10^{-3}$, or 1 when the start alone met the tolerance and no Newton step followed. On the flap the start "
    "residual sets the scale, and the ratio lies below the tolerance.")

_TABLE = [("benchmark", "benchmark", "{}"), ("knob", "knob", "{}"), ("value", "value", "{}"),
          ("triangles", "triangles", "{:d}"), ("dofs", "dofs", "{:d}"), ("ms_median", "ms/frame", "{:.1f}"),
          ("newton", "Newton/frame", "{:.2f}"), ("error", "rel. L2 error", "{:.2e}"),
          ("converged_share", "converged", "{:.0%}"), ("residual_median", "median residual / start residual", "{:.1e}"),
          ("min_J", "min J", "{:.3f}"), ("inverted", "inverted", "{:d}")]


def _accuracy_text(row) -> str:
    """A run's accuracy as its frames reported it, for a progress line."""
    return (f"converged {row['converged_share']:.0%}  median residual / start residual {row['residual_median']:.1e}  "
            f"min J {row['min_J']:.3f}  {row['inverted']} inverted  {row['undone_frames']} frames left work undone")


def format_knob_table(rows) -> str:
    """The knob rows as a Markdown table."""
    return markdown_table(rows, _TABLE, text_columns=3)
