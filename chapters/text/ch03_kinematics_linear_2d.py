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
# # Chapter 3 — Kinematics and 2D linear elasticity
#
# **Goals.** By the end of this chapter you can
# 1. describe a deformation by the maps $\phi$ and $\mathbf u$ and the deformation gradient
#    $\mathbf F$, with the index convention we use throughout, $F_{ij} = \partial\phi_i/\partial X_j$
#    (and say why the notes' printed transpose does not fit their own weak form);
# 2. compute $\mathbf F$ on every triangle of a mesh from nodal displacements;
# 3. get the Lamé parameters from Young's modulus and Poisson's ratio, in plane strain and plane stress;
# 4. write the linear-elastic energy and stress, and check one against the other;
# 5. show numerically why linear elasticity only holds for small deformations: a rigid rotation
#    costs it energy and stress, and a block turned at one edge grows.
#
# *Time: about 40 min to read and run, and three exercises.*
#
# *Reading:* the notes' "Kinematics" and the first half of "Elasticity and constitutive modeling".

# %%
# %matplotlib inline
import numpy as np
from IPython.display import Markdown, display

from tissuefem import Handle, LinearElastic, Model, NeoHookean, P1Assembler, lame_parameters, rectangle, solve
from tissuefem.engine.materials import det2
from tissuefem.workbook.figures.kinematics import fig02_kinematics, fig_ch03_rotation_stress
from tissuefem.workbook.studies import (bending_gradient, bending_map, displacement_from_map,
                               handle_force, rigid_rotation_response, rotated_block, rotation)

# %% [markdown]
# ## 1. Kinematics: $\phi$, $\mathbf u$ and $\mathbf F$
#
# A body occupies the reference (material) configuration $B_0 = \{\mathbf X\}$; at time $t$ it
# occupies the deformed (current) configuration $B_t = \{\mathbf x\}$. The deformation is the map
#
# $$ \phi(\cdot, t): B_0 \to B_t, \qquad \mathbf x = \phi(\mathbf X, t), $$
#
# the displacement is $\mathbf u(\mathbf X, t) = \phi(\mathbf X, t) - \mathbf X$, and the
# deformation gradient is the derivative of $\phi$ with respect to the material point,
#
# $$ F_{ij} = \frac{\partial \phi_i}{\partial X_j}, \qquad \mathbf F = \mathbf I + \frac{\partial \mathbf u}{\partial \mathbf X} . $$
#
# Row $i$ is a spatial component, column $j$ a material direction: column $j$ of $\mathbf F$ is
# the image of the unit material vector $\mathbf e_j$, and a short material segment $d\mathbf X$
# is carried to $d\mathbf x = \mathbf F\, d\mathbf X$. Its determinant $J = \det\mathbf F$ is the
# ratio of deformed to reference area.
#
# > **Index convention (erratum 4 in the README).** The notes define $F_{ij} = \partial\phi_j/\partial X_i$,
# > the transpose of ours, but write the balance law as $-P_{ij,j} = f_i$ and the weak form with
# > $w_{i,j} P_{ij}$. Those only fit $F_{ij} = \partial\phi_i/\partial X_j$: the stress
# > $P_{ij} = \partial\Psi/\partial F_{ij}$ has the index layout of $\mathbf F$, and the work
# > of $\mathbf P$ on a virtual displacement $\mathbf w$ is $P_{ij}\,\delta F_{ij}$. With our
# > convention $\delta F_{ij} = \partial w_i/\partial X_j = w_{i,j}$, which is the notes' weak form;
# > with theirs $\delta F_{ij} = w_{j,i}$ and the weak form would have to read $w_{j,i}P_{ij}$.
# > So we use $F_{ij} = \partial\phi_i/\partial X_j$ everywhere — also scikit-fem's
# > convention (`grad(u)[i, j]` is $\partial u_i/\partial X_j$) and Bonet & Wood's.
#
# **Counting indices (the one convention of this workbook).** In formulas, indices count from 1, as in
# the notes: the entries of $\mathbf F$ are $F_{11}, F_{12}, F_{21}, F_{22}$, the coordinates $X_1, X_2$,
# the singular values (chapter 6) $s_1, s_2$, the vertices of a triangle 1, 2, 3. In code, arrays count
# from 0, so $F_{12}$ is `F[0, 1]` and $X_2$ is `X[1]`. Node and dof numbers printed by code (node $a$
# owns the dofs $2a$ and $2a+1$) are the code's own numbers, starting at 0. Every chapter keeps to this.
#
# The notes' Figure 2, redrawn: a block bent into an arch by a map $\phi$ that we know in closed
# form (`tissuefem.workbook.studies.bending_map`), one material point, and $\mathbf F$ acting on two
# short material vectors. The notes' figure has a second half, redrawn in the right panel: the
# stress. Cut the material at $\mathbf X$ along a short line with unit normal $\mathbf N$ (in the
# reference configuration). The material on one side pulls on the other, and the first Piola–Kirchhoff
# stress $\mathbf P$ turns the normal into that force: $\mathbf P\mathbf N\,dA$ is the force across a
# piece of the cut whose *reference* area (a length, in 2D) is $dA$. The same force, counted per unit
# of *deformed* area $da$ and against the deformed normal $\mathbf n$, defines the **Cauchy stress**
# $\boldsymbol\sigma$: $\boldsymbol\sigma\mathbf n\,da = \mathbf P\mathbf N\,dA$. With Nanson's formula
# $\mathbf n\,da = J\mathbf F^{-T}\mathbf N\,dA$ this gives
#
# $$ \boldsymbol\sigma = \frac{1}{J}\,\mathbf P\,\mathbf F^{T}, \qquad J = \det\mathbf F . $$
#
# $\mathbf P$ is the stress to compute with (it is $\partial\Psi/\partial\mathbf F$, on the fixed
# reference body); $\boldsymbol\sigma$ is the one to look at (a true force per true area, symmetric), so
# the figures of the later chapters colour elements by it: by its largest eigenvalue, the largest
# principal stress, positive where the tissue is pulled.

# %%
fig02_kinematics()

# %% [markdown]
# ## 2. $\mathbf F$ on a mesh
#
# On linear (P1) triangles the displacement is linear inside each triangle, so $\mathbf F$ is one
# constant matrix per triangle. The affine map of a triangle sends each edge vector to its image:
# with the edge matrices $D_m = [\mathbf X_2 - \mathbf X_1,\ \mathbf X_3 - \mathbf X_1]$ (reference)
# and $D_s = [\mathbf x_2 - \mathbf x_1,\ \mathbf x_3 - \mathbf x_1]$ (deformed) of a triangle with
# vertices 1, 2, 3,
#
# $$ \mathbf F\, D_m = D_s \quad\Longrightarrow\quad \mathbf F = D_s D_m^{-1} . $$
#
# The library does this for every triangle at once. The displacement vector is scikit-fem's:
# node $n$ carries the dofs $2n$ ($u_1$) and $2n+1$ ($u_2$).

# %%
mesh = rectangle(2.0, 1.0, 16, 8)
u = displacement_from_map(mesh, bending_map)             # nodal u = phi(X) - X
F = P1Assembler(mesh).deformation_gradient(u)            # one F per triangle, shape [2, 2, n_triangles]
print("F shape:", F.shape, "  J = det F ranges over", det2(F).min().round(3), "...", det2(F).max().round(3))

# %% [markdown]
# Is it right? The P1 interpolant of a curved map is not the map, so $\mathbf F_e$ should differ
# from the exact $\partial\phi/\partial\mathbf X$ at the triangle's centroid by $O(h)$, and an
# *affine* map $\phi(\mathbf X) = \mathbf A\mathbf X + \mathbf c$ should come out exactly — the
# first check of any FEM code (a "patch test").

# %%
for n in (4, 8, 16, 32, 64):
    mesh = rectangle(2.0, 1.0, 2 * n, n)
    F = P1Assembler(mesh).deformation_gradient(displacement_from_map(mesh, bending_map))
    centroids = mesh.p[:, mesh.t].mean(axis=1)
    err = np.abs(F - bending_gradient(centroids)).max()
    print(f"h = {1 / n:.4f}: largest |F_e - dphi/dX(centroid)| = {err:.2e}")

A, c = np.array([[1.2, 0.4], [-0.1, 0.8]]), np.array([[0.3], [-0.2]])
F = P1Assembler(mesh).deformation_gradient(displacement_from_map(mesh, lambda X: A @ X + c))
print("affine map: largest |F_e - A| =", np.abs(F - A[:, :, None]).max())

# %% [markdown]
# The error halves with $h$: first order, as expected for the gradient of a linear interpolant.
#
# ## 3. Lamé parameters from $E$ and $\nu$
#
# Materials are usually specified by Young's modulus $E$ (the notes write $K$) and Poisson's
# ratio $\nu$. The notes' conversion,
#
# $$ \lambda = \frac{E\nu}{(1+\nu)(1-2\nu)}, \qquad \mu = \frac{E}{2(1+\nu)}, $$
#
# holds in 3D, and in 2D for **plane strain** ($\epsilon_{33} = 0$: a thick body, e.g. a slice
# through a long muscle). For **plane stress** ($\sigma_{33} = 0$: a thin sheet, e.g. a skin flap)
# eliminate $\epsilon_{33}$ from $\sigma_{33} = \lambda(\operatorname{tr}\boldsymbol\epsilon_{2D} + \epsilon_{33}) + 2\mu\epsilon_{33} = 0$:
# $\epsilon_{33} = -\lambda\operatorname{tr}\boldsymbol\epsilon_{2D}/(\lambda + 2\mu)$, and the in-plane
# stress becomes $2\mu\boldsymbol\epsilon + \lambda^*\operatorname{tr}(\boldsymbol\epsilon)\mathbf I$ with
#
# $$ \lambda^* = \frac{2\lambda\mu}{\lambda + 2\mu}, \qquad \mu \text{ unchanged.} $$
#
# As $\nu \to \frac12$ (incompressible) $\lambda \to \infty$ in plane strain, while a thin sheet can
# always thin out, so $\lambda^* \to 2\mu$ stays finite. The admissible range is $-1 < \nu < \frac12$
# (the notes say $0 < \nu < \frac12$; auxetic materials have $\nu < 0$).
#
# **Which one the library uses, and why.** Every tissue model of the later chapters is **plane
# strain**: `NeoHookean.from_young(E, nu)` and its relatives use $\lambda$, and they refuse
# `plane="stress"`. The reason is not anatomy: a skin flap is thin, and for it plane stress is the
# better assumption. It is that the notes' energies are written for a $2\times 2$ $\mathbf F$, and taking
# them as they are *is* plane strain: the body keeps its thickness ($F_{33} = 1$). Plane stress for a
# nonlinear material is not a change of $\lambda$; it needs the thickness stretch $F_{33}$ at every
# quadrature point, found from $\sigma_{33} = 0$ by a small nonlinear solve of its own, which these notes
# (and this workbook) leave out. Only the linear model, where the condensation above is exact, offers
# both (`LinearElastic.from_young(E, nu, plane="stress")`).
#
# What changes between the two: plane stress is softer, since the sheet can thin where it is pulled
# ($\lambda^* < \lambda$, so a pulled sheet needs less force for the same stretch; section 6 lets you
# measure how much), and it cannot lock as $\nu \to \frac12$. So read the simulated "skin" of later
# chapters as a slice of a thick body: somewhat stiffer than a thin flap of the same material, and, with
# $\nu$ near $\frac12$, prone to the locking that chapter 4's "What to try" shows.

# %%
print(f"{'nu':>6} {'lam (strain)':>13} {'mu':>8} {'lam* (stress)':>14}")
for nu in (-0.5, 0.0, 0.3, 0.45, 0.49, 0.499):
    lam, mu = lame_parameters(1000.0, nu)
    lam_s, _ = lame_parameters(1000.0, nu, plane="stress")
    print(f"{nu:6.3f} {lam:13.1f} {mu:8.1f} {lam_s:14.1f}")

# %% [markdown]
# ## 4. The linear model: energy and stress
#
# The small-strain tensor and the energy density are
#
# $$ \epsilon_{ij} = \tfrac12 (F_{ij} + F_{ji}) - \delta_{ij} = \tfrac12 (u_{i,j} + u_{j,i}), \qquad
#    \Psi(\mathbf F) = \mu\, \epsilon_{ij}\epsilon_{ij} + \frac{\lambda}{2}\epsilon_{kk}^2 . $$
#
# Since $\partial\epsilon_{kl}/\partial F_{ij} = \frac12(\delta_{ki}\delta_{lj} + \delta_{kj}\delta_{li})$
# and $\boldsymbol\epsilon$ is symmetric,
#
# $$ P_{ij} = \frac{\partial\Psi}{\partial F_{ij}} = 2\mu\,\epsilon_{ij} + \lambda\,\epsilon_{kk}\,\delta_{ij},
#    \qquad \mathbf P = 2\mu\boldsymbol\epsilon + \lambda \operatorname{tr}(\boldsymbol\epsilon)\mathbf I . $$
#
# (Both formulas read the same in either index convention, because $\boldsymbol\epsilon$ is
# symmetric.) As always, we check the stress against a finite difference of the energy:

# %%
linear = LinearElastic.from_young(1000.0, 0.3)
rng = np.random.default_rng(3)
F = np.eye(2) + 0.2 * rng.standard_normal((2, 2))
h = 1e-6
P_fd = np.zeros((2, 2))
for i in range(2):
    for j in range(2):
        dF = np.zeros((2, 2))
        dF[i, j] = h
        P_fd[i, j] = (linear.energy(F + dF) - linear.energy(F - dF)) / (2 * h)
print("P         =", linear.stress(F).round(6).tolist())
print("dPsi/dF FD =", P_fd.round(6).tolist())

# %% [markdown]
# ### Two slips in the notes, checked
#
# *Erratum 5.* The notes say $\boldsymbol\epsilon$ vanishes when $\mathbf F$ is skew-symmetric. It
# vanishes when the **displacement gradient** $\mathbf F - \mathbf I$ is skew (an infinitesimal
# rotation); a skew $\mathbf F$ (e.g. a quarter turn) gives $\boldsymbol\epsilon = -\mathbf I$.
#
# *Erratum 6.* "If the displacement is spatially constant, then $\partial\mathbf u/\partial\mathbf X = -\mathbf I$":
# a constant displacement (a translation) has $\partial\mathbf u/\partial\mathbf X = \mathbf 0$, so
# $\mathbf F = \mathbf I$ and $\boldsymbol\epsilon = \mathbf P = \mathbf 0$. The gradient $-\mathbf I$
# belongs to a constant **deformation** $\phi \equiv \mathbf c$, which collapses the body to a
# point: $\mathbf F = \mathbf 0$, $\boldsymbol\epsilon = -\mathbf I$, and a large stress.

# %%
strain = lambda F: 0.5 * (F + F.T) - np.eye(2)
W = np.array([[0.0, -0.1], [0.1, 0.0]])                     # a skew matrix
print("F skew (a quarter turn):  eps =", strain(W / 0.1).tolist())
print("F - I skew:               eps =", strain(np.eye(2) + W).tolist())

mesh = rectangle(2.0, 1.0, 4, 2)
fast = P1Assembler(mesh, linear)
translation = displacement_from_map(mesh, lambda X: X + np.array([[0.7], [-0.3]]))
collapse = displacement_from_map(mesh, lambda X: 0 * X + np.array([[0.7], [-0.3]]))
for name, u in (("constant displacement u = c", translation), ("constant deformation phi = c", collapse)):
    F = fast.deformation_gradient(u)[:, :, 0]
    print(f"{name:29s}: F = {F.round(12).tolist()},  P = {linear.stress(F).round(6).tolist()}")

# %% [markdown]
# ## 5. Rigid motions: where linear elasticity fails
#
# A rigid motion $\phi(\mathbf X) = \mathbf R\mathbf X + \mathbf c$ with a rotation
# $\mathbf R_\theta = \begin{bmatrix}\cos\theta & -\sin\theta\\ \sin\theta & \cos\theta\end{bmatrix}$ has
# $\mathbf F = \mathbf R_\theta$, $\mathbf F^T\mathbf F = \mathbf I$: no change of shape, so a good
# model must give no energy and no stress. Linear elasticity gives
#
# $$ \boldsymbol\epsilon = (\cos\theta - 1)\,\mathbf I, \quad
#    \Psi = 2(\lambda + \mu)(1 - \cos\theta)^2, \quad \mathbf P = 2(\lambda + \mu)(\cos\theta - 1)\,\mathbf I . $$
#
# For small angles $\boldsymbol\epsilon \approx -\frac{\theta^2}{2}\mathbf I$ is of second order —
# which is why the model is fine for small deformations and only then. The Neo-Hookean energy
# (chapter 4), $\Psi = \frac\mu2(\mathbf F:\mathbf F - 2) - \mu\ln J + \frac\lambda2 (\ln J)^2$, gives
# $\mathbf R:\mathbf R = 2$ and $J = 1$, hence $\Psi = 0$ and
# $\mathbf P = \mu\mathbf R - \mu\mathbf R^{-T} = \mathbf 0$ for every angle.

# %%
neo = NeoHookean.from_young(1000.0, 0.3)
angles = np.radians([1.0, 10.0, 45.0, 90.0, 180.0])
lin, nh = rigid_rotation_response(linear, angles), rigid_rotation_response(neo, angles)
closed = 2 * (linear.lam + linear.mu) * (1 - np.cos(angles)) ** 2
print(f"{'theta':>6} {'Psi linear':>11} {'closed form':>11} {'|P| linear':>11} {'Psi neo':>9} {'|P| neo':>9}")
for k, th in enumerate(np.degrees(angles)):
    print(f"{th:6.0f} {lin['energy'][k]:11.4g} {closed[k]:11.4g} {lin['stress_norm'][k]:11.4g} "
          f"{nh['energy'][k]:9.1e} {nh['stress_norm'][k]:9.1e}")

# %% [markdown]
# > **Erratum 3.** The notes print the Neo-Hookean energy with $F_{ij}F_{ji} = \operatorname{tr}(\mathbf F\mathbf F)$
# > instead of $F_{ij}F_{ij} = \mathbf F:\mathbf F$. For a rotation
# > $\operatorname{tr}(\mathbf R_\theta\mathbf R_\theta) = 2\cos 2\theta$, so the printed energy would be
# > $\mu(\cos 2\theta - 1) < 0$ — a rigid quarter turn would *release* energy $2\mu$. The
# > printed stress $\mu\mathbf F + \dots$ is the derivative of $\mathbf F:\mathbf F$, confirming the fix.

# %%
for th in (30.0, 90.0):
    R = rotation(np.radians(th))
    print(f"theta = {th:4.0f}:  F_ij F_ji = {np.einsum('ij,ji->', R, R):+.4f}   "
          f"F_ij F_ij = {np.einsum('ij,ij->', R, R):.4f}   "
          f"printed energy mu/2 (F_ij F_ji - 2) = {0.5 * neo.mu * (np.einsum('ij,ji->', R, R) - 2):+.2f}")

# %% [markdown]
# What does this mean for a whole body? Clamp the left edge of a unit block to a wall, turn the
# wall by 60° about the edge's midpoint and let the rest of the block find its equilibrium
# (`tissuefem.workbook.studies.rotated_block` sets up the `Model`; the Neo-Hookean solve turns the wall in
# 15° steps). The Neo-Hookean block simply turns with the wall. The linear-elastic block cannot:
# its zero-energy motions are the *infinitesimal* rotations $\mathbf u = \mathbf W\mathbf X$ with
# $\mathbf W$ skew, and at finite size $\mathbf I + \mathbf W$ is a rotation combined with a
# stretch by $\sqrt{1 + w^2}$. Held by an edge that really turns, the block ends up strained, and
# its area grows.

# %%
for material in (neo, linear):
    model, result = rotated_block(material, np.radians(60.0))
    J = det2(model.deformation_gradient(result.u))           # area ratio of every triangle
    print(f"{material.name:12s}: converged {result.converged}, stored energy {model.stored_energy(result.u):9.2g}, "
          f"deformed area {model.element_areas() @ J:.3f} (reference 1)")

# %%
fig_ch03_rotation_stress()

# %% [markdown]
# ## 6. When is linear elasticity good enough?
#
# For small deformations the two models agree: at $\mathbf F = \mathbf I$ the Neo-Hookean tangent
# *is* the linear-elastic one (chapter 4). Pull a $2 \times 1$ block by $\delta$ at its right edge
# (left edge fixed) and compare the two solutions — the displacements, and the force the handle
# needs (`handle_force`: the internal forces summed over the handle's dofs; it is what a haptic
# device would make the surgeon feel). The linear problem is solved by the same Newton solver,
# in one step.

# %%
mesh = rectangle(2.0, 1.0, 16, 8)
print(f"{'delta':>6} {'stretch':>8} {'|u_lin - u_neo|/|u_neo|':>24} {'force linear':>13} {'force neo':>10} {'difference':>10}")
compared = {}
for delta in (0.01, 0.1, 0.5, 1.0):
    handles = [Handle("left"), Handle("right", (delta, 0.0))]
    solved = []
    for material in (linear, neo):
        model = Model(mesh, material, handles=handles)
        u = solve(model).u
        solved.append((u, handle_force(model, u, "right")[0]))
    (u_lin, f_lin), (u_neo, f_neo) = solved
    shape, force = np.linalg.norm(u_lin - u_neo) / np.linalg.norm(u_neo), (f_lin - f_neo) / f_neo
    compared[delta / 2] = shape, force
    print(f"{delta:6.2f} {delta / 2:8.1%} {shape:24.1e} {f_lin:13.2f} {f_neo:10.2f} {force:10.1%}")
display(Markdown(" ".join(
    f"At a {100 * stretch:g} % stretch the displacements differ by {100 * shape:.2g} % and the force by "
    f"{100 * force:.2g} %." for stretch, (shape, force) in compared.items())))

# %% [markdown]
# The difference grows with $\delta$, in the force far more than in the shape: while the shapes still look
# alike, the Neo-Hookean block needs less force, because it softens as it stretches and thins, and the linear
# one cannot. Soft tissue in surgery stretches by tens of percent and turns freely — hence the Neo-Hookean
# model of the next chapter.
#
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Turn the wall by 10° instead of 60°: how much does the linear block's area grow, and how much
#   energy does it store? Compare with $2(\lambda+\mu)(1-\cos\theta)^2$, the energy per unit area of a
#   *free* rigid turn (section 5): is the held block's energy above or below it, and why?
#
# ```python
# import numpy as np
# from tissuefem import LinearElastic
# from tissuefem.engine.materials import det2
# from tissuefem.workbook.studies import rotated_block
#
# linear = LinearElastic.from_young(1000.0, 0.3)
# for degrees in (10.0, 60.0):
#     theta = np.radians(degrees)
#     model, result = rotated_block(linear, theta)
#     area = model.element_areas() @ det2(model.deformation_gradient(result.u))
#     free_turn = 2 * (linear.lam + linear.mu) * (1 - np.cos(theta)) ** 2
#     print(f"{degrees:4.0f} degrees: area {area:.4f}, stored energy {model.stored_energy(result.u):.4g}, "
#           f"free rigid turn {free_turn:.4g}")
# ```
#
# - Replace the bending map by your own, a shear $x_1 = X_1 + \gamma X_2$, $x_2 = X_2$, and check $\mathbf F$
#   and $J$ per triangle against your hand computation.
#
# ```python
# import numpy as np
# from tissuefem import P1Assembler, rectangle
# from tissuefem.engine.materials import det2
# from tissuefem.workbook.studies import displacement_from_map
#
# gamma = 0.4
# shear = lambda X: np.stack([X[0] + gamma * X[1], X[1]])
# mesh = rectangle(2.0, 1.0, 4, 2)
# F = P1Assembler(mesh).deformation_gradient(displacement_from_map(mesh, shear))
# print("F of the first triangle:", F[:, :, 0].round(12).tolist())
# print("J of every triangle:", det2(F).round(12))
# ```
#
# - Solve the pulled block of section 6 in plane stress: is it softer or stiffer than in plane strain,
#   and by how much? (Compare the ratio of the forces with $(\lambda^* + 2\mu)/(\lambda + 2\mu)$ and with
#   $E$ over the plane-strain modulus $E/(1 - \nu^2)$.)
#
# ```python
# from tissuefem import Handle, LinearElastic, Model, rectangle, solve
# from tissuefem.workbook.studies import handle_force
#
# mesh = rectangle(2.0, 1.0, 16, 8)
# force = {}
# for plane in ("strain", "stress"):
#     material = LinearElastic.from_young(1000.0, 0.3, plane=plane)
#     model = Model(mesh, material, handles=[Handle("left"), Handle("right", (0.1, 0.0))])
#     force[plane] = handle_force(model, solve(model).u, "right")[0]
#     print(f"plane {plane}: lam = {material.lam:6.1f}, handle force {force[plane]:.3f}")
# print(f"stress / strain = {force['stress'] / force['strain']:.3f}")
# ```
#
# - Push $\nu$ to 0.499 and look at $\lambda$. What do you expect of the Neo-Hookean solver, and of the
#   stretched block's area?
#
# ```python
# from tissuefem import Handle, Model, NeoHookean, rectangle, solve
# from tissuefem.engine.materials import det2
#
# for nu in (0.3, 0.49, 0.499):
#     model = Model(rectangle(2.0, 1.0, 16, 8), NeoHookean.from_young(1000.0, nu),
#                   handles=[Handle("left"), Handle("right", (0.5, 0.0))])
#     result = solve(model)
#     area = model.element_areas() @ det2(model.deformation_gradient(result.u))
#     print(f"nu = {nu}: lam = {model.material.lam:8.0f}, converged {result.converged} in "
#           f"{result.newton_iterations} Newton iterations, area {area:.4f} (reference 2)")
# ```
#
# ## Exercises (graded by pytest)
# In `exercises/ch03.py`:
# - **3.1** `lame_from_young(E, nu, plane="strain")` — $(\lambda, \mu)$, also for plane stress;
# - **3.2** `deformation_gradient_p1(X_nodes, x_nodes)` — $\mathbf F$ of one triangle from its
#   reference and deformed vertices (2×3 arrays, one column per vertex), with $F_{ij} = \partial x_i/\partial X_j$;
# - **3.3** `linear_elastic_stress_2d(F, lam, mu)` — the linear-elastic $\mathbf P$ of one 2×2 $\mathbf F$.
#
# Grade: `python -m tissuefem grade ch03`.
