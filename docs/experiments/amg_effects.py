"""Smoothed aggregation (rigid-body modes as near-nullspace) against the kept factorization, on `bench scenes`.

The base, the probe and the "everything" variants of `tissuefem.workbook.bench.scenes.variants` at 8k triangles,
each run with the default linear solver ("reuse-background": CG preconditioned by a kept SuperLU factorization,
refreshed on the second core) and with CG preconditioned by one V-cycle of a kept smoothed-aggregation hierarchy
(pyamg; the library's "reuse-background-cg-amg"), given the body's rigid motions as near-nullspace and refreshed
the same way, the two alternating in one process. Its coarsest level is a sparse LU made with the hierarchy, off
the frame (pyamg's default, a pseudo-inverse made at the first V-cycle on the frame's thread, cost 0.6-4 s per
hierarchy for 360 unknowns on the busy machine, the BLAS's two threads fighting the other work). Per run:
the median wall ms of a frame, the median CPU ms of the frame's thread (time.thread_time), Newton steps, CG
iterations (one back-substitution or one V-cycle each) and factorizations (or hierarchies) on the frame, per
frame; and, in CPU ms at the end state, the floor's pieces (one assembly, one back-substitution or V-cycle) and
a factorization (or hierarchy); the frame's CPU over the floor's.

    python docs/experiments/amg_effects.py [n_triangles] [frames] [repeats]
"""

import sys
import time

import numpy as np

from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation
from tissuefem.workbook.bench.common import load_average
from tissuefem.workbook.bench.scenes import variants
from tissuefem.workbook.timestepping import flap_drag


SOLVERS = {"kept SuperLU": "reuse-background", "AMG (rigid modes)": "reuse-background-cg-amg"}
VARIANTS = ("base: stable neo-Hookean, quasistatic", "+ probe", "everything")


def run(data, options, solver, frames):
    sim = Simulation(Scene.from_dict(data), linear_solver=solver, **options)
    wall, cpu, newton, cg, fac = [], [], [], [], []
    for f in range(frames):
        cg0 = sim.solver.linear.backend.cg_iterations  # all of the frame's solves, the linearised start's too
        t = time.thread_time()
        report = flap_drag(sim, 1, start=f)[0]
        cpu.append(1e3 * (time.thread_time() - t))
        wall.append(1e3 * report.elapsed)
        newton.append(report.newton_iterations)
        cg.append(sim.solver.linear.backend.cg_iterations - cg0)
        fac.append(report.newton.factorizations)
    pieces = floor(sim)
    sim.solver.linear.close()
    return {"wall": np.median(wall), "cpu": np.median(cpu), "newton": np.mean(newton), "cg": np.mean(cg),
            "fac": np.mean(fac), **pieces, "over_floor": np.median(cpu) / (pieces["assembly"] + pieces["apply"])}


def cpu_ms(work, repeats=9):
    """Median CPU ms of the calling thread over ``repeats`` calls of ``work``."""
    times = []
    for _ in range(repeats):
        t = time.thread_time()
        work()
        times.append(1e3 * (time.thread_time() - t))
    return float(np.median(times))


def floor(sim):
    """CPU ms of the floor's pieces at the end state: a tangent assembly, one back-substitution or V-cycle, and
    one factorization or hierarchy (all on this thread)."""
    model, u, linear = sim.model, sim.u, sim.solver.linear
    fixed, _ = model.prescribed()
    free = np.ones(model.n_dofs, dtype=bool)
    free[fixed] = False
    A = linear.matrix(lambda: model.hessian(u), free)  # (passes the rigid motions of these dofs on)
    rhs = -model.gradient(u)[free]
    made = cpu_ms(lambda: linear.factorizing.factorize(A), 3)
    factor = linear.factorizing.factorize(A)
    apply = getattr(factor, "precondition", None) or factor.solve
    return {"assembly": cpu_ms(lambda: model.hessian(u)), "apply": cpu_ms(lambda: apply(rhs)), "factorize": made}


def main(n_triangles=8000, frames=30, repeats=3):
    runs = {(v, s): [] for v in VARIANTS for s in SOLVERS}
    loads = [load_average()[0]]
    chosen = [(name, data, options) for name, data, options in variants(n_triangles) if name in VARIANTS]
    for r in range(repeats):
        for name, data, options in chosen:
            order = list(SOLVERS.items()) if r % 2 == 0 else list(SOLVERS.items())[::-1]  # alternate who goes first
            for label, solver in order:
                runs[name, label].append(run(data, options, solver, frames))
                loads.append(load_average()[0])
                print(f"round {r + 1} {name[:12]:12s} {label:18s} " + " ".join(
                    f"{k} {v:.2f}" for k, v in runs[name, label][-1].items()), flush=True)
    print(f"\n1-minute load average during the runs: {min(loads):.1f}-{max(loads):.1f}")
    print("| variant | preconditioner | median ms/frame (runs' range) | frame thread CPU ms (runs' range) | "
          "Newton/frame | CG iterations/frame | made on the frame/frame | CPU ms: assembly, back-substitution or "
          "V-cycle, factorization or hierarchy | frame / floor (CPU) |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|")
    for (name, label), rows in runs.items():
        med = {k: float(np.median([row[k] for row in rows])) for k in rows[0]}
        w, c = [row["wall"] for row in rows], [row["cpu"] for row in rows]
        print(f"| {name.split(':')[0]} | {label} | {med['wall']:.0f} ({min(w):.0f}-{max(w):.0f}) | {med['cpu']:.1f} "
              f"({min(c):.1f}-{max(c):.1f}) | {med['newton']:.2f} | {med['cg']:.1f} | {med['fac']:.2f} | "
              f"{med['assembly']:.1f}, {med['apply']:.2f}, {med['factorize']:.0f} | {med['over_floor']:.1f}x |")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
