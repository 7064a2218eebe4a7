"""A quasi-Newton inner loop against today's Newton, on the base and probe variants of `bench scenes`.

Inside a frame the real-time solver makes a linearised start (one tangent assembly and a CG solve preconditioned by
the kept factorization) and then Newton steps, each one tangent assembly and a CG solve. Here, after ``newton_steps``
of those Newton steps (0: right after the linearised start), the frame goes on with L-BFGS (memory 5): its initial
inverse Hessian is the kept factorization, so each iteration costs one gradient, one back-substitution and the
line search (Armijo on the energy, as Newton's), until the same residual as Newton's (the same target). Runs of
the ways alternate in one process. Per way: the median wall ms and frame-thread CPU ms (time.thread_time) of a
frame, Newton steps (the linearised start counted as one) and quasi-Newton iterations, CG iterations (the
linearised start's too) and back-substitutions (CG's and L-BFGS's) per frame, the largest
residual reached over its target, and how far the end state is from Newton's.

    python docs/experiments/quasi_newton.py [n_triangles] [frames] [repeats]
"""

import sys
import time

import numpy as np

import tissuefem.engine.stepping as stepping
from tissuefem.engine.minimize import NewtonResult, newton
from tissuefem.surgery.scene import Scene
from tissuefem.surgery.simulation import Simulation
from tissuefem.workbook.bench.common import load_average
from tissuefem.workbook.bench.scenes import variants
from tissuefem.workbook.timestepping import flap_drag

MEMORY = 5
COUNT = {"qn": 0, "back": 0}


def lbfgs_direction(g, pairs, apply_h0):
    """-H g by the two-loop recursion, H0 = apply_h0 (the kept factorization's back-substitution)."""
    q, alphas = g.copy(), []
    for s, y, rho in reversed(pairs):
        a = rho * (s @ q)
        q -= a * y
        alphas.append(a)
    r = apply_h0(q)
    COUNT["back"] += 1
    for (s, y, rho), a in zip(pairs, reversed(alphas)):
        r += (a - rho * (y @ r)) * s
    return -r


def quasi_newton(x0, gradient, hessian, *, newton_steps=1, **options):
    """Newton's first ``newton_steps`` steps, then L-BFGS to Newton's target; a NewtonResult like newton's."""
    seen = []

    def recorded(x):  # the gradients Newton computes (its first at x0, its last at the accepted iterate)
        g = np.asarray(gradient(x), dtype=float)
        seen.append(g)
        return g

    first = newton(x0, recorded, hessian, **{**options, "max_iterations": newton_steps})
    if first.status != "max-iterations" or newton_steps >= options["max_iterations"]:
        return first
    energy, free, linear, limit = options["energy"], options["free"], options["linear"], options["step_limit"]
    factor = linear.backend._factor  # the kept factorization (the linearised start made or refreshed it)
    x, E, g = first.x, first.energy, seen[-1]
    target, r0 = first.target, first.initial_residual
    rnorm, pairs = np.linalg.norm(g[free]), []
    if newton_steps:
        pairs.append(((x - x0)[free], (g - seen[0])[free]))
    pairs = [(s, y, 1.0 / (s @ y)) for s, y in pairs if s @ y > 0]
    k, tolerance = first.iterations, 1e-11 * max(abs(E), 1.0)
    while rnorm > target and k < options["max_iterations"]:
        d = lbfgs_direction(g[free], pairs, factor.solve)
        slope = g[free] @ d
        if not slope < 0:  # not downhill: the pairs are dropped
            pairs, d = [], lbfgs_direction(g[free], [], factor.solve)
            slope = g[free] @ d
        dx = np.zeros_like(x)
        dx[free] = d
        alpha = 1.0 if limit is None else min(1.0, float(limit(x, dx)))
        for _ in range(30):
            x_new = x + alpha * dx
            E_new = energy(x_new)
            if E_new <= E + 1e-4 * alpha * slope:
                g_new = np.asarray(gradient(x_new), dtype=float)
                break
            if E_new - E <= tolerance:
                g_new = np.asarray(gradient(x_new), dtype=float)
                if np.linalg.norm(g_new[free]) < rnorm:
                    break
            alpha *= 0.5
        else:
            return NewtonResult(x, False, "line-search-failed", k, rnorm, r0, target, E, first.start_energy,
                                first.linear_iterations, first.factorizations, first.history)
        s, y = (x_new - x)[free], (g_new - g)[free]
        if s @ y > 1e-12 * np.linalg.norm(s) * np.linalg.norm(y):
            pairs = (pairs + [(s, y, 1.0 / (s @ y))])[-MEMORY:]
        x, E, g, rnorm, k = x_new, min(E, E_new), g_new, np.linalg.norm(g_new[free]), k + 1
        COUNT["qn"] += 1
    return NewtonResult(x, rnorm <= target, "converged" if rnorm <= target else "max-iterations", k, rnorm, r0,
                        target, E, first.start_energy, first.linear_iterations, first.factorizations, first.history)


WAYS = {"Newton (today)": None, "L-BFGS after the linearised start": 0, "L-BFGS after one Newton step": 1}


def run(data, way, frames):
    steps = WAYS[way]
    stepping.newton = newton if steps is None else (
        lambda x0, g, h, **o: quasi_newton(x0, g, h, newton_steps=steps, **o))
    sim = Simulation(Scene.from_dict(data))
    rows = []
    try:
        for f in range(frames):
            COUNT.update(qn=0, back=0)
            cg0 = sim.solver.linear.backend.cg_iterations  # all of the frame's, the linearised start's too
            t = time.thread_time()
            r = flap_drag(sim, 1, start=f)[0]
            cpu = 1e3 * (time.thread_time() - t)
            cg = sim.solver.linear.backend.cg_iterations - cg0
            rows.append((1e3 * r.elapsed, cpu, r.newton_iterations - COUNT["qn"], COUNT["qn"], cg, cg + COUNT["back"],
                         r.residual_norm / r.newton.target, r.converged))
    finally:
        stepping.newton = newton
        sim.solver.linear.close()
    wall, cpu, nt, qn, cg, back, over, conv = (np.array(c, dtype=float) for c in zip(*rows))
    return {"wall": np.median(wall), "cpu": np.median(cpu), "newton": nt.mean(), "qn": qn.mean(), "cg": cg.mean(),
            "back": back.mean(), "over_target": over.max(), "converged": conv.mean()}, sim.u.copy()


def main(n_triangles=8000, frames=20, repeats=3):
    chosen = [(n, d) for n, d, o in variants(n_triangles) if n in ("base: stable neo-Hookean, quasistatic",
                                                                     "+ probe")]
    runs, loads = {(n, w): [] for n, _ in chosen for w in WAYS}, [load_average()[0]]
    for r in range(repeats):
        for name, data in chosen:
            ways = list(WAYS) if r % 2 == 0 else list(WAYS)[::-1]
            ends = {}
            for way in ways:
                row, ends[way] = run(data, way, frames)
                runs[name, way].append(row)
                loads.append(load_average()[0])
            reference = ends["Newton (today)"]
            for way in ways:
                runs[name, way][-1]["state"] = np.abs(ends[way] - reference).max() / np.abs(reference).max()
                print(f"round {r + 1} {name[:8]:8s} {way:34s} " + " ".join(
                    f"{k} {v:.3g}" for k, v in runs[name, way][-1].items()), flush=True)
    print(f"\n1-minute load average during the runs: {min(loads):.1f}-{max(loads):.1f}")
    print("| variant | inner loop | median ms/frame (runs' range) | frame thread CPU ms (runs' range) | Newton/frame | "
          "quasi-Newton/frame | CG/frame | back-substitutions/frame | worst residual / target | converged | "
          "end state vs Newton's |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for (name, way), rows in runs.items():
        med = {k: float(np.median([row[k] for row in rows])) for k in rows[0]}
        w = [row["wall"] for row in rows]
        c = [row["cpu"] for row in rows]
        print(f"| {name.split(':')[0]} | {way} | {med['wall']:.1f} ({min(w):.1f}-{max(w):.1f}) | {med['cpu']:.1f} "
              f"({min(c):.1f}-{max(c):.1f}) | {med['newton']:.2f} | {med['qn']:.2f} | {med['cg']:.1f} | "
              f"{med['back']:.1f} | {max(row['over_target'] for row in rows):.2f} | "
              f"{min(row['converged'] for row in rows):.0%} | {max(row['state'] for row in rows):.1e} |")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:]))
