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
# # Chapter 6b — Inversion, robustly: a descent direction, a crushed block, and the hard cases
#
# **Goals.** By the end of this chapter you can
# 1. make every Newton direction a descent direction with the projected tangent, and say what it costs;
# 2. crush a block past flat and let it go with four models, read what each one did, and tell an inverted
#    element from a folded mesh;
# 3. say why our version of the notes' Figure 6 does not show what the notes' caption promises, and what
#    the models do promise;
# 4. release a body from violent states and read which models recover.
#
# *Time: about 45 min to read and run.* The second sitting of chapter 6: it uses the four models, the
# rotation-preserving SVD and the cover counts of chapter 6a.
#
# *Reading:* the notes' "Inversion" section (Figure 6). Behind it: Irving, Teran and Fedkiw, *Invertible
# finite elements* (SCA 2004); Teran, Sifakis, Irving and Fedkiw, *Robust quasistatic finite elements*
# (SCA 2005).
#
# **Index convention.** As everywhere in this workbook (chapter 3), $F_{ij} = \partial\phi_i/\partial X_j$,
# formulas count from 1 and code from 0: the singular values $s_1 \ge |s_2|$ are `s[0]` and `s[1]`.

# %%
# %matplotlib inline
import time
import warnings

import numpy as np
from IPython.display import Markdown, display
from scipy.sparse.linalg import MatrixRankWarning

from tissuefem.workbook.figures.inversion import fig06_crush_release
from tissuefem.workbook.hardcases import (block, cover_counts, crush_and_release_runs, crush_in_frames,
                                          element_jacobians, inversion_models, release, start_states)
from tissuefem.workbook.tables import markdown_table
from tissuefem import (Handle, ITFClamped, Model, P1Assembler, StableNeoHookean, TaylorNeoHookean,
                       projected_tangent, rotation_preserving_svd)

E, nu = 1000.0, 0.3
models = inversion_models(E, nu)          # the four models of chapter 6a, by name
lam, mu = models["neo-Hookean (ln J)"].lam, models["neo-Hookean (ln J)"].mu
mesh = block()                            # the unit square, 6 x 6 cells
states = start_states(mesh)               # the violent start states of chapter 6a, section 1
print(f"lam = {lam:.2f}, mu = {mu:.2f};  block: {mesh.p.shape[1]} nodes, {mesh.t.shape[1]} triangles; "
      f"models: {', '.join(models)}")


def rotation(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])

# %% [markdown]
# ## 1. The definiteness fix: a projected tangent
#
# Newton solves $\mathbf K\,\Delta\mathbf u = -\mathbf q$. Where the energy is convex, $\mathbf K$ is positive
# definite and $\Delta\mathbf u$ points downhill. Near inversion the Neo-Hookean family is far from convex,
# $\mathbf K$ turns indefinite, and $\Delta\mathbf u$ may point uphill or to a saddle; the energy line search
# then cuts the step again and again, or fails. Teran, Sifakis, Irving and Fedkiw (2005) repair the
# tangent **element by element**. For an isotropic material it rotates with the SVD,
# $\mathbb A(\mathbf F) = (\mathbf U\otimes\mathbf V)\,\hat{\mathbb A}(\mathbf s)\,(\mathbf U\otimes\mathbf V)^T$, and
# in 2D the diagonal-space tangent $\hat{\mathbb A}$ splits into two $2\times 2$ blocks:
#
# - the **stretch** block over $(dF_{11}, dF_{22})$: the Hessian of $\hat\Psi(s_1, s_2)$;
# - the **twist/flip** block over $(dF_{12}, dF_{21})$, with eigenvalues
#   $\dfrac{\psi_1 - \psi_2}{s_1 - s_2}$ (twist: a rotation of the element) and
#   $\dfrac{\psi_1 + \psi_2}{s_1 + s_2}$ (flip: a reflection-like shear).
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
    print(f"   twist (psi1-psi2)/(s1-s2) = {twist:.1f},  flip (psi1+psi2)/(s1+s2) = {flip:.1f}")

# %% [markdown]
# The negative eigenvalues are clamped to zero; the positive ones are kept exactly, and the twist and
# flip values reappear among the eigenvalues of the exact tangent. Where the tangent is already
# positive semi-definite (near rest), the projection changes nothing.
#
# ## 2. Crush and release: the notes' Figure 6 as an experiment
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
print(f"four crushes and releases in {time.perf_counter() - start:.1f} s")
rows = []
for name, run in runs.items():
    deepest = run["frames"][-2]                     # the last crush state that converged
    failed = [f"{0.1 * (k + 1):.1f}: {r.status}" for k, r in enumerate(run["crush"]) if not r.converged]
    rows.append({"model": name, "depth": run["crushed"], "inverted": int((element_jacobians(mesh, deepest) <= 1e-12).sum()),
                 "failed": ", ".join(failed) or "none", "iterations": run["iterations"], "cuts": run["cuts"],
                 "release": run["released"].status, "energy": run["final_energy"],
                 "rest": run["released"].rest_error})
display(Markdown(markdown_table(rows, [
    ("model", "model", "{}"), ("failed", "failed crush step", "{}"), ("release", "release", "{}"),
    ("depth", "depth reached", "{:.1f}"), ("inverted", "J <= 0 there", "{:d}"),
    ("iterations", "Newton iterations", "{:d}"), ("cuts", "line-search cuts", "{:d}"),
    ("energy", "final energy", "{:.4g}"), ("rest", "rest error", "{:.2g}")], text_columns=3)))

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
# $J$, the cover counts of chapter 6a, and the smallest eigenvalue of the *exact* (unprojected) Hessian on
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
# the rest shape; nothing guarantees it in general (section 3 shows a case where it too lands elsewhere).
#
# **Why does the ITF crush stop at flat?** Look inside the failed step: the Newton history, and the
# crushed elements' flip value $(\psi_1 + \psi_2)/(s_1 + s_2)$ at its last iterate:

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
      f"smallest s1 + s2 there: {(s[0] + s[1])[crushed].min():.2f}; flip values from "
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
# $\psi_2$ dominates), so the exact Hessian of the flat-and-beyond state is indefinite: the flat block is
# unstable and wants to buckle away. The projected tangent replaces those negative curvatures by zero at
# element level, so along exactly the directions the body wants to move, Newton steps as if the energy were
# curving up, takes steps that are far too short, and converges only linearly. The $s_1 + s_2$ values are
# far from zero, so this is not the kink of chapter 6a, section 4. Projection buys a descent direction, not
# Newton's quadratic convergence.
#
# So the ITF crush stops at flat because of how we solve, not because of the model: each load step of the
# offline `solve` must converge within 100 iterations, or the crush ends there. The real-time solver of
# chapter 7 works differently: a frame that runs out of iterations commits what it has and the next frame
# carries on from there (the *anytime* rule). The same crush as quasistatic frames
# (`tissuefem.workbook.hardcases.crush_in_frames`: 13 frames down to 1.3, then frames at 1.3 until one
# converges), then the same release:

# %%
rows = []
for name in ("ITF-clamped neo-Hookean", "Taylor neo-Hookean", "stable neo-Hookean"):
    run = crush_in_frames(models[name], mesh)
    rows.append({"model": name, "reached": run["reached"], "frames": run["frames"], "inverted": run["inverted"],
                 "folded": run["folded"], "release": run["released"].status, "rest": run["released"].rest_error})
display(Markdown(markdown_table(rows, [
    ("model", "model", "{}"), ("release", "release", "{}"), ("reached", "depth reached", "{:.1f}"),
    ("frames", "frames", "{:d}"), ("inverted", "J <= 0 there", "{:d}"),
    ("folded", "centroids covered twice there", "{:d}"), ("rest", "rest error after the release", "{:.2g}")],
    text_columns=2)))

# %% [markdown]
# Given a few frames more, the ITF block goes past flat to 1.3 like the others, and ends where they end: no
# inverted element at all, and a mesh folded over itself (most centroids covered twice). Released,
# it does not come back (the release stops at its iteration cap, far from rest); the Taylor block stays
# folded too; only the stable model finds the rest shape again.
#
# **Why our Figure 6 shows the opposite of the notes' caption.** The caption (from Irving, Teran and
# Fedkiw) promises robustness to large deformation: the algorithm recovers. What we can check here is
# narrower, and it separates two things the word "inversion" covers:
#
# - **Inverted elements** ($J \le 0$, an element turned inside out). This is what the ITF construction is
#   about, and its promise holds: released from every start state with inverted elements (section 3 below,
#   the mirrored block, the collapses, the crush with inverted triangles), the ITF model returns to rest.
# - **A folded mesh**: every element upright, but the map is not one-to-one. Crushing a block held on one
#   edge past flat does not invert its elements, it folds the mesh (column "J <= 0 there" is 0 for every
#   model past flat). A fold is invisible to any energy that looks at one element at a time, and a folded
#   shape can be a genuine local minimum (the Taylor check above). No per-element repair, ITF included,
#   promises to undo it; only the global shape of the energy decides, which is why the stable model
#   recovers here and the others do not.
#
# The paper's demonstrations are dynamic 3D simulations in which elements are inverted (by collisions,
# by large time steps, by a user's pull) and pushed back a little in every time step; its ITF clamps the
# diagonal stress itself, while ours extends the energy so that Newton's line search stays valid (chapter
# 6a, section 4). We do not reproduce those scenes here. What we can say from our own runs: our quasistatic
# crush tests a harder, different thing (an unstable equilibrium at flat, and a fold beyond it), so our
# Figure 6 is a test of robustness (no model crashes, no NaN) and a warning, not a picture of recovery.
#
# ## 3. Hard cases: release from violent states
#
# Now release the block from each start state of chapter 6a, section 1 (bottom edge held), with each model
# (`tissuefem.workbook.hardcases.release`; absolute tolerance $10^{-7}$, steps capped at 0.5, at most 400
# iterations):

# %%
def release_table(models, states):
    results, rows = {}, []
    for state, x_start in states.items():
        for name, material in models.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", MatrixRankWarning)   # NaN tangents of the ln J model
                r = release(mesh, material, x_start)
            results[state, name] = r
            rows.append({"state": state, "model": name, "status": r.status, "iterations": r.iterations,
                         "cuts": r.cuts, "rest": r.rest_error})
    display(Markdown(markdown_table(rows, [
        ("state", "start state", "{}"), ("model", "model", "{}"), ("status", "status", "{}"),
        ("iterations", "Newton iterations", "{:d}"), ("cuts", "line-search cuts", "{:d}"),
        ("rest", "rest error", "{:.2g}")], text_columns=3)))
    return results


start = time.perf_counter()
hard = release_table(models, states)
print(f"({time.perf_counter() - start:.1f} s)")

# %% [markdown]
# The $\ln J$ model fails at once from every start with an element at $J \le 0$ (its energy is NaN there)
# and only survives the 10× stretch. The other three recover from everything, including the collapse to a
# point. That last one deserves a second look after chapter 6a, section 4: for the Taylor and stable models $\mathbf F = 0$
# is a stationary point, so why do they move? Because the held bottom nodes are *not* collapsed: the
# elements along the bottom edge have $\mathbf F \ne 0$, feel a force, and pull the rest along. A block with
# every node on one point would be in equilibrium under those two models (zero stress in every element).
#
# **Nearly incompressible tissue** ($\nu = 0.499$) makes the volumetric term about five hundred times stiffer
# than the shear term ($\lambda/\mu = 2\nu/(1 - 2\nu) = 499$, chapter 3's table). Release from the point collapse again:

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
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Change the ITF threshold and crush again, offline: how deep does the crush get with $c = 0.1$ and
#   $c = 0.6$, and what stops it?
#
# ```python
# from tissuefem import ITFClamped, NeoHookean
# from tissuefem.workbook.hardcases import crush_and_release
#
# base = NeoHookean.from_young(1000.0, 0.3)
# for c in (0.1, 0.6):
#     run = crush_and_release(ITFClamped(base, threshold=c))
#     print(f"c = {c}: crushed to {run['crushed']:.1f}, last step {run['crush'][-1].status}, "
#           f"released {run['released'].status}, rest error {run['released'].rest_error:.2g}")
# ```
#
# - Give the offline crush more Newton iterations per step. Does the ITF model get past flat, and how many
#   iterations does each step take?
#
# ```python
# from tissuefem.workbook.hardcases import crush_and_release, inversion_models
#
# run = crush_and_release(inversion_models()["ITF-clamped neo-Hookean"], depth=1.1, steps=11, max_iterations=400)
# print(f"crushed to {run['crushed']:.1f}; iterations per step {[r.newton_iterations for r in run['crush']]}")
# ```
#
# - Release the Taylor block from depth 1.0 instead of 1.3. Does it still fold?
#
# ```python
# from tissuefem.workbook.hardcases import crush_and_release, inversion_models
#
# run = crush_and_release(inversion_models()["Taylor neo-Hookean"], depth=1.0, steps=10)
# print(f"crushed to {run['crushed']:.1f}; released {run['released'].status}, "
#       f"rest error {run['released'].rest_error:.2g}")
# ```
#
# - Solve the crush with the *unprojected* Taylor tangent (no `ProjectedTangent` wrapper). Count the
#   line-search cuts and the steps whose tangent had to be shifted.
#
# ```python
# from tissuefem import TaylorNeoHookean
# from tissuefem.workbook.hardcases import crush_and_release
#
# run = crush_and_release(TaylorNeoHookean.from_young(1000.0, 0.3), depth=1.0, steps=10)
# shifted = sum(1 for r in run["crush"] for s in r.steps for h in s.history if h.shift)
# print(f"crushed to {run['crushed']:.1f}; line-search cuts {run['cuts']}; shifted tangents {shifted}")
# ```
#
# - Drag a handle through a clamped sheet, with each model, and look at the final positions.
#
# ```python
# import matplotlib.pyplot as plt
# from tissuefem.workbook.figures.inversion import draw_state
# from tissuefem.workbook.hardcases import block, drag_through, inversion_models
#
# mesh = block()
# models = inversion_models()
# fig, axes = plt.subplots(1, len(models), figsize=(13, 3), layout="constrained")
# for ax, (name, material) in zip(axes, models.items()):
#     run = drag_through(material, mesh, depth=0.8, steps=8)
#     draw_state(ax, mesh, run["positions"][-1])
#     ax.set(aspect="equal", title=name)
# ```
#
# ## Exercises
# The exercises of chapter 6 (6.1 to 6.3: the rotation-preserving SVD, the cubic $r(J)$, the Taylor stress
# with the cofactor) are listed in chapter 6a; `python -m tissuefem grade ch06` grades them.
