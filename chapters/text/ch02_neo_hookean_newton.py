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
# # Chapter 2 — 1D Neo-Hookean elasticity and Newton's method
#
# **Goals.**
# 1. Write the 1D Neo-Hookean energy, stress and tangent, and check each by finite differences.
# 2. Build the nonlinear residual $q(u)$ and its tangent $\partial q/\partial u$ as scikit-fem forms.
# 3. Solve with Newton's method and *see* quadratic convergence in its history.
# 4. Use load stepping for large loads.
# 5. Understand what happens under strong compression: the logarithm of a non-positive $J$.
#
# *Time: about 25 min to read and run, and three exercises.*
#
# *Reading:* the notes' "1D elasticity" (second half) and "Inversion".

# %%
# %matplotlib inline
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

from tissuefem import Bar1D, NeoHookean1D, TaylorNeoHookean1D, Traction, lame_parameters

from tissuefem.engine.bar1d import nonlinear_forms, uniform_bar_stretch
from tissuefem.workbook.figures.oned import fig05_admissible_maps, fig07_neo_hookean_1d, fig_ch02_newton

lam, mu = lame_parameters(E=1000.0, nu=0.3)
neo = NeoHookean1D(lam, mu)

# %% [markdown]
# ## 1. The model
#
# In 1D, $J = \det F = F$. The Neo-Hookean energy density, with the constant chosen so that
# $\Psi(1) = 0$, is
#
# $$ \Psi(F) = \frac{\mu}{2}(F^2 - 1) - \mu \ln F + \frac{\lambda}{2} (\ln F)^2 . $$
#
# (In 2D the constant is $-2$, the dimension; see the erratum on $F_{ij}F_{ji}$ in the README.)
# Differentiating,
#
# $$ P = \mu F + \frac{\lambda \ln F - \mu}{F}, \qquad
#    \frac{\partial P}{\partial F} = \mu + \frac{\mu + \lambda(1 - \ln F)}{F^2} , $$
#
# which is the notes' formula for $P$ with $F = 1 + u'$. At $F = 1$ the tangent is
# $2\mu + \lambda$: the linear modulus of chapter 1. We never trust a derivative we have not
# checked, so here are both against central differences:

# %%
F = np.array([0.05, 0.3, 0.8, 1.0, 1.5, 3.0])
h = 1e-6 * F
print("P(F)    :", neo.stress(F))
print("dPsi/dF :", (neo.energy(F + h) - neo.energy(F - h)) / (2 * h))
print("dP/dF   :", neo.tangent(F))
print("FD      :", (neo.stress(F + h) - neo.stress(F - h)) / (2 * h))

# %% [markdown]
# ## 2. Residual and tangent as scikit-fem forms
#
# With $u = u_j N_j$ the discrete equilibrium equations are $q(u) = 0$ with
#
# $$ q_i(u) = \int_a^b N_i' \, P(F(u)) \, dX - F^{\text{ext}}_i - g_i , \qquad
#    \frac{\partial q_i}{\partial u_j} = \int_a^b N_i' \, \frac{\partial P}{\partial F} \, N_j' \, dX . $$
#
# > **Erratum.** The notes write $q_i = \int N_i' P\,dX - F^{\text{ext}}_i + g_i$. For a linear
# > material $q = Au - F^{\text{ext}} \mp g$ must vanish exactly when $Au = F^{\text{ext}} + g$
# > (their own linear system), so the sign of $g$ must be minus.
#
# The forms, as `tissuefem.engine.bar1d.nonlinear_forms` writes them:
#
# ```python
# @LinearForm
# def internal_force(v, w):
#     F = 1.0 + w["u"].grad[0]
#     return material.stress(F) * v.grad[0]            # N_i' P(F)
#
# @BilinearForm
# def tangent(du, v, w):
#     F = 1.0 + w["u"].grad[0]
#     return material.tangent(F) * du.grad[0] * v.grad[0]   # N_i' dP/dF N_j'
# ```
#
# The tangent really is the derivative of the residual — check it by finite differences:

# %%
from skfem import asm

bar = Bar1D(0.0, 1.0, n=5)
internal_force, tangent, _ = nonlinear_forms(neo)
rng = np.random.default_rng(0)
u = 0.05 * rng.standard_normal(bar.ndofs)
q = lambda u: asm(internal_force, bar.basis, u=bar.basis.interpolate(u))
K = asm(tangent, bar.basis, u=bar.basis.interpolate(u)).toarray()
eps = 1e-7
K_fd = np.column_stack([(q(u + eps * e) - q(u - eps * e)) / (2 * eps) for e in np.eye(bar.ndofs)])
print("largest |K - K_fd| / |K| =", np.abs(K - K_fd).max() / np.abs(K).max())

# %% [markdown]
# ## 3. Newton's method
#
# Starting from $u^0$, repeat: solve $\frac{\partial q}{\partial u}(u^k)\,\Delta u = -q(u^k)$ on
# the free nodes and set $u^{k+1} = u^k + \Delta u$. Near the solution the residual should be
# roughly *squared* at every step: the last column, $\|q_{k+1}\|/\|q_k\|^2$, settles to a
# constant — that is quadratic convergence, until the residual reaches round-off (what that means for
# the last ratio is written below the table).
#
# The bar is fixed at $X = 0$ and pulled by a traction $T$ at $X = 1$. Then $P \equiv T$
# everywhere, so $F$ is the uniform root of $P(F) = T$: a closed form to compare with.

# %%
T = 300.0
bar = Bar1D(0.0, 1.0, n=16)
u, results = bar.solve_nonlinear(neo, right=Traction(T), rtol=1e-13)
print(results[0].table())
F_exact = uniform_bar_stretch(neo, T)
print(f"\nclosed form: F = {F_exact:.12f};  largest nodal error {np.abs(u - (F_exact - 1) * bar.nodes).max():.2e}")

# %%
norms = results[0].residual_norms()
display(Markdown(
    f"The last ratio printed (row {len(norms) - 2}, {norms[-1] / norms[-2] ** 2:.1e}) means nothing: that step took "
    f"the residual down to round-off, {norms[-1]:.1e} here, which cannot fall further, so the ratio measures "
    f"round-off over the square of a small residual. The last row ({len(norms) - 1}) has no ratio at all."))

# %%
fig_ch02_newton()

# %% [markdown]
# ## 4. Load stepping
#
# Newton converges quadratically only *near* the solution. For a large load we ramp it up in
# steps $s = 1/n, 2/n, \dots, 1$, warm-starting each solve from the previous one. Each step is
# an easy problem. In tension the 1D Neo-Hookean bar softens and plain Newton copes with any
# load; in compression it stiffens sharply, and a large push needs ramping:

# %%
failed = []
for steps in (1, 2, 4, 8):
    u, results = bar.solve_nonlinear(neo, right=Traction(-3000.0), load_steps=steps)
    its = [r.iterations for r in results]
    print(f"{steps} load step(s): Newton iterations per step {its}, "
          f"status of the last step: {results[-1].status}")
    failed += [] if results[-1].converged else [steps]

# %%
display(Markdown(f"With {' and '.join(map(str, failed))} load step(s) the push fails; with more it converges."
                 if failed else "Every number of load steps converges."))

# %% [markdown]
# ## 5. Strong compression: the logarithm of a non-positive $J$
#
# Why did too few steps fail at $T = -3000$? Take $T = -1500$. A solution exists — $P(F) \to -\infty$ as $F \to 0^+$,
# so some $F \in (0, 1)$ balances any compression — but the very first Newton step from rest is
# the *linear* prediction $F = 1 + T/(2\mu + \lambda)$:

# %%
T = -1500.0
print("first Newton prediction F =", 1 + T / (2 * mu + lam))
bar = Bar1D(0.0, 1.0, n=8)
u, results = bar.solve_nonlinear(neo, right=Traction(T))
print(results[0].table())
print("state kept by the solver is finite:", np.all(np.isfinite(u)))

# %% [markdown]
# The first step overshoots to $F < 0$: the material is *inverted*, $\ln J$ is undefined and the
# residual becomes NaN. Our Newton solver notices, keeps the last good iterate and reports the
# status `non-finite` — a plain implementation would carry NaN on silently
# (`np.log` of a negative number returns NaN with only a warning).
#
# The picture explains it: $P(F)$ is very steep for small $F$ and the tangent line at $F = 1$
# crosses $P = T$ far left of the true root, below zero.

# %%
Fs = np.linspace(0.02, 1.6, 400)
fig, ax = plt.subplots(figsize=(6, 3.8))
ax.plot(Fs, neo.stress(Fs), label="Neo-Hookean $P(F)$")
ax.plot(Fs, (2 * mu + lam) * (Fs - 1), "--", label="tangent at $F = 1$ (Newton's model)")
ax.axhline(T, color="C3", lw=1, label=f"$P = T = {T:g}$")
F_root = uniform_bar_stretch(neo, T)
ax.plot([F_root], [T], "ko", label=f"solution F = {F_root:.3f}")
ax.plot([1 + T / (2 * mu + lam)], [T], "rx", ms=10, mew=2, label="first Newton iterate")
ax.set(xlim=(-0.2, 1.6), ylim=(-4000, 1500), xlabel="F", ylabel="P")
ax.axvspan(-0.2, 0, color="C3", alpha=0.1)
ax.legend(fontsize=8);

# %% [markdown]
# Three ways out, each used later in the workbook:
# 1. **Load stepping** keeps each Newton step small.
# 2. **A safeguarded step** (here: halve $\Delta u$ until the residual is finite; chapters 4 and 6 use
#    a line search on the energy).
# 3. **A model that is defined through inversion**: replace $\ln J$ by its cubic Taylor
#    polynomial $r(J)$ about $J = 1$ — the notes' Figure 7, below.

# %%
for label, kwargs, material in [("load stepping (10 steps)", dict(load_steps=10), neo),
                                ("step halving", dict(line_search="finite"), neo),
                                ("cubic Taylor r(J), plain Newton", dict(), TaylorNeoHookean1D(lam, mu))]:
    u, results = bar.solve_nonlinear(material, right=Traction(T), **kwargs)
    F_end = 1 + (u[bar.dof_b] - u[bar.dof_a])
    print(f"{label:34s} converged={results[-1].converged}  F = {F_end:.4f}")

# %%
fig07_neo_hookean_1d()

# %% [markdown]
# The Taylor model agrees with $\ln J$ near $J = 1$ but stays finite for $J \le 0$, so an
# inverted element pushes back with a finite force instead of breaking the solver. The price is
# that it is **softer in compression**: where $\ln J \to -\infty$ as $J \to 0$, the cubic $r(J)$ stays
# finite, so its stress does not blow up. Under the same push $T = -1500$ the Taylor bar is squeezed
# to $F \approx 0.41$, the $\ln J$ bar only to $F \approx 0.48$ (the last two lines printed above):
# robustness has a price in accuracy far from rest. The notes' Figure 5 shows why
# $F \le 0$ is not physical in the first place — the map folds material onto itself:

# %%
fig05_admissible_maps()

# %% [markdown]
# (In the admissible panel $\phi(X) = X^2$ marks $X = 0$ in red: there $\phi'(0) = 0$, at the end point only.
# Inside the bar $\phi' > 0$, so the map touches the bound at one point without folding anything.)

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Make the traction larger in tension: does plain Newton (one load step) still converge, and in
#   how many iterations?
#
# ```python
# from tissuefem import Bar1D, NeoHookean1D, Traction, lame_parameters
#
# neo = NeoHookean1D(*lame_parameters(E=1000.0, nu=0.3))
# bar = Bar1D(0.0, 1.0, n=16)
# for T in (300.0, 5000.0, 50000.0):
#     u, results = bar.solve_nonlinear(neo, right=Traction(T))
#     print(f"T = {T:7.0f}: {results[-1].status}, {results[-1].iterations} Newton iterations")
# ```
#
# - Refine the mesh: does the number of Newton iterations change? (Why not? Think of what the
#   solution looks like.)
#
# ```python
# from tissuefem import Bar1D, NeoHookean1D, Traction, lame_parameters
#
# neo = NeoHookean1D(*lame_parameters(E=1000.0, nu=0.3))
# for n in (4, 16, 64, 256):
#     u, results = Bar1D(0.0, 1.0, n=n).solve_nonlinear(neo, right=Traction(300.0), rtol=1e-13)
#     print(f"{n:4d} elements: {results[0].iterations} Newton iterations")
# ```
#
# - Compare the Taylor model with the log model under a milder push, $T = -600$, and under
#   $T = -1500$: how far apart are they?
#
# ```python
# from tissuefem import NeoHookean1D, TaylorNeoHookean1D, lame_parameters
# from tissuefem.engine.bar1d import uniform_bar_stretch
#
# lam, mu = lame_parameters(E=1000.0, nu=0.3)
# for T in (-600.0, -1500.0):
#     F_log = uniform_bar_stretch(NeoHookean1D(lam, mu), T)
#     F_taylor = uniform_bar_stretch(TaylorNeoHookean1D(lam, mu), T)
#     print(f"T = {T:6.0f}: ln J model F = {F_log:.4f}, Taylor model F = {F_taylor:.4f}")
# ```
#
# ## Exercises (graded by pytest)
# In `exercises/ch02.py`:
# - **2.1** `neo_hookean_stress_1d(F, lam, mu)`;
# - **2.2** `neo_hookean_tangent_1d(F, lam, mu)`;
# - **2.3** `newton_step_1d(nodes, u, lam, mu, traction)` — one Newton step, element by element.
#
# Grade: `python -m tissuefem grade ch02`.
