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
# # Chapter 6 — Inversion: elements turned inside out, and models that survive it
#
# **Goals.** By the end of this chapter you can
# 1. say what inversion means for one element ($J \le 0$) and for the whole deformation
#    ($\phi$ no longer one-to-one), carrying the 1D picture of chapter 2 to 2D;
# 2. explain why the $\ln J$ Neo-Hookean model breaks on an inverted element, and write the notes'
#    cubic-Taylor repair with the correct cofactor;
# 3. compute the *rotation-preserving* SVD and read inversion off the sign of the smallest singular value;
# 4. extend an energy below a compression threshold (the ITF construction) and say why $\mathbf F = 0$ is a
#    resting point for some models and not for others;
# 5. make every Newton direction a descent direction with the projected tangent;
# 6. crush a block past flat and let it go with four models, and read what each one did.
#
# *Reading:* the notes' "Inversion" section (Figures 5, 6 and 7). Behind it: Irving, Teran and Fedkiw,
# *Invertible finite elements* (SCA 2004); Teran, Sifakis, Irving and Fedkiw, *Robust quasistatic finite
# elements* (SCA 2005); Smith, de Goes and Kim, *Stable Neo-Hookean flesh simulation* (2018).
#
# **Index convention.** As everywhere in this workbook, $F_{ij} = \partial\phi_i/\partial X_j$ with
# indices **0 and 1** in code and formulas alike, so $J = F_{00}F_{11} - F_{01}F_{10}$.

# %%
# %matplotlib inline
import time
import warnings

import numpy as np
import matplotlib.pyplot as plt
from scipy.sparse.linalg import MatrixRankWarning

from tissuefem.workbook.figures.inversion import (cover_counts, crush_and_release_runs, draw_state, element_jacobians,
                                         fig06_crush_release, fig_ch06_itf_energy)
from tissuefem.workbook.hardcases import block, inversion_models, release, start_states
from tissuefem import (Handle, ITFClamped, Model, NeoHookean, P1Assembler, StableNeoHookean, TaylorNeoHookean,
                       projected_tangent, rotation_preserving_svd)
from tissuefem.engine.materials1d import taylor_log, taylor_log_prime

E, nu = 1000.0, 0.3
models = inversion_models(E, nu)          # the four models of this chapter, by name
lam, mu = models["neo-Hookean (ln J)"].lam, models["neo-Hookean (ln J)"].mu
mesh = block()                            # the unit square, 6 x 6 cells
print(f"lam = {lam:.2f}, mu = {mu:.2f};  block: {mesh.p.shape[1]} nodes, {mesh.t.shape[1]} triangles")
for name, material in models.items():
    print(f"  {name:25s} {type(material).__name__}")


def rotation(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


# %% [markdown]
# ## 1. What inversion means
#
# **In 1D** (chapter 2, the notes' Figure 5) a deformation $\phi$ must keep $\phi'(X) > 0$: where
# $\phi' \le 0$ the bar is squashed to nothing or folded back over itself, and two material points land
# on the same spot. The notes put it as a rule of continuum mechanics: $\phi$ must be a bijection.
#
# **In 2D** the local measure is $J = \det\mathbf F$, the ratio of a small deformed area to its
# reference area. On a P1 triangle $\mathbf F$ is constant, and $J$ is exactly the deformed signed area
# over the reference one:
# - $J > 0$: the triangle keeps its orientation (its corners still run counter-clockwise);
# - $J = 0$: it is flat, or collapsed to a point;
# - $J < 0$: it is **inverted**, turned inside out, its corners now run clockwise.
#
# For the whole map, an inverted triangle next to an upright one lies on top of it (they share an edge and
# now sit on the same side of it), so some points of space are reached twice: $\phi$ is no longer
# one-to-one. The converse is false: every triangle can have $J > 0$ while the mesh still folds over itself
# somewhere. We will meet exactly that in section 6. (A mirror image, $\mathbf F = \mathrm{diag}(1, -1)$, is
# one-to-one but has $J = -1$; no continuous motion reaches it without passing $J = 0$, which is why an
# admissible deformation needs $J > 0$, not only a bijection: erratum 11.)
#
# **The 1D picture, carried to 2D.** Apply the notes' inverting map of Figure 5 along $X_0$ and leave $X_1$
# alone: $\phi(\mathbf X) = (\sin 2\pi X_0,\ X_1)$, so $\mathbf F = \mathrm{diag}(2\pi\cos 2\pi X_0,\ 1)$ and
# $J = 2\pi\cos 2\pi X_0$, negative on the middle half of the block. To test the *global* property we
# ask, for the centroid of every deformed triangle, how many deformed triangles contain it
# (`cover_counts`; 1 everywhere for a one-to-one map):

# %%
fine = block(12)
x_fold = np.stack([np.sin(2 * np.pi * fine.p[0]), fine.p[1]])
J_fold, covers = element_jacobians(fine, x_fold), cover_counts(fine, x_fold)
print(f"{int((J_fold <= 0).sum())} of {J_fold.size} triangles have J <= 0; "
      f"{int((covers > 1).sum())} of {covers.size} centroids are covered more than once "
      f"(at most {covers.max()} times)")
fig, axes = plt.subplots(1, 2, figsize=(9, 3), layout="constrained")
draw_state(axes[0], fine, fine.p, J=J_fold)          # the reference, coloured by the J it will get
draw_state(axes[1], fine, x_fold)
axes[0].set_title("reference $B_0$, coloured by the sign of $J$")
axes[1].set_title("deformed: $\\phi(\\mathbf{X}) = (\\sin 2\\pi X_0, X_1)$")
for ax in axes:
    ax.set(aspect="equal", xlim=(-1.1, 1.1), ylim=(-0.1, 1.1))

# %% [markdown]
# The middle half of the block (red on the left) is turned inside out and laid over the outer quarters:
# every point of the deformed strip is reached twice, once by an upright triangle and once by an inverted
# one. That is the 2D version of the crossing lines in the bottom row of Figure 5.
#
# A simulator does not get to choose. A surgeon's tool pushes tissue flat, a collision solver leaves a
# few elements turned over, a large time step overshoots. Here are five such states of our block, used
# in section 7 as *start states* (`tissuefem.workbook.hardcases.start_states`), drawn as the release there sees
# them: the bottom edge is held at its rest position. Triangles with $J \le 0$ are red, nodes are dots:

# %%
states = start_states(mesh)
bottom = np.flatnonzero(mesh.p[1] == 0.0)
fig, axes = plt.subplots(1, 5, figsize=(13, 3.4), layout="constrained")
for ax, (name, x) in zip(axes, states.items()):
    x = x.copy()
    x[:, bottom] = mesh.p[:, bottom]                 # the held edge, as the release holds it
    J = element_jacobians(mesh, x)
    draw_state(ax, mesh, x)
    ax.plot(x[0], x[1], "k.", ms=3)
    ax.plot(mesh.p[0, bottom], mesh.p[1, bottom], color="k", lw=2)
    pad = 0.25
    ax.set(aspect="equal", xlim=(x[0].min() - pad, x[0].max() + pad), ylim=(x[1].min() - pad, x[1].max() + pad),
           xticks=[], yticks=[])
    ax.set_title(f"{name}\n$J$ from {J.min():.3g} to {J.max():.3g}; "
                 f"{int((J <= 1e-12).sum())} of {J.size} at $J \\leq 0$", fontsize=8)

# %% [markdown]
# The triangles of the two collapsed states have $J = 0$, they have no area left, except, in the collapse to
# a point, the few that keep an edge on the held bottom edge: they are stretched between that edge and the
# point. The formula for $J$ from signed areas is the same $\det\mathbf F$ the assembler computes from the
# shape gradients:

# %%
x = states["crushed past flat"]
model = Model(mesh, models["stable neo-Hookean"], handles=[Handle("bottom")])
u = model.zeros()
u[model.basis.nodal_dofs] = x - mesh.p                          # displacement dofs of the state
F_elements = model.deformation_gradient(u)                      # shape (2, 2, n_elements)
J_from_F = F_elements[0, 0] * F_elements[1, 1] - F_elements[0, 1] * F_elements[1, 0]
print("largest |det F - area ratio| =", np.abs(J_from_F.ravel() - element_jacobians(mesh, x)).max())

# %% [markdown]
# ## 2. Why $\ln J$ fails, and the notes' cubic Taylor repair
#
# The Neo-Hookean energy of chapter 4,
#
# $$ \Psi(\mathbf F) = \frac{\mu}{2}(\mathbf F:\mathbf F - 2) - \mu\ln J + \frac{\lambda}{2}(\ln J)^2 , $$
#
# is not defined for $J \le 0$, and it grows without bound as $J \to 0^+$. That barrier is the point of
# the log term (it resists crushing), but a single inverted element makes the *total* energy of the
# mesh undefined. The library returns NaN there (no warning), and the Newton solver reports the status
# `non-finite` and keeps the last state that was finite instead of carrying NaN on:

# %%
neo = NeoHookean(lam, mu)
F_inv = np.array([[0.9, 0.5], [-0.1, -0.4]])       # an inverted F (J < 0) with F01 != F10
print(f"J = {np.linalg.det(F_inv):.3f};  ln J energy = {neo.energy(F_inv)}")
with warnings.catch_warnings():
    # the NaN tangent also makes SciPy warn that the matrix is singular; the status says it better
    warnings.simplefilter("ignore", MatrixRankWarning)
    r = release(mesh, models["neo-Hookean (ln J)"], states["mirrored"])
print(f"release of the mirrored block with ln J: status {r.status!r}, iterations {r.iterations}, "
      f"state finite: {r.finite}")

# %% [markdown]
# The notes' repair replaces $\ln J$ by its cubic Taylor polynomial about $J = 1$,
#
# $$ r(J) = (J - 1) - \frac{(J-1)^2}{2} + \frac{(J-1)^3}{3}, \qquad r'(J) = 1 - (J - 1) + (J-1)^2 > 0 , $$
#
# which agrees with $\ln J$ up to $(J-1)^4$ and is finite for every $J$ (the notes' Figure 7, chapter 2).
# The energy becomes $\Psi = \frac{\mu}{2}(\mathbf F:\mathbf F - 2) - \mu\, r(J) + \frac{\lambda}{2} r(J)^2$.
# Its stress needs one identity, $\partial J/\partial\mathbf F = \operatorname{cof}\mathbf F$, which in 2D
# with our 0-based indices reads
#
# $$ \operatorname{cof}\mathbf F = \begin{bmatrix} F_{11} & -F_{10} \\ -F_{01} & F_{00} \end{bmatrix}, \qquad
#    \mathbf P = \mu\mathbf F + \big(\lambda\, r(J) - \mu\big)\, r'(J)\, \operatorname{cof}\mathbf F . $$
#
# > **Erratum (README, item 8).** The notes print the matrix $\begin{bmatrix} F_{22} & -F_{12} \\ -F_{21} & F_{11}\end{bmatrix}$
# > (1-based), in our indices $\begin{bmatrix} F_{11} & -F_{01} \\ -F_{10} & F_{00}\end{bmatrix}$: that is the
# > *adjugate* $J\mathbf F^{-1}$, the transpose of the cofactor. The two agree only when $F_{01} = F_{10}$, so
# > the printed stress is not the derivative of the printed energy as soon as there is shear.
#
# Which one is the gradient? Ask the energy, by central differences, at the inverted $\mathbf F$ above:

# %%
taylor = TaylorNeoHookean(lam, mu)
J = np.linalg.det(F_inv)
r_J, r1_J = taylor_log(J), taylor_log_prime(J)
cof = np.array([[F_inv[1, 1], -F_inv[1, 0]], [-F_inv[0, 1], F_inv[0, 0]]])
P_cofactor = mu * F_inv + (lam * r_J - mu) * r1_J * cof
P_adjugate = mu * F_inv + (lam * r_J - mu) * r1_J * cof.T      # the matrix the notes print
h = 1e-6
P_fd = np.zeros((2, 2))
for i in range(2):
    for j in range(2):
        dF = np.zeros((2, 2))
        dF[i, j] = h
        P_fd[i, j] = (taylor.energy(F_inv + dF) - taylor.energy(F_inv - dF)) / (2 * h)
print(f"Taylor energy at J = {J:.3f}: {taylor.energy(F_inv):.2f} (finite)")
print("largest |P - P_fd| with the cofactor :", np.abs(P_cofactor - P_fd).max())
print("largest |P - P_fd| with the adjugate :", np.abs(P_adjugate - P_fd).max())
print("library TaylorNeoHookean.stress is the cofactor form:", np.allclose(taylor.stress(F_inv), P_cofactor))

# %% [markdown]
# The **stable Neo-Hookean** model of Smith, de Goes and Kim does the same job with a quadratic in $J$:
# $\Psi = \frac{\mu}{2}(\mathbf F:\mathbf F - 2) + \frac{\lambda + \mu}{2}(J - \alpha)^2 - \text{const}$ with
# $\alpha = 1 + \mu/(\lambda + \mu)$, so $\mathbf P = \mu\mathbf F + (\lambda + \mu)(J - \alpha)\operatorname{cof}\mathbf F$.
# Both repairs are polynomials, finite for every $\mathbf F$; neither has a barrier at $J = 0$, so both
# let an element pass through flat and come back. The price is accuracy far from rest: in compression
# they no longer reproduce the $\ln J$ model.
#
# ## 3. The rotation-preserving SVD
#
# The Neo-Hookean family is **isotropic** and **frame indifferent**: its energy depends on $\mathbf F$ only
# through its singular values. The ordinary SVD $\mathbf F = \mathbf U\boldsymbol\Sigma\mathbf V^T$ has
# $\boldsymbol\Sigma \ge 0$; when $J < 0$ one of $\mathbf U$, $\mathbf V$ must then be a reflection, and the
# fact "this element is inverted" hides in $\det\mathbf U\det\mathbf V = -1$.
#
# Irving, Teran and Fedkiw instead keep $\mathbf U$ and $\mathbf V$ **rotations** and move the reflection
# onto the smallest singular value:
#
# $$ \mathbf F = \mathbf U \begin{bmatrix} s_0 & 0 \\ 0 & s_1\end{bmatrix}\mathbf V^T,\qquad
#    \det\mathbf U = \det\mathbf V = 1,\qquad s_0 \ge |s_1|,\qquad J = s_0 s_1 . $$
#
# Now $s_1 < 0$ exactly when the element is inverted, and an isotropic energy becomes a function
# $\hat\Psi(s_0, s_1)$ on a half-plane that contains the inverted states as ordinary points: we are free
# to *define* the energy there. In 2D there is a closed form with no branches. Split $\mathbf F$ into a
# similarity part (a rotation times a scaling) and an anti-similarity part (a reflection times a scaling):
#
# $$ \mathbf F = \begin{bmatrix} E + A & G - H \\ G + H & E - A\end{bmatrix}, \quad
#    E = \tfrac{F_{00} + F_{11}}{2},\ H = \tfrac{F_{10} - F_{01}}{2},\ A = \tfrac{F_{00} - F_{11}}{2},\
#    G = \tfrac{F_{10} + F_{01}}{2}. $$
#
# With $Q = \sqrt{E^2 + H^2}$ and $R = \sqrt{A^2 + G^2}$ the singular values are $s_0 = Q + R$ and
# $s_1 = Q - R$ (so $J = Q^2 - R^2$: an element is inverted when its reflecting part outweighs its
# similarity part), and the two angles $\arctan(G/A)$ and $\arctan(H/E)$ give the rotations
# (`tissuefem.engine.inversion.rotation_preserving_svd`; exercise 6.1 asks you to derive them). A reflected
# $\mathbf F$, both ways:

# %%
F_refl = rotation(0.4) @ np.diag([1.5, -0.5]) @ rotation(-0.9).T     # built inverted: J = -0.75
U_np, S_np, Vt_np = np.linalg.svd(F_refl)
U, s, V = rotation_preserving_svd(F_refl)
print(f"J = {np.linalg.det(F_refl):.4f}")
print(f"numpy : Sigma = {S_np.round(6)},  det U = {np.linalg.det(U_np):+.0f}, det V = {np.linalg.det(Vt_np):+.0f}")
print(f"ours  : s     = {s.round(6)},  det U = {np.linalg.det(U):+.0f}, det V = {np.linalg.det(V):+.0f}")
print("largest |U diag(s) V^T - F| =", np.abs(U @ np.diag(s) @ V.T - F_refl).max())
for name, F in {"F = 0": np.zeros((2, 2)), "mirror diag(1, -1)": np.diag([1.0, -1.0]),
                "rotation by 2 rad": rotation(2.0), "-I (a half turn)": -np.eye(2)}.items():
    print(f"{name:20s} s = {rotation_preserving_svd(F)[1].round(12) + 0.0}")

# %% [markdown]
# Note the last line: in 2D $-\mathbf I$ is a rotation by $\pi$ ($J = +1$), not an inversion, and it gets
# $s = (1, 1)$.
#
# ## 4. Extending the energy below a threshold (ITF)
#
# The Taylor and stable models change the energy everywhere. Irving, Teran and Fedkiw keep the $\ln J$
# model wherever it is well behaved and **extrapolate** it below a compression threshold $c$
# (here $c = 0.3$) on the signed singular values. `tissuefem.engine.inversion.ITFClamped` has three regions:
#
# | region | energy $\hat\Psi(s_0, s_1)$ |
# |---|---|
# | $s_1 \ge c$ (the usual case) | the $\ln J$ model itself |
# | $s_1 < c \le s_0$ (one direction crushed, flat or inverted) | $\hat\Psi(s_0, c) + \psi_1(s_0, c)\,d_1 + \frac k2 d_1^2$, $\ d_1 = s_1 - c$ |
# | $s_0 < c$ (both crushed, down to $\mathbf F = 0$) | the expansion about $(c, c)$: $\hat\Psi + \psi_0 d_0 + \psi_1 d_1 + \hat\Psi_{01} d_0 d_1 + \frac k2(d_0^2 + d_1^2)$, all taken at $(c, c)$, $d_0 = s_0 - c$ |
#
# with $\psi_i = \partial\hat\Psi/\partial s_i$ and a spring $k$ (by default $\partial^2\hat\Psi/\partial s_1^2$ at
# $(c, c)$). Each piece continues the previous one in one more variable, so the energy and its gradient are
# continuous: the stress $\mathbf P = \mathbf U\,\mathrm{diag}(\psi_0, \psi_1)\,\mathbf V^T$ is the exact
# gradient of the energy, and Newton's energy line search stays valid. (ITF's paper clamps the
# diagonal stress itself; extrapolating the energy gives the same finite push-back and keeps the two
# consistent.) An element crushed to a point, or turned inside out, now feels a *finite* force that grows
# only linearly with the depth of inversion.
#
# Why only the $\ln J$ model? With one direction below $c$ and the other stretched far ($s_0$ large),
# the extension adds $\psi_1(s_0, c)\, d_1$, and the spring keeps the energy bounded below only if $\psi_1$
# grows slowly with $s_0$. For $\ln J$ it grows like $\ln s_0$; with the polynomial volumetric terms of the
# Taylor and stable models it grows like a power of $s_0$ and the extended energy would have no minimum.
# Those models need no clamping anyway. `ITFClamped` refuses them with a `ValueError` that says so.
#
# Along $s_1$ with $s_0 = 1$, and along a uniform shrink $\mathbf F = t\mathbf I$ to a point:

# %%
fig_ch06_itf_energy()

# %% [markdown]
# Read the left two panels from the right: near rest the four curves agree. The $\ln J$ energy (blue)
# shoots up and ends at $s_1 = 0$. The ITF-clamped energy (red) *is* the $\ln J$ energy down to $s_1 = c$,
# then leaves it along a straight slope plus the spring and continues through $s_1 = 0$ into inversion. The
# Taylor (green) and stable (orange) energies are smooth through $s_1 = 0$, but they part from $\ln J$ long
# before: a compression that never inverts anything is already softer with them. In numbers, the push
# back $\partial\hat\Psi/\partial s_1$ at a few points of the middle panel:

# %%
s1_values = np.array([0.7, 0.5, 0.3, 0.0, -0.5])
F_line = np.zeros((2, 2, s1_values.size))
F_line[0, 0], F_line[1, 1] = 1.0, s1_values             # F = diag(1, s1)
print(f"{'s1':>25s}" + "".join(f"{v:9.1f}" for v in s1_values))
for name, material in models.items():
    push = material.stress(F_line)[1, 1]
    print(f"{name:>25s}" + "".join(f"{v:9.0f}" for v in push))

# %% [markdown]
# Below the threshold the ITF extension pushes back hardest and the stable model least; the Taylor cubic
# sits in between and stiffens fast as the inversion deepens.
#
# **Is $\mathbf F = 0$ a resting point?** The right panel says: not for every model. For the whole
# Neo-Hookean family $\mathbf P = \mu\mathbf F + h'(J)\operatorname{cof}\mathbf F$, and both $\mathbf F$ and
# $\operatorname{cof}\mathbf F$ vanish at $\mathbf F = 0$. So for the Taylor and stable models, whose $h'(0)$ is
# finite, **$\mathbf F = 0$ is a stationary point**: an element collapsed to a point feels no force at all. It
# is a saddle: in 2D $\operatorname{cof}$ is linear, with eigenvalue $+1$ on the similarity directions and
# $-1$ on the anti-similarity ones, so the Hessian at $\mathbf F = 0$ has the eigenvalues $\mu + h'(0) < 0$
# (twice: growing back lowers the energy) and $\mu - h'(0) > 0$ (twice). For the ITF-clamped model $\mathbf F = 0$
# lies in the third region, where $\mathbf P = \psi\,\mathbf I$ with $\psi = \psi_0(c, c) - c\,(\hat\Psi_{01} + k) < 0$
# there: a push outward.
#
# (Strictly, $\mathbf F = 0$ is a kink of the ITF energy. Near it the energy falls off linearly in
# $s_0 + s_1 = 2\sqrt{E^2 + H^2}$, twice the size of the similarity part of $\mathbf F$: a cone with its tip up,
# steepest outward in every similarity direction. The stress printed below is the one the SVD's choice of
# rotations at $\mathbf F = 0$ picks. The extension has such a kink wherever $s_0 + s_1 = 0$ and
# $\psi_0 + \psi_1 \ne 0$; there the flip value $(\psi_0 + \psi_1)/(s_0 + s_1)$ of section 5 is unbounded.)

# %%
Z = np.zeros((2, 2, 1))                           # F = 0, as a field of one matrix
for name in ("Taylor neo-Hookean", "stable neo-Hookean", "ITF-clamped neo-Hookean"):
    P0 = models[name].stress(Z)[:, :, 0]
    print(f"{name:25s} P(0) = {P0.round(2).tolist()}")
for name in ("Taylor neo-Hookean", "stable neo-Hookean"):
    exact = models[name].material                  # the model without the projection of section 5
    eig = np.linalg.eigvalsh(exact.tangent(np.zeros((2, 2))).reshape(4, 4))
    print(f"{name:25s} eigenvalues of the exact tangent at F = 0: {eig.round(1)}")

# %% [markdown]
# ## 5. The definiteness fix: a projected tangent
#
# Newton solves $\mathbf K\,\Delta\mathbf u = -\mathbf q$. Where the energy is convex, $\mathbf K$ is positive
# definite and $\Delta\mathbf u$ points downhill. Near inversion the Neo-Hookean family is far from convex,
# $\mathbf K$ turns indefinite, and $\Delta\mathbf u$ may point uphill or to a saddle; the energy line search
# then cuts the step again and again, or fails. Teran, Sifakis, Irving and Fedkiw (2005) repair the
# tangent **element by element**. For an isotropic material it rotates with the SVD,
# $\mathbb A(\mathbf F) = (\mathbf U\otimes\mathbf V)\,\hat{\mathbb A}(\mathbf s)\,(\mathbf U\otimes\mathbf V)^T$, and
# in 2D the diagonal-space tangent $\hat{\mathbb A}$ splits into two $2\times 2$ blocks:
#
# - the **stretch** block over $(dF_{00}, dF_{11})$: the Hessian of $\hat\Psi(s_0, s_1)$;
# - the **twist/flip** block over $(dF_{01}, dF_{10})$, with eigenvalues
#   $\dfrac{\psi_0 - \psi_1}{s_0 - s_1}$ (twist: a rotation of the element) and
#   $\dfrac{\psi_0 + \psi_1}{s_0 + s_1}$ (flip: a reflection-like shear).
#
# Clamping each block's negative eigenvalues at zero and rotating back gives the closest positive
# semi-definite tangent (`projected_tangent`; `ProjectedTangent(material)` wraps a material with it).
# Energy and stress are untouched, so the equilibria are the same; only the search direction changes,
# and it is always a descent direction. In the models of this chapter the Taylor and stable models
# wear `ProjectedTangent`; `ITFClamped` projects its own. An inverted $\mathbf F$, before and after:

# %%
F_demo = rotation(0.3) @ np.diag([1.2, -0.4]) @ rotation(-0.5).T     # inverted: s = (1.2, -0.4)
U, s, V = rotation_preserving_svd(F_demo)
for base in (TaylorNeoHookean(lam, mu), StableNeoHookean(lam, mu)):
    before = np.linalg.eigvalsh(base.tangent(F_demo).reshape(4, 4))
    after = np.linalg.eigvalsh(projected_tangent(base, F_demo).reshape(4, 4))
    psi = np.diag(base.stress(np.diag(s)))                       # psi_i = dPsi/ds_i
    twist, flip = (psi[0] - psi[1]) / (s[0] - s[1]), (psi[0] + psi[1]) / (s[0] + s[1])
    print(f"{base.name}:  s = {s.round(3)}")
    print(f"   eigenvalues of the tangent    : {before.round(1)}")
    print(f"   eigenvalues after projection  : {after.round(1) + 0.0}")
    print(f"   twist (psi0-psi1)/(s0-s1) = {twist:.1f},  flip (psi0+psi1)/(s0+s1) = {flip:.1f}")

# %% [markdown]
# The negative eigenvalues are clamped to zero; the positive ones are kept exactly, and the twist and
# flip values reappear among the eigenvalues of the exact tangent. Where the tangent is already
# positive semi-definite (near rest), the projection changes nothing.
#
# ## 6. Crush and release: the notes' Figure 6 as an experiment
#
# The notes' Figure 6 shows the ITF algorithm recovering from violent deformations. Our version is a
# test anyone can rerun (`tissuefem.workbook.hardcases.crush_and_release`):
# 1. hold the bottom edge of the block; move the top edge down in 13 steps of 0.1, to flat (1.0) and past
#    it (1.3), solving for equilibrium after each step from the previous state (Newton with the energy
#    line search, steps capped at 0.5);
# 2. if a step fails, the crush stops at the last depth that converged;
# 3. then let go of the top edge (the bottom is still held) and solve for equilibrium from the crushed
#    shape. A model that survives should come back to the rest shape: we measure the **rest error**
#    $\|\mathbf x - \mathbf X\| / \|\mathbf X\|$ over the nodes.

# %%
start = time.perf_counter()
runs = crush_and_release_runs(E, nu, mesh)
print(f"four crushes and releases in {time.perf_counter() - start:.1f} s\n")
print("| model | depth reached | J <= 0 there | Newton iterations | line-search cuts | final energy | rest error |")
print("|---|---:|---:|---:|---:|---:|---:|")
for name, run in runs.items():
    deepest = run["frames"][-2]                     # the last crush state that converged
    inverted = int((element_jacobians(mesh, deepest) <= 1e-12).sum())
    print(f"| {name} | {run['crushed']:.1f} | {inverted} | {run['iterations']} | {run['cuts']} | "
          f"{run['final_energy']:.4g} | {run['released'].rest_error:.2g} |")
print()
for name, run in runs.items():
    failed = [f"{0.1 * (k + 1):.1f}: {r.status}" for k, r in enumerate(run["crush"]) if not r.converged]
    print(f"{name}: failed crush step {failed or 'none'}; release {run['released'].status!r} "
          f"after {run['released'].iterations} iterations")

# %%
fig06_crush_release(runs=runs)

# %% [markdown]
# (The iterations and cuts count the whole experiment, crush and release; the final energy is that of
# the released shape, zero at rest.) Row by row:
#
# - **$\ln J$ Neo-Hookean.** The crush gets to 0.9; the step to flat cannot converge, because any element
#   that reaches $J \le 0$ makes the energy NaN (status `non-finite`). Released from 0.9 it springs back
#   perfectly: the model is fine as long as nothing inverts.
# - **Taylor Neo-Hookean** (projected tangent). It goes flat and past flat, but the released block does
#   **not** come back: it settles in a different equilibrium, with a finite energy, folded around the held
#   bottom edge (see the check below).
# - **Stable Neo-Hookean** (projected tangent). Flat, past flat, and back to rest to round-off.
# - **ITF-clamped Neo-Hookean.** It reaches flat exactly (with inverted triangles, in red), but the next
#   step does not converge within its iteration cap (status `max-iterations`). Released from flat it returns
#   to rest.
#
# Notice also what the crushed blocks look like past flat: the Taylor and stable meshes at 1.3 contain no
# red triangle at all (the column "J <= 0 there"). Their elements are not turned inside out; the mesh has
# **folded** over itself instead, every triangle upright, the body bulging above and below the held edge
# (the darker fill is where the mesh overlaps itself).
#
# **Is the Taylor result a real equilibrium, and is it one-to-one?** Check the released shape: every
# $J$, the cover counts of section 1, and the smallest eigenvalue of the *exact* (unprojected) Hessian on
# the free nodes:

# %%
for name in ("Taylor neo-Hookean", "stable neo-Hookean"):
    released = runs[name]["released"]
    x = runs[name]["frames"][-1]
    model = Model(mesh, models[name].material, handles=[Handle("bottom")])
    free = np.setdiff1d(np.arange(model.n_dofs), model.prescribed()[0])
    K = model.hessian(released.u).toarray()[np.ix_(free, free)]
    J = element_jacobians(mesh, x)
    top = np.abs(mesh.p[1] - 1.0) < 1e-9
    print(f"{name}: J from {J.min():.3f} to {J.max():.3f};  centroids covered twice: "
          f"{int((cover_counts(mesh, x) > 1).sum())} of {mesh.t.shape[1]};  "
          f"top edge at y from {x[1, top].min():.2f} to {x[1, top].max():.2f};  "
          f"smallest exact Hessian eigenvalue {np.linalg.eigvalsh(K)[0]:.3g}; energy {released.final_energy:.4g}")

# %% [markdown]
# Every triangle of the Taylor result is upright, yet many points of space are covered twice and the top
# edge sits *below* the bottom edge it started above: the block has turned over through its held edge,
# folding onto itself. The release converged (residual below its tolerance) and the exact Hessian is
# positive definite there, so this is a
# genuine **local minimum** of the Taylor energy, not a place where Newton gave up. No element test can
# see it ($J > 0$ everywhere); only the global map is wrong. Robustness to inversion (no NaN, no crash)
# and *recovering the right shape* are different promises. The same release with the stable model finds
# the rest shape; nothing guarantees it in general (section 7 shows a case where it too lands elsewhere).
#
# **Why does the ITF crush stop at flat?** Look inside the failed step: the Newton history, and the
# crushed elements' flip value $(\psi_0 + \psi_1)/(s_0 + s_1)$ at its last iterate:

# %%
itf = models["ITF-clamped neo-Hookean"]
failed = runs["ITF-clamped neo-Hookean"]["crush"][-1].steps[-1]
steps = [h.step_norm for h in failed.history]
print(f"status {failed.status!r} after {failed.iterations} iterations (the cap); last energies "
      f"{np.round(failed.energies[-4:], 3)}")
print(f"last step sizes {np.round(steps[-4:], 4)}, each {steps[-1] / steps[-2]:.2f} times the one before")
U, s, V = rotation_preserving_svd(P1Assembler(mesh).deformation_gradient(failed.x))
psi = itf.diagonal_gradient(s)
crushed = s[1] < itf.threshold
flip = (psi[0] + psi[1]) / (s[0] + s[1])
print(f"elements below the threshold: {int(crushed.sum())} (inverted: {int((s[1] < 0).sum())}); "
      f"smallest s0 + s1 there: {(s[0] + s[1])[crushed].min():.2f}; flip values from "
      f"{flip[crushed].min():.0f} to {flip[crushed].max():.0f}")
exact = Model(mesh, ITFClamped(itf.base, itf.threshold, project=False), handles=[Handle("bottom"), Handle("top")])
free = np.setdiff1d(np.arange(exact.n_dofs), exact.prescribed()[0])
w_exact = np.linalg.eigvalsh(exact.hessian(failed.x).toarray()[np.ix_(free, free)])
w_proj = np.linalg.eigvalsh(P1Assembler(mesh, itf).tangent(failed.x).toarray()[np.ix_(free, free)])
print(f"exact Hessian: {int((w_exact < 0).sum())} negative eigenvalues (smallest {w_exact[0]:.0f}); "
      f"projected tangent: smallest eigenvalue {w_proj[0]:.0f}")

# %% [markdown]
# The energy falls by a tiny fraction of itself per iteration while the step *grows* by a constant
# factor: Newton is creeping. The crushed elements' flip values are strongly negative (their compressive push
# $\psi_1$ dominates), so the exact Hessian of the flat-and-beyond state is indefinite: the flat block is
# unstable and wants to buckle away. The projected tangent replaces those negative curvatures by zero at
# element level, so along exactly the directions the body wants to move, Newton steps as if the energy were
# curving up, takes steps that are far too short, and converges only linearly. The $s_0 + s_1$ values are
# far from zero, so this is not the kink of section 4. Projection buys a descent direction, not
# Newton's quadratic convergence.
#
# ## 7. Hard cases: release from violent states
#
# Now release the block from each start state of section 1 (bottom edge held), with each model
# (`tissuefem.workbook.hardcases.release`; absolute tolerance $10^{-7}$, steps capped at 0.5, at most 400
# iterations):

# %%
def release_table(models, states):
    print(f"{'start state':22s} {'model':25s} {'status':11s} {'iter':>5s} {'cuts':>5s} {'rest error':>11s}")
    results = {}
    for state, x_start in states.items():
        for name, material in models.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", MatrixRankWarning)   # NaN tangents of the ln J model
                r = release(mesh, material, x_start)
            results[state, name] = r
            print(f"{state:22s} {name:25s} {r.status:11s} {r.iterations:5d} {r.cuts:5d} {r.rest_error:11.2g}")
    return results


start = time.perf_counter()
hard = release_table(models, states)
print(f"({time.perf_counter() - start:.1f} s)")

# %% [markdown]
# The $\ln J$ model fails at once from every start with an element at $J \le 0$ (its energy is NaN there)
# and only survives the 10× stretch. The other three recover from everything, including the collapse to a
# point. That last one deserves a second look after section 4: for the Taylor and stable models $\mathbf F = 0$
# is a stationary point, so why do they move? Because the held bottom nodes are *not* collapsed: the
# elements along the bottom edge have $\mathbf F \ne 0$, feel a force, and pull the rest along. A block with
# every node on one point would be in equilibrium under those two models (zero stress in every element).
#
# **Nearly incompressible tissue** ($\nu = 0.499$) makes the volumetric term a thousand times stiffer than the
# shear term. Release from the point collapse again:

# %%
stiff = inversion_models(E, 0.499)
hard_stiff = release_table(stiff, {"collapsed to a point": states["collapsed to a point"]})

# %% [markdown]
# At $\nu = 0.499$ the stable model, too, settles in another local minimum: no status flags it, only the
# rest error does. This is a known weakness of releasing a body from far away with a quasistatic solver:
# the energy of a hyperelastic body has many wells once the map can fold, and a descent method finds one of
# them, not necessarily the one you wanted.
#
# ## What to try
# - Change the ITF threshold, `ITFClamped(NeoHookean(lam, mu), threshold=0.1)` or `0.6`. How deep does the
#   crush get? How far is the model from $\ln J$ in a strong (but uninverted) compression?
# - Give the crush more Newton iterations (`crush_and_release(material, max_iterations=400)`). Does the ITF model
#   get past flat? How many iterations does each step take?
# - Release the Taylor block from depth 1.0 instead of 1.3 (`crush_and_release(material, depth=1.0, steps=10)`).
#   Does it still fold?
# - Solve the crush with the *unprojected* Taylor tangent, `TaylorNeoHookean(lam, mu)` (no wrapper).
#   Count line-search cuts and shifted tangents (`result.steps[-1].history[k].shift`).
# - Drag a handle through a clamped sheet: `tissuefem.workbook.hardcases.drag_through(material)`. Draw the
#   positions with `draw_state` for each model.
# - Predict, then check: what are $\mu + h'(0)$ and $\mu - h'(0)$ for the stable model in terms of
#   $\lambda$ and $\mu$? Compare with the eigenvalues printed in section 4.
#
# ## Exercises (graded by pytest)
# In `exercises/ch06.py`:
# - **6.1** `rotation_preserving_svd(F)` — for one $2\times 2$ matrix: $\mathbf U$, $\mathbf s$, $\mathbf V$ with
#   rotations $\mathbf U$, $\mathbf V$, $s_0 \ge |s_1|$ and $s_1 < 0$ exactly when $J < 0$;
# - **6.2** `taylor_log(J)` — the notes' cubic $r(J)$ and its derivative $r'(J)$;
# - **6.3** `taylor_neo_hookean_stress(F, lam, mu)` — $\mathbf P$ of the Taylor model, with the cofactor.
#
# Grade: `python -m tissuefem grade ch06`.
