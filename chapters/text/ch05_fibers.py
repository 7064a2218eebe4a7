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
# # Chapter 5 — Anisotropic fibers: muscle, tendon and the invariant $I_4$
#
# **Goals.** By the end of this chapter you can
# 1. say why muscle, tendon and ligament need *anisotropic* models, and describe a tissue's fibers
#    by a field of unit directions $\mathbf g$ on the reference configuration;
# 2. define the invariant $I_4 = \mathbf g^T \mathbf F^T \mathbf F \mathbf g$ and read it as the squared
#    stretch of a fiber;
# 3. derive the fiber stress $\mathbf P_{\text{fiber}} = 2\Psi_{\text{fiber}}'(I_4)\,\mathbf F\mathbf g\mathbf g^T$
#    (and its tangent), and check both by finite differences;
# 4. show that for small strains the fiber adds its modulus $k$ to one elastic constant only, $C_{ffff}$;
# 5. measure it: pull a block along and across its fibers, and pull a muscle by its tendons.
#
# *Time: about 40 min to read and run, and four exercises.*
#
# *Reading:* the notes' "Continuum mechanics and elasticity", the paragraph after the Neo-Hookean
# model, and the notes' Figure 3.
#
# **Index convention.** As everywhere in this workbook, $F_{ij} = \partial\phi_i/\partial X_j$
# (row: spatial component, column: material derivative), so a material line element $d\mathbf X$ is
# carried to $d\mathbf x = \mathbf F\, d\mathbf X$. Section 2 shows why this matters for $I_4$.

# %%
# %matplotlib inline
import numpy as np
import matplotlib.pyplot as plt

from tissuefem import FiberReinforced, NeoHookean, fusiform_fiber_field, fusiform_muscle
from tissuefem.engine.materials import fiber_energy, fiber_invariant, fiber_stress, fiber_tangent
from tissuefem.workbook.fibers import (K_FIBER, along_vs_across, block_pull, confined_pull, fiber_direction,
                                       fiber_modulus_gain, muscle_pull, predicted_confined_modulus)
from tissuefem.workbook.figures.fibers import fig03_fiber_field, fig_ch05_along_vs_across, fig_ch05_muscle_pull

matrix = NeoHookean.from_young(E=1000.0, nu=0.3)  # the isotropic "ground substance"
print(f"lam = {matrix.lam:.2f}, mu = {matrix.mu:.2f}, fiber modulus k = {K_FIBER:g}")

# %% [markdown]
# ## 1. Why fibers?
#
# Linear elasticity and the Neo-Hookean model are *isotropic*: a stretch costs the same energy
# whatever its direction. Many tissues are nothing like that. Skeletal muscle is made of long
# fibers bundled into fascicles; tendons and ligaments are ropes of collagen fibers lined up with
# the load they carry. Along its fibers such a tissue is far stiffer than across them. The notes'
# Figure 3 shows the fiber field of a rectus femoris (a thigh muscle): at every material point a
# direction, sweeping from one tendon through the belly to the other.
#
# So the model needs an extra ingredient, a **fiber field**
#
# $$ \mathbf g : B_0 \to \mathbb R^2, \qquad |\mathbf g(\mathbf X)| = 1, $$
#
# the local fiber direction in the **reference** (material) configuration. It belongs to the
# material point, not to space: when the tissue deforms the fiber through $\mathbf X$ is carried to
# $\mathbf F\mathbf g$, while $\mathbf g$ itself never changes.
#
# Our 2D stand-in for the rectus femoris is a *fusiform* (spindle-shaped) muscle: a belly of
# width $w(X_1)$ between two narrow tendons. Its mesh is the image of a structured grid under
# $(\xi, \eta) \mapsto (\xi, \eta\, w(\xi))$, and the fibers follow the curves $\eta = $ const,
# whose tangent is $(1, \eta\, w'(X_1))$, normalised. On P1 triangles $\mathbf F$ is constant per
# element, so one fiber direction per element (at its centroid) is all we need:

# %%
mesh = fusiform_muscle()          # length 4, belly width 1, tendons 0.25 wide
g = fusiform_fiber_field(mesh)    # (2, n_elements) unit vectors
print(f"{mesh.t.shape[1]} triangles; fiber field shape {g.shape}")
print("largest | |g| - 1 |:", np.abs(np.hypot(*g) - 1).max())
print(f"largest fiber angle to the long axis: {np.degrees(np.arctan2(np.abs(g[1]), g[0])).max():.1f} degrees")

# %%
fig03_fiber_field()

# %% [markdown]
# ## 2. The fiber invariant $I_4$
#
# Take a short piece of fiber, $d\mathbf X = \mathbf g\, ds$. It is carried to
# $d\mathbf x = \mathbf F\mathbf g\, ds$, so its squared stretch is
#
# $$ I_4 = \frac{|d\mathbf x|^2}{|d\mathbf X|^2} = |\mathbf F\mathbf g|^2
#        = \mathbf g^T \mathbf F^T \mathbf F\, \mathbf g = \mathbf g^T \mathbf C\, \mathbf g,
#        \qquad \mathbf C = \mathbf F^T\mathbf F , $$
#
# the notes' $\mathbf g^T\mathbf F^T\mathbf F\mathbf g$. The fiber stretch is $\lambda_f = \sqrt{I_4}$:
# $I_4 > 1$ when the fiber is stretched, $< 1$ when it is shortened, and $I_4 = 1$ under any rotation
# ($(\mathbf Q\mathbf F)^T\mathbf Q\mathbf F = \mathbf F^T\mathbf F$), so an energy of $I_4$ is frame
# indifferent.
#
# > **Erratum (index convention, applied to $I_4$).** The notes define
# > $F_{ij} = \partial\phi_j/\partial X_i$, the transpose of ours. With that matrix,
# > $\mathbf g^T\mathbf F^T\mathbf F\mathbf g$ would be $|(\nabla\phi)^T\mathbf g|^2$, which is *not* the fiber
# > stretch. In the simple shear $\phi = (X_1 + \gamma X_2,\, X_2)$ a vertical fiber becomes
# > $(\gamma, 1)$, so $I_4 = 1 + \gamma^2$; the transposed matrix gives $1$. The formula is right
# > with $F_{ij} = \partial\phi_i/\partial X_j$, which the notes' balance law uses anyway (erratum 4 of the README).

# %%
gamma = 0.5
F_shear = np.array([[1.0, gamma], [0.0, 1.0]])      # F_ij = d phi_i / d X_j for phi = (X1 + gamma X2, X2)
vertical = np.array([0.0, 1.0])
print("deformed vertical fiber F g =", F_shear @ vertical)
print("I4 with F_ij = dphi_i/dX_j :", fiber_invariant(F_shear, vertical), " (= 1 + gamma^2)")
print("I4 with the transposed F   :", fiber_invariant(F_shear.T, vertical), " (misses the stretch)")
R = np.array([[np.cos(1.0), -np.sin(1.0)], [np.sin(1.0), np.cos(1.0)]])
print(f"I4 under a rotation        : {fiber_invariant(R, fiber_direction(30.0)):.12f}")

# %% [markdown]
# ## 3. Energy, stress and tangent
#
# The notes add a term in $I_4$ to the isotropic energy:
#
# $$ \Psi(\mathbf F) = \Psi_{\text{iso}}(\mathbf F) + \Psi_{\text{fiber}}(I_4),
#    \qquad I_4 = \mathbf g^T\mathbf F^T\mathbf F\mathbf g . $$
#
# **Stress.** With $\mathbf a = \mathbf F\mathbf g$, a change $d\mathbf F$ changes $I_4 = \mathbf a\cdot\mathbf a$ by
#
# $$ dI_4 = 2\,\mathbf a\cdot(d\mathbf F\,\mathbf g) = 2\, a_i\, dF_{ij}\, g_j
#    \quad\Longrightarrow\quad \frac{\partial I_4}{\partial F_{ij}} = 2 (\mathbf F\mathbf g)_i\, g_j , $$
#
# and the chain rule gives the fiber part of the first Piola–Kirchhoff stress
#
# $$ \mathbf P_{\text{fiber}} = \Psi_{\text{fiber}}'(I_4)\,\frac{\partial I_4}{\partial\mathbf F}
#    = 2\,\Psi_{\text{fiber}}'(I_4)\, \mathbf F\mathbf g\,\mathbf g^T . $$
#
# It pulls along the *deformed* fiber $\mathbf F\mathbf g$ on faces whose reference normal has a
# component along $\mathbf g$: a tension carried by the fibers.
#
# **Tangent** (for Newton). Differentiating once more, with
# $\partial(\mathbf F\mathbf g)_i/\partial F_{kl} = \delta_{ik} g_l$:
#
# $$ \frac{\partial P^{\text{fiber}}_{ij}}{\partial F_{kl}}
#    = 4\,\Psi_{\text{fiber}}''(I_4)\, a_i g_j\, a_k g_l + 2\,\Psi_{\text{fiber}}'(I_4)\, \delta_{ik}\, g_j g_l . $$
#
# **Our choice.** The notes leave $\Psi_{\text{fiber}}$ open. Any choice needs
# $\Psi_{\text{fiber}}'(1) = 0$: at $\mathbf F = \mathbf I$ the fiber stress is $2\Psi_{\text{fiber}}'(1)\,\mathbf g\mathbf g^T$,
# and an unloaded tissue should not be pre-stressed. We take
#
# $$ \Psi_{\text{fiber}}(I_4) = \frac{k}{8}(I_4 - 1)^2, \qquad
#    \mathbf P_{\text{fiber}} = \frac{k}{2}(I_4 - 1)\,\mathbf F\mathbf g\,\mathbf g^T , $$
#
# where the factor $1/8$ makes $k$ the fiber's own small-strain modulus (section 4). This is the
# energy of a model's fibre term (`Model(..., fibers=(k, directions))`, one direction per element),
# and what `FiberReinforced(base, k, fibers)` adds to any base material at a point. It resists shortening as much as
# stretching; real fibers buckle instead (see *What to try*). Both formulas, checked against
# central differences of the energy:

# %%
rng = np.random.default_rng(0)
F = np.eye(2) + 0.3 * rng.standard_normal((2, 2))
g0 = fiber_direction(25.0)
h = 1e-6
P_fd = np.zeros((2, 2))
A_fd = np.zeros((2, 2, 2, 2))
for i in range(2):
    for j in range(2):
        dF = np.zeros((2, 2))
        dF[i, j] = h
        P_fd[i, j] = (fiber_energy(F + dF, g0, K_FIBER) - fiber_energy(F - dF, g0, K_FIBER)) / (2 * h)
        A_fd[i, j] = (fiber_stress(F + dF, g0, K_FIBER) - fiber_stress(F - dF, g0, K_FIBER)) / (2 * h)
A_fd = A_fd.transpose(2, 3, 0, 1)  # A_fd[k, l] held dP/dF_kl; reorder to A[i, j, k, l]
print("stress : largest |P - P_fd| / |P| =", np.abs(fiber_stress(F, g0, K_FIBER) - P_fd).max()
      / np.abs(P_fd).max())
print("tangent: largest |A - A_fd| / |A| =", np.abs(fiber_tangent(F, g0, K_FIBER) - A_fd).max()
      / np.abs(A_fd).max())
tissue = FiberReinforced(matrix, K_FIBER, g0)
print("FiberReinforced = matrix + fiber term:",
      np.allclose(tissue.stress(F), matrix.stress(F) + fiber_stress(F, g0, K_FIBER)))

# %% [markdown]
# What the fiber term does in 1D: stretch a fiber along $X_1$ by $\lambda_f$
# ($\mathbf F = \mathrm{diag}(\lambda_f, 1)$, $\mathbf g = \mathbf e_1$). Then $I_4 = \lambda_f^2$ and
# $P^{\text{fiber}}_{11} = \frac k2(\lambda_f^2 - 1)\lambda_f$: slope $k$ at rest and stiffening in tension. It
# resists shortening too, but ever more weakly: the slope $\frac k2(3\lambda_f^2 - 1)$ vanishes at
# $\lambda_f = 1/\sqrt 3$ and is negative below, where a shortened fiber *softens* (one more reason to make
# fibers tension-only, see *What to try*).

# %%
lam_f = np.linspace(0.6, 1.4, 161)
P11 = [fiber_stress(np.diag([s, 1.0]), [1.0, 0.0], K_FIBER)[0, 0] for s in lam_f]
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(lam_f, P11, label="$P^{fiber}_{11} = (k/2)(\\lambda_f^2 - 1)\\lambda_f$")
ax.plot(lam_f, K_FIBER * (lam_f - 1), "--", label="small strain: $k(\\lambda_f - 1)$")
ax.axvspan(0.6, 1.0, color="C3", alpha=0.08, label="fiber shortened ($I_4 < 1$)")
ax.axhline(0, color="k", lw=0.6)
ax.set(xlabel="fiber stretch $\\lambda_f = \\sqrt{I_4}$", ylabel="fiber stress $P_{11}$",
       title="The fiber term alone, stretched along the fiber")
ax.legend(fontsize=8);

# %% [markdown]
# ## 4. The small-strain limit: the fiber adds $k$ to $C_{ffff}$ only
#
# Write $\mathbf F = \mathbf I + \mathbf H$ with $\mathbf H = \partial\mathbf u/\partial\mathbf X$ small and
# $\boldsymbol\epsilon = (\mathbf H + \mathbf H^T)/2$. Then
#
# $$ I_4 - 1 = 2\,\mathbf g\cdot\mathbf H\mathbf g + |\mathbf H\mathbf g|^2 \approx 2\,\mathbf g^T\boldsymbol\epsilon\,\mathbf g = 2\epsilon_{ff},
#    \qquad \Psi_{\text{fiber}} \approx \frac{k}{8}(2\epsilon_{ff})^2 = \frac{k}{2}\epsilon_{ff}^2 , $$
#
# a 1D spring of modulus $k$ along the fiber (hence the $1/8$). Equivalently, at $\mathbf F = \mathbf I$
# the tangent above is $k\, g_i g_j g_k g_l$: in a frame $(\mathbf f, \mathbf t)$ aligned with the fiber,
# $C_{ffff}$ gains $k$ and every other component ($C_{tttt}$, $C_{fftt}$, $C_{ftft}$, ...) is unchanged.
# Pulling along a unit direction $\mathbf e$ at angle $\theta$ to the fiber, the extra modulus is
#
# $$ e_i e_j e_k e_l\; k\, g_i g_j g_k g_l = k\,(\mathbf e\cdot\mathbf g)^4 = k\cos^4\theta : $$
#
# all of $k$ along the fiber, a quarter of it at $45°$, nothing across.

# %%
A_extra = tissue.tangent(np.eye(2)) - matrix.tangent(np.eye(2))
f, t = fiber_direction(25.0), fiber_direction(115.0)   # the fiber's own frame
for name, (a, b, c, d) in {"ffff": (f, f, f, f), "tttt": (t, t, t, t), "fftt": (f, f, t, t),
                           "ftft": (f, t, f, t)}.items():
    print(f"extra C_{name} = {np.einsum('ijkl,i,j,k,l->', A_extra, a, b, c, d).round(9) + 0.0:10.4f}")
print("extra modulus at 0, 45, 90 degrees:", [round(fiber_modulus_gain(K_FIBER, a), 6) for a in (0, 45, 90)])

# %% [markdown]
# ## 5. Pulling along versus across the fibers
#
# **A clean measurement.** Take a unit square with a *uniform* fiber direction at angle $\theta$
# to $X_1$ and impose the homogeneous uniaxial strain $\mathbf F = \mathrm{diag}(1 + \varepsilon, 1)$ on its
# whole boundary with one handle. P1 elements reproduce a homogeneous deformation exactly (the
# patch test), so the stress is uniform, and the force that holds the right edge, per unit height, is
# $P_{11}$. For small $\varepsilon$ the *confined modulus* $P_{11}/\varepsilon$ should be
#
# $$ C_{1111} = \lambda + 2\mu + k\cos^4\theta . $$
#
# The core of `tissuefem.workbook.fibers.confined_pull`, in four lines:
#
# ```python
# handle = Handle(on_boundary, target=lambda X: np.vstack([(1 + eps) * X[0], X[1]]))
# model = Model(rectangle(1, 1, 4, 4), matrix, fibers=(k, fiber_direction(theta)), handles=[handle])
# u = solve(model).u
# force = model.internal_force(u)[model.basis.get_dofs("right").nodal["u^1"]].sum()
# ```
#
# **The prediction.** Along ($\theta = 0$) minus across ($\theta = 90°$) is $k\cos^4 0 - k\cos^4 90° = k$.
# At finite strain it is exact too: both runs share the matrix and $\mathbf F$, so the matrix cancels;
# across, $\mathbf F\mathbf g = \mathbf g$ and the fiber carries nothing; along,
# $I_4 - 1 = (1+\varepsilon)^2 - 1$ and $P^{\text{fiber}}_{11} = \frac k2\big((1+\varepsilon)^2 - 1\big)(1 + \varepsilon)$, so
#
# $$ \frac{P_{11}^{\text{along}} - P_{11}^{\text{across}}}{\varepsilon} = k\,(1+\varepsilon)(1+\tfrac{\varepsilon}{2})
#    \;\longrightarrow\; k . $$

# %%
r = along_vs_across(strain=1e-4)
print(f"strain {r.strain:g}: modulus along {r.modulus_along:.3f}, across {r.modulus_across:.3f}")
print(f"  difference {r.difference:.4f}   predicted k = {r.predicted_difference:g}   "
      f"relative error {r.relative_error:.1e}   exact k(1+e)(1+e/2) = {r.exact_difference:.4f}")
print(f"  lam + 2 mu = {matrix.lam + 2 * matrix.mu:.3f}")
print("\nangle   P11/eps (FE)   lam + 2 mu + k cos^4")
for angle in (0, 15, 30, 45, 60, 75, 90):
    measured = confined_pull(angle, 1e-4).nominal_stress[0] / 1e-4
    print(f"{angle:5d}   {measured:12.2f}   {predicted_confined_modulus(angle):12.2f}")
big = along_vs_across(strain=0.2)
print(f"\nstrain 0.2: along {big.modulus_along:.0f}, across {big.modulus_across:.0f}; difference "
      f"{big.difference:.1f} = k (1.2)(1.1) = {big.exact_difference:.1f}")

# %% [markdown]
# The small-strain difference matches $k$ to the size of $\varepsilon$ (the test suite holds it to
# $10^{-3}$), and the finite-strain formula to round-off. At $\varepsilon = 0.2$ the fiber, whose stress
# grows like $(I_4 - 1)\sqrt{I_4}$, is already a third stiffer than its small-strain modulus.
#
# **A tensile test.** A real test clamps a strip at both ends and leaves its sides free, so it can
# narrow; nothing is homogeneous any more and there is no closed form, but the picture is the
# same. `block_pull(angle, stretches)` ramps the right clamp, warm-starting each Newton solve:

# %%
stretches = np.linspace(1.0, 1.3, 7)
for angle in (0.0, 45.0, 90.0, None):
    result = block_pull(angle, stretches)
    label = "no fibers" if angle is None else f"fibers at {angle:g} deg"
    print(f"{label:17s} force/height at stretch 1.1, 1.3: {result.nominal_stress[2]:7.1f} "
          f"{result.nominal_stress[-1]:7.1f}   ({result.newton_iterations} Newton iterations)")

# %%
fig_ch05_along_vs_across()

# %% [markdown]
# Three things to read off the figure:
# - **Along** the fibers the strip is several times stiffer, and it stiffens as it stretches.
# - **At 45°** the strip *shears* between its clamps: stretching along $X_1$ stretches the tilted
#   fibers, and their tension $\mathbf P_{\text{fiber}} \propto \mathbf F\mathbf g\,\mathbf g^T$ has a shear part
#   ($P_{21} \neq 0$ at small strain). Anisotropy couples stretch and shear.
# - **Across** the fibers the strip is still a little stiffer than without them: pulled along $X_1$
#   it wants to narrow, and our fiber term resists shortening as much as stretching.
#
# ## 6. A muscle pulled by its tendons
#
# Now the fusiform muscle with its curved fiber field: the left tendon is held, the right one is
# pulled along the muscle's axis (`muscle_pull`).

# %%
tendon_stretches = np.linspace(1.0, 1.2, 5)
with_fibers = muscle_pull(tendon_stretches)
without = muscle_pull(tendon_stretches, with_fibers=False)
for s, f1, f0 in zip(tendon_stretches[1:], with_fibers.forces[1:], without.forces[1:]):
    print(f"stretch {s:.2f}: tendon force {f1:6.1f} with fibers, {f0:5.1f} without (ratio {f1 / f0:.1f})")

# %%
fig_ch05_muscle_pull()

# %% [markdown]
# With fibers the muscle needs several times the force. Yet the two deformed shapes look alike: in
# a pull whose ends are *prescribed*, where the stretch goes is decided mostly by the geometry
# (the narrow tendon ends are in series with the wide belly and stretch most), and the stiffness
# decides the force. Real tendons are much stiffer than the muscle belly; giving them their own
# material is one of the things to try.
#
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Change the fiber modulus. Is the difference of the moduli still $k$? Does it depend on the matrix?
#
# ```python
# from tissuefem import LinearElastic
# from tissuefem.workbook.fibers import along_vs_across
#
# for k in (500.0, 4000.0, 20000.0):
#     print(f"k = {k:7.0f}: along - across = {along_vs_across(1e-4, stiffness=k).difference:9.2f}")
# linear = LinearElastic.from_young(1000.0, 0.3)
# print(f"linear matrix, k = 4000: {along_vs_across(1e-4, stiffness=4000.0, base=linear).difference:9.2f}")
# ```
#
# - Make the fibers *tension-only*, $\Psi_{\text{fiber}} = \frac k8 \max(I_4 - 1, 0)^2$: a small material class
#   that adds the fiber term of section 3 only where the fiber is stretched. Predict first: which curve of
#   the tensile test changes, along or across?
#
# ```python
# import numpy as np
# from tissuefem import NeoHookean
# from tissuefem.engine.materials import fiber_energy_term, fiber_invariant, fiber_stress_term, fiber_tangent_term
# from tissuefem.workbook.fibers import K_FIBER, block_pull, fiber_direction
#
#
# class TensionOnlyFibers(NeoHookean):
#     """Neo-Hookean plus fibers that resist stretching only: k/8 max(I4 - 1, 0)^2 along the unit vector g."""
#
#     def __init__(self, lam, mu, k, g):
#         super().__init__(lam, mu)
#         self.k, self.g = k, np.asarray(g, dtype=float).reshape(2, 1)  # (2, 1): one fiber for every element
#
#     def _stretched(self, F):
#         return fiber_invariant(F, self.g) > 1.0
#
#     def energy(self, F):
#         return super().energy(F) + self._stretched(F) * fiber_energy_term(F, self.g, self.k)
#
#     def stress(self, F):
#         return super().stress(F) + self._stretched(F) * fiber_stress_term(F, self.g, self.k)
#
#     def tangent(self, F):
#         return super().tangent(F) + self._stretched(F) * fiber_tangent_term(F, self.g, self.k)
#
#
# matrix = NeoHookean.from_young(1000.0, 0.3)
# stretches = np.linspace(1.0, 1.3, 4)
# for angle in (0.0, 90.0):
#     both = block_pull(angle, stretches)
#     tension_only = block_pull(None, stretches,
#                               base=TensionOnlyFibers(matrix.lam, matrix.mu, K_FIBER, fiber_direction(angle)))
#     print(f"fibers at {angle:2.0f} deg: force/height {both.nominal_stress.round(1)} (both ways), "
#           f"{tension_only.nominal_stress.round(1)} (tension only)")
# ```
#
# - Pull the 45° strip further, and the $-45°$ one. Which way does the material line $X_1 = 1$ (across
#   the middle) tilt, and why that way? (Where does a stretched tilted fiber want to turn?)
#
# ```python
# import numpy as np
# from tissuefem.workbook.fibers import block_pull
#
# for angle in (45.0, -45.0):
#     r = block_pull(angle, np.linspace(1.0, 1.4, 5))
#     X, u1 = r.model.mesh.p, r.u[r.model.basis.nodal_dofs[0]]
#     top = np.isclose(X[0], 1.0) & np.isclose(X[1], 1.0)
#     bottom = np.isclose(X[0], 1.0) & np.isclose(X[1], 0.0)
#     print(f"fibers at {angle:+.0f} deg: the middle line's top moves {float(u1[top][0] - u1[bottom][0]):+.3f} "
#           "in X1 relative to its bottom")
# ```
#
# - Turn the muscle's fibers by $90°$ and pull again: how much of the stiffening is left?
#
# ```python
# import numpy as np
# from tissuefem import fusiform_fiber_field, fusiform_muscle
# from tissuefem.workbook.fibers import muscle_pull
#
# mesh = fusiform_muscle()
# g = fusiform_fiber_field(mesh)
# stretches = np.linspace(1.0, 1.1, 3)
# for label, fibers in (("along", g), ("turned by 90 degrees", np.stack([-g[1], g[0]]))):
#     print(f"fibers {label:22s}: tendon force {muscle_pull(stretches, fibers=fibers, mesh=mesh).forces.round(1)}")
# print(f"no fibers{'':15s}: tendon force {muscle_pull(stretches, with_fibers=False, mesh=mesh).forces.round(1)}")
# ```
#
# - Tendons are much stiffer than muscle. Give the fibers a stiffness per element, ten times larger for
#   $X_1 < 0.4$ and $X_1 > 3.6$, and see where the stretch goes (compare the largest $J$ or the stretch of the
#   belly with and without).
#
# ```python
# import numpy as np
# from tissuefem import NeoHookean, fusiform_fiber_field, fusiform_muscle
# from tissuefem.engine.materials import fiber_energy_term, fiber_stress_term, fiber_tangent_term
# from tissuefem.workbook.fibers import K_FIBER, muscle_pull
#
#
# class FibersPerElement(NeoHookean):
#     """Neo-Hookean plus k/8 (I4 - 1)^2 with a fiber g and a stiffness k for every element."""
#
#     def __init__(self, lam, mu, k, g):
#         super().__init__(lam, mu)
#         self.k, self.g = np.asarray(k, dtype=float), np.asarray(g, dtype=float)
#
#     def energy(self, F):
#         return super().energy(F) + fiber_energy_term(F, self.g, self.k)
#
#     def stress(self, F):
#         return super().stress(F) + fiber_stress_term(F, self.g, self.k)
#
#     def tangent(self, F):
#         return super().tangent(F) + fiber_tangent_term(F, self.g, self.k)
#
#
# mesh = fusiform_muscle()
# centre = mesh.p[:, mesh.t].mean(axis=1)                          # (2, n_elements)
# tendon = (centre[0] < 0.4) | (centre[0] > 3.6)
# matrix = NeoHookean.from_young(1000.0, 0.3)
# for label, k in (("uniform k", np.full(mesh.nelements, K_FIBER)), ("stiff tendons", np.where(tendon, 10 * K_FIBER, K_FIBER))):
#     r = muscle_pull([1.0, 1.1], with_fibers=False, mesh=mesh,
#                     base=FibersPerElement(matrix.lam, matrix.mu, k, fusiform_fiber_field(mesh)))
#     J = np.linalg.det(np.moveaxis(r.model.deformation_gradient(r.u), -1, 0))
#     print(f"{label:13s}: tendon force {r.forces[-1]:6.1f}, mean J in the tendons {J[tendon].mean():.3f}, "
#           f"in the belly {J[~tendon].mean():.3f}")
# ```
#
# ## Exercises (graded by pytest)
# In `exercises/ch05.py` (single $2\times2$ $\mathbf F$, unit $\mathbf g$ of shape (2,)):
# - **5.1** `fiber_invariant(F, g)` — $I_4 = \mathbf g^T\mathbf F^T\mathbf F\mathbf g$;
# - **5.2** `fiber_stress(F, g, k)` — $\mathbf P_{\text{fiber}}$ for $\Psi_{\text{fiber}} = \frac k8(I_4 - 1)^2$;
# - **5.3** `fiber_tangent(F, g, k)` — $\partial P^{\text{fiber}}_{ij}/\partial F_{kl}$, shape (2, 2, 2, 2);
# - **5.4** `fiber_modulus_gain(k, angle_deg)` — the small-strain modulus the fiber adds to a pull at an angle.
#
# Grade: `python -m tissuefem grade ch05`.
