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
# # Chapter 1 — 1D linear elasticity: the notes' Poisson problem
#
# **Goals.** By the end of this chapter you can
# 1. write the 1D equilibrium problem and its weak form in the notes' notation;
# 2. derive the 1D elastic modulus from the energy (and spot a slip in the notes);
# 3. assemble the stiffness matrix, the body-force vector and the boundary term $g$ with scikit-fem;
# 4. impose displacement (Dirichlet) and traction ends, and check the result against closed forms;
# 5. measure how the error falls as the mesh is refined, and read off the convergence rates.
#
# *Time: about 15 min to read and run, and two exercises.*
#
# *Reading:* Teran's notes, sections "Equilibrium and weak form" and "1D elasticity".

# %%
# %matplotlib inline
import numpy as np
import matplotlib.pyplot as plt

from tissuefem import Bar1D, Displacement, Linear1D, NeoHookean1D, Traction, lame_parameters
from tissuefem.workbook.figures.oned import fig_ch01_convergence
from tissuefem.workbook.oned import convergence_study

# %% [markdown]
# ## 1. The problem
#
# A bar occupies $[a, b]$ in its rest (material) configuration. A point $X$ moves to
# $x = \phi(X) = X + u(X)$, so the deformation gradient is the scalar
# $F = \phi'(X) = 1 + u'(X)$. Without inertia, balance of forces says
#
# $$ -\frac{\partial P}{\partial X} = f^{\text{ext}} \quad \text{on } (a, b), $$
#
# with $P$ the first Piola–Kirchhoff stress. Multiplying by a test function $w$ and
# integrating by parts gives the weak form
#
# $$ \int_a^b w' P \, dX = w(b) P(b) - w(a) P(a) + \int_a^b w f^{\text{ext}}\, dX . $$
#
# ## 2. The 1D modulus, derived
#
# The notes' linear energy is $\Psi = \mu\, \epsilon_{ij}\epsilon_{ij} + \frac{\lambda}{2}\epsilon_{kk}^2$.
# In 1D there is one strain component, $\epsilon = F - 1$, so
#
# $$ \Psi = \left(\mu + \tfrac{\lambda}{2}\right)\epsilon^2, \qquad
#    P = \frac{\partial \Psi}{\partial F} = (2\mu + \lambda)\, \epsilon . $$
#
# > **Erratum.** The notes print the modulus as $(2\mu - \lambda)$. The sign is a slip: with
# > $\lambda > 2\mu$ (any $\nu > 1/3$) it would even be negative. The right value is
# > $E_1 = 2\mu + \lambda$, which is also the slope of the Neo-Hookean stress at rest (chapter 2):
# > the cell below checks it numerically.

# %%
lam, mu = lame_parameters(E=1000.0, nu=0.3)
neo = NeoHookean1D(lam, mu)
h = 1e-6
slope_at_rest = (neo.stress(1 + h) - neo.stress(1 - h)) / (2 * h)
print(f"lam = {lam:.2f}, mu = {mu:.2f}")
print(f"2 mu + lam = {2*mu + lam:.4f}   slope of the Neo-Hookean P(F) at F = 1: {slope_at_rest:.4f}")
print(f"2 mu - lam = {2*mu - lam:.4f}   (the notes' value)")

# %% [markdown]
# So for linear elasticity $P = E_1 u'$ and equilibrium is Poisson's equation
# $-E_1 u'' = f^{\text{ext}}$.
#
# ## 3. Discretisation with P1 elements
#
# With piecewise-linear shape functions $N_i$ and $u = u_j N_j$, choosing $w = N_i$ gives the
# notes' linear system
#
# $$ A_{ij} u_j = F^{\text{ext}}_i + g_i, \quad
#    A_{ij} = E_1 \int_a^b N_i' N_j' \, dX, \quad
#    F^{\text{ext}}_i = \int_a^b f^{\text{ext}} N_i \, dX, \quad
#    g_i = N_i(b) P(b) - N_i(a) P(a). $$
#
# In scikit-fem the two integrals are forms that read like the formulas
# (this is exactly what `tissuefem.engine.bar1d` uses):
#
# ```python
# @BilinearForm
# def stiffness(u, v, w):
#     return w["modulus"] * u.grad[0] * v.grad[0]      # E1 N_j' N_i'
#
# @LinearForm
# def body_force(v, w):
#     return w["f"] * v                                # f N_i
# ```
#
# Since $N_i(b)$ is 1 at the last node and 0 elsewhere, $g$ is nonzero only at the two end
# nodes. We prescribe a **traction** $t = P n$ at an end: the X component of the applied force
# per unit area, with $n = +1$ at $b$ and $n = -1$ at $a$. A **displacement** end fixes $u$ there;
# its row is removed from the system (condensation).

# %%
bar = Bar1D(a=0.0, b=1.0, n=4)
E1 = Linear1D(lam, mu).modulus
print("nodes:", bar.nodes)
print("A / E1 =\n", bar.stiffness(E1).toarray() / E1)
print("F_ext for f = 1:", bar.body_force(1.0))
print("g for a right-end traction t = 5:", bar.boundary_term(left=Displacement(0.0), right=Traction(5.0)))

# %% [markdown]
# ## 4. Checking against closed forms
#
# Fix $u(0) = 0$, pull the right end with $t = T$, and load the bar with a constant body force
# $f$. Integrating $-E_1 u'' = f$ twice with $E_1 u'(1) = T$ gives
#
# $$ u(X) = \frac{(T + f)X - f X^2/2}{E_1} . $$
#
# In 1D, P1 finite elements are *exact at the nodes* for this problem — the cell below shows
# the nodal error at round-off level, even on a coarse mesh.

# %%
T, f = 200.0, 500.0
bar = Bar1D(0.0, 1.0, n=6)
u = bar.solve_linear(E1, f, left=Displacement(0.0), right=Traction(T))
X = np.linspace(0, 1, 200)
exact = lambda X: ((T + f) * X - f * X**2 / 2) / E1
print("largest nodal error:", np.abs(u - exact(bar.nodes)).max())

fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(X, exact(X), label="closed form")
ax.plot(bar.nodes, u, "o-", label="P1, 6 elements")
ax.set(xlabel="X", ylabel="u(X)", title="Bar fixed at X = 0, traction at X = 1, body force")
ax.legend();

# %% [markdown]
# ## 5. How fast does the error fall?
#
# With a body force that is not a polynomial the solution is no longer exact between nodes.
# We use a *manufactured* solution $u = \sin(\pi X) + cX$ (the body force is chosen to make it
# exact) and measure the $L^2$ error and the $H^1$ (gradient) error as $h$ halves.
# Theory predicts rates $h^{p+1}$ and $h^{p}$ for elements of order $p$.

# %%
rows = convergence_study(orders=(1, 2), ns=(4, 8, 16, 32, 64))
print(f"{'order':>5} {'n':>4} {'L2 error':>11} {'rate':>5} {'H1 error':>11} {'rate':>5}")
for r in rows:
    print(f"{r['order']:>5} {r['n']:>4} {r['L2']:11.3e} {r['rate_L2']:5.2f} {r['H1']:11.3e} {r['rate_H1']:5.2f}".replace("nan", "  -"))

# %%
fig_ch01_convergence()

# %% [markdown]
# The observed rates are 2 and 1 for P1, and 3 and 2 for P2, as theory says. Accuracy costs
# degrees of freedom: halving the error in the gradient needs twice the P1 elements, but P2 gets
# there with far fewer. Later chapters measure what that costs in *time*.
#
# ## What to try
# Each suggestion comes with a few lines to paste into a new cell (they run on their own); change
# the numbers and run them again.
#
# - Push `nu` towards 0.5: what happens to $\lambda$ and to $E_1$?
#
# ```python
# from tissuefem import Linear1D, lame_parameters
#
# for nu in (0.3, 0.45, 0.49, 0.499):
#     lam, mu = lame_parameters(E=1000.0, nu=nu)
#     print(f"nu = {nu}: lam = {lam:9.1f}, mu = {mu:6.1f}, E1 = {Linear1D(lam, mu).modulus:9.1f}")
# ```
#
# - Put the traction on the left end and fix the right end. Predict the sign of $u$ first
#   (at $X = 0$ the outward normal is $n = -1$).
#
# ```python
# from tissuefem import Bar1D, Displacement, Linear1D, Traction, lame_parameters
#
# E1 = Linear1D(*lame_parameters(E=1000.0, nu=0.3)).modulus
# bar = Bar1D(0.0, 1.0, n=6)
# u = bar.solve_linear(E1, 0.0, left=Traction(200.0), right=Displacement(0.0))
# print(u.round(4))
# ```
#
# - Use a non-uniform mesh: is the nodal exactness of section 4 lost?
#
# ```python
# import numpy as np
# from tissuefem import Bar1D, Displacement, Linear1D, Traction, lame_parameters
#
# E1 = Linear1D(*lame_parameters(E=1000.0, nu=0.3)).modulus
# T, f = 200.0, 500.0
# nodes = np.sort(np.r_[0.0, 1.0, np.random.default_rng(1).uniform(0.0, 1.0, 5)])
# bar = Bar1D(nodes=nodes)
# u = bar.solve_linear(E1, f, left=Displacement(0.0), right=Traction(T))
# exact = ((T + f) * nodes - f * nodes**2 / 2) / E1
# print("largest nodal error on a random mesh:", np.abs(u - exact).max())
# ```
#
# ## Exercises (graded by pytest)
# Open `exercises/ch01.py` and implement:
# - **1.1** `linear_modulus_1d(lam, mu)` — the 1D modulus, from the energy;
# - **1.2** `assemble_stiffness_1d(nodes, modulus)` — the P1 stiffness on any mesh, element by element.
#
# Then grade yourself from the workbook root: `python -m tissuefem grade ch01`.
