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
# # Chapter 7 — Time stepping and real time
#
# **Goals.** By the end of this chapter you can
# 1. derive backward Euler for the notes' elastodynamics, find the slips in the printed residual
#    $q_i^a$, and write one time step as the minimisation of an *incremental potential*;
# 2. say why an explicit scheme (symplectic Euler) needs $\Delta t$ below a limit that shrinks with the
#    mesh size (the CFL condition), measure that limit, and see the price backward Euler pays for having
#    none (numerical damping);
# 3. run the notes' simulation loop as a library object with a wall-clock budget per frame, and read its
#    frame report;
# 4. explain what makes a frame fast (warm starts, a reused factorization as the preconditioner of
#    conjugate gradients, the fast assembly path) and what an unfinished frame leaves behind.
#
# *Reading:* the notes' "Time stepping" section (the loop, backward Euler, the residual $q_i^a$). Behind
# it: Sifakis and Barbič, *FEM simulation of 3D deformable solids* (SIGGRAPH 2012 course); Kim and Eberle,
# *Dynamic deformables* (SIGGRAPH 2020 course), for the incremental potential and the energy line search.
#
# *Time: about 60 min to read and run, and two exercises.*
#
# **Index convention.** As everywhere (chapter 3): $F_{ij} = \partial\phi_i/\partial X_j$, formulas count from
# 1 and code from 0; dof vectors in scikit-fem's order (node $a$ has dofs $2a$, $2a+1$).

# %%
# %matplotlib inline
import math

import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

from tissuefem import (FRAME_BUDGET, Handle, Model, NeoHookean, RealtimeSolver, Simulation, StableNeoHookean,
                       SymplecticEuler, critical_time_step, flap, flap_path, flap_scene, largest_stable_dt, mesh_size,
                       rectangle, wave_speed)
from tissuefem.engine import linsolve
from tissuefem.workbook.figures.dynamics import (CFL_SIZES, ENERGY_T_END, fig_ch07_budget_residual, fig_ch07_cfl,
                                                 fig_ch07_energy, fig_ch07_released_flap)
from tissuefem.workbook.timestepping import cfl_study, released_flap, symplectic_energies

E, nu, rho0 = 1000.0, 0.3, 1.0
material = NeoHookean.from_young(E, nu)
print(f"lam = {material.lam:.1f}, mu = {material.mu:.1f}")

# %% [markdown]
# ## 1. From the balance of momentum to one step
#
# The notes write the balance of momentum in the reference configuration,
# $\rho_0\,\ddot{\mathbf u} = \nabla_{\mathbf X}\cdot\mathbf P + \mathbf f^{\text{ext}}$, and discretise it in
# space exactly as in the quasistatic chapters: test with the P1 shape functions $N^a$, integrate the
# stress term by parts. The new term is the inertia, which gives the **mass matrix**
#
# $$M_{(ai)(bj)} = \int_{B_0} \rho_0\, N^a N^b\, \delta_{ij}\, d\mathbf X ,$$
#
# and the semi-discrete equations read $\mathbf M\ddot{\mathbf u} = \mathbf f^{\text{ext}} - \mathbf f^{\text{int}}(\mathbf u)$
# with $f^{\text{int}}_{ai} = \int_{B_0} N^a_{,j} P_{ij}\,d\mathbf X$ and $\mathbf f^{\text{ext}}$ collecting
# tractions and body forces.
#
# **Backward Euler** (the notes' choice) differences both derivatives backwards and evaluates the forces
# at the *new* time:
#
# $$\mathbf v^{m+1} = \frac{\mathbf u^{m+1} - \mathbf u^{m}}{\Delta t}, \qquad
#   \mathbf M\,\frac{\mathbf v^{m+1} - \mathbf v^{m}}{\Delta t} = \mathbf f^{\text{ext}} - \mathbf f^{\text{int}}(\mathbf u^{m+1}).$$
#
# Put the first into the second and multiply by $\Delta t^2$: the unknown $\mathbf u^{m+1}$ solves
#
# $$\mathbf q(\mathbf u) = \mathbf M\big(\mathbf u - [\mathbf u^m + \Delta t\,\mathbf v^m]\big)
#   + \Delta t^2\big(\mathbf f^{\text{int}}(\mathbf u) - \mathbf f^{\text{ext}}\big) = \mathbf 0 .$$
#
# **Two slips in the notes' $q_i^a$** (README, erratum 10). The notes print the inertia term as
# $M u^{m+1} - M[u^{m+1} + \Delta t\,v^m]$: with $u^{m+1}$ inside the bracket the two cancel and no
# trace of the previous position is left; the bracket must hold $u^m$. And the boundary-traction and
# body-force integrals appear without the factor $\Delta t^2$ that the stress integral carries: after
# multiplying through by $\Delta t^2$ every force term has it.
#
# In the library a time step is one more **term** of the model: give a `Model` a time step and it gains
# the inertia term (its mass matrix is `model.inertia.M`); the stepper sets
# $\tilde{\mathbf u} = \mathbf u^m + \Delta t\,\mathbf v^m$ before each step. The model's gradient is then
# $\mathbf q / \Delta t^2$ (the same equations divided through). The cell below checks it against the
# semi-discrete equations written out directly, for random data.

# %%
rng = np.random.default_rng(7)
mesh = flap(n_triangles=200)
model = Model(mesh, material, handles=[Handle("fixed")], body_force=(0.0, -2.0),
              dt=1 / 30, density=rho0, mass="consistent")
M, dt, n = model.inertia.M, model.inertia.dt, model.n_dofs
u_m, v_m, u = 0.01 * rng.normal(size=n), rng.normal(size=n), 0.01 * rng.normal(size=n)
model.inertia.x_tilde = u_m + dt * v_m            # what the stepper sets at the start of a step
q = dt**2 * model.gradient(u)
f_int, f_ext = model.internal_force(u), model.external
direct = dt**2 * (M @ (((u - u_m) / dt - v_m) / dt) + f_int - f_ext)
print("max |q - dt^2 (M a + f_int - f_ext)| =", np.abs(q - direct).max())

# the notes' printed bracket: u^{m+1} instead of u^m, and no dt^2 on the loads
printed = M @ u + dt**2 * f_int - M @ (u + dt * v_m) - f_ext
print("the printed form differs by", np.abs(printed - q).max(), "(relative",
      f"{np.abs(printed - q).max() / np.abs(q).max():.2f})")

# %% [markdown]
# ### One step is a minimisation
#
# The residual above is the gradient of the **incremental potential**
#
# $$E(\mathbf u) = \tfrac12(\mathbf u - \tilde{\mathbf u})^T\mathbf M(\mathbf u - \tilde{\mathbf u})
#   + \Delta t^2\Big[\sum_e A_e\,\Psi(\mathbf F_e) - \mathbf f^{\text{ext}\,T}\mathbf u\Big],
#   \qquad \tilde{\mathbf u} = \mathbf u^m + \Delta t\,\mathbf v^m ,$$
#
# (the stored energy $W = \sum_e A_e\Psi(\mathbf F_e)$ has gradient $\mathbf f^{\text{int}}$), and its
# Hessian is $\mathbf M + \Delta t^2\mathbf K$. That is good news twice over:
# - a time step is the quasistatic problem of chapter 4 with one extra, convex term, so Newton with the
#   **energy line search** of chapter 4 solves it safely (every accepted iterate lowers $E$);
# - $\mathbf M$ is positive definite, so $E$ is bounded below whenever $W$ is, *whatever* $\Delta t$:
#   there is always a step to take. This is where backward Euler's unconditional stability comes from.
#
# The model's energy is $E / \Delta t^2$: the inertia term $\frac{1}{2\Delta t^2}(\mathbf u - \tilde{\mathbf u})^T\mathbf M(\mathbf u - \tilde{\mathbf u})$
# plus the stored energy minus the loads' work. Dividing by a constant changes neither the minimiser nor
# the safeguards, and it puts the residual of a dynamic step in the same units (forces) as a quasistatic
# one: a model *without* a time step simply has no inertia term. A finite-difference check of
# "gradient of $E$ = $\mathbf q$":

# %%
d = rng.normal(size=n)
h = 1e-6
fd = dt**2 * (model.energy(u + h * d) - model.energy(u - h * d)) / (2 * h)
print(f"directional derivative: finite difference {fd:.10e}, q . d = {q @ d:.10e}")

# %% [markdown]
# ## 2. Explicit against implicit
#
# **Symplectic Euler** updates the velocity from the forces at the *old* position, then the position
# from the new velocity:
#
# $$\mathbf v^{m+1} = \mathbf v^m + \Delta t\,\mathbf M_L^{-1}\big(\mathbf f^{\text{ext}} - \mathbf f^{\text{int}}(\mathbf u^m)\big),
#   \qquad \mathbf u^{m+1} = \mathbf u^m + \Delta t\,\mathbf v^{m+1}.$$
#
# With the lumped (diagonal) mass $\mathbf M_L$ a step is one force evaluation and no linear solve:
# far cheaper than a Newton solve. The catch: linearise about rest, and each vibration mode
# $\omega$ of $\mathbf M_L^{-1}\mathbf K$ is advanced by a map that stays bounded only if
# $\Delta t\,\omega \le 2$. The fastest mode of a mesh is a wave across one element, so
# $\omega_{\max} \sim c/h$ with the dilatational wave speed $c = \sqrt{(\lambda + 2\mu)/\rho_0}$, and
#
# $$\Delta t \;\le\; \frac{2}{\omega_{\max}} \;\approx\; C\,\frac{h}{c} \qquad\text{(the CFL condition).}$$
#
# Halve the element size and the explicit time step halves too (and the number of elements
# quadruples). The library measures the limit by bisection (the largest $\Delta t$ at which a small
# perturbation does not blow up over a fixed simulated time) and compares it with the eigenvalue estimate
# $2/\omega_{\max}$:

# %%
for nx in (4, 8, 16):
    p = Model(rectangle(2.0, 1.0, nx, nx // 2), StableNeoHookean.from_young(E, nu), handles=[Handle("left")],
              density=rho0)  # no dt: the explicit scheme brings its own
    dt_eig = critical_time_step(p)
    dt_meas = largest_stable_dt(p)
    print(f"h = {mesh_size(p.mesh):.4f} (c dt/h at the limit {wave_speed(p.material, rho0) * dt_meas / mesh_size(p.mesh):.2f}):"
          f" 2/omega_max = {dt_eig:.2e} s, measured {dt_meas:.2e} s, ratio {dt_meas / dt_eig:.2f}")
print(f"the frame time 1/30 s = {1 / 30:.2e} s")

# %% [markdown]
# The figure sweeps further, from 4 × 2 to 64 × 32 cells. Read it as the number of explicit steps one
# displayed frame needs, the frame time over the stable step:

# %%
study = cfl_study(CFL_SIZES)
for r in study.rows:
    print(f"{r['nx']:2d} x {r['nx'] // 2:2d} cells, h = {r['h']:.4f}: stable step {r['dt_measured']:.2e} s, "
          f"{FRAME_BUDGET / r['dt_measured']:5.1f} explicit steps per frame")
print(f"fitted: dt ~ h^{study.exponent:.2f}")
fig_ch07_cfl(study=study)

# %% [markdown]
# About 3 steps per frame on the coarsest mesh and about 48 on the finest: the step count doubles with each
# halving of $h$. By itself that is not an argument against explicit integration: an explicit step is one
# force evaluation and no linear solve, much cheaper than a Newton step, so a few dozen of them per frame
# can cost less than the two or three Newton steps of an implicit frame. The argument is in what makes the
# count grow:
#
# - **refinement costs twice**: halving $h$ quadruples the elements (in 2D; eightfold in 3D) *and* doubles
#   the steps, so an explicit frame's cost grows like $h^{-3}$ ($h^{-4}$ in 3D), where an implicit frame's
#   grows with the cost of a few linear solves;
# - **the stiffest thing in the scene sets the step, not the softest**: the wave speed $c$ grows with
#   $\lambda$, and soft tissue is nearly incompressible ($\nu$ close to $\frac12$), as the cell below shows;
#   the stiff penalty springs of a probe or a suture (chapter 8) raise $\omega_{\max}$ further;
# - **a step beyond the limit is not a little wrong, it blows up**, and a surgical simulator may not crash
#   (the notes' second demand). Backward Euler has no limit at all; its price is damping (below).
#
# The same 16 × 8 mesh, the tissue made more nearly incompressible (the eigenvalue estimate $2/\omega_{\max}$):

# %%
for nu_q in (0.3, 0.45, 0.49, 0.499):
    p = Model(rectangle(2.0, 1.0, 16, 8), StableNeoHookean.from_young(E, nu_q), handles=[Handle("left")], density=rho0)
    dt_q = critical_time_step(p)
    print(f"nu = {nu_q:5}: stable step {dt_q:.2e} s, {FRAME_BUDGET / dt_q:6.1f} explicit steps per frame")

# %% [markdown]
# From about 12 steps per frame at $\nu = 0.3$ to about 130 at $\nu = 0.499$, on the same mesh: at 64 × 32 cells
# that would be some five hundred steps per frame. Implicit integration buys independence from both the mesh
# and the material's stiffness, which is what an interactive simulator with refinable meshes, nearly
# incompressible tissue and stiff contact needs.

# %% [markdown]
# **Backward Euler has no such limit** — and pays for it in *numerical damping*. Below, a flap is lifted,
# held, and released. Symplectic Euler at a stable step keeps the total energy (kinetic plus stored)
# bounded: it oscillates but does not drift (the numbers follow the figure). Backward Euler loses energy every
# step, the more the larger $\Delta t$: at the frame time 1/30 s the flap settles within a few swings. For
# a surgical simulator that damping is welcome (tissue is heavily damped anyway); for a physics
# experiment it is an error that has to be bought down with smaller steps.

# %%
fig_ch07_energy()

# %%
# the figure's symplectic run again, for its numbers: half the critical step, over the figure's time span
released, u_released = released_flap()
symplectic = symplectic_energies(released, u_released, 0.5 * critical_time_step(released), ENERGY_T_END)
symplectic = symplectic / symplectic[0]
display(Markdown(
    f"Symplectic Euler's energy stays between {symplectic.min():.3f} and {symplectic.max():.3f} times its start "
    f"(mostly above it: {100 * np.mean(symplectic > 1):.0f} % of the steps), within "
    f"{100 * max(1 - symplectic.min(), symplectic.max() - 1):.0f} % and without drift."))

# %% [markdown]
# The released flap at $\Delta t = 1/30$ s, as a filmstrip (`python -m tissuefem figures` also writes the
# animation `figures/fig_ch07_released_flap.gif`):

# %%
fig_ch07_released_flap()

# %% [markdown]
# ## 3. The notes' loop with a budget
#
# The notes' simulator repeats: *get the user's boundary input, $t \leftarrow t + \Delta t$, solve,
# render*, and the solve must fit in 1/30 s. `RealtimeSolver` is that loop, one call of `frame()` per
# pass. It is the library's one stepper (the same object takes quasistatic and backward-Euler steps for
# the other chapters) with a wall-clock budget and *anytime* commits:
#
# 1. **input**: the handles' new targets (checked before anything changes: a non-finite target is a
#    `ValueError` and the state is untouched);
# 2. **warm start**: the lowest-energy of $\tilde{\mathbf u}$, $\mathbf u^m$ and a constant-acceleration
#    prediction, with the handles moved;
# 3. **solve**: Newton on $E$ with the energy line search, until the residual is below `rtol` times its
#    scale (the first residual, or the load a linearised start balances if that is larger) *or the budget
#    is spent*. The solver learns what each piece of work costs (an assembly, a factorization, a
#    back-substitution, a CG iteration, a line search) from its last runs, and starts a piece only if it
#    fits in what is left of the budget; a factorization that does not fit runs on the other core while
#    the frame goes on with the old one as a preconditioner, and CG asks before each iteration whether
#    another fits. The first Newton iteration's short pieces always run, so every frame makes progress. A
#    step of which not even one Newton iteration fits a frame (by the learned costs; the very first step,
#    with nothing learned, by a cost predicted per dof) runs off the frame, on a budget of its own of a few
#    frames, and a later frame commits it; simulated time then runs slower than real time. With
#    `off_frame=False` every step stays on the frame;
# 4. **commit**: the last accepted iterate becomes $\mathbf u^{m+1}$, converged or not. It passed the
#    line search, so it is finite and $E(\mathbf u^{m+1}) \le E(\text{start})$ — the solver is *anytime*.
#    What is left of the residual carries into the next frame's warm start.
#
# The standard scene of this workbook (`flap_scene`, also the benchmarks'): the flap $[0, 2]\times[0, 1]$,
# left edge fixed, the right edge carried along a slow loop (`flap_path`) by a handle named `"handle"`.

# %%
sim = Simulation(flap_scene(2000))
solver = sim.solver                 # the scene's RealtimeSolver
solver.budget = FRAME_BUDGET        # 1/30 s of the real clock (the benchmark scene sets none)
for f in range(30):
    report = solver.frame({"handle": flap_path((f + 1) / 30)})
print(f"status {report.status}, Newton steps {report.newton_iterations}, CG iterations {report.linear_iterations}, "
      f"new factorizations {report.factorizations}, relative residual {report.relative_residual:.1e}, "
      f"energy {report.energy:.4g} (start {report.start_energy:.4g}), {1e3 * report.elapsed:.1f} ms, "
      f"warm start {report.warm_start!r}")

# %% [markdown]
# The report says how the frame went: Newton steps, conjugate-gradient iterations, new factorizations,
# the residual (absolute and relative to the frame's first), the energy against the start energy, the
# clock time used. Time for a whole drag:

# %%
reports = solver.run([{"handle": flap_path((f + 31) / 30)} for f in range(60)])
ms = np.array([1e3 * r.elapsed for r in reports])
print(f"{sim.mesh.t.shape[1]} triangles: median {np.median(ms):.1f} ms per frame, 95th percentile "
      f"{np.percentile(ms, 95):.1f} ms; Newton steps per frame {np.mean([r.newton_iterations for r in reports]):.2f}, "
      f"CG iterations {np.mean([r.linear_iterations for r in reports]):.1f}, "
      f"factorizations in all {sum(r.factorizations for r in reports)}; converged: "
      f"{sum(r.converged for r in reports)}/{len(reports)}")

# %% [markdown]
# *(These numbers are measured on your machine, now: rerun the cell and they change. The benchmark in
# section 5 compares configurations in one run.)*
#
# ### What makes a frame fast
# - **The fast assembly path** (chapter 4): $\mathbf M + \Delta t^2\mathbf K$ goes straight into a fixed
#   sparsity pattern, and the free-free block is a precomputed gather of that array: no sparse slicing per
#   Newton step.
# - **Warm starts**: a frame starts from the prediction $\tilde{\mathbf u}$, which is already close.
# - **A reused factorization.** Beyond a couple of thousand triangles the linear solve, not assembly, is
#   the cost: a SuperLU factorization of the 8k-triangle matrix takes ~20 ms, a back-substitution with it
#   ~1 ms. The tangent changes little from one Newton step to the next and from one frame to the next, so
#   the solver keeps one factorization and uses it as the **preconditioner of conjugate gradients** for
#   the current matrix. A handful of CG iterations replaces a factorization. When CG slows down (more than
#   15 iterations) the next solve refactorizes; when it fails, the current one does.
# - **Inexact Newton**: a Newton direction does not need to be exact, so CG stops at 0.1% of the current
#   residual (less later in the frame), never tighter than the frame needs. At 8k triangles a 10% cap
#   cost 3.3 Newton steps per frame, 1% cost 3.0, 0.1% cost 2.2, for about the same number of CG
#   iterations.
# - **A predictor that follows the drag**: besides $\tilde{\mathbf u}$ the warm start tries
#   $\tilde{\mathbf u} + \Delta t(\mathbf v^m - \mathbf v^{m-1})$ (constant acceleration) and keeps the
#   lowest energy.
#
# The reused factorization at work, against a fresh factorization every Newton step (same frames, same
# answers):

# %%
for name in ("reuse", "direct"):
    s = RealtimeSolver(Simulation(flap_scene(2000)).model, budget=math.inf, linear_solver=name)
    rs = s.run([{"handle": flap_path((f + 1) / 30)} for f in range(40)])
    print(f"{s.linear_solver_name:28s} median {1e3 * np.median([r.elapsed for r in rs]):6.1f} ms/frame, "
          f"Newton/frame {np.mean([r.newton_iterations for r in rs]):.2f}, "
          f"factorizations {sum(r.factorizations for r in rs):4d}, max |u| {np.abs(s.u).max():.6f}")

# %% [markdown]
# ### Linear solver backends
# `tissuefem.engine.linsolve` puts the choices behind one interface (`factorize(A).solve(b)`):
# - `SuperLU()` — SciPy's SuperLU with the symmetric minimum-degree ordering of $A + A^T$ in *symmetric
#   mode*. On these matrices it roughly halves the fill of SciPy's default `COLAMD` ordering. Symmetric
#   mode matters: without it SuperLU's off-diagonal pivoting can make the same ordering slower than the default.
# - `SuperLU("COLAMD")` — SciPy's default, for comparison;
# - `Pardiso()` — Intel MKL's PARDISO, when the optional `pypardiso` is installed
#   (`pip install "tissuefem[pardiso]"`, several hundred MB); never required;
# - `ReusedFactorization(direct)` — CG preconditioned by a kept factorization of any of the above.
#
# Newton reaches them through one policy object, `LinearSolver` (`"reuse"`, `"direct"`, a backend's name,
# or `"constant"` for a model whose tangent never changes), which also condenses the tangent to its free
# rows and columns. Below, the backends on the free block of $\mathbf M/\Delta t^2 + \mathbf K$ (the model's
# Hessian) at rest:

# %%
p = Simulation(flap_scene(2000)).model
fixed, _ = p.prescribed()
free = np.setdiff1d(np.arange(p.n_dofs), fixed)
A = p.hessian(p.zeros())[free][:, free]
b = np.ones(A.shape[0])
for backend in [linsolve.SuperLU(), linsolve.SuperLU("COLAMD")] + ([linsolve.Pardiso()] if linsolve.available("pardiso") else []):
    x = backend(A, b)
    print(f"{backend.name:16s} residual {np.linalg.norm(A @ x - b):.1e}")

# %% [markdown]
# ### A budget that is too small
# With a fake clock the solver is deterministic, which is how the tests check it. Below, every look at
# the clock "costs" 1 ms and the budget is 1 ns: every frame that starts unconverged gets its one guaranteed
# Newton step and no more, and a frame that starts converged takes none (the 0 and 1 printed below). The
# handle jumps to a target and stays; the state is valid after every frame, and the residual left over
# carries into the next frames (what happens to it is written below the plot). Here every step stays on its
# frame (`off_frame=False`); by default a step that the learned costs say cannot fit a frame runs off it, on the
# second core, and a later frame commits it (section 5).

# %%
class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        self.now += 1e-3   # reading this clock takes a millisecond
        return self.now


clock = FakeClock()
tiny = RealtimeSolver(Simulation(flap_scene(500)).model, budget=1e-9, clock=clock, rtol=1e-8, off_frame=False)
history = []
for f in range(120):
    r = tiny.frame({"handle": (0.4, 0.3)})
    history.append((r.newton_iterations, r.residual_norm, r.converged,
                    r.energy <= r.start_energy + 1e-12 * abs(r.start_energy), 1e-8 * r.residual_scale))
steps, res, conv, descent, tolerance = map(np.array, zip(*history))
print("Newton steps per frame:", sorted(set(steps.tolist())), "| energy never above the start:", descent.all(),
      "| first converged frame:", int(np.argmax(conv)) + 1)
print(f"frames with one step: {int((steps == 1).sum())}, with none (converged at their start): "
      f"{int((steps == 0).sum())}, with more: {int((steps > 1).sum())}")
fig, ax = plt.subplots(figsize=(6, 3.2))
ax.semilogy(np.arange(1, res.size + 1), res, ".-", label="residual left")
ax.semilogy(np.arange(1, res.size + 1), tolerance, "k--", lw=1, label="tolerance (rtol x the frame's scale)")
ax.legend(fontsize=8)
ax.set(xlabel="frame", ylabel="residual left at the end of the frame",
       title="One Newton step per frame: the unfinished work carries over")
ax.grid(True, which="both", alpha=0.3)

# %%
first = int(np.argmax(conv)) + 1
steady = max(f for f in range(1, conv.size + 1) if not conv[f - 1]) + 1   # every frame from here on converged
idle = max(f for f in range(1, steps.size + 1) if steps[f - 1] > 0) + 1    # every frame from here on took no step
display(Markdown(
    f"Convergence comes intermittently at first: frame {first} converges, but {int((~conv[first:]).sum())} frames "
    f"after it do not, and only from frame {steady} on does every frame end converged. Those frames still take "
    f"their step, and it pushes the residual as low as {res[steady - 1:idle - 1].min():.1e}. From frame {idle} on "
    "the frames start converged and take no step at all, so the residual stays where such a start leaves it: a "
    f"plateau at {res[-1]:.1e}, above what the last steps reached but below the tolerance "
    f"({tolerance[-1]:.1e}, dashed)."))

# %% [markdown]
# ## 4. What an unfinished frame trades
#
# A budget buys a number of Newton steps; how many fit in 33 ms depends on the mesh (the benchmark
# below). The figure caps the steps per frame at 1, 2 or 3 on the standard drag (reproducible: no clock
# involved) and shows what is left: the relative residual at the end of each frame, and how far the state
# has drifted from the fully converged simulation after 40 frames. With the warm start of section 3, one
# step per frame leaves about $10^{-3}$ of the frame's first residual and a state error below $10^{-6}$ of
# the motion; two steps already meet the $10^{-6}$ tolerance. For one and two steps per frame both grow with
# the mesh size: finer meshes
# need a little more work per frame, on top of costing more per step. (A handle jerked hard, rather than
# dragged smoothly, leaves much more: try it below.)

# %%
fig_ch07_budget_residual()

# %% [markdown]
# ## 5. The frame-rate benchmark
#
# `python -m tissuefem bench realtime` runs the standard scene (E = 1000, ν = 0.3, ρ₀ = 1, Δt = 1/30,
# every frame converged to a relative residual of $10^{-6}$) at about 2k, 8k, 16k and 32k triangles, and
# in the same run the same frames solved the way scikit-fem's hyperelasticity example (ex43) solves a
# Newton step: `BilinearForm`/`LinearForm` assembled with `asm` every iteration, `condense`, `solve`. It
# prints the table and writes `bench-results/realtime.json`, `.csv` and `.png` (milliseconds per frame
# against mesh size, with the 33 ms line). It also measures the *floor* of a frame in the same run: one
# tangent assembly and one back-substitution, the least any Newton frame can cost, and runs the same drag once
# more with the 33 ms budget on the real clock. The package ships one recorded run, two rounds on the 2-core
# reference machine with nothing else running (medians over the rounds; the real-time default, whose kept
# factorization is refreshed on the second core while the frames go on):

# %%
from tissuefem.workbook.bench.realtime import recorded_realtime, recorded_realtime_table

rows, record = recorded_realtime()
loads = [r["machine"]["load_average"][0] for r in record["rounds"]]
print(f"recorded {record['date']}: {len(record['rounds'])} rounds, {record['rounds'][0]['settings']['frames']} frames "
      f"per size; 1-minute load average before the session's benchmarks {record['load_before']:.2f}, at each round's "
      f"start {', '.join(f'{x:.2f}' for x in loads)} (the previous benchmark's own)")
display(Markdown(recorded_realtime_table()))

# %%
fit = [r for r in rows if r["fast_median_ms"] <= 1e3 * FRAME_BUDGET]
speedups = [r["speedup"] for r in rows]
display(Markdown(
    f"Up to {fit[-1]['triangles']:,} triangles a converged frame fits the 33 ms budget (the median does), "
    f"{min(speedups):.0f}–{max(speedups):.0f}× faster than the ex43 way, the more the larger the mesh. A frame costs "
    f"{min(r['frame_over_floor'] for r in rows):.1f}–{max(r['frame_over_floor'] for r in rows):.1f} floors: about "
    f"{rows[1]['fast_newton']:.0f} tangent assemblies and {rows[1]['fast_cg']:.0f} back-substitutions inside CG, which decide "
    "the frame time beyond ~10k triangles."))

# %%
frames = record["rounds"][0]["settings"]["budget_frames"]
missed = [r for r in rows if r["budget_p99_ms"] > 1.15e3 * FRAME_BUDGET]
off = [r for r in rows if r["budget_off_frame"] >= frames / 2]
display(Markdown(
    f"With the budget (the frames paced at 30 a second), the first step's cost is predicted from its size, and where "
    f"it may not fit, the step runs off the frame and learns the costs there: the first frame took at most "
    f"{max(r['budget_first_ms'] for r in rows):.0f} ms. The 99th percentile of the frames stays within 1.15 budgets "
    f"at {len(rows) - len(missed)} of the {len(rows)} sizes"
    + "".join(f" (not at {r['triangles']:,} triangles: {r['budget_p99_ms']:.0f} ms)" for r in missed) + ". "
    + (f"From {off[0]['triangles']:,} triangles on, a step's start and first Newton iteration do not fit the frame: "
       "most steps run off the frame, on the second core, on a budget of their own, and the frames show the last "
       "committed state until one is done, so the picture keeps its rate and the simulation slows down: "
       f"{off[-1]['budget_steps']:.0f} steps in {frames} frames at {off[-1]['triangles']:,} triangles. " if off else "")
    + "Chapter 9 §6 measures what the unfinished frames leave."))

# %% [markdown]
# (The ex43 way needed one safeguard: at 32k plain Newton ends in NaN in the first frame, so a step with a
# non-finite residual is halved.)

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Run the drag of section 3 with the real 33 ms budget on finer meshes (4000 here; then 8000 and 16000).
#   What share of frames converge in budget? How much residual do the others leave?
#
# ```python
# import numpy as np
# from tissuefem import FRAME_BUDGET, Simulation, flap_path, flap_scene
#
# sim = Simulation(flap_scene(4000))
# sim.solver.budget = FRAME_BUDGET
# reports = sim.solver.run([{"handle": flap_path((f + 1) / 30)} for f in range(30)])
# left = [r.relative_residual for r in reports if not r.converged]
# print(f"{sim.mesh.nelements} triangles: {sum(r.converged for r in reports)}/{len(reports)} frames converged "
#       f"within 33 ms; median residual left by the others: {np.median(left) if left else 0.0:.1e}")
# ```
#
# - Compare linear solvers: a fresh factorization with SciPy's default ordering every Newton step, one
#   with the minimum-degree ordering, and the default (a kept factorization preconditioning CG). Which one
#   is fastest at 2000 triangles? At 8000?
#
# ```python
# import math
# import numpy as np
# from tissuefem import RealtimeSolver, Simulation, flap_path, flap_scene
#
# for name in ("superlu-colamd", "direct", "reuse"):
#     solver = RealtimeSolver(Simulation(flap_scene(2000)).model, budget=math.inf, linear_solver=name)
#     reports = solver.run([{"handle": flap_path((f + 1) / 30)} for f in range(20)])
#     print(f"{name:15s} median {1e3 * np.median([r.elapsed for r in reports]):6.1f} ms per frame")
# ```
#
# - Drag the handle through the body, from $(0, 0)$ to $(-3, 0)$: past the fixed edge. Watch the share of
#   its motion the handle makes (`handle_fraction`) with the plain Neo-Hookean model and the stable one.
#
# ```python
# import math
# from tissuefem import Handle, Model, NeoHookean, RealtimeSolver, StableNeoHookean, flap
#
# for material in (NeoHookean.from_young(1000.0, 0.3), StableNeoHookean.from_young(1000.0, 0.3)):
#     model = Model(flap(n_triangles=300), material, dt=1 / 30,
#                   handles=[Handle("fixed", name="fixed"), Handle("handle", name="handle")])
#     solver = RealtimeSolver(model, budget=math.inf)
#     reports = [solver.frame({"handle": (-3.0 * k / 60, 0.0)}) for k in range(1, 61)]
#     print(f"{type(material).__name__:17s}: smallest handle_fraction {min(r.handle_fraction for r in reports):.2f}, "
#           f"last frame {reports[-1].status}")
# ```
#
# - Quasistatic frames have no inertia term (no mass matrix is built). How does the drag differ: Newton
#   steps per frame, and where the flap is when the handle stops?
#
# ```python
# import numpy as np
# from tissuefem import Simulation, flap_path, flap_scene
#
# for dynamic in (True, False):
#     sim = Simulation(flap_scene(2000, dynamic=dynamic))
#     reports = sim.solver.run([{"handle": flap_path((f + 1) / 30)} for f in range(30)])
#     print(f"dynamic={dynamic!s:5}: mass matrix built {sim.model.inertia is not None}, Newton steps per frame "
#           f"{np.mean([r.newton_iterations for r in reports]):.2f}, largest |u| {np.abs(sim.u).max():.3f}")
# ```
#
# - Jerk the handle instead of dragging it, with one Newton step per frame: targets that jump to $(0.5, 0.3)$
#   at once. How many frames until a frame converges? What is left of the residual in the first frames?
#
# ```python
# import math
# from tissuefem import RealtimeSolver, Simulation, flap_scene
#
# solver = RealtimeSolver(Simulation(flap_scene(2000)).model, budget=math.inf, max_iterations=1)
# for f in range(1, 13):
#     report = solver.frame({"handle": (0.5, 0.3)})
#     print(f"frame {f:2d}: converged {report.converged!s:5}, relative residual {report.relative_residual:.1e}")
# ```
#
# - Find the largest stable step of symplectic Euler for a small flap, run it at 0.9 and 1.1 times that
#   step from the same small perturbation, and plot the total energy against time.
#
# ```python
# import matplotlib.pyplot as plt
# import numpy as np
# from tissuefem import Handle, Model, StableNeoHookean, SymplecticEuler, flap, largest_stable_dt
#
# model = Model(flap(n_triangles=200), StableNeoHookean.from_young(1000.0, 0.3), handles=[Handle("fixed")],
#               density=1.0)
# dt = largest_stable_dt(model)
# fig, ax = plt.subplots(figsize=(6, 3))
# for factor in (0.9, 1.1):
#     integrator = SymplecticEuler(model, factor * dt)
#     integrator.u = 1e-3 * np.random.default_rng(0).standard_normal(model.n_dofs)
#     integrator.u[model.prescribed()[0]] = 0.0
#     energy = integrator.run(300, energy_limit=1e6)
#     ax.semilogy(integrator.dt * np.arange(energy.size), energy, label=f"{factor} x the stable step")
# ax.set(xlabel="time (s)", ylabel="total energy")
# ax.legend()
# ```
#
# ## Exercises (graded by pytest)
# In `exercises/ch07.py`:
# - **7.1** `backward_euler_residual(M, u, u_n, v_n, dt, f_int, f_ext)` — the backward-Euler residual times
#   $\Delta t^2$, with the notes' slips mended;
# - **7.2** `budgeted_newton(x0, energy, gradient, newton_step, clock, budget, rtol)` — one budgeted frame:
#   the first step always, later steps only within the budget, never a higher energy than the start.
#
# Grade: `python -m tissuefem grade ch07`.
