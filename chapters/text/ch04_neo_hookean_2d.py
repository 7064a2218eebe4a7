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
# # Chapter 4 — 2D Neo-Hookean quasistatics
#
# **Goals.**
# 1. Write the 2D Neo-Hookean energy (with the correct $\mathbf F:\mathbf F$ term), its stress
#    $\mathbf P$ and its tangent, and check them by finite differences.
# 2. Read the residual and the tangent of the notes' weak form as scikit-fem forms.
# 3. Stretch and shear a block of tissue with two handles; read Newton's convergence table; use
#    load stepping; compute the force on a handle.
# 4. Measure how the error falls as the mesh is refined, P1 against P2 — and what each costs in
#    time against the 33 ms of a frame. This is the workbook's first data on *what accuracy costs*.
#
# *Time: about 45 min to read and run, and five exercises.*
#
# *Reading:* the notes' "Elasticity and constitutive modeling" (Neo-Hookean part) and
# "Equilibrium and weak form".

# %%
# %matplotlib inline
import numpy as np
from IPython.display import Markdown, display
from skfem import asm

from tissuefem import (Handle, LinearElastic, Model, NeoHookean, P1Assembler, rectangle, residual_form, solve,
                       tangent_form)
from tissuefem.workbook.figures.kinematics import fig_ch04_block, fig_ch04_cost_accuracy
from tissuefem.workbook.studies import (RECORDED_COST_ACCURACY, cost_accuracy_markdown, cost_accuracy_study,
                                        handle_force)

material = NeoHookean.from_young(1000.0, 0.3)        # E = 1000, nu = 0.3: the notes' typical values
lam, mu = material.lam, material.mu

# %% [markdown]
# ## 1. The model
#
# The notes' Neo-Hookean energy density, with $J = \det\mathbf F$, is
#
# $$ \Psi(\mathbf F) = \frac{\mu}{2}\left(\mathbf F:\mathbf F - 2\right) - \mu \ln J + \frac{\lambda}{2} (\ln J)^2 ,
#    \qquad \mathbf F:\mathbf F = F_{ij}F_{ij} . $$
#
# (The notes print $F_{ij}F_{ji}$, which is not frame indifferent — erratum 3, shown in
# chapter 3. The $-2$ is the dimension: it makes $\Psi(\mathbf I) = 0$.) Two derivatives do all
# the work: $\partial(\mathbf F:\mathbf F)/\partial\mathbf F = 2\mathbf F$, and
# $\partial J/\partial\mathbf F = \operatorname{cof}\mathbf F = J\mathbf F^{-T}$, in 2D
# $\operatorname{cof}\mathbf F = \begin{bmatrix} F_{22} & -F_{21}\\ -F_{12} & F_{11}\end{bmatrix}$. Hence
#
# $$ \mathbf P = \frac{\partial\Psi}{\partial\mathbf F} = \mu\mathbf F + (\lambda\ln J - \mu)\,\mathbf F^{-T}, $$
#
# the notes' formula (it reads the same in both index conventions). Newton also needs the tangent
# $\mathbb A_{ijkl} = \partial P_{ij}/\partial F_{kl}$. Writing the volumetric part as
# $h(J) = -\mu\ln J + \frac\lambda2(\ln J)^2$, so that $\mathbf P = \mu\mathbf F + h'(J)\operatorname{cof}\mathbf F$,
#
# $$ \mathbb A = \mu\,\delta_{ik}\delta_{jl} + h''(J)\,(\operatorname{cof}\mathbf F)_{ij}(\operatorname{cof}\mathbf F)_{kl}
#    + h'(J)\,\frac{\partial(\operatorname{cof}\mathbf F)_{ij}}{\partial F_{kl}},
#    \qquad h' = \frac{\lambda\ln J - \mu}{J},\quad h'' = \frac{\lambda + \mu - \lambda\ln J}{J^2}, $$
#
# and the last derivative is a constant (cof F is linear in F in 2D). `tissuefem.engine.materials.NeoHookean`
# implements all three; the module's docstring has the derivation. We never trust a derivative we
# have not checked:

# %%
rng = np.random.default_rng(4)
F = np.eye(2) + 0.3 * rng.standard_normal((2, 2))
print("J =", np.linalg.det(F).round(4))
h = 1e-6
P_fd, A_fd = np.zeros((2, 2)), np.zeros((2, 2, 2, 2))
for k in range(2):
    for l in range(2):
        dF = np.zeros((2, 2))
        dF[k, l] = h
        P_fd[k, l] = (material.energy(F + dF) - material.energy(F - dF)) / (2 * h)
        A_fd[:, :, k, l] = (material.stress(F + dF) - material.stress(F - dF)) / (2 * h)
print("largest |P - dPsi/dF| / |P| =", (np.abs(material.stress(F) - P_fd).max() / np.abs(P_fd).max()).round(10))
print("largest |A - dP/dF|   / |A| =", (np.abs(material.tangent(F) - A_fd).max() / np.abs(A_fd).max()).round(10))
I = np.eye(2)
print("tangent at F = I equals the linear-elastic one:",
      np.allclose(material.tangent(I), LinearElastic(lam, mu).tangent(I)))

# %% [markdown]
# The last line is why $\lambda$ and $\mu$ "can be set as in linear elasticity", as the notes say:
# for small strains the Neo-Hookean model *is* linear elasticity.
#
# ## 2. The weak form as scikit-fem forms
#
# The notes' weak form of $-\nabla_{\mathbf X}\cdot\mathbf P = \mathbf f^{\text{ext}}$ is
# $\int_{B_0} w_{i,j} P_{ij}\, d\mathbf X = \int_{\partial B_0} w_i P_{ij} n_j \, dS + \int_{B_0} w_i f^{\text{ext}}_i \, d\mathbf X$.
# With vector shape functions $\mathbf v_a$ for both $\mathbf u$ and $\mathbf w$, the discrete
# equations are $\mathbf q(\mathbf u) = \mathbf f^{\text{ext}}$ with the internal force and its
# derivative
#
# $$ q_a(\mathbf u) = \int_{B_0} \nabla\mathbf v_a : \mathbf P(\mathbf F)\, d\mathbf X, \qquad
#    K_{ab} = \frac{\partial q_a}{\partial u_b} = \int_{B_0} \nabla\mathbf v_a : \mathbb A(\mathbf F) : \nabla\mathbf v_b \, d\mathbf X,
#    \qquad \mathbf F = \mathbf I + \nabla\mathbf u . $$
#
# `tissuefem.engine.forms` writes them the way they read:
#
# ```python
# @LinearForm
# def residual(v, w):
#     F = deformation_gradient(w["u"])                       # I + grad u at the quadrature points
#     return ddot(material.stress(F), grad(v))              # P : grad v
#
# @BilinearForm
# def tangent(du, v, w):
#     F = deformation_gradient(w["u"])
#     dP = np.einsum("ijkl...,kl...->ij...", material.tangent(F), grad(du))   # A : grad du
#     return ddot(dP, grad(v))
# ```
#
# These forms are the readable reference. On P1 triangles $\mathbf F$ is constant per element, the
# integrals are the element's area $A_e$ times the integrand, and the sums become a loop over the
# triangles: on triangle $e$, with the constant shape-function gradients $\partial N_a/\partial X_j$ of its
# vertices $a = 1, 2, 3$,
#
# $$ q_{ai} \mathrel{+}= A_e\, P_{ij}\,\frac{\partial N_a}{\partial X_j}, \qquad
#    K_{(ai)(bk)} \mathrel{+}= A_e\,\frac{\partial N_a}{\partial X_j}\,\mathbb A_{ijkl}\,\frac{\partial N_b}{\partial X_l} , $$
#
# each entry added into the rows and columns of the dofs the vertices own (**exercise 4.4** asks you to
# write this loop, for any material given by its $\mathbf P$ and $\mathbb A$). `P1Assembler` computes the same
# sums for all triangles at once, without a Python loop (chapter 3 used its `deformation_gradient`); the
# forms and the fast path must agree to round-off:

# %%
mesh = rectangle(2.0, 1.0, 16, 8)
model = Model(mesh, material, handles=[Handle("left")], assembly="forms")
u = 0.005 * rng.standard_normal(model.n_dofs)               # small enough to keep J > 0
uh = model.basis.interpolate(u)
q_forms, K_forms = asm(residual_form(material), model.basis, u=uh), asm(tangent_form(material), model.basis, u=uh)
fast = P1Assembler(mesh, material)
print("largest |q_fast - q_forms| =", np.abs(fast.residual(u) - q_forms).max())
print("largest |K_fast - K_forms| =", np.abs(fast.tangent(u) - K_forms).max())

# %% [markdown]
# ## 3. A block of tissue, stretched and sheared by handles
#
# A $2 \times 1$ block (think of a strip of skin, in plane strain) is held at its left edge; a
# handle grabs the right edge and moves it by $(0.6, 0.4)$: a 30 % stretch and a shear. A
# `Handle` is a set of material points with a target; a `Model` is the body with its terms and
# handles, and `solve` finds its equilibrium: it eliminates the prescribed dofs and runs Newton on
# the rest. (`tissuefem.workbook.studies.block_model` builds the same model for the study in section 5.)
# Here each Newton step solves its linear system exactly (a fresh factorization, `linear_solver="direct"`);
# the default reuses one factorization across steps and solves only as accurately as each step needs,
# which costs an iteration more but far fewer factorizations.

# %%
mesh = rectangle(2.0, 1.0, 24, 12)
model = Model(mesh, material, handles=[Handle("left"), Handle("right", (0.6, 0.4))])
result = solve(model, linear_solver="direct")
print(f"converged: {result.converged} in {result.newton_iterations} Newton iterations, "
      f"{mesh.t.shape[1]} triangles, {model.n_dofs} dofs")
print(result.steps[-1].table())

# %% [markdown]
# The residual falls $22 \to 1 \to 2\cdot 10^{-3} \to 2\cdot 10^{-8}$: the number of correct
# digits doubles every iteration, and the last column $\|q_{k+1}\|/\|q_k\|^2$ stays roughly
# constant — quadratic convergence, as in chapter 2, now with $\approx 600$ unknowns. (The solver
# starts from a *predictor*: one linearised Newton step from the rest state that moves the free
# nodes along with the handle. It is counted in the total printed above; the table shows the iterations
# after it.)
#
# Each of those iterations is guarded by a **line search on the energy**. The Newton step $\Delta\mathbf u$
# solves $\mathbf K\,\Delta\mathbf u = -\mathbf q$ on the free dofs; the solver tries $\mathbf u + \alpha\,\Delta\mathbf u$
# with $\alpha = 1, \frac12, \frac14, \dots$ and accepts the first point whose energy is finite and lower by a
# little more than nothing (the Armijo test $E(\mathbf u + \alpha\Delta\mathbf u) \le E(\mathbf u) + 10^{-4}\alpha\,\mathbf q\cdot\Delta\mathbf u$).
# Near the solution $\alpha = 1$ passes at once and the quadratic convergence is kept; far from it, a full
# step that would overshoot, or invert an element and make $\ln J$ undefined, is cut back. The column
# `alpha` of the table shows the accepted step. **Exercise 4.5** asks you to write this loop.
#
# The force the handles exert on the block follows from the internal forces at their dofs (at
# equilibrium, nothing else balances them there). The two forces are equal and opposite:

# %%
for edge in ("right", "left"):
    print(f"force of the {edge:5s} handle on the block: {handle_force(model, result.u, edge).round(2)}")

# %%
fig_ch04_block()

# %%
F = P1Assembler(mesh, material).deformation_gradient(result.u)
J, psi = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0], material.energy(F)
centroid = mesh.p[:, mesh.t].mean(axis=1)
corners = {(0.0, 0.0): "bottom corner of the held edge", (0.0, 1.0): "top corner of the held edge",
           (2.0, 0.0): "bottom corner of the handle", (2.0, 1.0): "top corner of the handle"}


def nearest_corner(e):
    return corners[min(corners, key=lambda c: np.hypot(*(centroid[:, e] - c)))]


peak = {name: psi[np.hypot(*(centroid - np.array(c)[:, None])) < 0.15].max() / np.median(psi)
        for c, name in corners.items()}
display(Markdown(f"$J$ runs from {J.min():.3f} to {J.max():.3f} over the triangles, largest at the "
                 f"{nearest_corner(J.argmax())}. Next to each corner the energy density reaches "
                 + ", ".join(f"{ratio:.1f} (the {name})" for name, ratio in peak.items())
                 + " times its median over the block."))

# %% [markdown]
# The area grows everywhere ($J > 1$: with $\nu = 0.3$ the block thins less than it stretches). The
# energy density peaks at two opposite corners, where the shear and the stretch add up. At every corner a
# held edge meets a free one, and there the exact solution is *singular* (its gradient blows up like a
# power of the distance to the corner). Keep that in mind for section 5.
#
# ## 4. Load stepping
#
# Ramping the handle in $n$ steps (each solved by Newton, warm-started from the previous one) costs
# iterations:

# %%
iterations = {}
for steps in (1, 2, 4, 8):
    r = solve(model, load_steps=steps, linear_solver="direct")
    iterations[steps] = r.newton_iterations
    print(f"{steps} load step(s): converged {r.converged}, Newton iterations per step {[s.iterations for s in r.steps]}")
display(Markdown(f"With the predictor, this block needs no ramp at all: one step takes {iterations[1]} iterations, "
                 f"eight take {iterations[8]}."))

# %% [markdown]
# Load stepping buys robustness for harder loads (chapter 2's compressed bar) and gives the
# intermediate states, but every step costs at least one factorization. A real-time simulator does
# something similar for free: each frame starts from the previous frame's solution and the
# handle has moved only a little, so a frame is "one load step" of a few iterations (chapter 7 counts them).
#
# ## 5. What accuracy costs: P1 against P2
#
# How fine must the mesh be, and is it better to refine or to raise the polynomial order? We
# solve the block on a sequence of meshes with P1 and with P2 elements and compare each solution
# with a **reference**: P2 on a mesh twice as fine as the finest of the sweep. The error
# measure is the relative $L^2$ norm of the displacement error,
#
# $$ e = \frac{\|\mathbf u_h - \mathbf u_{\text{ref}}\|_{L^2(B_0)}}{\|\mathbf u_{\text{ref}}\|_{L^2(B_0)}} , $$
#
# integrated by quadrature on the coarse mesh, with $\mathbf u_{\text{ref}}$ evaluated at the
# coarse mesh's quadrature points (scikit-fem locates the points in the fine mesh). It is
# well defined for any pair of meshes, needs no node to coincide, and measures the whole field.
# As a cross-check the study also reports the relative error in the stored energy $\int\Psi\,dX$.
#
# The time is the wall time of the whole solve from rest (`time.perf_counter`, median of a few
# repeats), and, separately, of one Newton iteration at the solution (residual, tangent, sparse
# factorization and solve) — the least a frame can do. P1 uses the fast `P1Assembler`; P2 uses
# `QuadratureAssembler`, the same vectorised idea over all quadrature points,
# so that both orders are timed with the same kind of assembly.
#
# The sizes below are modest to keep the notebook quick; the study takes any sizes. (Timings
# depend on the machine and on what else it is doing: read them, compare within one run.)

# %%
rows = cost_accuracy_study(p1_sizes=(2, 4, 8, 16), p2_sizes=(1, 2, 4, 8), reference_size=32, repeats=5)
display(Markdown(cost_accuracy_markdown(rows)))

# %%
fig_ch04_cost_accuracy(rows=rows)

# %%
recorded = {(r["order"], r["n"]): r for r in RECORDED_COST_ACCURACY}
mine = {(r["order"], r["n"]): r for r in rows}
shared = [key for key in mine if key in recorded]
apart = max(abs(mine[k]["L2"] / recorded[k]["L2"] - 1) for k in shared)
counted = [k for k in shared if mine[k]["newton_iterations"] != recorded[k]["newton_iterations"]]
counts = (f"its Newton iterations per solve are the recording's on every one of them (section 3's predictor "
          f"counted in both, {', '.join(map(str, sorted({mine[k]['newton_iterations'] for k in shared})))})"
          if not counted else "its Newton iterations per solve differ from the recording's on "
          + ", ".join(f"P{o}, n = {n} ({mine[(o, n)]['newton_iterations']} against "
                      f"{recorded[(o, n)]['newton_iterations']})" for o, n in counted))
display(Markdown(
    f"This run's errors differ from those of the recorded run below by up to {100 * apart:.0f} % on the same "
    f"meshes: its reference is coarser (P2 on $n = 32$, the recorded one's on $n = 64$), and a reference's own "
    f"error enters every error it judges. On those meshes {counts}. Its timings are this machine's, today."))

# %% [markdown]
# How to read this, on the recorded run of the lecture figure (`tissuefem.workbook.studies.RECORDED_COST_ACCURACY`:
# larger meshes and a finer reference; every number below is computed from it):

# %%
p1 = [r for r in RECORDED_COST_ACCURACY if r["order"] == 1]
p2 = [r for r in RECORDED_COST_ACCURACY if r["order"] == 2]
by_dofs = {r["dofs"]: r for r in p1}
pairs = [(by_dofs[r["dofs"]], r) for r in p2 if r["dofs"] in by_dofs]  # the same dofs: P2 at h is P1 at h/2
accuracy = [a["L2"] / b["L2"] for a, b in pairs]
iteration_cost = [b["iteration_ms"] / a["iteration_ms"] for a, b in pairs]


def p2_error_at(ms):
    # P2's error at a solve time, interpolated log-log between its rows (None outside them)
    t, e = np.log([r["solve_ms"] for r in p2]), np.log([r["L2"] for r in p2])
    return float(np.exp(np.interp(np.log(ms), t, e))) if t[0] <= np.log(ms) <= t[-1] else None


same_time = [(a["solve_ms"], a["L2"] / p2_error_at(a["solve_ms"])) for a in p1 if p2_error_at(a["solve_ms"])]
ahead = [ms for ms, ratio in same_time if ratio > 1]
fits = {order: max((r for r in RECORDED_COST_ACCURACY if r["order"] == order and r["solve_ms"] <= 33),
                   key=lambda r: r["dofs"]) for order in (1, 2)}
slowest = max(RECORDED_COST_ACCURACY, key=lambda r: r["iteration_ms"])
rate = {order: [r["rate_L2"] for r in RECORDED_COST_ACCURACY if r["order"] == order and r["rate_L2"] == r["rate_L2"]]
        for order in (1, 2)}
display(Markdown(f"""
- **Rates.** P1 converges at $h^{{{min(rate[1]):.2f}}}$ to $h^{{{max(rate[1]):.2f}}}$ and P2 at
  $h^{{{min(rate[2]):.2f}}}$ to $h^{{{max(rate[2]):.2f}}}$ in $L^2$, not the $h^2$ and $h^3$ of chapter 1's smooth bar.
- **At equal dofs** ({pairs[0][0]["dofs"]} to {pairs[-1][0]["dofs"]}) P2 is {min(accuracy):.2f} to
  {max(accuracy):.2f} times more accurate, more so the more dofs, but a P2 Newton iteration costs
  {min(iteration_cost):.1f} to {max(iteration_cost):.1f} times as much.
- **At equal time** P2's error is the smaller from {min(ahead):.0f} ms on, by a factor of {same_time[-1][1]:.1f}
  at {same_time[-1][0]:.0f} ms.
- **Against the frame budget.** Solved from rest, {fits[1]["dofs"]} dofs of P1 fit in 33 ms with an error of
  {fits[1]["L2"]:.1e}, {fits[2]["dofs"]} dofs of P2 with {fits[2]["L2"]:.1e}. One Newton iteration takes at most
  {slowest["iteration_ms"]:.0f} ms ({slowest["dofs"]} dofs, P{slowest["order"]}).
"""))

# %%
display(Markdown(
    "Both orders converge below their smooth-solution rates because of the corner singularities seen in the "
    f"block figure. P1's rate stays between {min(rate[1]):.2f} and {max(rate[1]):.2f}; P2's falls from "
    f"{rate[2][0]:.2f} on the coarsest meshes to {rate[2][-1]:.2f} on the finest, where it meets P1's "
    f"{rate[1][-1]:.2f}: once the mesh resolves the smooth part, the singularity limits both orders alike. On the "
    "coarser meshes P2 converges faster, and that is why its advantage at equal dofs grows with the dofs "
    f"({', '.join(f'{x:.2f}' for x in accuracy)} times more accurate)."))

# %% [markdown]
# A P2 row couples to more
# unknowns, so its matrix has more nonzeros and its factorization fills in more; on the smallest meshes fixed
# costs dominate and the two orders are close in time. A Newton iteration's cost grows faster than the dofs:
# beyond a few thousand dofs the sparse factorization dominates. Real time therefore hinges on warm starts (a
# frame is one small load step) and on the linear solver — the subject of the later chapters on time stepping
# and real time.
#
# The lecture figure plots that recorded run; `python -m tissuefem figures --only fig_ch04_cost_accuracy`
# redraws it:

# %%
fig_ch04_cost_accuracy()

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Move the handle further, by $(1.2, 0.8)$, or push it left by $0.8$: how many Newton iterations,
#   with and without load stepping? Which load fails without a ramp, and why (print `r.status`)?
#
# ```python
# from tissuefem import Handle, Model, NeoHookean, rectangle, solve
#
# mesh = rectangle(2.0, 1.0, 24, 12)
# for target in ((0.6, 0.4), (1.2, 0.8), (-0.8, 0.0)):
#     model = Model(mesh, NeoHookean.from_young(1000.0, 0.3), handles=[Handle("left"), Handle("right", target)])
#     for steps in (1, 4):
#         r = solve(model, load_steps=steps)
#         print(f"target {target}, {steps} load step(s): {r.status}, {r.newton_iterations} Newton iterations")
# ```
#
# - Nearly incompressible material makes P1 triangles *lock* (too stiff). Repeat the study with
#   $\nu = 0.45$ and then 0.49: which order suffers more?
#
# ```python
# from tissuefem import NeoHookean
# from tissuefem.workbook.studies import cost_accuracy_study
#
# for nu in (0.3, 0.45):
#     rows = cost_accuracy_study(p1_sizes=(2, 4, 8), p2_sizes=(1, 2, 4), reference_size=16, repeats=1,
#                                material=NeoHookean.from_young(1000.0, nu))
#     print(f"nu = {nu}: " + ", ".join(f"P{r['order']} n={r['n']}: {r['L2']:.1e}" for r in rows))
# ```
#
# - Time P1 with the readable forms against the fast path: what does vectorised assembly buy, and
#   from which mesh size on does the linear solve dominate a Newton iteration?
#
# ```python
# import time
# from tissuefem.workbook.studies import block_model
#
# for n in (4, 8, 16):
#     for assembly in ("fast", "forms"):
#         model = block_model(n, assembly=assembly)
#         u = model.zeros()
#         t0 = time.perf_counter()
#         model.gradient(u), model.hessian(u)
#         print(f"n = {n:2d}, {assembly:5s}: residual + tangent {1e3 * (time.perf_counter() - t0):7.1f} ms")
# ```
#
# - Use the force on the handle instead of the $L^2$ error as the measure of accuracy: does it
#   converge faster or slower as the mesh is refined?
#
# ```python
# from tissuefem import solve
# from tissuefem.workbook.studies import block_model, handle_force
#
# for n in (2, 4, 8, 16):
#     model = block_model(n)
#     print(f"n = {n:2d}: force on the right handle {handle_force(model, solve(model).u, 'right').round(4)}")
# ```
#
# ## Exercises (graded by pytest)
# In `exercises/ch04.py`:
# - **4.1** `neo_hookean_energy_2d(F, lam, mu)` — $\Psi$ of one 2×2 $\mathbf F$;
# - **4.2** `neo_hookean_stress_2d(F, lam, mu)` — $\mathbf P$ of one 2×2 $\mathbf F$;
# - **4.3** `element_forces_p1(X_nodes, x_nodes, lam, mu)` — the internal forces on the three
#   vertices of one linear triangle, $f_{ia} = A\, P_{ij}\, \partial N_a/\partial X_j$ (area $A$):
#   the triangle's share of $q$, and the gradient of its energy $A\,\Psi(\mathbf F)$;
# - **4.4** `assemble_p1(X_nodes, triangles, u, stress, tangent)` — the whole vector $\mathbf q$ and matrix
#   $\mathbf K$ of section 2, by a loop over the triangles, for a material given by two functions of one
#   $\mathbf F$ (its $\mathbf P$ and its $\mathbb A$); graded against the library's assembler with two
#   materials and two meshes;
# - **4.5** `newton_line_search(u0, energy, gradient, hessian, free)` — Newton's method with the
#   backtracking energy line search of section 3, handles held; graded on a function where plain Newton
#   diverges, one where a full step lands where the energy is NaN, and the stretched block of section 3,
#   against the library's solver.
#
# Grade: `python -m tissuefem grade ch04`.
