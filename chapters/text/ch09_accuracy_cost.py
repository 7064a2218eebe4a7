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
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Chapter 9 — What accuracy costs in time
#
# **Goals.** By the end of this chapter you can
# 1. say what a *setting* of the simulator is, and measure one by two numbers: its error against a
#    reference and its wall time per frame;
# 2. check that a reference deserves the name: a published benchmark solved to its value, the nonlinear
#    models converging at their rate, and the reference's own error estimated and shown to be far below
#    every error it judges;
# 3. read a Pareto plot: which knob buys accuracy cheaply, which buys nothing, and which setting a
#    33 ms frame can afford, without crowning a winner by its last digits;
# 4. tell how the cost of a frame grows with the mesh for each linear solver, and what the budgeted
#    solver leaves unfinished;
# 5. choose settings for a lecture demo, an interactive simulator and a validation run.
#
# *Time: about 60 min to read and run, and three exercises.*
#
# Every chapter so far added a capability. This one adds none: it puts numbers on the notes' qualitative
# advice (finer meshes are more accurate, Newton converges quadratically, backward Euler is stable for any
# time step) and on the promise of this workbook's first paragraph, *show what accuracy costs in time*.
#
# **Index convention.** As everywhere (chapter 3), $F_{ij} = \partial\phi_i/\partial X_j$, formulas count
# from 1 and code from 0.

# %%
# %matplotlib inline
import math
import time

import numpy as np
from IPython.display import Markdown, display

from tissuefem.workbook.verification import beam_problem_tip, manufactured_convergence
from tissuefem.workbook.measure import best_within_budget, cost_at_error, fitted_exponent, pareto_front
from tissuefem.workbook.bench.accuracy_cost import (RESIDUAL_COLUMN_NOTE, accuracy_study, capped_newton_experiment,
                                               format_knob_table, recorded_results, time_convergence)
from tissuefem.workbook.figures.tradeoffs import (ERROR_RESOLUTION, fig_ch09_verification, plot_budget, plot_pareto,
                                                 plot_scaling)

recorded = recorded_results()
machine = recorded["machine"]
print(f"recorded study: plan '{recorded['plan_name']}', {len(recorded['knobs'])} settings, "
      f"{recorded['seconds'] / 60:.0f} minutes on {machine['cpu_count']} cores; python {machine['python']}, "
      f"numpy {machine['numpy']}, scipy {machine['scipy']}, scikit-fem {machine['scikit-fem']}")
conditions = recorded["conditions"]
print(f"recorded on {conditions['date']}, {'nothing else running' if conditions['quiet'] else 'a busy machine'}: "
      f"{conditions['note']}")


def rows_of(benchmark, knob=None, results=recorded):
    return [r for r in results["knobs"] if r["benchmark"] == benchmark and (knob is None or r["knob"] == knob)]


def show(rows):
    display(Markdown(format_knob_table(rows)))


# %% [markdown]
# ## 1. A setting, its error, its cost
#
# A **setting** fixes every choice the simulator makes that is not part of the physics: the mesh, the
# element order, the quadrature rule, the material model, when Newton stops, the time step and the linear
# solver. Each is a *knob*: turn it one way and the answer gets closer to the truth, turn it the other and
# frames get cheaper. We measure settings on two benchmarks, both on the rectangle $[0,2]\times[0,1]$ with its
# left edge fixed and a handle on its right edge ($E = 1000$, $\nu = 0.3$, plane strain):
#
# * **the flap** of chapters 7 and 8: backward Euler with $\Delta t = 1/30$ s, $\rho_0 = 1$, the handle carried
#   along chapter 7's loop, but *eased in* over the first half second (it starts at rest instead of already
#   moving; section 2 says why); one displayed frame every 1/30 s;
# * **the quasistatic block** of chapter 4: the right edge carried to $(0.6, 0.4)$ in ten equal frames.
#
# The **cost** is the median wall time of a displayed frame (assembly, every Newton iteration and linear
# solve, every substep). The **error** is the relative $L^2$ norm of the displacement error against a
# reference $\mathbf u^\star$,
#
# $$e = \frac{\lVert \mathbf u_h - \mathbf u^\star \rVert_{L^2(B_0)}}{\lVert \mathbf u^\star \rVert_{L^2(B_0)}},$$
#
# by quadrature on the setting's mesh (the reference, on another mesh, found by point location): for the
# flap the largest over every fifth frame, for the block at the final equilibrium. Knobs are turned **one at a
# time** away from a *baseline*, chapter 7's defaults: P1 on about 8 000 triangles, Neo-Hookean ($\ln J$),
# Newton to a relative residual of $10^{-6}$ (relative to the larger of the frame's start residual and the
# load it carries; section 3 says how the tables report it), one backward-Euler step per frame, CG preconditioned by a kept
# SuperLU factorization.
#
# ## 2. A reference that deserves the name
#
# The **reference** pushes every knob further than any setting at once: P2 elements, Newton to $10^{-10}$,
# and for the flap a small time step, extrapolated: backward Euler's error is first order,
# $\mathbf u_{\Delta t} = \mathbf u + \Delta t\,\mathbf c + O(\Delta t^2)$, so two runs with steps $\tau$ and $\tau/2$
# combine into $\mathbf u^\star = 2\,\mathbf u_{\tau/2} - \mathbf u_{\tau} = \mathbf u + O(\tau^2)$ (Richardson),
# here with $\tau = \Delta t/16$. The mesh is **graded**: its nodes are pulled towards the edges, most of all
# towards the four corners where a held edge meets a free one. There the exact solution is singular, and on
# uniform meshes even P2 converges at a rate below 2 there instead of 3 (chapter 4); graded, it converges at
# the rate printed in (c) below.
# A measured curve is only as good as its reference, so we check it three ways.
#
# **(a) A published linear benchmark.** The end-loaded cantilever of Timoshenko and Goodier (*Theory of
# Elasticity*): length 48, depth 12, a parabolic shear load of $P = 1000$ on the free end,
# $E = 3\cdot 10^7$, $\nu = 0.3$, plane stress; its tip deflection is $8.9\cdot 10^{-3}$. The exact displacement
# is held on $x = 0$ and the exact traction applied on $x = L$.

# %%
beam_errors = {}
for order, meshes in ((1, ((8, 2), (16, 4), (32, 8), (64, 16))), (2, ((8, 2), (16, 4), (32, 8)))):
    for nx, ny in meshes:
        tip, exact = beam_problem_tip(nx, ny, order)
        beam_errors.setdefault(order, []).append(abs(tip - exact) / exact)
        print(f"P{order} on {nx:2d} x {ny:2d} cells: tip deflection {tip:.6e}, relative error {abs(tip - exact) / exact:.1e}")
print(f"exact: {exact:.6e}")

# %%
p1_factors = [a / b for a, b in zip(beam_errors[1], beam_errors[1][1:])]
display(Markdown(
    "P1 elements are stiff in bending: each halving of $h$ divides the error by "
    f"{', '.join(f'{x:.1f}' for x in p1_factors)}, approaching four, the second order of P1's error. P2 "
    "represents the quadratic part of the bending field exactly and lands on the published value to a relative "
    f"{beam_errors[2][-1]:.0e} on its finest mesh ({beam_errors[2][0]:.0e} on its coarsest)."))

# %% [markdown]
#
# **(b) The nonlinear models converge at their rate.** Take chapter 3's bending map $\boldsymbol\phi$ and load the
# block with the body force $\mathbf b = -\nabla_{\mathbf X}\cdot\mathbf P(\mathbf F)$ that holds it there
# (computed by central differences of the material's own stress); with the whole boundary held at
# $\boldsymbol\phi$, the solution must be $\boldsymbol\phi$ itself, and its $L^2$ error should fall like $h^{k+1}$ for
# P$k$ elements.

# %%
rows = manufactured_convergence()
for r in rows:
    print(f"{r['model']:20s} P{r['order']}: errors {r['errors'][0]:.1e} ... {r['errors'][-1]:.1e}; "
          f"rates {', '.join(f'{x:.2f}' for x in r['rates'])} (expected {r['expected_rate']})")
for order in (1, 2):
    fitted = [r["fitted_rate"] for r in rows if r["order"] == order]
    spread = (f"lie between {min(fitted):.2f} and {max(fitted):.2f}" if f"{min(fitted):.2f}" != f"{max(fitted):.2f}"
              else f"are all {min(fitted):.2f}")
    print(f"P{order}: the three models' fitted rates {spread} (expected {order + 1})")
fig_ch09_verification(rows=rows)

# %% [markdown]
# All three models converge at the expected rates (the fits printed above): material, P2 assembly, handles,
# load stepping and Newton are verified together, nonlinearity included.
#
# **(c) The reference's own error, estimated.** The same reference on meshes with a quarter and a sixteenth
# of the triangles (each halving $h$) shows how fast it converges; if the distance between successive levels
# falls like $2^{-p}$, the finest one's own error is about $d/(2^p - 1)$, with $d$ its distance to the next
# coarser. The same in time for the flap, from the extrapolations with steps two and four times larger. The
# estimate must lie well below the smallest error the reference is asked to judge:

# %%
for name, ref in recorded["references"].items():
    best = min(r["error"] for r in rows_of(name))
    line = (f"{name:5s}: P2 on {ref['triangles']} graded triangles ({ref['dofs']} dofs); in space: distance "
            f"{ref['space_distance']:.1e}, rate {ref['space_rate']:.2f}, estimate {ref['space_error_estimate']:.1e}")
    if ref["substeps"]:
        line += (f"; in time ({ref['substeps'][0]} and {ref['substeps'][1]} substeps): distance "
                 f"{ref['time_distance']:.1e}, rate {ref['time_rate']:.2f}, estimate {ref['time_error_estimate']:.1e}")
    print(line)
    print(f"       error estimate {ref['error_estimate']:.1e}: {best / ref['error_estimate']:.0f} times below "
          f"the smallest error of any setting ({best:.2e})")

# %%
for name, ref in recorded["references"].items():
    largest = max(r["dofs"] for r in rows_of(name))
    display(Markdown(f"The {name}'s reference has {ref['dofs']:,} unknowns, {ref['dofs'] / largest:.1f} times the "
                     f"{largest:,} of the largest setting it judges."))

# %% [markdown]
# So a reference need not be much larger than every setting: the flap's has about as many unknowns as the
# largest one. It is better *where the error is made*: P2 on a mesh graded towards the corners, and in time,
# extrapolated from substeps. What qualifies both references is the estimate printed above: each one's own
# error lies well below the smallest error it is asked to judge, so the errors below are the settings' own,
# to within that estimate. Getting there for the flap needed one change to chapter 7's drag. That loop starts with the handle already moving: a jump
# in velocity at $t = 0$, which sends a wave through the body. How fast does backward Euler converge then? The
# distance between runs whose steps differ by a factor of two should halve with each halving for a first-order
# method (`time_convergence`: the flap on 500 triangles, five frames):

# %%
time_ratios = {}
for drag in ("jump", "eased"):
    tc = time_convergence(drag)
    time_ratios[drag] = np.asarray(tc["ratios"])
    print(f"{drag:5s} drag: distances between successive halvings of dt {np.round(tc['distances'], 4)}; "
          f"each over the one before {np.round(tc['ratios'], 2)}")

# %%
jump, eased = time_ratios["jump"], time_ratios["eased"]
display(Markdown(
    f"With the abrupt start the first halving does not shrink the distance at all (ratio {jump[0]:.2f}), and the "
    f"later ones by only {', '.join(f'{x:.2f}' for x in jump[1:])} (an order of "
    f"{', '.join(f'{-np.log2(x):.1f}' for x in jump[1:])}): at that pace no affordable reference could be "
    f"checked. Eased in, the motion is smooth in time and the ratio goes {' -> '.join(f'{x:.2f}' for x in eased)}, "
    "approaching one half: backward Euler converges at first order, and the extrapolation at about second."))

# %% [markdown]
#
# ## 3. The study: every knob on one plot
#
# `python -m tissuefem bench accuracy` runs the full study (about a quarter of an hour here) and writes
# `bench-results/accuracy.json`, one CSV per table with the machine and library versions in every row, and
# three figures. The package ships one recorded run, which the figures and this chapter read.

# %%
plot_pareto(recorded)

# %% [markdown]
# Each coloured curve is one knob, its points the settings swept; the black star is the baseline, where the
# curves meet; the dashed line is the 33 ms frame budget. The grey staircase is the **Pareto front**: the
# settings that no other setting beats on *both* cost and error. Errors that agree to 1 % are treated as
# equal (`pareto_front(costs, errors, rtol=0.01)`; exercise 9.1 writes the strict version): a setting that is
# slower and better only in the third digit is not worth choosing, and the reference cannot tell it anyway.
# The settings on the fronts:

# %%
for b in ("flap", "block"):
    sel = rows_of(b)
    front = pareto_front([r["ms_median"] for r in sel], [r["error"] for r in sel], rtol=ERROR_RESOLUTION)
    print(f"{b}:")
    show([sel[i] for i in front])
display(Markdown(RESIDUAL_COLUMN_NOTE))

# %% [markdown]
# The two panels tell opposite stories, and that is the first lesson of the chapter.
#
# ## 4. Knob by knob
#
# This section reads each knob's curve; the tables of every setting, both benchmarks, are the book's appendix,
# [chapter 9, knob by knob](../appendix_ch09_knobs.html) (`python -m tissuefem book` writes it). In this
# notebook, `show(rows_of("block", "newton_cap"))` prints one knob's table, `show(rows_of("flap"))` a benchmark's.
#
# **Mesh size and element order.** On the block the error falls steadily with the mesh, at a rate below 2
# because of the corners, and the cost grows about in proportion to the triangles. P2 reaches a given error
# with fewer unknowns than P1 but pays more per unknown; what counts is the time to reach an error:

# %%
block_p1, block_p2 = rows_of("block", "mesh"), rows_of("block", "P2")
h = [1 / math.sqrt(r["triangles"]) for r in block_p1]
print(f"block, P1: error ~ h^{fitted_exponent(h, [r['error'] for r in block_p1]):.2f}, "
      f"cost ~ triangles^{fitted_exponent([r['triangles'] for r in block_p1], [r['ms_median'] for r in block_p1]):.2f}")
p2_gain = {}
for target in (2e-4, 1e-4, 6e-5):
    t1, t2 = (cost_at_error([r["ms_median"] for r in rs], [r["error"] for r in rs], target) for rs in (block_p1, block_p2))
    p2_gain[target] = t1 / t2
    print(f"to reach {target:.0e}: P1 {t1:5.1f} ms, P2 {t2:5.1f} ms per frame: P2 {t1 / t2:.1f} times cheaper")
for knob in ("mesh", "P2"):
    errors = [r["error"] for r in rows_of("flap", knob)]
    triangles = [r["triangles"] for r in rows_of("flap", knob)]
    print(f"flap, {knob}: error from {min(errors):.3e} to {max(errors):.3e} over {min(triangles)} to {max(triangles)} "
          "triangles")

# %%
display(Markdown(
    "On the block P2 is cheaper than P1 for the same error" + (", and more so the smaller the error" if
    list(p2_gain.values()) == sorted(p2_gain.values()) else "") + ": "
    + ", ".join(f"{gain:.1f} times at an error of {target:.0e}" for target, gain in p2_gain.items()) + "."))

# %% [markdown]
# On the flap, in striking contrast, the mesh curves are nearly flat: from 500 to 32 000 triangles, P1 or P2,
# the error moves by a few per cent. Something else dominates it. (The errors are reproducible, and
# trustworthy to within the reference's own error estimated in section 2; the milliseconds are this recording's,
# made with nothing else running on the machine.)
#
# **The time step.** That something is backward Euler's numerical damping (chapter 7): at $\Delta t = 1/30$ s it
# takes the energy out of the flap's vibrations within a few frames, while the reference keeps them. Only
# smaller steps (more backward-Euler steps per displayed frame, each a full nonlinear solve) bring the error
# down, each halving of $\Delta t$ by a factor of about 1.7 at twice the cost:

# %%
steps = rows_of("flap", "time_step")
for a, b in zip(steps, steps[1:]):
    print(f"{a['value']} -> {b['value']} substeps: error / {a['error'] / b['error']:.2f}, "
          f"time x {b['ms_median'] / a['ms_median']:.2f}")

# %% [markdown]
# **Quadrature and the linear solver** change nothing that matters. The P2 errors with quadrature of degree
# 2, 3, 4 and 6 agree to 1 % (fewer than 3 points would leave a P2 triangle with zero-energy modes), and all
# linear solvers solve the same equations, so their errors agree to the Newton tolerance: only their cost
# differs. A kept factorization preconditioning CG (chapter 7) beats a fresh factorization every Newton step,
# the minimum-degree ordering beats SciPy's default COLAMD, and CG with cheap preconditioners (Jacobi,
# incomplete LU) loses at this size: the elasticity matrices are ill-conditioned.
#
# **The material model** is not a speed knob. The reference is Neo-Hookean ($\ln J$); the other models are
# other materials that agree with it at small strain, and their "error" on the block is the *modelling error*
# of using them in its place at a 30 % stretch: under $10^{-3}$ for the Taylor variant, over one per cent for
# corotated and stable Neo-Hookean, three per cent for linear elasticity, far above every discretisation
# error. Choose the model for the tissue, then tune the rest.
#
# One row of the flap's Pareto front needs saying. There the *linear* material sits on the front, cheaper than
# the Neo-Hookean baseline and no worse, against a Neo-Hookean reference:

# %%
flap_material = {r["value"]: r for r in rows_of("flap", "material")}
linear, neo = flap_material["linear"], flap_material["neo-hookean"]
block_linear = next(r for r in rows_of("block", "material") if r["value"] == "linear")
display(Markdown(
    f"On the flap the linear material's error is {linear['error']:.3e} against the Neo-Hookean "
    f"{neo['error']:.3e} ({100 * (linear['error'] / neo['error'] - 1):+.1f} %), at {linear['ms_median']:.1f} ms "
    f"a frame against {neo['ms_median']:.1f}. On the block, stretched by 30 %, the same linear material is "
    f"{block_linear['error']:.1e} "
    "away from the reference."))

# %% [markdown]
# That is no vote for linear elasticity. The flap's error is the time step's damping (section 4, "The time step"),
# some per cent of the motion; its strains stay small, where the two materials agree, so the modelling error is
# far below the damping and the two runs differ by less than the 1 % the front treats as a tie. Judged against
# a reference, a setting's error is the sum of every error it makes, and a small one hides under a large one.
# The block, with its large strain, shows the modelling error plainly. Choose the material for the tissue and
# the strains you expect, not from a front on which another error dominates.
#
# **Newton's tolerance and a cap on its steps.** On the block a quasistatic frame starts with its linearised
# step (chapter 4), which counts as one Newton step. A tolerance of $10^{-3}$ or looser is already met after
# it, and so is a cap of one step: those settings stop there and leave 20 % more error (2.1e-4 against
# 1.8e-4). One Newton step after the start reaches the discretisation error, and anything tighter buys
# nothing but cost. The column `from_baseline` of the study's CSV says the same directly: how far each
# setting's answer lies from the baseline's.
#
#
# On the flap, a cap of one Newton step per frame shows an error that differs from the converged one only in
# the fourth digit; in this workbook's earlier recording, with the drag that starts abruptly, it showed an
# error 2 % *lower* than converging. Why would doing less work give a better answer? An experiment
# (`capped_newton_experiment`: the flap on 500 triangles for five frames, Newton converged and capped at one
# step, against a time-converged reference on the same mesh) measures what the cap changes, and in which
# direction:

# %%
for drag in ("jump", "eased"):
    x = capped_newton_experiment(drag=drag)
    print(f"{drag:5s} drag: error converged {x['error_converged']:.4e}, capped {x['error_capped']:.4e}; the cap moves "
          f"the state by {x['capped_moved']:.1e}, at cosine {x['cosine']:+.2f} to the converged run's error")

# %% [markdown]
# The capped state stops short of backward Euler's answer, between the frame's start (a prediction that
# carries the previous motion on) and the fully damped implicit solution. With the abrupt drag the part it
# leaves undone points largely *towards* the reference (cosine about 0.8): backward Euler's error here is
# damping, and the unfinished step keeps a little of the motion that the damping takes away. Two errors of
# opposite sign cancel a little; the capped run does not solve its equations better (it is $10^{-3}$ away from
# them). With the eased drag the cap's change is nearly at right angles to the error (cosine about 0.1), and
# the two errors nearly agree.

# %%
display(Markdown(
    f"The capped run's error is {x['error_capped']:.4e} against the converged {x['error_converged']:.4e}, "
    f"{100 * abs(x['error_capped'] / x['error_converged'] - 1):.1f} % apart. So the lower error was a coincidence "
    "of two errors, not a better method, and a cap is no accuracy knob."))

# %% [markdown]
#
# ## 5. How the cost grows with the mesh
#
# A frame costs a few Newton iterations, each an assembly (linear in the triangles) and a linear solve
# (superlinear for a direct solver: the fill grows faster than the matrix). A log-log fit of ms per frame
# against triangles, $\text{ms} \approx C\,n^{p}$, measures $p$ for each solver:

# %%
for solver, p in recorded["scaling"]["exponents"].items():
    print(f"  {solver:16s} p = {p:.2f}")
plot_scaling(recorded)

# %% [markdown]
# Where a curve crosses the dashed line is the largest mesh that solver can run at 30 frames per second. With
# $p$ near 1 a machine twice as fast allows twice the triangles; with $p = 1.5$ only $2^{1/1.5} \approx 1.6$ times.
#
# ## 6. What the budget leaves unfinished
#
# The real-time solver of chapter 7 commits the last accepted iterate when its 33 ms are spent. For each
# mesh, the flap run with the budget and the real clock, against the same run with every frame converged (here
# every step stays on its frame; a step too long for a frame can also run off it, as chapter 7's benchmark shows):

# %%
for r in recorded["budget"]:
    print(f"  {r['triangles']:6d} triangles: frame {r['ms_median']:6.1f} ms median, {r['ms_p95']:6.1f} ms p95; "
          f"{r['converged_share']:4.0%} of frames converged, median residual / start residual {r['residual_median']:.1e}, "
          f"state error after the drag {r['state_error']:.1e}")
plot_budget(recorded)

# %%
fits = [r for r in recorded["budget"] if r["converged_share"] == 1.0]
over = [r for r in recorded["budget"] if r["converged_share"] < 1.0]
scaled = {r["triangles"]: r["ms_median"] for r in recorded["scaling"]["rows"] if r["solver"] == "reuse"}
budget_ms = recorded["frame_budget_ms"]
text = (f"Up to {fits[-1]['triangles']:,} triangles every budgeted frame converged, in a median of "
        f"{fits[-1]['ms_median']:.1f} ms: nothing is lost there. ")
if over:
    first = over[0]
    text += (f"From {first['triangles']:,} triangles on, {100 * first['converged_share']:.0f} % or fewer of the frames "
             f"converged, and the frames did not keep to the budget either: a median of {first['ms_median']:.0f} ms "
             f"(p95 {first['ms_p95']:.0f} ms) against {budget_ms:.0f} ms. ")
    if first["triangles"] in scaled:
        text += (f"Unbudgeted, the scaling run of section 5 puts a converged frame of that mesh at "
                 f"{scaled[first['triangles']]:.1f} ms: the budget does not make the frame cheaper, it only stops "
                 "Newton early, and a Newton step once started (an assembly, a linear solve) runs to its end. ")
    text += (f"What the unfinished frames cost in accuracy is small: the state ends {max(r['state_error'] for r in over):.0e} "
             "from the converged run, far below the time-step error of section 4. What they cost in time is "
             "not: a frame that overruns its budget is a dropped frame on the screen.")
display(Markdown(text))

# %% [markdown]
# ## 7. Your own run, and recommendations
#
# Timings are one machine's. The **reduced** plan runs the same study on smaller meshes with fewer settings
# (`python -m tissuefem bench accuracy --plan reduced`); compare its *ratios* with the recorded ones, not its
# milliseconds.

# %%
start = time.perf_counter()
mine = accuracy_study("reduced", scaling=False, budget=False, verification=False, progress=None)
print(f"reduced study: {len(mine['knobs'])} settings in {time.perf_counter() - start:.0f} s")


def ratio(results, benchmark, a, b):
    rows = {(r["knob"], r["value"]): r for r in rows_of(benchmark, results=results)}
    return rows[a]["ms_median"] / rows[b]["ms_median"]


for results, label in ((recorded, "recorded"), (mine, "yours")):
    print(f"{label:8s}: flap, fresh SuperLU / kept factorization = "
          f"{ratio(results, 'flap', ('linear_solver', 'direct'), ('linear_solver', 'reuse')):.1f}x; "
          f"flap, 4 substeps / 1 = {ratio(results, 'flap', ('time_step', 4), ('time_step', 1)):.1f}x")

# %% [markdown]
# What the recorded study recommends (the cell after the list recomputes the choices):
#
# * **For teaching** (a lecture demo, a student's laptop): P1 on about 2 000 triangles, Neo-Hookean or stable
#   Neo-Hookean, the default solver, $\Delta t = 1/30$. Frames take a few milliseconds, which leaves room for
#   substeps when the lesson is about dynamics: the time step is what changes the motion.
# * **For an interactive simulator** (30 frames per second): the most accurate setting under 33 ms, errors
#   that agree to 1 % counted as ties and the cheapest of them taken. On the block that is P2 on about 2 000
#   triangles, with any quadrature rule (their errors agree to 1 %); on the flap, spend the budget on
#   *substeps*, not triangles. Keep the kept factorization and the minimum-degree ordering.
# * **For a validation run** (a number to compare with an experiment): P2 on a graded mesh, Newton to $10^{-8}$
#   or tighter, a small time step with an extrapolation check, and the reference's own error estimate as the
#   error bar, as in section 2.

# %%
budget = recorded["frame_budget_ms"]
for b in ("flap", "block"):
    sel = rows_of(b)
    base = next(r for r in sel if r["baseline"])
    best = sel[best_within_budget([r["ms_median"] for r in sel], [r["error"] for r in sel], budget,
                                  rtol=ERROR_RESOLUTION)]
    tied = [r for r in sel if r["ms_median"] <= budget and r["error"] <= best["error"] * (1 + ERROR_RESOLUTION)]
    print(f"{b}: baseline {base['ms_median']:.1f} ms, error {base['error']:.2e}; best under {budget:.0f} ms: "
          f"{best['knob']} = {best['value']} ({best['triangles']} triangles, P{best['order']}): "
          f"{best['ms_median']:.1f} ms, error {best['error']:.2e}; tied within 1 %: "
          + ", ".join(f"{r['knob']}={r['value']}" for r in tied))

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Run the reduced study and look at its Pareto plot. Which knob's ranking changed on your machine, and
#   which did not? (`python -m tissuefem bench accuracy --plan reduced --out my-results` writes the files.)
#
# ```python
# from tissuefem.workbook.bench.accuracy_cost import accuracy_study
# from tissuefem.workbook.figures.tradeoffs import plot_pareto
#
# results = accuracy_study("tiny", scaling=False, budget=False, verification=False, progress=None)
# plot_pareto(results)
# ```
#
# - Second-order accuracy the cheap way: run the flap with 1 and 2 substeps and extrapolate,
#   $2\mathbf u_{\Delta t/2} - \mathbf u_{\Delta t}$. How close to the reference does that get, and at what cost?
#
# ```python
# from tissuefem.workbook.bench.accuracy_cost import PLANS, Setting, reference_run, run_setting
# from tissuefem.workbook.measure import relative_l2_error
#
# plan = PLANS["tiny"]
# reference_model, reference, _ = reference_run("flap", plan, check=False)
# frame = max(reference)
# runs = {s: run_setting("flap", Setting(triangles=400, substeps=s), plan["frames"], (frame,)) for s in (1, 2)}
# model = runs[1][0]
# extrapolated = 2 * runs[2][1][frame] - runs[1][1][frame]
# for label, u in (("1 substep", runs[1][1][frame]), ("2 substeps", runs[2][1][frame]), ("extrapolated", extrapolated)):
#     print(f"{label:12s}: error {relative_l2_error(model, u, reference_model, reference[frame]):.2e}")
# ```
#
# - Make a knob of your own, the Poisson ratio near $\frac12$ say: a plan is a dict, and each knob maps to the
#   values it sweeps (see `PLANS` in `tissuefem.workbook.bench.accuracy_cost`). Start from the tiny plan:
#
# ```python
# from tissuefem.workbook.bench.accuracy_cost import PLANS, accuracy_study
#
# plan = dict(PLANS["tiny"], knobs={"mesh": (100, 200), "newton_tolerance": (1e-2, 1e-6)})
# results = accuracy_study(plan, benchmarks=("block",), scaling=False, budget=False, verification=False,
#                          progress=None)
# for r in results["knobs"]:
#     print(r["knob"], r["value"], f"{r['ms_median']:.1f} ms, error {r['error']:.2e}")
# ```
#
# ## Exercises (graded by pytest)
# In `exercises/ch09.py`:
# - **9.1** `pareto_front(costs, errors)`: the indices of the settings no other setting beats, in order of
#   increasing cost (ties and failed settings included in the test);
# - **9.2** `observed_rates(h, errors)`: the convergence rate between each pair of successive meshes;
# - **9.3** `best_within_budget(costs, errors, budget)`: the setting to choose under a frame budget.
#
# Grade: `python -m tissuefem grade ch09`.
