"""What accuracy costs in time: the measured study of chapter 9 (``python -m tissuefem bench accuracy``).

Every speed/accuracy knob of the simulator is turned, one at a time, away
from a *baseline* setting, and each setting is run on two benchmarks:

``flap``
    the standard flap scene of :mod:`tissuefem.bench_realtime` (Neo-Hookean,
    E = 1000, nu = 0.3, rho0 = 1, left edge fixed, right edge on the scripted
    loop :func:`~tissuefem.bench_realtime.flap_path`), backward Euler, one
    displayed frame every 1/30 s;
``block``
    a quasistatic benchmark: the same rectangle ``[0, 2] x [0, 1]`` with its
    right edge carried to ``(0.6, 0.4)`` (chapter 4's stretched and sheared
    block) in equal increments, one quasistatic solve per frame.

For each run it records the *cost*, the median wall time per displayed frame
(the solver's own clock, every Newton iteration, assembly and linear solve
included), and the *error*, the relative ``L2`` norm of the displacement error
against a reference solution (:func:`tissuefem.studies.relative_l2_error`,
the reference evaluated by point location): for the flap the largest of the
errors at a few checkpoint frames (``error``; ``errors`` lists them all and
``error_final`` is the last), for the block the error of the final
equilibrium.

The reference is the discretisation pushed as far as the plan allows in every
knob at once: P2 elements on the finest mesh, consistent mass, Newton
converged to ``rtol = 1e-10`` (the linear solver does not matter at that
tolerance), and for the flap a time step
``dt / s`` extrapolated in time (backward Euler is first order, so
``2 u(dt/2s) - u(dt/s)`` removes the leading time error; Richardson). The
module's ``verification`` answers how good the reference is:
mesh convergence of the nonlinear models at their expected rates
(:func:`tissuefem.accuracy.manufactured_convergence`), the published linear
benchmark (:func:`tissuefem.accuracy.beam_problem_tip`), and the reference's
own distance to its next-coarser sibling.

The knobs (``KNOBS``): mesh resolution (P1), element order (P2 over the
same meshes), quadrature order (P2), material model, Newton tolerance, a cap
on Newton iterations, time step (substeps per displayed frame, flap only) and
linear solver (a fresh SuperLU factorization with the minimum-degree ordering
and with SciPy's default COLAMD, CG with a Jacobi or an incomplete-LU
preconditioner, CG preconditioned by a reused factorization, and PARDISO when
it is installed).

Two further measurements use the flap scene alone: how the time per frame
grows with the mesh for each linear solver (:func:`solver_scaling`, with a
fitted exponent ``ms ~ triangles^p``), and what the budgeted solver leaves
unfinished when its 33 ms are spent (:func:`budget_residual`).

Timings are medians of one run on one machine: compare settings within one
run and quote ratios, never assert them. The errors are deterministic.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from ...engine.constants import FRAME_BUDGET
from ...engine.linsolve import LinearSolver, available
from ...engine.materials import MATERIALS
from ...engine.stepping import solve
from ...surgery.scene import Scene, flap_path, flap_scene
from ...surgery.simulation import Simulation
from ..accuracy import beam_problem_tip, manufactured_convergence
from ..measure import fitted_exponent, pareto_front, relative_l2_error
from .common import load_results, machine_info, markdown_table, write_csv, write_json

__all__ = [
    "Setting",
    "KNOBS",
    "PLANS",
    "BLOCK_TARGET",
    "make_simulation",
    "run_setting",
    "reference_run",
    "knob_sweep",
    "solver_scaling",
    "budget_residual",
    "accuracy_study",
    "write_results",
    "read_results",
    "recorded_results",
    "format_knob_table",
]

#: Where the quasistatic benchmark's handle ends: the right edge moved by (0.6, 0.4), as in chapter 4.
BLOCK_TARGET = (0.6, 0.4)
BENCHMARKS = ("flap", "block")


@dataclass(frozen=True)
class Setting:
    """One setting of every knob. The defaults are the baseline of the study (except the mesh size,
    which each plan sets)."""

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
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"setting {name} must be a positive integer, got {value!r}")
        if self.order not in (1, 2):
            raise ValueError(f"setting order must be 1 or 2, got {self.order!r}")
        if self.material not in MATERIALS:
            raise ValueError(f"setting material must be one of {sorted(MATERIALS)}, got {self.material!r}")
        if not (isinstance(self.rtol, (int, float)) and 0 < self.rtol < 1):
            raise ValueError(f"setting rtol must be in (0, 1), got {self.rtol!r}")
        if not isinstance(self.linear_solver, str):
            raise ValueError(f"setting linear_solver must be a name, got {self.linear_solver!r}")
        try:
            LinearSolver(self.linear_solver) if _runnable(self.linear_solver) else None
        except ValueError as err:
            raise ValueError(f"setting linear_solver: {err}") from None
        return self


#: The knobs and, for each, the label of the setting it changes. Values come from the plan.
KNOBS = {
    "mesh": "triangles",
    "P2": "triangles",
    "quadrature": "intorder",
    "material": "material",
    "newton_tolerance": "rtol",
    "newton_cap": "max_iterations",
    "time_step": "substeps",
    "linear_solver": "linear_solver",
}

_MATERIALS = ("linear", "corotated", "neo-hookean", "stable-neo-hookean", "taylor-neo-hookean")
_SOLVERS = ("reuse", "direct", "superlu-colamd", "cg-ilu", "cg-jacobi", "pardiso", "reuse-pardiso")

#: Sweep plans: ``full`` for the CLI, ``reduced`` for chapter 9's notebook, ``tiny`` for the tests.
PLANS = {
    "full": {
        "base_triangles": 8000,
        "frames": 30,
        "checkpoints": 5,  # the flap's error is the largest over every 5th frame
        "block_frames": 10,
        "reference": {"triangles": 8000, "substeps": 4},
        "knobs": {
            "mesh": (500, 1000, 2000, 4000, 8000, 16000, 32000),
            "P2": (250, 500, 1000, 2000, 4000),
            "quadrature": (2, 3, 4, 6),
            "quadrature_triangles": 2000,
            "material": _MATERIALS,
            "newton_tolerance": (1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 1e-8),
            "newton_cap": (1, 2, 3),
            "time_step": (1, 2, 4),
            "linear_solver": _SOLVERS,
        },
        # the slow solvers stop at 8k triangles (at 32k one CG-ILU frame takes minutes)
        "scaling": {"sizes": (500, 1000, 2000, 4000, 8000, 16000, 32000), "frames": 8,
                    "solvers": ("reuse", "direct", "superlu-colamd", "cg-ilu", "cg-jacobi", "pardiso"),
                    "largest": {"cg-ilu": 8000, "cg-jacobi": 8000, "pardiso": 8000}},
        "budget": {"sizes": (1000, 2000, 4000, 8000, 16000, 32000), "frames": 30, "solvers": ("reuse",)},
    },
    "reduced": {
        "base_triangles": 1000,
        "frames": 15,
        "checkpoints": 5,
        "block_frames": 5,
        "reference": {"triangles": 2000, "substeps": 4},
        "knobs": {
            "mesh": (250, 500, 1000, 2000),
            "P2": (250, 500),
            "quadrature": (2, 4),
            "quadrature_triangles": 250,
            "material": ("linear", "corotated", "neo-hookean", "stable-neo-hookean"),
            "newton_tolerance": (1e-1, 1e-3, 1e-6),
            "newton_cap": (1, 2),
            "time_step": (1, 2, 4),
            "linear_solver": ("reuse", "direct", "cg-ilu", "cg-jacobi"),
        },
        "scaling": {"sizes": (500, 1000, 2000, 4000), "frames": 5, "solvers": ("reuse", "direct", "cg-jacobi")},
        "budget": {"sizes": (1000, 4000), "frames": 10, "solvers": ("reuse",)},
    },
    "tiny": {
        "base_triangles": 200,
        "frames": 4,
        "checkpoints": 2,
        "block_frames": 2,
        "reference": {"triangles": 400, "substeps": 2},
        "knobs": {
            "mesh": (100, 200),
            "P2": (100,),
            "quadrature": (2, 4),
            "quadrature_triangles": 100,
            "material": ("linear", "neo-hookean"),
            "newton_tolerance": (1e-2, 1e-6),
            "newton_cap": (1,),
            "time_step": (1, 2),
            "linear_solver": ("reuse", "direct", "cg-jacobi", "cg-ilu", "superlu-colamd"),
        },
        "scaling": {"sizes": (100, 200), "frames": 2, "solvers": ("reuse", "cg-jacobi")},
        "budget": {"sizes": (100, 200), "frames": 2, "solvers": ("reuse",)},
    },
}


# --------------------------------------------------------------------------------------------------
# one run
# --------------------------------------------------------------------------------------------------

def _runnable(linear_solver: str) -> bool:
    """Whether this machine has the solver (PARDISO needs the optional pypardiso)."""
    return "pardiso" not in linear_solver or available("pardiso")


def make_simulation(setting: Setting, benchmark: str = "flap", budget=math.inf, clock=time.perf_counter) -> Simulation:
    """The standard flap scene with ``setting`` (mesh, order, quadrature, material, Newton, time step, solver).

    ``benchmark="flap"``: backward Euler with ``dt = 1/30 / substeps`` (P2 takes the consistent mass:
    row-sum lumping gives its vertices none); ``"block"``: the same body quasistatic. A linear material
    runs on its constant factorization (the Simulation chooses it for a quadratic model).
    """
    setting.check()
    scene = flap_scene(setting.triangles, model=setting.material, dynamic=benchmark == "flap",
                       rtol=setting.rtol, linear_solver=setting.linear_solver).to_dict()
    scene["solver"]["max_iterations"] = setting.max_iterations
    if benchmark == "flap":
        scene["effects"]["inertia"] = {"time_step": FRAME_BUDGET / setting.substeps,
                                       "mass": "consistent" if setting.order == 2 else "lumped"}
    sim = Simulation(Scene.from_dict(scene), order=setting.order, intorder=setting.intorder, clock=clock)
    sim.solver.budget = budget
    return sim


def _targets(benchmark: str, frame: int, substep: int, substeps: int, frames: int):
    """The handle's target for ``substep`` (1-based) of displayed ``frame`` (1-based)."""
    if benchmark == "flap":
        return {"handle": flap_path((frame - 1 + substep / substeps) * FRAME_BUDGET)}
    return {"handle": np.array(BLOCK_TARGET) * frame / frames}


def _checkpoints(benchmark: str, frames: int, every: int) -> tuple[int, ...]:
    if benchmark == "block":
        return (frames,)
    return tuple(f for f in range(1, frames + 1) if f % every == 0 or f == frames)


def run_setting(benchmark: str, setting: Setting, frames: int, checkpoints=(), budget=math.inf,
                clock=time.perf_counter):
    """Run ``frames`` displayed frames of ``benchmark`` with ``setting``.

    Returns ``(model, states, stats)``: ``states`` maps each checkpoint frame
    to a copy of ``u``; ``stats`` holds the per-frame milliseconds (summed over
    substeps), Newton and linear iterations, factorizations, whether every
    frame converged, and the relative residuals left at the end of frames.
    """
    if benchmark not in BENCHMARKS:
        raise ValueError(f"benchmark must be one of {BENCHMARKS}, got {benchmark!r}")
    if benchmark == "block" and setting.substeps != 1:
        raise ValueError("the quasistatic block has no time step: substeps must be 1")
    sim = make_simulation(setting, benchmark, budget=budget, clock=clock)
    solver = sim.solver
    states, ms, newton, linear, fac, converged, residual, fraction = {}, [], [], [], [], [], [], []
    for f in range(1, frames + 1):
        spent = 0.0
        for s in range(1, setting.substeps + 1):
            report = solver.frame(_targets(benchmark, f, s, setting.substeps, frames))
            spent += report.elapsed
            newton.append(report.newton_iterations)
            linear.append(report.linear_iterations)
            fac.append(report.factorizations)
            converged.append(report.converged)
            residual.append(report.relative_residual)
            fraction.append(report.handle_fraction)
        ms.append(1e3 * spent)
        if f in checkpoints:
            states[f] = solver.u.copy()
    stats = {
        "ms": ms,
        "ms_median": float(np.median(ms)),
        "ms_p95": float(np.percentile(ms, 95)),
        "newton": float(np.sum(newton) / frames),  # per displayed frame (all substeps)
        "linear_iterations": float(np.sum(linear) / frames),
        "factorizations": int(np.sum(fac)),
        "converged_share": float(np.mean(converged)),
        "residual_median": float(np.median(residual)),
        # the smallest share of its motion a handle made in one frame (< 1: a frame could not move it all the
        # way without inverting elements, and the real-time solver kept the state valid instead)
        "handle_fraction_min": float(np.min(fraction)),
        "finite": bool(np.all(np.isfinite(solver.u))),
    }
    return sim.model, states, stats


def reference_run(benchmark: str, plan: dict, progress=None):
    """The reference of ``benchmark`` for ``plan``: ``(problem, states, info)``.

    P2 on ``plan["reference"]["triangles"]``, Newton to ``rtol = 1e-10``. For the flap, two runs with ``s`` and
    ``2 s`` substeps (``s = plan["reference"]["substeps"]``) are combined as
    ``2 u(dt/2s) - u(dt/s)`` (Richardson extrapolation of backward Euler's
    first-order time error); ``info["time_error_estimate"]`` is the relative
    ``L2`` distance between the two runs, an estimate of the finer one's own
    time error, which the extrapolation removes to leading order.
    """
    ref = plan["reference"]
    frames = plan["frames"] if benchmark == "flap" else plan["block_frames"]
    checkpoints = _checkpoints(benchmark, frames, plan["checkpoints"])
    base = Setting(triangles=ref["triangles"], order=2, rtol=1e-10)
    t0 = time.perf_counter()
    if benchmark == "block":
        # the final equilibrium does not depend on the path: solve it directly, with the load-stepping
        # solver's linearised predictor (moving a P2 edge alone would invert the elements beside it)
        problem = make_simulation(base, "block").model
        problem.handle("handle").move(np.array(BLOCK_TARGET))
        result = solve(problem, load_steps=max(4, frames), rtol=1e-10)
        if not result.converged:
            raise RuntimeError(f"the block reference did not converge ({result.status})")
        states = {frames: result.u}
        info = {"time_error_estimate": 0.0}
    else:
        s = int(ref["substeps"])
        problem, coarse, _ = run_setting("flap", replace(base, substeps=s), frames, checkpoints)
        _, fine, _ = run_setting("flap", replace(base, substeps=2 * s), frames, checkpoints)
        states = {f: 2.0 * fine[f] - coarse[f] for f in checkpoints}
        M = _l2_gram(problem)
        info = {"time_error_estimate": max(_relative_same_mesh(M, fine[f], coarse[f]) for f in checkpoints)}
    info.update({"triangles": int(problem.mesh.t.shape[1]), "dofs": int(problem.basis.N), "order": 2,
                 "substeps": None if benchmark == "block" else [int(ref["substeps"]), 2 * int(ref["substeps"])],
                 "seconds": time.perf_counter() - t0})
    if progress:
        progress(f"{benchmark}: reference P2, {info['triangles']} triangles, {info['dofs']} dofs "
                 f"({info['seconds']:.0f} s)")
    return problem, states, info


def _l2_gram(model):
    """The consistent ``L2`` mass matrix of the model's basis (for norms of differences on one mesh)."""
    return model.assembler.csr(model.assembler.mass(1.0, lumped=False))


def _relative_same_mesh(M, u, u_ref) -> float:
    d = u - u_ref
    return float(np.sqrt((d @ (M @ d)) / (u_ref @ (M @ u_ref))))


def _errors(problem, states, reference) -> list[float]:
    """Relative ``L2`` errors at the checkpoints against the reference (same checkpoints, in order)."""
    ref_problem, ref_states = reference[0], reference[1]
    return [relative_l2_error(problem, states[f], ref_problem, ref_states[f]) for f in sorted(ref_states)]


def _error(problem, states, reference) -> float:
    """Largest relative ``L2`` error over the checkpoints against the reference."""
    return max(_errors(problem, states, reference))


# --------------------------------------------------------------------------------------------------
# the sweeps
# --------------------------------------------------------------------------------------------------

def _knob_settings(knob: str, plan: dict, base: Setting):
    values = plan["knobs"].get(knob, ())
    for value in values:
        if knob == "mesh":
            yield value, replace(base, triangles=int(value))
        elif knob == "P2":
            yield value, replace(base, triangles=int(value), order=2)
        elif knob == "quadrature":
            yield value, replace(base, triangles=int(plan["knobs"]["quadrature_triangles"]), order=2,
                                 intorder=int(value))
        elif knob == "material":
            yield value, replace(base, material=value)
        elif knob == "newton_tolerance":
            yield value, replace(base, rtol=float(value))
        elif knob == "newton_cap":
            yield value, replace(base, max_iterations=int(value), rtol=1e-12)
        elif knob == "time_step":
            yield value, replace(base, substeps=int(value))
        elif knob == "linear_solver":
            yield value, replace(base, linear_solver=value)
        else:
            raise ValueError(f"unknown knob {knob!r}; knobs: {sorted(KNOBS)}")


def knob_sweep(benchmark: str, plan: dict, reference, knobs=None, progress=None) -> list[dict]:
    """One row per (knob, value) of ``plan`` on ``benchmark``: the setting, its cost and its error.

    Settings that cannot run here (PARDISO without pypardiso) are skipped;
    a setting that fails (a ``ValueError`` or ``RuntimeError`` from the
    solver) gives a row with ``error = nan`` and the reason in ``failed``.
    """
    knobs = list(KNOBS) if knobs is None else list(knobs)
    frames = plan["frames"] if benchmark == "flap" else plan["block_frames"]
    checkpoints = _checkpoints(benchmark, frames, plan["checkpoints"])
    base = Setting(triangles=int(plan["base_triangles"]))
    rows = []
    for knob in knobs:
        if knob == "time_step" and benchmark == "block":
            continue
        for value, setting in _knob_settings(knob, plan, base):
            if not _runnable(setting.linear_solver):
                continue
            row = {"benchmark": benchmark, "knob": knob, "value": value, **asdict(setting),
                   "baseline": setting == base}
            try:
                problem, states, stats = run_setting(benchmark, setting, frames, checkpoints)
                errors = _errors(problem, states, reference) if stats["finite"] else [float("nan")]
                row.update({"triangles": int(problem.mesh.t.shape[1]), "dofs": int(problem.basis.N),
                            "error": max(errors), "error_final": errors[-1], "errors": errors,
                            "checkpoints": sorted(states), "failed": ""})
                row.update({k: v for k, v in stats.items() if k not in ("ms", "finite")})
            except (ValueError, RuntimeError) as err:
                row.update({"error": float("nan"), "ms_median": float("nan"), "failed": str(err)})
            rows.append(row)
            if progress:
                progress(f"  {benchmark:5s} {knob:16s} {str(value):18s} {row.get('ms_median', float('nan')):8.1f} ms/frame"
                         f"  error {row['error']:.2e}" + (f"  FAILED: {row['failed']}" if row["failed"] else ""))
    return rows


def solver_scaling(sizes, solvers, frames: int, largest=None, progress=None) -> dict:
    """Time per frame of the flap scene against mesh size, per linear solver, with fitted exponents.

    ``largest`` maps a solver to the largest size it is run at (the slow ones).
    Returns ``{"rows": [...], "exponents": {solver: p}}`` where ``ms ~ C triangles^p``
    is fitted over the sizes (sizes where a solver failed are left out).
    """
    largest = largest or {}
    rows = []
    for solver in solvers:
        if not _runnable(solver):
            continue
        for n in sizes:
            if n > largest.get(solver, math.inf):
                continue
            setting = Setting(triangles=int(n), linear_solver=solver)
            try:
                model, _, stats = run_setting("flap", setting, frames)
            except (ValueError, RuntimeError) as err:
                rows.append({"solver": solver, "triangles": int(n), "ms_median": float("nan"), "failed": str(err)})
                continue
            rows.append({"solver": solver, "triangles": int(model.mesh.t.shape[1]), "dofs": int(model.n_dofs),
                         "ms_median": stats["ms_median"], "ms_p95": stats["ms_p95"], "newton": stats["newton"],
                         "linear_iterations": stats["linear_iterations"], "factorizations": stats["factorizations"],
                         "failed": ""})
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
    """What the budgeted real-time solver leaves when its budget is spent, on the flap scene, by mesh size.

    For each size and solver: the share of frames that converged within
    ``budget`` seconds, the median relative residual at the end of a frame
    (``|grad E| / |grad E(x0)|``, 1e-6 or less for a converged frame) and the
    relative ``L2`` distance of the final state from the same scene run with
    every frame converged. ``clock`` is injectable (tests use a fake one).
    """
    rows = []
    for solver in solvers:
        if not _runnable(solver):
            continue
        for n in sizes:
            setting = Setting(triangles=int(n), linear_solver=solver)
            model, states, stats = run_setting("flap", setting, frames, (frames,), budget=budget, clock=clock)
            _, converged_states, _ = run_setting("flap", setting, frames, (frames,))
            M = _l2_gram(model)
            rows.append({
                "solver": solver,
                "triangles": int(model.mesh.t.shape[1]),
                "dofs": int(model.n_dofs),
                "budget_ms": 1e3 * budget,
                "converged_share": stats["converged_share"],
                "residual_median": stats["residual_median"],
                "ms_median": stats["ms_median"],
                "ms_p95": stats["ms_p95"],
                "state_error": _relative_same_mesh(M, states[frames], converged_states[frames]),
            })
            if progress:
                r = rows[-1]
                progress(f"  budget {solver:8s} {r['triangles']:6d} triangles  converged {r['converged_share']:.0%}  "
                         f"median residual {r['residual_median']:.1e}  state error {r['state_error']:.1e}")
    return rows


# --------------------------------------------------------------------------------------------------
# the whole study
# --------------------------------------------------------------------------------------------------

def _plan(plan) -> tuple[str, dict]:
    if isinstance(plan, str):
        if plan not in PLANS:
            raise ValueError(f"plan must be one of {sorted(PLANS)} or a dict, got {plan!r}")
        return plan, PLANS[plan]
    if isinstance(plan, dict):
        missing = {"base_triangles", "frames", "checkpoints", "block_frames", "reference", "knobs"} - set(plan)
        if missing:
            raise ValueError(f"plan is missing {sorted(missing)}")
        return "custom", plan
    raise ValueError(f"plan must be a name ({sorted(PLANS)}) or a dict, got {plan!r}")


def accuracy_study(plan="full", benchmarks=BENCHMARKS, knobs=None, scaling: bool = True, budget: bool = True,
                   verification: bool = True, out=None, progress=print) -> dict:
    """Run the study; return its results (and write them to the folder ``out``).

    ``plan`` is ``"full"`` (the CLI's, several minutes), ``"reduced"``
    (chapter 9's, under a minute), ``"tiny"`` (the tests'), or a dict shaped
    like them. The results dict holds ``machine`` (platform and library
    versions), ``plan``, ``references``, ``knobs`` (the rows of
    :func:`knob_sweep`), ``pareto`` (per benchmark, the indices of the
    Pareto-optimal rows), ``scaling``, ``budget`` and ``verification``.
    """
    name, plan = _plan(plan)
    for b in benchmarks:
        if b not in BENCHMARKS:
            raise ValueError(f"benchmarks must be among {BENCHMARKS}, got {b!r}")
    say = progress or (lambda *_: None)
    started = time.perf_counter()
    # one untimed run first: imports, caches and the allocator warm up before anything is timed
    run_setting("flap", Setting(triangles=int(plan["base_triangles"])), 2)
    results = {"study": "accuracy", "plan_name": name, "plan": plan, "machine": machine_info(),
               "frame_budget_ms": 1e3 * FRAME_BUDGET, "references": {}, "knobs": [], "pareto": {}}
    for b in benchmarks:
        reference = reference_run(b, plan, progress=say)
        results["references"][b] = reference[2]
        say(f"{b}: sweeping the knobs")
        rows = knob_sweep(b, plan, reference, knobs=knobs, progress=say)
        offset = len(results["knobs"])
        results["knobs"] += rows
        front = pareto_front([r.get("ms_median", float("nan")) for r in rows], [r["error"] for r in rows])
        results["pareto"][b] = [int(offset + i) for i in front]
        if verification:
            # the reference against its next-coarser sibling: how much of the smallest errors is the reference's own
            half = dict(plan, reference=dict(plan["reference"], triangles=max(1, plan["reference"]["triangles"] // 4)))
            coarse = reference_run(b, half)
            results["references"][b]["coarser_sibling_error"] = _error(coarse[0], coarse[1], reference)
            results["references"][b]["coarser_sibling_triangles"] = coarse[2]["triangles"]
    if scaling and "scaling" in plan:
        say("flap: time per frame against mesh size, per linear solver")
        sc = plan["scaling"]
        results["scaling"] = solver_scaling(sc["sizes"], sc["solvers"], sc["frames"], sc.get("largest"), progress=say)
    if budget and "budget" in plan:
        say(f"flap: the budgeted solver ({1e3 * FRAME_BUDGET:.0f} ms per frame, real clock)")
        bp = plan["budget"]
        results["budget"] = budget_residual(bp["sizes"], bp["frames"], bp.get("solvers", ("reuse",)), progress=say)
    if verification:
        computed, exact = beam_problem_tip(32, 8, 2)
        results["verification"] = {
            "cantilever_P2_32x8": {"tip": computed, "exact": exact, "relative_error": abs(computed - exact) / abs(exact)},
            "manufactured": manufactured_convergence(sizes={1: (4, 8, 16), 2: (2, 4, 8)} if name != "full" else None),
        }
    results["seconds"] = time.perf_counter() - started
    say(format_knob_table(results["knobs"]))
    if out is not None:
        paths = write_results(results, out)
        say("wrote " + ", ".join(str(p) for p in paths))
    return results


# --------------------------------------------------------------------------------------------------
# results files
# --------------------------------------------------------------------------------------------------

_VERSION_COLUMNS = ("python", "numpy", "scipy", "scikit-fem", "platform")


def write_results(results: dict, out) -> list[Path]:
    """Write ``accuracy.json`` and one CSV per table (knobs, scaling, budget; library versions in every row)
    into the folder ``out``; return the paths. (The figures of the study draw from these results.)"""
    out = Path(out)
    paths = [write_json(out / "accuracy.json", results)]
    machine = results.get("machine", {})
    versions = {c: machine.get(c, "") for c in _VERSION_COLUMNS}
    tables = {"knobs": results.get("knobs", []), "scaling": results.get("scaling", {}).get("rows", []),
              "budget": results.get("budget", [])}
    for table, rows in tables.items():
        if rows:
            paths.append(write_csv(out / f"accuracy_{table}.csv", rows, versions))
    return paths


def read_results(path) -> dict:
    """Read an ``accuracy.json`` written by :func:`write_results` (JSON nulls become NaN in number fields)."""
    results = load_results(path)
    for row in results.get("knobs", []) + results.get("scaling", {}).get("rows", []) + results.get("budget", []):
        for k, v in row.items():
            if v is None and k not in ("intorder",):
                row[k] = float("nan")
    return results


def recorded_results() -> dict:
    """The full study as recorded on the reference machine (shipped with the package; chapter 9 reads it)."""
    return read_results(Path(__file__).parents[1] / "data" / "accuracy_study.json")


_TABLE = [
    ("benchmark", "benchmark", "{}"),
    ("knob", "knob", "{}"),
    ("value", "value", "{}"),
    ("triangles", "triangles", "{:d}"),
    ("dofs", "dofs", "{:d}"),
    ("ms_median", "ms/frame", "{:.1f}"),
    ("newton", "Newton/frame", "{:.2f}"),
    ("error", "rel. L2 error", "{:.2e}"),
]


def format_knob_table(rows) -> str:
    """The knob rows as a Markdown table."""
    return markdown_table(rows, _TABLE, text_columns=3)
