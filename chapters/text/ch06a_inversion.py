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
# # Chapter 6a — Inversion: elements turned inside out, and energies defined through it
#
# **Goals.** By the end of this chapter you can
# 1. say what inversion means for one element ($J \le 0$) and for the whole deformation
#    ($\phi$ no longer one-to-one), carrying the 1D picture of chapter 2 to 2D;
# 2. explain why the $\ln J$ Neo-Hookean model breaks on an inverted element, and write the notes'
#    cubic-Taylor repair with the correct cofactor;
# 3. compute the *rotation-preserving* SVD and read inversion off the sign of the smallest singular value;
# 4. extend an energy below a compression threshold (the ITF construction) and say why $\mathbf F = 0$ is a
#    resting point for some models and not for others.
#
# *Time: about 45 min to read and run, and three exercises.* Chapter 6 comes in two sittings: this one
# builds the models, chapter 6b solves with them (a descent direction near inversion, the notes' Figure 6
# as an experiment, and the hard cases).
#
# *Reading:* the notes' "Inversion" section (Figures 5 and 7). Behind it: Irving, Teran and Fedkiw,
# *Invertible finite elements* (SCA 2004); Teran, Sifakis, Irving and Fedkiw, *Robust quasistatic finite
# elements* (SCA 2005); Smith, de Goes and Kim, *Stable Neo-Hookean flesh simulation* (2018).
#
# **Index convention.** As everywhere in this workbook (chapter 3), $F_{ij} = \partial\phi_i/\partial X_j$,
# formulas count from 1 and code from 0: $J = F_{11}F_{22} - F_{12}F_{21}$ is `F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]`,
# and the singular values $s_1 \ge |s_2|$ are `s[0]` and `s[1]`.

# %%
# %matplotlib inline
import warnings

import numpy as np
import matplotlib.pyplot as plt
from scipy.sparse.linalg import MatrixRankWarning

from tissuefem.workbook.figures.inversion import draw_state, fig_ch06_itf_energy
from tissuefem.workbook.hardcases import block, cover_counts, element_jacobians, inversion_models, release, start_states
from tissuefem import Handle, Model, NeoHookean, TaylorNeoHookean, rotation_preserving_svd
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
# somewhere. We will meet exactly that in chapter 6b. (A mirror image, $\mathbf F = \mathrm{diag}(1, -1)$, is
# one-to-one but has $J = -1$; no continuous motion reaches it without passing $J = 0$, which is why an
# admissible deformation needs $J > 0$, not only a bijection: erratum 11.)
#
# **The 1D picture, carried to 2D.** Apply the notes' inverting map of Figure 5 along $X_1$ and leave $X_2$
# alone: $\phi(\mathbf X) = (\sin 2\pi X_1,\ X_2)$, so $\mathbf F = \mathrm{diag}(2\pi\cos 2\pi X_1,\ 1)$ and
# $J = 2\pi\cos 2\pi X_1$, negative on the middle half of the block. To test the *global* property we
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
axes[1].set_title("deformed: $\\phi(\\mathbf{X}) = (\\sin 2\\pi X_1, X_2)$")
for ax in axes:
    ax.set(aspect="equal", xlim=(-1.1, 1.1), ylim=(-0.1, 1.1))

# %% [markdown]
# The middle half of the block (red on the left) is turned inside out and laid over the outer quarters:
# every point of the deformed strip is reached twice, once by an upright triangle and once by an inverted
# one. That is the 2D version of the crossing lines in the bottom row of Figure 5.
#
# A simulator does not get to choose. A surgeon's tool pushes tissue flat, a collision solver leaves a
# few elements turned over, a large time step overshoots. Here are five such states of our block, used
# in chapter 6b as *start states* (`tissuefem.workbook.hardcases.start_states`), drawn as the release there sees
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
# reads
#
# $$ \operatorname{cof}\mathbf F = \begin{bmatrix} F_{22} & -F_{21} \\ -F_{12} & F_{11} \end{bmatrix}, \qquad
#    \mathbf P = \mu\mathbf F + \big(\lambda\, r(J) - \mu\big)\, r'(J)\, \operatorname{cof}\mathbf F . $$
#
# > **Erratum (README, item 8).** The notes print the matrix $\begin{bmatrix} F_{22} & -F_{12} \\ -F_{21} & F_{11}\end{bmatrix}$:
# > that is the *adjugate* $J\mathbf F^{-1}$, the transpose of the cofactor. The two agree only when $F_{12} = F_{21}$, so
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
# $$ \mathbf F = \mathbf U \begin{bmatrix} s_1 & 0 \\ 0 & s_2\end{bmatrix}\mathbf V^T,\qquad
#    \det\mathbf U = \det\mathbf V = 1,\qquad s_1 \ge |s_2|,\qquad J = s_1 s_2 . $$
#
# Now $s_2 < 0$ exactly when the element is inverted, and an isotropic energy becomes a function
# $\hat\Psi(s_1, s_2)$ on a half-plane that contains the inverted states as ordinary points: we are free
# to *define* the energy there. In 2D there is a closed form with no branches. Split $\mathbf F$ into a
# similarity part (a rotation times a scaling) and an anti-similarity part (a reflection times a scaling):
#
# $$ \mathbf F = \begin{bmatrix} E + A & G - H \\ G + H & E - A\end{bmatrix}, \quad
#    E = \tfrac{F_{11} + F_{22}}{2},\ H = \tfrac{F_{21} - F_{12}}{2},\ A = \tfrac{F_{11} - F_{22}}{2},\
#    G = \tfrac{F_{21} + F_{12}}{2}. $$
#
# With $Q = \sqrt{E^2 + H^2}$ and $R = \sqrt{A^2 + G^2}$ the singular values are $s_1 = Q + R$ and
# $s_2 = Q - R$ (so $J = Q^2 - R^2$: an element is inverted when its reflecting part outweighs its
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
# | region | energy $\hat\Psi(s_1, s_2)$ |
# |---|---|
# | $s_2 \ge c$ (the usual case) | the $\ln J$ model itself |
# | $s_2 < c \le s_1$ (one direction crushed, flat or inverted) | $\hat\Psi(s_1, c) + \psi_2(s_1, c)\,d_2 + \frac k2 d_2^2$, $\ d_2 = s_2 - c$ |
# | $s_1 < c$ (both crushed, down to $\mathbf F = 0$) | the expansion about $(c, c)$: $\hat\Psi + \psi_1 d_1 + \psi_2 d_2 + \hat\Psi_{12} d_1 d_2 + \frac k2(d_1^2 + d_2^2)$, all taken at $(c, c)$, $d_1 = s_1 - c$ |
#
# with $\psi_i = \partial\hat\Psi/\partial s_i$ and a spring $k$ (by default $\partial^2\hat\Psi/\partial s_2^2$ at
# $(c, c)$). Each piece continues the previous one in one more variable, so the energy and its gradient are
# continuous: the stress $\mathbf P = \mathbf U\,\mathrm{diag}(\psi_1, \psi_2)\,\mathbf V^T$ is the exact
# gradient of the energy, and Newton's energy line search stays valid. (ITF's paper clamps the
# diagonal stress itself; extrapolating the energy gives the same finite push-back and keeps the two
# consistent.) An element crushed to a point, or turned inside out, now feels a *finite* force that grows
# only linearly with the depth of inversion.
#
# Why only the $\ln J$ model? With one direction below $c$ and the other stretched far ($s_1$ large),
# the extension adds $\psi_2(s_1, c)\, d_2$, and the spring keeps the energy bounded below only if $\psi_2$
# grows slowly with $s_1$. For $\ln J$ it grows like $\ln s_1$; with the polynomial volumetric terms of the
# Taylor and stable models it grows like a power of $s_1$ and the extended energy would have no minimum.
# Those models need no clamping anyway. `ITFClamped` refuses them with a `ValueError` that says so.
#
# Along $s_2$ with $s_1 = 1$, and along a uniform shrink $\mathbf F = t\mathbf I$ to a point:

# %%
fig_ch06_itf_energy()

# %% [markdown]
# Read the left two panels from the right: near rest the four curves agree. The $\ln J$ energy (blue)
# shoots up and ends at $s_2 = 0$. The ITF-clamped energy (red) *is* the $\ln J$ energy down to $s_2 = c$,
# then leaves it along a straight slope plus the spring and continues through $s_2 = 0$ into inversion. The
# Taylor (green) and stable (orange) energies are smooth through $s_2 = 0$, but they part from $\ln J$ long
# before: a compression that never inverts anything is already softer with them. In numbers, the push
# back $\partial\hat\Psi/\partial s_2$ at a few points of the middle panel:

# %%
s2_values = np.array([0.7, 0.5, 0.3, 0.0, -0.5])
F_line = np.zeros((2, 2, s2_values.size))
F_line[0, 0], F_line[1, 1] = 1.0, s2_values             # F = diag(1, s2): s1 = 1 stays, s2 is squeezed
print(f"{'s2':>25s}" + "".join(f"{v:9.1f}" for v in s2_values))
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
# lies in the third region, where $\mathbf P = \psi\,\mathbf I$ with $\psi = \psi_1(c, c) - c\,(\hat\Psi_{12} + k) < 0$
# there: a push outward.
#
# (Strictly, $\mathbf F = 0$ is a kink of the ITF energy. Near it the energy falls off linearly in
# $s_1 + s_2 = 2\sqrt{E^2 + H^2}$, twice the size of the similarity part of $\mathbf F$: a cone with its tip up,
# steepest outward in every similarity direction. The stress printed below is the one the SVD's choice of
# rotations at $\mathbf F = 0$ picks. The extension has such a kink wherever $s_1 + s_2 = 0$ and
# $\psi_1 + \psi_2 \ne 0$; there the flip value $(\psi_1 + \psi_2)/(s_1 + s_2)$ of chapter 6b is unbounded.)

# %%
Z = np.zeros((2, 2, 1))                           # F = 0, as a field of one matrix
for name in ("Taylor neo-Hookean", "stable neo-Hookean", "ITF-clamped neo-Hookean"):
    P0 = models[name].stress(Z)[:, :, 0]
    print(f"{name:25s} P(0) = {P0.round(2).tolist()}")
for name in ("Taylor neo-Hookean", "stable neo-Hookean"):
    exact = models[name].material                  # the model without the projection of chapter 6b
    eig = np.linalg.eigvalsh(exact.tangent(np.zeros((2, 2))).reshape(4, 4))
    print(f"{name:25s} eigenvalues of the exact tangent at F = 0: {eig.round(1)}")

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Change the ITF threshold $c$: how far is the clamped model from $\ln J$ in a strong but uninverted
#   compression, $\mathbf F = \mathrm{diag}(1, s_2)$?
#
# ```python
# import numpy as np
# from tissuefem import ITFClamped, NeoHookean
#
# base = NeoHookean.from_young(1000.0, 0.3)
# s2 = np.array([0.8, 0.5, 0.3, 0.2, 0.1])
# F = np.zeros((2, 2, s2.size))
# F[0, 0], F[1, 1] = 1.0, s2
# print("s2          ", s2)
# print("ln J model  ", base.stress(F)[1, 1].round(0))
# for c in (0.1, 0.3, 0.6):
#     print(f"ITF, c = {c}", ITFClamped(base, threshold=c).stress(F)[1, 1].round(0))
# ```
#
# - Predict, then check: what are $\mu + h'(0)$ and $\mu - h'(0)$ for the stable model, in terms of $\lambda$
#   and $\mu$? Compare with the eigenvalues of its exact tangent at $\mathbf F = 0$ (section 4).
#
# ```python
# import numpy as np
# from tissuefem import StableNeoHookean
#
# stable = StableNeoHookean.from_young(1000.0, 0.3)
# lam, mu = stable.lam, stable.mu
# print("eigenvalues of the tangent at F = 0:", np.linalg.eigvalsh(stable.tangent(np.zeros((2, 2))).reshape(4, 4)).round(2))
# print(f"lam = {lam:.2f}, mu = {mu:.2f}: your prediction here")
# ```
#
# - Build an inverted $\mathbf F$ of your own (a rotation, a reflection, another rotation) and check the
#   rotation-preserving SVD: rotations $\mathbf U$, $\mathbf V$, $s_2 < 0$, and $\mathbf U\,\mathrm{diag}(\mathbf s)\,\mathbf V^T = \mathbf F$.
#
# ```python
# import numpy as np
# from tissuefem import rotation_preserving_svd
#
# def rotation(angle):
#     c, s = np.cos(angle), np.sin(angle)
#     return np.array([[c, -s], [s, c]])
#
# F = rotation(1.0) @ np.diag([0.7, -1.4]) @ rotation(0.3).T
# U, s, V = rotation_preserving_svd(F)
# print("s =", s.round(6), " det U =", round(np.linalg.det(U), 12), " det V =", round(np.linalg.det(V), 12))
# print("largest |U diag(s) V^T - F| =", np.abs(U @ np.diag(s) @ V.T - F).max())
# ```
#
# ## Exercises (graded by pytest)
# In `exercises/ch06.py`:
# - **6.1** `rotation_preserving_svd(F)` — for one $2\times 2$ matrix: $\mathbf U$, $\mathbf s$, $\mathbf V$ with
#   rotations $\mathbf U$, $\mathbf V$, $s_1 \ge |s_2|$ and $s_2 < 0$ exactly when $J < 0$ (in code `s[0]` and `s[1]`);
# - **6.2** `taylor_log(J)` — the notes' cubic $r(J)$ and its derivative $r'(J)$;
# - **6.3** `taylor_neo_hookean_stress(F, lam, mu)` — $\mathbf P$ of the Taylor model, with the cofactor.
#
# Grade: `python -m tissuefem grade ch06`.
