# ---
# jupyter:
#   jupytext:
#     formats: ipynb,text//py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Chapter 9 — What accuracy costs in time
#
# **Goals.** By the end of this chapter you can
# 1. say what a *setting* of the simulator is, and measure one by two numbers: its error against a
#    reference and its wall time per frame;
# 2. check that a reference deserves the name: a published linear benchmark solved to its value, and
#    the nonlinear models converging at the rate their elements promise;
# 3. read a Pareto plot: which knob buys accuracy cheaply, which buys nothing, and which setting a
#    33 ms frame can afford;
# 4. tell how the cost of a frame grows with the mesh for each linear solver, and what the budgeted
#    solver leaves unfinished when the budget runs out;
# 5. choose settings for a lecture demo, an interactive simulator and a validation run, and justify
#    each choice with a measured number.
#
# Every chapter so far added a capability. This one adds none: it turns the promise in this workbook's
# first paragraph, *show what accuracy costs in time*, into measured curves. The notes' own advice on
# the subject is qualitative (finer meshes are more accurate, Newton converges quadratically, backward
# Euler is stable for any time step); here we put numbers on it.
#
# **Index convention.** $F_{ij} = \partial\phi_i/\partial X_j$, as in every chapter.

# %%
# %matplotlib inline
import math
import time

import numpy as np
import matplotlib.pyplot as plt

from tissuefem.workbook.accuracy import beam_problem_tip, manufactured_convergence
from tissuefem.workbook.measure import best_within_budget, fitted_exponent, pareto_front
from tissuefem.workbook.bench.accuracy import PLANS, accuracy_study, format_knob_table, recorded_results
from tissuefem.workbook.figures.accuracy import fig_ch09_verification, plot_budget, plot_pareto, plot_scaling

recorded = recorded_results()
machine = recorded["machine"]
print(f"recorded study: plan '{recorded['plan_name']}', {len(recorded['knobs'])} settings, "
      f"{recorded['seconds'] / 60:.0f} minutes on {machine['cpu_count']} cores")
print(f"python {machine['python']}, numpy {machine['numpy']}, scipy {machine['scipy']}, "
      f"scikit-fem {machine['scikit-fem']}")

# %% [markdown]
# ## 1. A setting, its error, its cost
#
# A **setting** fixes every choice the simulator makes that is not part of the physics: the mesh, the
# element order, the quadrature rule, the material model, when Newton stops, the time step and the
# linear solver. Each is a *knob*: turn it one way and the answer gets closer to the truth, turn it the
# other and frames get cheaper.
#
# We measure a setting on two benchmarks, both on the rectangle $[0,2]\times[0,1]$ with its left edge
# fixed and a handle on its right edge ($E = 1000$, $\nu = 0.3$, plane strain):
#
# * **the flap scene** of chapters 7 and 8: backward Euler with $\Delta t = 1/30$ s, $\rho_0 = 1$, the
#   handle carried along a scripted loop; one displayed frame every 1/30 s;
# * **the quasistatic block** of chapter 4: the right edge carried to $(0.6, 0.4)$ in equal increments,
#   one equilibrium solve per frame.
#
# The **cost** of a setting is the median wall time of a displayed frame (everything: assembly, every
# Newton iteration, every linear solve, and all substeps if the time step is below 1/30 s). The
# **error** is the relative $L^2$ norm of the displacement error against a reference solution $\mathbf u^\star$:
#
# $$e = \frac{\lVert \mathbf u_h - \mathbf u^\star \rVert_{L^2(B_0)}}{\lVert \mathbf u^\star \rVert_{L^2(B_0)}},$$
#
# evaluated by quadrature on the setting's own mesh (the reference, on another mesh, is found by point
# location). For the flap it is the largest error over every fifth frame of the drag; for the block the
# error of the final equilibrium, which does not depend on the path.
#
# Knobs are turned **one at a time** away from a *baseline*: P1 on about 8 000 triangles, Neo-Hookean
# ($\ln J$), Newton to a relative residual of $10^{-6}$, one backward-Euler step per frame, CG
# preconditioned by a reused SuperLU factorization (chapter 7's defaults). So each curve tells what one
# knob does when everything else stays as a real-time simulator would run it.

# %% [markdown]
# ## 2. First, a reference that deserves the name
#
# The **reference** pushes every knob to its accurate end at once: P2 elements on the finest mesh of
# the study, consistent mass, Newton to a relative residual of $10^{-10}$ and, for the flap, a small
# time step. Backward Euler's error is first order in $\Delta t$, $\mathbf u_{\Delta t} = \mathbf u + \Delta t\,\mathbf c + O(\Delta t^2)$,
# so two runs with steps $\tau$ and $\tau/2$ combine into
#
# $$\mathbf u^\star = 2\,\mathbf u_{\tau/2} - \mathbf u_{\tau} = \mathbf u + O(\tau^2)$$
#
# (Richardson extrapolation), with $\tau = \Delta t/4$. A measured curve is only as good as its
# reference, so we check the reference three ways.
#
# **(a) A published linear benchmark.** The end-loaded cantilever of Timoshenko and Goodier
# (*Theory of Elasticity*): length 48, depth 12, a parabolic shear load totalling $P = 1000$ on the free
# end, $E = 3\cdot 10^7$, $\nu = 0.3$, plane stress. Its exact displacement is a cubic polynomial; the
# tip deflection is $8.9\cdot 10^{-3}$. We hold the exact displacement on $x = 0$ and apply the exact
# traction on $x = L$ (the test suite re-derives both from the closed form by finite differences).

# %%
print(" elements   mesh     tip deflection   relative error")
for order, meshes in ((1, ((8, 2), (16, 4), (32, 8), (64, 16))), (2, ((8, 2), (16, 4), (32, 8)))):
    for nx, ny in meshes:
        tip, exact = beam_problem_tip(nx, ny, order)
        print(f"   P{order}     {nx:3d} x {ny:2d}    {tip:.6e}     {abs(tip - exact) / exact:.2e}")
print(f"exact: {exact:.6e}")

# %% [markdown]
# P1 elements are stiff in bending: on 16 cells along the beam they miss the deflection by a few per
# cent, and the error falls by four with each halving of $h$. P2 represents the quadratic part of the
# bending field exactly and lands on the published value to a few parts in $10^{7}$.
#
# **(b) The nonlinear models converge at the expected rate.** The flap's truth is unknown, but we can
# *make* a problem whose truth we know. Take chapter 3's bending map $\boldsymbol\phi$ (the block bent
# into an arch), with its exact gradient $\mathbf F$. It is in equilibrium under the body force
#
# $$\mathbf b = -\nabla_{\mathbf X}\cdot\mathbf P(\mathbf F), \qquad b_i = -\frac{\partial P_{iJ}}{\partial X_J},$$
#
# so holding the whole boundary at $\boldsymbol\phi$ and loading the block with $\mathbf b$ must return
# $\boldsymbol\phi$ itself. (`manufactured_body_force` takes the divergence by central differences of
# the material's own stress.) The displacement is smooth, so the $L^2$ error of P$k$ elements should
# fall like $h^{k+1}$: rate 2 for P1 and 3 for P2, for every model.

# %%
rows = manufactured_convergence()
for r in rows:
    rates = ", ".join(f"{x:.2f}" for x in r["rates"])
    print(f"{r['model']:20s} P{r['order']}: errors {r['errors'][0]:.1e} ... {r['errors'][-1]:.1e}; "
          f"rates {rates} (expected {r['expected_rate']})")
fig_ch09_verification(rows=rows)

# %% [markdown]
# All three models converge at 2.00 (P1) and 2.99 (P2). The whole chain (material, P2 quadrature
# assembly, handles, load stepping, Newton) is verified, nonlinearity included; the earlier studies of
# chapter 4 saw lower rates only because the block's corners make its solution singular.
#
# **(c) The reference against its own coarser sibling.** The same reference computed on a mesh four
# times coarser (twice the $h$) should already be closer to it than any setting of the sweep. And the
# two time steps of the flap's extrapolation tell how much time error the finer one still had.

# %%
for name, ref in recorded["references"].items():
    line = (f"{name:6s} reference: P2, {ref['triangles']} triangles, {ref['dofs']} dofs; "
            f"its sibling on {ref['coarser_sibling_triangles']} triangles differs by {ref['coarser_sibling_error']:.1e}")
    if ref["substeps"]:
        line += f"; the two time steps differ by {ref['time_error_estimate']:.1e}"
    print(line)

# %% [markdown]
# ## 3. The study: every knob on one plot
#
# `python -m tissuefem bench accuracy` runs the full study (about a quarter of an hour here) and writes
# `bench-results/accuracy.json`, one CSV per table (with the machine and library versions in every
# row) and three figures. The package ships one recorded run, which the lecture figures and this chapter
# read. Here is the table behind the plot, one row per setting:

# %%
print(format_knob_table(recorded["knobs"]))

# %%
plot_pareto(recorded)

# %% [markdown]
# How to read it. Each coloured curve is one knob, its points the settings swept; the black star is
# the baseline, where all curves of a panel meet; the dashed line is the 33 ms frame budget. The thick
# grey staircase is the **Pareto front**: the settings that no other setting beats on *both* error and
# cost. Only these are worth choosing; everything above-right of the staircase pays more for less.
# `pareto_front(costs, errors)` finds them (exercise 9.1 asks you to write it).
#
# The two panels tell opposite stories, and that is the first lesson of the chapter.

# %% [markdown]
# ## 4. Knob by knob
#
# The numbers quoted below are read from the recorded run by this small helper, so they always match
# the table above.

# %%
def knob(benchmark, name):
    """The recorded rows of one knob of one benchmark: value, triangles, ms per frame, Newton per frame, error."""
    out = [r for r in recorded["knobs"] if r["benchmark"] == benchmark and r["knob"] == name]
    for r in out:
        print(f"  {str(r['value']):20s} {r['triangles']:6d} tri  {r['ms_median']:8.1f} ms/frame  "
              f"{r['newton']:5.2f} Newton  error {r['error']:.2e}")
    return out


print("block, mesh (P1):")
block_mesh = knob("block", "mesh")
print("block, P2:")
block_p2 = knob("block", "P2")
print("flap, mesh (P1):")
flap_mesh = knob("flap", "mesh")
print("flap, time step (substeps per frame):")
flap_dt = knob("flap", "time_step")

# %% [markdown]
# **Mesh size and element order.** On the quasistatic block the error falls steadily with the mesh
# (the fitted rate below: under 2 because of the corner singularities) and the cost grows about in
# proportion to the number of triangles. P2 reaches a given error with fewer unknowns than P1, but each
# P2 triangle costs more (six quadrature points, denser matrices). In the recorded run the two are even
# at the 33 ms line (about $1.6\cdot 10^{-4}$ for P1 on 8 000 triangles, $1.2\cdot 10^{-4}$ for P2 on
# 1 000 at 36 ms); below $10^{-4}$ P2 is about three times cheaper for the same error.
#
# On the flap, in striking contrast, the mesh curves are flat: from 500 to 32 000 triangles, P1 or P2,
# the error does not move. Something else dominates it.

# %%
h = [1 / math.sqrt(r["triangles"]) for r in block_mesh]
print(f"block, P1: error ~ h^{fitted_exponent(h, [r['error'] for r in block_mesh]):.2f}, "
      f"cost ~ triangles^{fitted_exponent([r['triangles'] for r in block_mesh], [r['ms_median'] for r in block_mesh]):.2f}")
spread = max(r["error"] for r in flap_mesh) / min(r["error"] for r in flap_mesh)
print(f"flap: the largest mesh error is {spread:.2f} times the smallest")

# %% [markdown]
# **The time step.** That something is backward Euler. Its numerical damping (chapter 7) takes the
# energy out of the flap's vibrations within a few frames at $\Delta t = 1/30$ s, while the reference
# keeps them; only smaller steps (more backward-Euler steps per displayed frame, each one a full
# nonlinear solve) bring the error down, and each halving of $\Delta t$ roughly doubles the frame's
# cost. The error falls more slowly than first order here because the worst checkpoint is early in the
# drag, where the start-up transient is strongest. Later in the drag the errors are smaller, and there
# a caveat applies: the reference's two time steps differ by $1.9\cdot 10^{-2}$ (section 2), so flap
# errors much below $10^{-2}$ are at the resolution of the reference itself, and we draw no conclusion
# from them.

# %%
for r in flap_dt:
    per_frame = ", ".join(f"{e:.1e}" for e in r["errors"])
    print(f"  {r['value']} substep(s): errors at frames {r['checkpoints']}: {per_frame}")

# %% [markdown]
# **Quadrature.** The default rule for P2 is exact for degree 4 (6 points). For Neo-Hookean the
# integrand is not a polynomial, so no rule is exact; but 3 points (degree 2) already give the same error
# to within about one per cent (1.1 % in the recorded run), and a rule beyond degree 4 only adds cost. Quadrature is a knob worth setting
# once and forgetting. (Fewer than 3 points would leave a P2 triangle with zero-energy modes.)
#
# **The material model.** The reference is Neo-Hookean ($\ln J$); the other models are different
# materials that agree with it at small strain. On the block their error is the *modelling error* of
# using them in place of $\ln J$ Neo-Hookean at a 30 % stretch, and it dwarfs every discretisation
# error of the sweep. The Taylor variant (whose $r(J)$ matches $\ln J$ to third order, chapter 2) stays
# within $10^{-3}$; corotated and stable Neo-Hookean (whose volume term differs at large strain) are off
# by more than one per cent; linear elasticity (which knows only small rotations, chapter 3) by three per
# cent, but its frames are an order of magnitude cheaper: one back-substitution with a kept
# factorization. So the model is not a speed knob like the others: choose it for the tissue, then tune
# the rest.

# %%
print("block, material:")
block_material = knob("block", "material")
print("block, Newton tolerance:")
block_tol = knob("block", "newton_tolerance")
print("block, Newton iterations cap:")
block_cap = knob("block", "newton_cap")

# %% [markdown]
# **Newton's tolerance and a cap on its iterations.** Tolerances tighter than the discretisation error
# buy nothing: the block's error is the same to three digits from $10^{-1}$ to $10^{-8}$, while the
# tighter tolerances cost more iterations. Even a cap of one Newton step per frame, the budgeted
# solver's worst case, leaves the error unchanged here: the warm start of a quasistatic frame is a
# linearised step that carries the free nodes along with the handle, and one Newton step from there
# lands within round-off of the discretisation error. (Chapter 7's figure shows the same cap on the
# *dynamic* flap, where it leaves a visible residual.)
#
# **The linear solver.** All solvers solve the same equations, so their errors agree to the Newton
# tolerance: on the plot they form a horizontal row of points and the only question is cost.

# %%
print("flap, linear solver:")
flap_solvers = knob("flap", "linear_solver")

# %% [markdown]
# Reusing one factorization as the preconditioner of CG (chapter 7) beats a fresh factorization every
# Newton iteration, and the minimum-degree ordering beats SciPy's default COLAMD (chapter 7, `linsolve`).
# Iterative solvers with cheap preconditioners lose at this size: with Jacobi, CG needs over a thousand
# iterations per Newton step at 8 000 triangles (the elasticity matrices are ill-conditioned, and the
# count grows like $1/h$); incomplete LU cuts that to about ten but costs nearly a factorization to
# build. PARDISO, when installed, is measured too, and shows that how a library is called matters as
# much as the library: a fresh PARDISO solver per Newton iteration costs about a third of a second here
# *whatever the mesh size* (set-up, not factorization), while PARDISO reused as the CG preconditioner is
# within a factor of two of the default.
#
# ## 5. How the cost grows with the mesh
#
# The cost of a frame is the cost of a few Newton iterations, and an iteration is assembly (linear in
# the number of triangles) plus a linear solve (superlinear for a direct solver: the fill grows faster
# than the matrix). A log-log fit of ms per frame against triangles, $\text{ms} \approx C\,n^{p}$,
# measures $p$ for each solver; $p = 1$ would be perfect scaling.

# %%
for solver, p in recorded["scaling"]["exponents"].items():
    print(f"  {solver:16s} p = {p:.2f}")
plot_scaling(recorded)

# %% [markdown]
# Where a curve crosses the dashed line is the largest mesh that solver can run at 30 frames per
# second. The exponent tells how fast that limit recedes on a faster machine: with $p$ near 1 a machine
# twice as fast allows twice the triangles; with $p = 1.5$ only $2^{1/1.5} \approx 1.6$ times.
#
# ## 6. What the budget leaves unfinished
#
# The real-time solver of chapter 7 never overruns its 33 ms by more than one linear solve: when the
# budget is spent it commits the last accepted iterate. How far from converged is that iterate? For
# each mesh size, the flap scene run with the budget and the real clock, against the same scene with
# every frame converged:

# %%
for r in recorded["budget"]:
    print(f"  {r['solver']:8s} {r['triangles']:6d} triangles: {r['converged_share']:4.0%} of frames converged, "
          f"median residual {r['residual_median']:.1e}, state error after the drag {r['state_error']:.1e}")
plot_budget(recorded)

# %% [markdown]
# Up to the mesh where a converged frame fits the budget, nothing is lost. Beyond it the frames end
# unconverged, the residual left climbs by orders of magnitude, and the state drifts from the converged
# one: but smoothly, and far below the time-step error of section 4. The budget degrades gracefully;
# it never crashes and never returns NaN (chapter 7's promise, measured here across mesh sizes).
#
# ## 7. Your own run
#
# Timings are one machine's: yours will differ. The **reduced** plan runs the same study with smaller
# meshes and fewer settings in under a minute (`python -m tissuefem bench accuracy --plan reduced`; the
# full plan is the default). Compare its *ratios* with the recorded ones, not its milliseconds.

# %%
start = time.perf_counter()
mine = accuracy_study("reduced", scaling=False, budget=False, verification=False, progress=None)
print(f"reduced study: {len(mine['knobs'])} settings in {time.perf_counter() - start:.0f} s")
plot_pareto(mine)

# %%
def ratio(results, benchmark, knob_a, value_a, knob_b, value_b):
    rows = {(r["knob"], r["value"]): r for r in results["knobs"] if r["benchmark"] == benchmark}
    return rows[(knob_a, value_a)]["ms_median"] / rows[(knob_b, value_b)]["ms_median"]


for results, label in ((recorded, "recorded"), (mine, "yours")):
    print(f"{label:8s}: flap, fresh SuperLU / reused factorization = "
          f"{ratio(results, 'flap', 'linear_solver', 'direct', 'linear_solver', 'reuse'):.1f}x; "
          f"flap, 4 substeps / 1 = {ratio(results, 'flap', 'time_step', 4, 'time_step', 1):.1f}x")

# %% [markdown]
# ## 8. Recommendations
#
# Each recommendation below is read off the recorded study; the cell after it recomputes the numbers.
#
# * **For teaching** (a lecture demo, a student's laptop): P1, Neo-Hookean or stable Neo-Hookean,
#   2 000 triangles, the default solver, $\Delta t = 1/30$. Frames take a few milliseconds, so there is
#   room for several substeps when the lesson is about dynamics: a coarse mesh costs nothing visible,
#   and the time step is what changes the motion.
# * **For an interactive simulator** (30 frames per second): the most accurate setting under 33 ms. On
#   the quasistatic block that is a fine P1 mesh with a loose Newton tolerance; on the flap, spend the
#   budget on *substeps*, not triangles: the mesh error is invisible next to backward Euler's damping.
#   Keep the reused factorization and the minimum-degree ordering; never use a fresh COLAMD
#   factorization per iteration.
# * **For a validation run** (a number to compare with an experiment): P2 on the finest mesh affordable,
#   Newton to $10^{-8}$ or tighter, a small time step with an extrapolation check, and report the
#   distance to a coarser sibling as the error bar. Its frames take seconds, not milliseconds.

# %%
budget = recorded["frame_budget_ms"]
for b in ("flap", "block"):
    rows_b = [r for r in recorded["knobs"] if r["benchmark"] == b]
    best = best_within_budget([r["ms_median"] for r in rows_b], [r["error"] for r in rows_b], budget)
    base = next(r for r in rows_b if r["baseline"])
    r = rows_b[best]
    print(f"{b}: the baseline costs {base['ms_median']:.1f} ms with error {base['error']:.2e}; "
          f"the best under {budget:.0f} ms is {r['knob']} = {r['value']} "
          f"({r['triangles']} triangles, P{r['order']}): {r['ms_median']:.1f} ms, error {r['error']:.2e}")
    front = [rows_b[i] for i in pareto_front([r["ms_median"] for r in rows_b], [r["error"] for r in rows_b])]
    print("   Pareto front: " + "; ".join(f"{r['knob']}={r['value']} ({r['ms_median']:.0f} ms, {r['error']:.1e})"
                                          for r in front))

# %% [markdown]
# ## What to try
#
# * Run `python -m tissuefem bench accuracy --plan reduced --out my-results` and open
#   `my-results/accuracy_pareto.png`. Which knob's ranking changed on your machine, and which did not?
# * Give the flap scene a second-order time integrator's worth of accuracy the cheap way: run the
#   baseline with 1 and 2 substeps and extrapolate ($2\mathbf u_{1/60} - \mathbf u_{1/30}$). How close to the
#   reference does that get, at what cost? (Use `run_setting` and `relative_l2_error`.)
# * Make a knob of your own: the mass matrix (lumped against consistent) or the Poisson ratio near 0.5.
#   Add it to a plan dict and pass the dict to `accuracy_study`.
#
# ## Exercises
#
# In `chapters/exercises/ch09.py`; grade them with `python -m tissuefem grade ch09`.
#
# * **9.1** `pareto_front(costs, errors)`: the indices of the settings no other setting beats, in order
#   of increasing cost (ties and failed settings included in the test).
# * **9.2** `observed_rates(h, errors)`: the convergence rate between each pair of successive meshes.
# * **9.3** `best_within_budget(costs, errors, budget)`: the setting to choose under a frame budget.
