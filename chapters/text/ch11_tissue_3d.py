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
# # Chapter 11 — Tissue in 3D: tetrahedra, a twisted bar, a crushed cube, a released slab
#
# **Goals.** By the end of this chapter you can
# 1. compute $\mathbf F$, $J$ and the cofactor of a tetrahedron, and say what changes from 2D: volumes for
#    areas, cross products in the cofactor, a third singular value that carries the inversion;
# 2. say how the tetrahedral ITF of Irving, Teran and Fedkiw splits the diagonal-space tangent into a stretch
#    block and three twist/flip blocks, and project it;
# 3. stretch and twist a Neo-Hookean bar and read $J$ and the stress on its surface;
# 4. crush a cube past flat and let it go with chapter 6's four models, and tell an inverted tetrahedron from
#    a folded mesh;
# 5. let a slab go under backward Euler, and drag a 3D body in real time.
#
# *Time: about 60 min to read and run, and two exercises.* Nothing here is new code: the library's engine
# takes a mesh of tetrahedra through the same classes as the triangles of chapters 3 to 8.
#
# *Reading:* Irving, Teran and Fedkiw, *Invertible finite elements for robust simulation of large
# deformation* (SCA 2004), and *Tetrahedral and hexahedral invertible finite elements* (Graphical Models,
# 2006); Sifakis and Barbič, *FEM simulation of 3D deformable solids* (SIGGRAPH 2012 course). The notes work
# in 2D throughout; every formula of theirs we use has a 3D twin derived here.
#
# **Index convention.** As everywhere (chapter 3): $F_{ij} = \partial\phi_i/\partial X_j$, formulas count from
# 1 and code from 0; the body's $y$ is up (the crush pushes along $-y$), and node $a$ has dofs $3a$, $3a+1$,
# $3a+2$.

# %%
# %matplotlib inline
import math
import time

import numpy as np
from IPython.display import Markdown, display

from tissuefem import (FRAME_BUDGET, TISSUE_E, TISSUE_NU, StableNeoHookean, TaylorNeoHookean, lame_parameters,
                       projected_tangent, rotation_preserving_svd)
from tissuefem.engine.materials import cofactor, cofactor_derivative, det
from tissuefem.engine.meshes import box, signed_volumes
from tissuefem.workbook.figures.tissue3d import (cube, fig_ch11_crush_release, fig_ch11_released_slab,
                                                 fig_ch11_twist, slab_run)
from tissuefem.workbook.hardcases import (cover_counts, crush_and_release_runs, crush_in_frames, edge_matrices,
                                          element_jacobians, inversion_models)
from tissuefem.workbook.tables import markdown_table
from tissuefem.workbook.tissue3d import probe_and_drag, realtime_drag, twisted_bar

E, nu = TISSUE_E, TISSUE_NU
lam, mu = lame_parameters(E, nu)          # in 3D the Lamé formulas need no plane-strain reading
print(f"E = {E:g}, nu = {nu:g}:  lam = {lam:.2f}, mu = {mu:.2f}")

# %% [markdown]
# ## 1. The 3 × 3 kinematics: what changes from 2D
#
# A P1 element in 3D is a tetrahedron: four nodes, and a map $\phi$ that is affine inside it, so
# $\mathbf F$ is one constant $3\times 3$ matrix per element. The map carries each edge vector
# $\mathbf X_a - \mathbf X_0$ to $\mathbf x_a - \mathbf x_0$ ($a = 1, 2, 3$); with the edges as the columns of
# $\mathbf D_m$ (rest) and $\mathbf D_s$ (deformed), $\mathbf F\mathbf D_m = \mathbf D_s$, hence
#
# $$\mathbf F = \mathbf D_s\,\mathbf D_m^{-1}, \qquad J = \det\mathbf F = \frac{\det\mathbf D_s}{\det\mathbf D_m}
#   = \frac{\text{signed volume after}}{\text{signed volume before}}$$
#
# (a tetrahedron's volume is $\det\mathbf D/6$; in 2D it was a triangle's area, $\det\mathbf D/2$). Exercise 11.1
# asks for this $\mathbf F$.
#
# **The cofactor.** $\partial J/\partial\mathbf F = \operatorname{cof}\mathbf F = J\,\mathbf F^{-T}$ as in 2D, and it
# is defined for every $\mathbf F$, singular ones too. In 2D it was a rearrangement of $\mathbf F$'s entries,
# linear in $\mathbf F$. In 3D its columns are **cross products** of $\mathbf F$'s columns $\mathbf f_j$:
#
# $$\operatorname{cof}\mathbf F = \big[\,\mathbf f_2\times\mathbf f_3 \;\big|\; \mathbf f_3\times\mathbf f_1 \;\big|\;
#   \mathbf f_1\times\mathbf f_2\,\big],$$
#
# which is Nanson's formula $\mathbf n\,da = \operatorname{cof}\mathbf F\,\mathbf N\,dA$ column by column: the
# material square spanned by $\mathbf E_2, \mathbf E_3$ becomes the parallelogram spanned by $\mathbf f_2,
# \mathbf f_3$. It is *quadratic* in $\mathbf F$, so its derivative
# $\partial(\operatorname{cof}\mathbf F)_{ij}/\partial F_{kl} = e_{ikm}\,e_{jln}\,F_{mn}$ is no longer a constant: every
# tangent that contains $\partial^2 J/\partial\mathbf F^2$ (Neo-Hookean's, the Taylor and stable variants') has a
# term that changes with $\mathbf F$. A cube of six tetrahedra under a random affine map checks all of it:

# %%
one_cube = box(1.0, 1.0, 1.0, 1, 1, 1)             # 6 tetrahedra around the diagonal
rng = np.random.default_rng(11)
A = np.eye(3) + 0.3 * rng.standard_normal((3, 3))  # an affine map x = A X + c
x = A @ one_cube.p + np.array([[0.5], [-0.2], [1.0]])
Ds, Dm = edge_matrices(one_cube, x), edge_matrices(one_cube, one_cube.p)   # (3, 3, n_tetrahedra)
F_each = np.array([Ds[:, :, e] @ np.linalg.inv(Dm[:, :, e]) for e in range(one_cube.t.shape[1])])
volume_before, volume_after = det(Dm) / 6, det(Ds) / 6
cross = np.column_stack([np.cross(A[:, 1], A[:, 2]), np.cross(A[:, 2], A[:, 0]), np.cross(A[:, 0], A[:, 1])])


def unit(k, l):
    e = np.zeros((3, 3))
    e[k, l] = 1.0
    return e


h = 1e-6
dJ = np.array([[(det(A + h * unit(k, l)) - det(A - h * unit(k, l))) / (2 * h) for l in range(3)] for k in range(3)])
print(f"F of the {len(F_each)} tetrahedra: all equal to A within {np.abs(F_each - A).max():.1e}")
print(f"rest volumes det(D_m)/6 against the mesh's: {np.abs(volume_before - signed_volumes(one_cube)).max():.1e}")
print(f"det A = {det(A):.4f};  volume after / before, tetrahedron by tetrahedron: "
      f"{np.round(volume_after / volume_before, 4)}")
print(f"cof A against the cross products of A's columns: {np.abs(cofactor(A) - cross).max():.1e};  "
      f"against J A^-T: {np.abs(cofactor(A) - det(A) * np.linalg.inv(A).T).max():.1e}")
print(f"dJ/dF by central differences against cof A: {np.abs(dJ - cofactor(A)).max():.1e}")
H_rest, H_A = cofactor_derivative(np.eye(3)), cofactor_derivative(A)
print(f"d(cof F)/dF at F = I and at F = A differ by up to {np.abs(H_A - H_rest).max():.2f} (in 2D: 0, a constant)")

# %% [markdown]
# **The rotation-preserving SVD in 3D.** Chapter 6a's SVD $\mathbf F = \mathbf U\,\operatorname{diag}(\mathbf s)\,
# \mathbf V^T$ with rotations $\mathbf U$, $\mathbf V$ works the same way with three singular values: a reflection
# in $\mathbf U$ or $\mathbf V$ (determinant $-1$) is moved onto the *smallest* one, so only $s_3$ can be negative
# and $s_1 s_2 s_3 = J$. The library takes LAPACK's SVD and fixes the signs (in 2D it had a closed form).
#
# **The tetrahedral ITF.** Irving, Teran and Fedkiw extend the energy below a threshold $c$ in each singular
# value, as in chapter 6a; what the third dimension changes is the tangent. In diagonal space it splits into
#
# - the **stretch** block over $(dF_{11}, dF_{22}, dF_{33})$: the $3\times 3$ Hessian of $\hat\Psi(s_1, s_2, s_3)$;
# - one **twist/flip** block over $(dF_{ij}, dF_{ji})$ for each pair $i < j$, three of them, with eigenvalues
#   $\dfrac{\psi_i - \psi_j}{s_i - s_j}$ (twist) and $\dfrac{\psi_i + \psi_j}{s_i + s_j}$ (flip).
#
# Clamping each block's negative eigenvalues (the $2\times 2$ ones in closed form, the stretch block
# numerically) and rotating back gives the projected tangent of chapter 6b. An inverted $\mathbf F$, before and
# after:

# %%
def rotation(axis, angle):
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


F_inv = rotation([1, 2, 0], 0.4) @ np.diag([1.2, 0.9, -0.4]) @ rotation([0, 1, 1], -0.7).T   # s3 < 0: inverted
U, s, V = rotation_preserving_svd(F_inv)
print(f"s = {s.round(3)}, det U = {np.linalg.det(U):.0f}, det V = {np.linalg.det(V):.0f}, "
      f"s1 s2 s3 = {np.prod(s):.4f} = J = {det(F_inv):.4f}")
for base in (TaylorNeoHookean(lam, mu), StableNeoHookean(lam, mu)):
    before = np.linalg.eigvalsh(base.tangent(F_inv).reshape(9, 9))
    after = np.linalg.eigvalsh(projected_tangent(base, F_inv).reshape(9, 9))
    psi = np.diag(base.stress(np.diag(s)))                       # psi_i = dPsi/ds_i
    pairs = [(i, j) for i in range(3) for j in range(i + 1, 3)]
    blocks = ",  ".join(f"({i + 1}{j + 1}) twist {(psi[i] - psi[j]) / (s[i] - s[j]):.0f} "
                        f"flip {(psi[i] + psi[j]) / (s[i] + s[j]):.0f}" for i, j in pairs)
    print(f"{base.name}:")
    print(f"   eigenvalues of the tangent   : {before.round(0) + 0.0}")
    print(f"   after the projection         : {after.round(0) + 0.0}")
    print(f"   the three pairs: {blocks}")
    values = {(i, j): {"twist": (psi[i] - psi[j]) / (s[i] - s[j]), "flip": (psi[i] + psi[j]) / (s[i] + s[j])}
              for i, j in pairs}
    negative = [f"({i + 1}{j + 1}) {kind}" for (i, j), v in values.items() for kind in v if v[kind] < 0]
    print(f"   negative blocks: {', '.join(negative)}")

# %% [markdown]
# As in 2D, the negative eigenvalues become zero and the others stay; each pair's twist and flip values are
# among the exact tangent's eigenvalues. The inversion is carried by $s_3 < 0$, so the flips of the pairs that
# contain it, $(13)$ and $(23)$, divide by $s_i + s_3$, a sum shrunk by the negative $s_3$; where their
# numerators turn negative (a compressive $\psi_3$ of the inverted direction outweighs $\psi_i$) they are the
# directions Newton would climb without the projection. The lines "negative blocks" name them for both models.
#
# ## 2. A Neo-Hookean bar, stretched and twisted
#
# A bar of tetrahedra is held at its left face; its right face is turned about the bar's axis and pulled along it,
# in equal load steps (`tissuefem.workbook.tissue3d.twisted_bar`). A turn must be followed in steps: each
# step starts Newton from the last state, the right face's nodes moved by the rotation itself. (Chapter 4's `solve`
# ramps a handle's *displacement* along a straight line, which for a turn would shrink the face half-way.)

# %%
start = time.perf_counter()
twist = twisted_bar()                                   # 90 degrees and 20 % of the length, in 6 steps
J_twist = twist.model.jacobian(twist.u)
display(Markdown(markdown_table(
    [{"angle": a, "newton": r.newton_iterations, "force": f} for a, r, f in zip(twist.angles, twist.reports,
                                                                                twist.axial_force)],
    [("angle", "turned by (degrees)", "{:.0f}"), ("newton", "Newton iterations", "{:d}"),
     ("force", "axial force on the right face", "{:.1f}")])))
display(Markdown(
    f"The bar has {twist.model.mesh.t.shape[1]} tetrahedra and {twist.model.n_dofs} unknowns; the {len(twist.angles)} "
    f"steps took {time.perf_counter() - start:.1f} s. At the end $J$ runs from {J_twist.min():.3f} to "
    f"{J_twist.max():.3f}: the volume changes by at most {100 * np.abs(J_twist - 1).max():.0f} %, "
    f"although the surface turns by {twist.angles[-1]:.0f}°."))

# %%
fig_ch11_twist(result=twist)

# %% [markdown]
# The colours show where the handles matter. Along the middle of the bar $J$ stays close to its smallest value: the
# bar thins as it lengthens, as a pulled bar does. Next to the held and the turned faces, which the handles keep
# from thinning, the volume grows the most. The largest principal stress peaks at the corners of the turned face,
# farthest from the axis, where the twist shears the most; a twist is a shear that grows with the distance from
# the axis.
#
# **A 3D effect: the Poynting effect.** Twist a rubber bar and it wants to get *longer*; held at both ends, it
# pushes on its holders instead. The same bar turned without a pull:

# %%
pure = twisted_bar(stretch=0.0)
forces = ", ".join(f"{f:.2f}" for f in pure.axial_force)
sign = "pushes on" if pure.axial_force[-1] < 0 else "pulls on"
display(Markdown(
    f"Axial force on the right face after each step of the pure twist: {forces}. It grows about with the square "
    f"of the angle (ratio of the last to the first: {pure.axial_force[-1] / pure.axial_force[0]:.0f}, with "
    f"{len(pure.angles)} steps) and its sign says the bar **{sign}** its holders."))

# %% [markdown]
# Linear elasticity has no such force (a twist is a pure shear, and linear shear does not change lengths): it is
# second order in the angle, one of the effects a 2D model cannot show.
#
# ## 3. The cube crushed past flat and released: chapter 6b in 3D
#
# Chapter 6b's experiment (`tissuefem.workbook.hardcases.crush_and_release`) takes tetrahedra as it takes
# triangles: the unit cube (`block(3, dim=3)`, `cube()` here), bottom face held, top face pushed down in the same
# steps to flat and past it, then let go; the four models of chapter 6a.

# %%
mesh = cube()
runs_models = inversion_models(E, nu)          # chapter 6a's four models, by name
start = time.perf_counter()
runs = crush_and_release_runs(E, nu, mesh)
seconds = time.perf_counter() - start
rows = []
for name, run in runs.items():
    deepest = run["frames"][-2]                     # the last crush state that converged
    failed = [f"{0.1 * (k + 1):.1f}: {r.status}" for k, r in enumerate(run["crush"]) if not r.converged]
    rows.append({"model": name, "depth": run["crushed"],
                 "inverted": int((element_jacobians(mesh, deepest) <= 1e-12).sum()),
                 "folded": int((cover_counts(mesh, deepest) > 1).sum()), "failed": ", ".join(failed) or "none",
                 "iterations": run["iterations"], "release": run["released"].status,
                 "rest": run["released"].rest_error})
display(Markdown(f"{mesh.t.shape[1]} tetrahedra, four crushes and releases in {seconds:.1f} s:\n\n"
                 + markdown_table(rows, [
    ("model", "model", "{}"), ("failed", "failed crush step", "{}"), ("release", "release", "{}"),
    ("depth", "depth reached", "{:.1f}"), ("inverted", "J <= 0 there", "{:d}"),
    ("folded", "centroids covered twice there", "{:d}"), ("iterations", "Newton iterations", "{:d}"),
    ("rest", "rest error", "{:.2g}")], text_columns=3)))

# %%
fig_ch11_crush_release(runs=runs)

# %%
def reading(name):
    """One sentence per model, from its run."""
    run, row = runs[name], next(r for r in rows if r["model"] == name)
    back = run["released"].converged and run["released"].rest_error < 1e-6
    how = (f"reaches {row['depth']:.1f}" + (" (flat or beyond)" if row["depth"] >= 1.0 - 1e-9 else
                                            f", then its next step fails ({run['crush'][-1].status})"))
    state = (f"{row['inverted']} tetrahedra inverted and {row['folded']} centroids covered twice at that depth")
    end = "comes back to rest" if back else f"does not come back (rest error {row['rest']:.2g})"
    return f"- **{name}** {how}, with {state}; released, it {end}."


display(Markdown("\n".join(reading(name) for name in runs)))

# %% [markdown]
# The columns "J <= 0 there" and "centroids covered twice there" tell chapter 6b's two kinds of "inversion"
# apart: an inverted tetrahedron (turned inside out, what the ITF construction handles) and a mesh of upright
# elements lying over itself (a fold, which no element-by-element test can see). A cube pushed past flat has both
# at once where the square of chapter 6b only folded: its sides can bulge in two directions, but a tetrahedron
# caught between the held face and the pushed one has no way out but through itself.
#
# A crush that stops at an iteration cap says how we solve, not what the model can do (chapter 6b, section 2).
# The same crush as real-time frames, each frame at most a fixed number of Newton steps with the rest carried
# over (`crush_in_frames`), then the same release:

# %%
start = time.perf_counter()
framed = {name: crush_in_frames(runs_models[name], mesh) for name in runs_models if "ln J" not in name}
rows_framed = [{"model": name, "reached": r["reached"], "frames": r["frames"], "inverted": r["inverted"],
                "folded": r["folded"], "release": r["released"].status, "rest": r["released"].rest_error}
               for name, r in framed.items()]
display(Markdown(f"({time.perf_counter() - start:.1f} s)\n\n" + markdown_table(rows_framed, [
    ("model", "model", "{}"), ("release", "release", "{}"), ("reached", "depth reached", "{:.1f}"),
    ("frames", "frames", "{:d}"), ("inverted", "J <= 0 there", "{:d}"),
    ("folded", "centroids covered twice there", "{:d}"), ("rest", "rest error after the release", "{:.2g}")],
    text_columns=2)))
home = [name for name, r in framed.items() if r["released"].converged and r["released"].rest_error < 1e-6]
away = [name for name in framed if name not in home]
reached = ", ".join(f"{name} {r['reached']:.1f} in {r['frames']} frames" for name, r in framed.items())
display(Markdown(
    f"Depths reached in frames: {reached}. Released from there, {' and '.join(home) or 'no model'} "
    f"come{'s' if len(home) == 1 else ''} back to rest"
    + (f"; {' and '.join(away)} settle{'s' if len(away) == 1 else ''} elsewhere"
       + (" after a converged release: another equilibrium, as chapter 6b's Taylor square did."
          if all(framed[name]["released"].converged for name in away) else ".") if away else ".")))

# %% [markdown]
# Robustness to inversion (no NaN, no crash) and recovering the rest shape remain different promises in 3D: the
# first is the models' (every model but $\ln J$ keeps a finite energy through $J \le 0$), the second depends on
# the whole energy landscape, which is why the same crush can end at rest for one model and in another well for
# the next. Compare the tables with chapter 6b's: which model recovers need not carry over from the square to
# the cube.
#
# ## 4. A released body: backward Euler in 3D
#
# Chapter 7's flap as a slab of tetrahedra (`released_flap` with `nz` cells across a depth): lifted at its right
# face, held at its left face and let go, one backward-Euler step per frame of 1/30 s (`backward_euler_run`,
# unchanged: a step is the minimisation of the incremental potential, whatever the element).

# %%
start = time.perf_counter()
slab = slab_run()
model_slab, times, energies, states = slab
J_min = min(float(model_slab.jacobian(u).min()) for u in states)
display(Markdown(
    f"{len(states) - 1} steps of backward Euler on {model_slab.mesh.t.shape[1]} tetrahedra ({model_slab.n_dofs} "
    f"unknowns) in {time.perf_counter() - start:.1f} s. After {times[-1]:.2f} s the total energy is "
    f"{energies[-1] / energies[0]:.3f} of its start: the numerical damping of chapter 7, unchanged by the third "
    f"dimension. The smallest $J$ of the whole motion is {J_min:.3f}."))

# %%
fig_ch11_released_slab(run=slab)

# %% [markdown]
# The motion as an animation (`python -m tissuefem figures --only fig_ch11_released_slab` writes it beside the
# filmstrip), the faces coloured by $J$:
#
# ![The slab let go under backward Euler, one step per frame of 1/30 s, coloured by J](../figures/fig_ch11_released_slab.gif)
#
# ## 5. Real time in 3D: a drag and a probe
#
# The notes' loop of chapter 7 (`RealtimeSolver`, a budget of 1/30 s per frame, anytime commits) needs nothing
# new for tetrahedra. A slab held at its left face; the nodes near one corner of its right face are grabbed and
# moved up, across and back, one frame per 1/30 s of the path (`tissuefem.workbook.tissue3d.realtime_drag`):

# %%
drag = realtime_drag()
reports = drag["reports"]
ms = np.array([1000 * r.elapsed for r in reports])
newton = np.array([r.newton_iterations for r in reports])
converged = np.mean([r.converged for r in reports])
display(Markdown(
    f"{len(reports)} frames on {drag['model'].mesh.t.shape[1]} tetrahedra ({drag['model'].n_dofs} unknowns, "
    f"{drag['grab'].size} nodes grabbed): median {np.median(ms):.1f} ms per frame, "
    f"{100 * np.median(ms) / (1000 * FRAME_BUDGET):.0f} % of the budget; slowest {ms.max():.1f} ms (frame "
    f"{int(np.argmax(ms)) + 1}); {newton.mean():.2f} Newton iterations per frame on average; "
    f"{100 * converged:.0f} % of the frames converged within the budget."))

# %% [markdown]
# **The surgical tools in 3D.** Chapter 8a's scenes and tools take a block of tetrahedra too: a scene's `block`
# domain, `grab` and `drag` of a point of the body, and the probe, a rigid **ball** now instead of a disc,
# pressing the surface nodes with a penalty weighted by each node's share of the boundary's *area* (so that,
# as in 2D, the penetration does not depend on the mesh). Cuts and self-contact stay 2D for now, and a 3D scene
# that names them is refused. Here a block held on its bottom face: a ball pressed into its top face and slid
# along it while a corner is dragged up and out, the tools moved between frames
# (`tissuefem.workbook.tissue3d.probe_and_drag`):

# %%
probed = probe_and_drag()
rows_probe = probed["rows"]
sim_probe = probed["simulation"]
display(Markdown(markdown_table(
    [{**r, "fy": float(r["force"][1]), "lateral": float(np.hypot(r["force"][0], r["force"][2]))}
     for r in rows_probe[2::3]],
    [("frame", "frame", "{:d}"), ("ball", "ball at x", "{:.2f}"), ("ms", "ms", "{:.1f}"),
     ("newton", "Newton iterations", "{:d}"), ("converged", "converged", "{}"),
     ("fy", "force on the ball, up", "{:.1f}"), ("lateral", "force on the ball, sideways", "{:.1f}"),
     ("penetration", "penetration left", "{:.4f}")])))
probe = sim_probe.model.probes[0]
display(Markdown(
    f"{len(rows_probe)} frames on {sim_probe.mesh.nelements} tetrahedra; every third frame above. The ball "
    f"(radius {probe.radius:g}, penalty {probe.stiffness:.3g}) is pushed back with up to "
    f"{max(float(r['force'][1]) for r in rows_probe):.1f} (in the units of E times an area) while it presses; the "
    f"penetration it leaves stays below {max(float(r['penetration']) for r in rows_probe):.4f}, "
    f"{100 * max(float(r['penetration']) for r in rows_probe) / probe.radius:.1f} % of its radius. "
    f"{sum(r['converged'] for r in rows_probe)} of {len(rows_probe)} frames converged within the budget; the "
    f"others committed what they had and the next frame carried on (chapter 7's anytime rule)."))

# %% [markdown]
# The cost of a 3D frame grows faster with the mesh than in 2D: a tetrahedron mesh with $n$ nodes along each side
# has $n^3$ nodes, and a node has more neighbours (a factorization fills in more), so the sizes chapter 9 found
# for triangles do not carry over.
#
# **With the mouse.** Chapter 8b's live view, `tissuefem.surgery.interactive.SurgeryView`, takes a body of
# tetrahedra too: the page draws its surface with WebGL, lit, coloured here by $J$ (blue shrunk, red stretched), and
# a drag with the shift key held turns the camera instead of grabbing. A press grabs the nodes near the surface
# point under the pointer, and dragging moves them in the plane that faces the camera. Without a browser (a
# headless run, as in the tests) nothing runs by itself: the cell sends made-up pointer events through the view's
# own message handler, a grab on the top face near the free end dragged up and towards you, steps the frames, and
# lets go. The cell ends with `view`, the live view; take over with the mouse.

# %%
from tissuefem import Scene, Simulation
from tissuefem.surgery.interactive import SurgeryView, snapshot, synthetic_mouse

live = Simulation(Scene.from_dict({
    "name": "live block",
    "domain": {"shape": "block", "lx": 2.0, "ly": 1.0, "lz": 1.0, "nx": 8, "ny": 4, "nz": 4},
    "material": {"model": "stable-neo-hookean", "youngs_modulus": 3000.0, "poisson_ratio": 0.3},
    "effects": {"inertia": {"time_step": 1.0 / 30.0}, "handles": [{"name": "fixed", "region": "left"}]},
}))
view = SurgeryView(live, color="J", autostart=False)
synthetic_mouse(view, "press", (1.9, 1.0, 0.5))                 # on the top face, near the free end
for k in range(1, 16):
    synthetic_mouse(view, "move", (1.9, 1.0 + 0.03 * k, 0.5 + 0.02 * k))
    view.step()
synthetic_mouse(view, "release", (1.9, 1.45, 0.8))              # let go: the block swings back
for _ in range(10):
    view.step()
display(Markdown(
    f"{live.mesh.nelements} tetrahedra ({live.model.n_dofs} unknowns), {len(view.frame_times)} frames stepped: "
    f"median {np.median(view.frame_times):.1f} ms per frame, slowest {max(view.frame_times):.1f} ms; "
    f"{view.pushes} pictures sent to the page; message {view.message or 'none'}."))
view

# %% [markdown]
# The same state as a static picture (`snapshot(view)`), for a page without the live view, such as the book:

# %%
snapshot(view)

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Twist the bar further, a half turn and more. Where does the smallest $J$ go, and how many Newton
#   iterations does a step take?
#
# ```python
# from tissuefem.workbook.tissue3d import twisted_bar
#
# for angle in (180.0, 270.0):
#     run = twisted_bar(angle=angle, stretch=0.0, steps=12)
#     J = run.model.jacobian(run.u)
#     print(f"{angle:.0f} degrees: converged {run.converged}, J from {J.min():.3f} to {J.max():.3f}, "
#           f"Newton iterations per step {[r.newton_iterations for r in run.reports]}")
# ```
#
# - Crush the cube with a nearly incompressible material. Which models still get past flat?
#
# ```python
# from tissuefem.workbook.hardcases import block, crush_and_release, inversion_models
#
# for name, material in inversion_models(1000.0, 0.45).items():
#     run = crush_and_release(material, block(2, dim=3), depth=1.2, steps=6)
#     print(f"{name}: crushed to {run['crushed']:.1f}, released {run['released'].status}, "
#           f"rest error {run['released'].rest_error:.2g}")
# ```
#
# - Release the cube from chapter 6a's violent start states, now in 3D.
#
# ```python
# from tissuefem.workbook.hardcases import block, inversion_models, release, start_states
#
# mesh = block(2, dim=3)
# material = inversion_models()["stable neo-Hookean"]
# for state, x_start in start_states(mesh).items():
#     r = release(mesh, material, x_start)
#     print(f"{state}: {r.status}, rest error {r.rest_error:.2g}")
# ```
#
# - Drag faster, or on a finer slab, or with half the budget: when do frames stop converging?
#
# ```python
# from tissuefem.workbook.tissue3d import realtime_drag
#
# run = realtime_drag(cells=(12, 3, 3), budget=1 / 60)
# print(f"converged frames: {sum(r.converged for r in run['reports'])} of {len(run['reports'])}; "
#       f"Newton iterations {[r.newton_iterations for r in run['reports']][:10]} ...")
# ```
#
# - Press the ball deeper, with a softer penalty, or without the time limit: how much penetration is left, and
#   how many Newton iterations does a frame need?
#
# ```python
# from tissuefem.workbook.tissue3d import probe_and_drag
#
# run = probe_and_drag(frames=12, depth=0.2, stiffness=2e4, budget=10.0)
# print(f"penetration left {max(r['penetration'] for r in run['rows']):.4f}; "
#       f"Newton iterations {[r['newton'] for r in run['rows']]}")
# ```
#
# ## Exercises
# In `chapters/exercises/ch11.py`; grade them with `python -m tissuefem grade ch11`.
#
# - **11.1** The deformation gradient of one tetrahedron from its four vertices, before and after: the 3D twin
#   of exercise 3.2. Check that $\det\mathbf F$ is the ratio of signed volumes, negative for an inverted one.
# - **11.2** The 3D Neo-Hookean stress $\mathbf P = \mu\mathbf F + (\lambda\ln J - \mu)\,\mathbf F^{-T}$ from its
#   energy $\Psi = \frac{\mu}{2}(\mathbf F:\mathbf F - 3) - \mu\ln J + \frac{\lambda}{2}(\ln J)^2$; the grader
#   compares it with central differences of the energy.
