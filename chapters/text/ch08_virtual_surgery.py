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
# # Chapter 8 — Virtual surgery
#
# **Goals.** By the end of this chapter you can
# 1. describe a simulation as a *scene* (a small TOML file: domain, material, effects) and check that the
#    simulator builds exactly the energy terms the scene calls for, and no others;
# 2. apply the operations of a surgical simulator to a running simulation, between two frames: pull and
#    drag the tissue, press a tool into it, cut it (node duplication along mesh edges), cut a piece off,
#    and stitch a wound closed;
# 3. run a whole procedure, a local advancement flap, and read its tension report;
# 4. say what each effect costs per frame, and why a linear scene costs almost nothing;
# 5. operate on the tissue with the mouse.
#
# *Reading:* the notes' introduction ("Real-time computing": the simulator the whole course aims at) and the
# loop of the "Time stepping" section. The procedure of section 7 follows Sifakis, Hellrung, Teran, Oliker
# and Cutting, *Local flaps: a real-time finite element based solution to the plastic surgery defect
# puzzle* (2009), the notes' reference [3]. Cutting along mesh edges is the simplest way to change a
# mesh's topology; Molino, Bao and Fedkiw, *A virtual node algorithm for changing mesh topology during
# simulation* (SIGGRAPH 2004), cut through elements instead.
#
# **Index convention.** As everywhere, $F_{ij} = \partial\phi_i/\partial X_j$; node $a$ sits at
# $\mathbf X_a$ in the reference configuration and at $\mathbf x_a = \mathbf X_a + \mathbf u_a$ now.

# %%
# %matplotlib inline
import tempfile
from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

from tissuefem.surgery import topology as surgery
from tissuefem.workbook.bench.scenes import effects_benchmark, format_effects_table
from tissuefem.workbook.figures.surgery import (draw_mesh, fig_ch08_flap, fig_ch08_incision, fig_ch08_probe, fig_ch08_two_pieces,
                                       sheet_scene)
from tissuefem import FRAME_BUDGET, Scene, Simulation, advancement_flap, demo_scene, rectangle
from tissuefem.surgery.scene import EFFECTS, EXAMPLE_TOML

print(f"frame budget {1e3 * FRAME_BUDGET:.1f} ms; effects a scene may name: {', '.join(EFFECTS)}")

# %% [markdown]
# ## 1. The simulator the notes aim at
#
# The notes open with the application: a surgeon in training (or a surgeon planning an operation) works on
# virtual tissue. They push it, pull it, cut it and remove parts of it, and the tissue must answer as the
# real one would, within a thirtieth of a second, every time. Two demands follow, and the notes name both:
# **speed** (a large nonlinear solve per frame, chapter 7) and **robustness** (no input, however clumsy,
# may crash the simulator or leave it in a state it cannot continue from).
#
# Chapter 7 turned the notes' loop into `RealtimeSolver.frame`: read the user's boundary input, advance
# time, solve, draw. In that chapter the input was only where the handles are. In a surgical simulator the
# input also changes the *problem*, between two frames:
#
# | the user ... | what changes | section |
# |---|---|---|
# | pulls or drags the tissue | the prescribed values of a handle (a Dirichlet condition) | 3 |
# | presses a tool into it | a new term of the energy (a contact penalty) | 4 |
# | cuts it | the mesh: nodes are duplicated along the cut | 5, 6 |
# | removes a lesion | the mesh: elements are deleted | 7 |
# | stitches a wound | a new term of the energy (springs between pairs of nodes) | 7 |
#
# `tissuefem.surgery.simulation.Simulation` offers each of these as a method to call between frames, and each one
# leaves a valid state: either the operation succeeds and the state (displacement, velocity, time, frame
# count) carries over to the new problem, or it raises a `ValueError` that names the bad argument and
# changes nothing.

# %% [markdown]
# ## 2. Scenes: simulate only what the scene calls for
#
# A **scene** is a declarative description of a simulation: its domain, its material, and a list of
# *effects* (inertia, gravity, fibres, inversion handling, handles, tractions, probes, excisions, incisions,
# sutures). It is a plain dictionary, so it can live in a TOML or JSON file. The library's example:

# %%
print(EXAMPLE_TOML)

# %% [markdown]
# Loading it checks every field (a wrong one raises a `ValueError` that says which, e.g.
# `effects.handles[1].region`), and `Simulation` builds the scene: the mesh, the `Model` of exactly the named
# terms, and a real-time solver for it. `sim.terms` lists what a frame evaluates:

# %%
scene = Scene.from_toml(EXAMPLE_TOML)
sim = Simulation(scene)
print(scene)
print("terms:", sim.terms)
print("model:", sim.model.describe())
print("linear solver:", sim.solver.linear_solver_name, "| mass matrix built:", sim.model.inertia is not None)
reports = sim.run(30)
print(f"after 30 frames (1 s): max |u| = {np.abs(sim.u).max():.3f}, last frame {reports[-1].status}, "
      f"{1e3 * reports[-1].elapsed:.1f} ms")

try:
    Scene.from_toml(EXAMPLE_TOML.replace("poisson_ratio = 0.3", "poisson_ratio = 0.5"))
except ValueError as err:
    print("a bad scene is refused:", err)

# %% [markdown]
# Effects are added (or removed) by editing the scene, and the term list follows. Nothing that is not named
# is built or evaluated: without `inertia` the scene is **quasistatic** and no mass matrix is ever built;
# without a probe there is no contact code in the frame; without fibres no fibre energy. (The test suite
# checks this by making the absent effects' functions raise.)

# %%
def variant(base, **effects):
    data = base.to_dict()
    for name, value in effects.items():
        if value is None:
            data["effects"].pop(name, None)
        else:
            data["effects"][name] = value
    return Scene.from_dict(data)


quasistatic = variant(scene, inertia=None, gravity=None)
with_fibers = variant(quasistatic, fibers={"stiffness": 500.0, "direction": [1.0, 0.0]})
with_probe = variant(with_fibers, probes=[{"center": [1.0, 1.1], "radius": 0.2}])
for name, s in [("example", scene), ("quasistatic", quasistatic), ("+ fibers", with_fibers),
                ("+ fibers + probe", with_probe)]:
    sm = Simulation(s)
    print(f"{name:18s} terms {sm.terms!s:58s} mass matrix: {'yes' if sm.model.inertia is not None else 'no'}")

# %% [markdown]
# A scene round-trips through a file (`Scene.save`, `Scene.load`; `.toml` or `.json`; the file written is the
# complete scene, defaults filled in). The workbook ships a few in `scenes/`, and
# `python -m tissuefem scene scenes/incision.toml -v` checks a scene file and runs it from the command line.

# %%
with tempfile.TemporaryDirectory() as folder:
    with_probe.save(Path(folder) / "probed.toml")
    print("saved and loaded back unchanged:", Scene.load(Path(folder) / "probed.toml") == with_probe)
for path in sorted((Path("..") / "scenes").glob("*.toml")):
    s = Scene.load(path)
    print(f"scenes/{path.name:18s} {s.name!r:28s} effects {list(s.effects)}")

# %% [markdown]
# **A linear scene factorises once.** If every term is quadratic in $\mathbf u$ (the `linear` material,
# sutures, gravity; a probe is not), the incremental potential is quadratic, its Hessian
# $\mathbf M + \Delta t^2\mathbf K$ (or $\mathbf K$) is constant, and one Newton step from anywhere is exact.
# The simulation then solves with the `"constant"` linear solver: it factorises the free-free block once per
# set of held dofs (and per time step) and every frame is a single back-substitution, without even assembling
# the tangent again. Drag the example's pull handle for 60 frames:

# %%
def drag(sim, frames=60):
    reports = [sim.frame({"pull": (0.3 * np.sin(np.pi * k / frames), 0.2 * k / frames)}) for k in range(frames)]
    ms = np.median([1e3 * r.elapsed for r in reports])
    return sum(r.factorizations for r in reports), np.mean([r.newton_iterations for r in reports]), ms


linear = Scene.from_dict({**scene.to_dict(), "material": {**scene.material, "model": "linear"}})
for name, s in [("linear", linear), ("stable neo-Hookean", scene)]:
    sm = Simulation(s)
    fac, newton, ms = drag(sm)
    print(f"{name:19s} {sm.solver.linear_solver_name:22s} factorizations in 60 frames: {fac:3d}, "
          f"Newton steps per frame {newton:.2f}, median {ms:.1f} ms")

# %% [markdown]
# (The nonlinear scene reuses its factorization too, as the preconditioner of conjugate gradients, chapter 7,
# but it needs two or three Newton steps per frame and refactorises now and then. The linear model is only
# trustworthy for small strains, chapter 3; it is in the workbook as a baseline.)

# %% [markdown]
# ## 3. Pull and drag
#
# A **handle** holds a set of nodes at prescribed displacements; the solver eliminates their dofs. A scene's
# handles (a fixed edge, a pulled edge) are named in the scene; the mouse makes new ones:
# `grab(point, radius)` holds the nodes within `radius` of `point` *where they are now* (deformed
# coordinates), `drag(name, point)` moves them by the pointer's offset from the grab point, and
# `release(name)` lets them go. Below, the right edge of a quasistatic sheet is grabbed and pulled up and
# out over 12 frames, then let go: being quasistatic, the sheet springs straight back to rest.

# %%
sim = Simulation(sheet_scene(800, handles=[{"name": "fixed", "region": "left"}]))
grip = sim.grab([2.0, 0.5], radius=0.15)
print(f"grabbed {sim.handles[grip].nodes.size} nodes as handle {grip!r}; handles now {list(sim.handles)}")
snapshots = [(0, sim.positions().copy())]
for k in range(1, 13):
    sim.drag(grip, [2.0 + 0.02 * k, 0.5 + 0.04 * k])
    sim.frame()
    if k in (6, 12):
        snapshots.append((k, sim.positions().copy()))
sim.release(grip)
sim.frame()
snapshots.append(("released", sim.positions().copy()))
fig, axes = plt.subplots(1, 4, figsize=(12, 2.6), layout="constrained")
for ax, (k, x) in zip(axes, snapshots):
    draw_mesh(ax, x, sim.mesh.t)
    ax.plot([0, 0], [0, 1], "k", lw=3)
    ax.set(aspect="equal", xlim=(-0.1, 2.5), ylim=(-0.2, 1.6), xticks=[], yticks=[], title=f"frame {k}")
print(f"after the release: max |u| = {np.abs(sim.u).max():.1e}")

# %% [markdown]
# ## 4. A probe: contact by a penalty
#
# A tool tip is a rigid disc of centre $\mathbf c$ and radius $R$. The tissue must stay out of it; instead of
# a constraint, we add an energy that grows as nodes enter the disc. With $d_a = |\mathbf x_a - \mathbf c|$,
# $\mathbf n_a = (\mathbf x_a - \mathbf c)/d_a$ and the lumped area of node $a$,
# $m_a = \int_{B_0} N^a\,d\mathbf X$ (a third of the area of each triangle around it),
#
# $$E_{\text{probe}}(\mathbf u) = \sum_{a:\ d_a < R} \frac{k\,m_a}{2}\,(R - d_a)^2 ,
#   \qquad \mathbf f_a = -\frac{\partial E_{\text{probe}}}{\partial \mathbf x_a} = k\,m_a\,(R - d_a)\,\mathbf n_a .$$
#
# The force pushes every node inside the disc straight out, in proportion to how deep it is; the weight
# $m_a$ makes $k$ a stiffness per unit area, so refining the mesh does not change the pressure. Its Hessian
# is $k\,m_a\big[\mathbf n_a\mathbf n_a^T - \tfrac{R - d_a}{d_a}(\mathbf I - \mathbf n_a\mathbf n_a^T)\big]$; the
# tangential part is negative (the disc's surface is curved), so Newton keeps only the positive
# $k\,m_a\mathbf n_a\mathbf n_a^T$ and the energy line search of chapter 6 makes the step safe.
#
# A penalty always leaves some **penetration**: at equilibrium the tissue's push balances $k\,m_a\,(R - d_a)$,
# so the depth left shrinks like $1/k$. Why not take $k$ huge, then? Its Hessian blocks $k\,m_a\mathbf n_a
# \mathbf n_a^T$ dwarf the tissue's stiffness, and the linear systems become badly conditioned. The default
# is $k = 1000\,E/R^2$. The same indentation (depth 0.2, in four frames) with four stiffnesses:

# %%
for k in (1e5, 1e6, 1e7, 1e8):
    sim = Simulation(sheet_scene(1200, handles=[{"name": "base", "region": "bottom"}]))
    tool = sim.add_probe([1.0, 1.25], radius=0.25, stiffness=k)
    newton = 0
    for depth in (0.05, 0.1, 0.15, 0.2):
        sim.move_probe(tool, [1.0, 1.25 - depth])
        newton += sim.frame().newton_iterations
    print(f"k = {k:.0e}: penetration left {sim.model.probes[0].penetration(sim.u):.1e}, "
          f"Newton steps for the 4 frames {newton}")
print("terms:", sim.terms)

# %% [markdown]
# Ten times the stiffness, a tenth of the penetration. Notice the Newton steps too: some fifteen per frame,
# whatever $k$. Contact is the hardest effect for Newton: every time a node enters or leaves the disc the
# energy's curvature jumps, and the Newton matrix leaves the curved part out (section 8 measures it).
#
# The figure presses a disc ever deeper into a block held on its bottom edge (default stiffness). Arrows: the
# nodal contact forces $\mathbf f_a$. Right: the force the tool feels, which a haptic device would play back
# to the surgeon's hand.

# %%
fig_ch08_probe()

# %% [markdown]
# ## 5. An incision: duplicating nodes
#
# A P1 mesh cannot have a crack *inside* a triangle, so our scalpel follows mesh edges: the stroke the user
# draws becomes the path of mesh edges that hugs it best (`surgery.cut_path`, a shortest path in which an
# edge costs more the farther it is from the stroke). To **open** those edges, the triangles on their two
# sides must stop sharing nodes. For every node $v$ on the path:
#
# 1. take the triangles around $v$; call two of them *neighbours* if they share an edge $(v, x)$ that is
#    **not** cut;
# 2. group them into **fans**: sets you can walk through from neighbour to neighbour without crossing the
#    cut. Each fan is one side of the wound at $v$;
# 3. one fan keeps $v$; every other fan gets a **copy** of $v$ (a new node at the same place) and its
#    triangles use the copy.
#
# A node in the middle of a cut has two fans (one copy). The **tip** of a crack inside the body has one cut
# edge and one fan (you can walk round the tip the other way), so it is not copied: the crack is open along
# its length and closed at its tip. Where cut edges cross, the middle node gets more fans. This is
# exercise 8.1. On the 4 × 2 grid of the exercise (15 nodes), a cut right through the middle row and a crack
# that stops inside:

# %%
grid = rectangle(4.0, 2.0, 4, 2)
cases = {"through the middle row": [(5, 6), (6, 7), (7, 8), (8, 9)], "a crack 6-7-8": [(6, 7), (7, 8)]}
fig, axes = plt.subplots(1, 2, figsize=(10, 2.9), layout="constrained")
for ax, (name, pairs) in zip(axes, cases.items()):
    new_t, parent = surgery.duplicate_along_edges(grid.t, grid.nvertices, np.array(pairs).T)
    n_pieces = surgery.connected_components(new_t, parent.size)[0]
    print(f"{name:24s}: {grid.nvertices} -> {parent.size} nodes (copies of {parent[grid.nvertices:].tolist()}), "
          f"{n_pieces} piece(s)")
    # draw every triangle shrunk towards its centre, its corners labelled with the node it now uses
    X = grid.p[:, parent]
    for e in range(new_t.shape[1]):
        corners = X[:, new_t[:, e]]
        centre = corners.mean(axis=1, keepdims=True)
        shrunk = centre + 0.78 * (corners - centre)
        copied = new_t[:, e] >= grid.nvertices
        ax.fill(*shrunk, color="mistyrose" if copied.any() else "0.9", ec="0.5", lw=0.5)
        for j in range(3):
            node = new_t[j, e]
            if parent[node] in np.unique(pairs):
                ax.text(*(centre[:, 0] + 0.62 * (corners[:, j] - centre[:, 0])), str(node), fontsize=7,
                        ha="center", va="center", color="C3" if node >= grid.nvertices else "k")
    ax.plot(*grid.p[:, np.array([pairs[0][0]] + [b for _, b in pairs])], color="C3", lw=1.5, ls="--")
    copies = parent.size - grid.nvertices
    ax.set(aspect="equal", xticks=[], yticks=[], title=f"{name}: {copies} cop{'y' if copies == 1 else 'ies'} (red)")

# %% [markdown]
# On a running simulation, `sim.cut(polyline)` does all of this on the *deformed* tissue (the stroke is drawn
# where the user sees the tissue), builds the new mesh and model, and carries the state over: each copy
# starts with the displacement and the velocity of the node it was copied from (`MeshEdit.transfer`). No
# element is lost, so the **mass** is unchanged; no velocity changes, and the lumped masses of a node's
# copies add up to the node's mass, so the **momentum** is unchanged too:

# %%
sim = Simulation(sheet_scene(800, handles=[{"name": "fixed", "region": "left"}], dynamic=True, gravity=True))
sim.run(5)
mass, momentum, nodes, elements = sim.total_mass(), sim.momentum(), sim.mesh.nvertices, sim.mesh.nelements
edit = sim.cut([[1.2, 1.3], [1.2, 0.4]])          # from above the top edge to inside the sheet
print(f"nodes {nodes} -> {sim.mesh.nvertices} ({edit.cut_edges.shape[1]} edges opened), "
      f"elements {elements} -> {sim.mesh.nelements}, pieces {sim.pieces()}")
print(f"mass {mass:.12f} -> {sim.total_mass():.12f}")
print(f"momentum {momentum} -> {sim.momentum()}")
print(f"frames {sim.frames}, time {sim.time:.3f} s: the clock goes on; terms {sim.terms}")
sim.run(5)
print("5 more frames, state finite:", bool(np.all(np.isfinite(sim.u))))

# %% [markdown]
# In a sheet under tension the wound **gapes**: the lips of the cut carried the tension across, and once they
# are free they pull apart. The tension they carried moves to the tip, where it concentrates: the largest
# value at the tip grows as the mesh is refined (a crack tip is a stress singularity), so read it as "large",
# not as a number.

# %%
fig_ch08_incision()

# %% [markdown]
# ## 6. A cut through the body: two pieces
#
# A stroke that starts and ends outside the body cuts it through. Every node on the path gets a copy, and the
# mesh falls into two **connected components** (`sim.pieces()`; `surgery.connected_components` on the
# triangles). Nothing else needs to happen: the piece that is no longer attached to a handle is free, and the
# next frames let it fall. Its internal forces cancel (they always sum to zero over a free body), so its centre
# of mass follows backward Euler's discrete free fall exactly, to the solver's tolerance:
#
# $$y_k = y_c + k\,\Delta t\,v_c - g\,\Delta t^2\,\frac{k(k+1)}{2}$$
#
# from its centre of mass $y_c$ and velocity $v_c$ at the cut.

# %%
sim = Simulation(sheet_scene(800, handles=[{"name": "fixed", "region": "left"}], dynamic=True, gravity=True))
sim.run(5)
sim.cut([[1.0, 1.3], [1.0, -0.3]])
count, labels = surgery.connected_components(sim.mesh.t, sim.mesh.nvertices)
held = labels[sim.handles["fixed"].nodes[0]]
print(f"{sim.pieces()} pieces: {np.sum(labels == held)} nodes held, {np.sum(labels != held)} nodes free")

# %% [markdown]
# The filmstrip (`python -m tissuefem figures` also writes it as the animation
# `figures/fig_ch08_two_pieces.gif`):

# %%
fig_ch08_two_pieces()

# %% [markdown]
# ## 7. Sutures, and a local flap
#
# ### Sutures: zero-length springs, tightened gradually
#
# A stitch ties node $a$ to node $b$. Each stitch $s$ is a stiff spring of stiffness $k$ and rest length zero,
# with a **slack** vector $\mathbf g_s$, the gap it still allows:
#
# $$E_{\text{sutures}}(\mathbf u) = \sum_s \frac{k}{2}\,\big|\mathbf x_a - \mathbf x_b - \mathbf g_s\big|^2,
#   \qquad \mathbf f_a = -k\,(\mathbf x_a - \mathbf x_b - \mathbf g_s) = -\mathbf f_b .$$
#
# A stitch is placed with its current gap $\mathbf g^0_s = \mathbf x_a - \mathbf x_b$ as slack (no force at
# first), then **tightened**: $\mathbf g_s = (1 - s)\,\mathbf g^0_s$ for a tightness $s$ from 0 to 1. The
# energy is quadratic, so its Hessian is constant: blocks $k\mathbf I$ and $-k\mathbf I$ that couple $a$ and
# $b$, two nodes that share no triangle. That widens the sparsity pattern of the tangent (the model
# rebuilds it when stitches are added). Below: the gaping incision of the figure, each copy stitched to its
# original, tightened over five frames:

# %%
sim = Simulation(sheet_scene(1200, handles=[{"name": "fixed", "region": "left"},
                                            {"name": "pull", "region": "right", "target": [0.4, 0.0]}]))
sim.frame()
n_before = sim.mesh.nvertices
edit = sim.cut([[1.0, 1.2], [1.0, 0.5]])
sim.frame()
copies = np.arange(n_before, sim.mesh.nvertices)
nnz = sim.model.pattern.nnz
stitches = sim.suture(np.vstack([copies, edit.parent[copies]]), tightness=0.0)
print(f"{stitches.shape[1]} stitches; terms {sim.terms}; nonzeros of the tangent {nnz} -> {sim.model.pattern.nnz}")
print(f"gaps when placed: {np.array2string(sim.suture_gaps(), precision=3)}")
for k in range(1, 6):
    sim.tighten(k / 5)
    report = sim.frame()
    print(f"tightness {k / 5:.1f}: widest gap {sim.suture_gaps().max():.4f}, Newton steps {report.newton_iterations}, "
          f"{report.status}")
forces = sim.model.sutures.forces(sim.u)
print(f"stitch forces k|x_a - x_b - g|: {np.array2string(forces, precision=1)}")

# %% [markdown]
# Once tight ($\mathbf g = \mathbf 0$) a stitch's force is $k$ times the gap it leaves: like the probe, a
# stiff spring is a penalty, and the wound stays open by force$/k$ (here $k = 100\,E$, the default).
#
# Why gradually? Here a single frame that closes the wound at once converges too (try `sim.tighten(1.0)`
# straight away): the safeguarded Newton of chapters 4 and 6 copes. But a frame has a budget, and a large
# change per frame means more Newton work in that one frame; in a dynamic scene it also means a snap. A
# surgeon pulls a stitch tight over a moment, and so does the simulator: a little per frame, each frame
# starting from the last one's answer.
#
# ### The local flap procedure
#
# A surgeon who removes a lesion leaves a **defect**, often too wide to pull shut directly. A **local flap**
# closes it with neighbouring skin: the flap is cut free on three sides, moved into the defect (advanced,
# rotated, transposed) and sutured there. Which design leaves the least tension in the skin is the
# question a simulator can answer before the operation, which is the point of Sifakis et al. (2009).
# `advancement_flap` runs the simplest design end to end, on a 4 × 2 patch of skin held on its outer edges:
#
# 1. **excise** a square defect (`sim.excise`: whole triangles inside the polygon are removed);
# 2. **incise** the flap: two parallel cuts continuing the defect's top and bottom edges;
# 3. **plan the stitches**: each wound node of the flap is moved by the planned motion (a translation by the
#    defect's width) and paired with the wound node nearest to where it lands (`flaps.pair_by_motion`;
#    a rotation flap would pass a rotation);
# 4. **suture** and tighten over a few quasistatic frames;
# 5. **report** the tension left: the largest principal Cauchy stress of every element
#    (`sim.tension()`), its maximum, 95th percentile and mean, the mean inside the flap, the stitch forces
#    and the gaps still open.

# %%
result = advancement_flap(n_triangles=2000, flap_length=1.2, tighten_frames=6)
print(result.summary())
print("Newton steps per tightening frame:", [r.newton_iterations for r in result.reports])
print("boundaries of the final mesh:", sorted(result.simulation.mesh.boundaries), "| terms:", result.simulation.terms)

# %% [markdown]
# The maximum sits at the corners of the defect and the ends of the incisions, which are singular like a
# crack tip; the percentile and the means are the numbers to compare between designs. The figure draws the
# procedure and compares three flap lengths: a longer flap spreads the same advance over more skin, so the
# flap is stretched less (at the price of longer incisions).

# %%
fig_ch08_flap()

# %% [markdown]
# ## 8. The cost of each effect
#
# `bench_scenes.effects_benchmark` runs the standard drag of chapter 7 once per variant of one scene: a base
# (stable neo-Hookean, quasistatic), the linear model with and without its constant factorisation, and the
# base with one effect added at a time, then everything together. Every frame is solved to the tolerance (no
# budget), so the columns compare the same work. A small run here (1000 triangles, 8 frames each); the full
# one, at 8000 triangles and 30 frames with JSON and CSV output, is `python -m tissuefem bench scenes`.
# **Timings are noisy** (this is a shared machine, and 8 frames are few): compare the rows of one run,
# rerun the cell, and expect the numbers to move.

# %%
record = effects_benchmark(n_triangles=1000, frames=8, out=None, progress=None)
display(Markdown(format_effects_table(record["rows"])))
print("one evaluation of each term of 'everything' (energy + force + Hessian), ms:",
      ", ".join(f"{name} {ms:.2f}" for name, ms in record["term_ms"].items()))

# %% [markdown]
# What to read in it:
# - an effect that is **not** in the scene costs nothing: the rows differ only by the terms listed;
# - the **linear** scene with its constant factorisation does one back-substitution per frame; forced through
#   the general Newton loop, the same scene costs more;
# - **inertia** adds the mass matrix but usually *lowers* the Newton count: the time step keeps each frame
#   close to the last;
# - the **probe** costs little to evaluate (the last line) but adds Newton steps: as nodes enter and leave the
#   disc the energy's curvature jumps, and its Newton matrix leaves out the curved part;
# - the **projected tangent** (inversion handling, chapter 6) costs an eigen-decomposition per element at
#   every assembly.

# %% [markdown]
# ## 9. With the mouse
#
# `tissuefem.surgery.interactive.SurgeryView` draws a running simulation in a matplotlib figure and turns mouse events
# into the operations above: in **drag** mode a press grabs the tissue under the pointer, moving drags it,
# releasing lets go; in **cut** mode a stroke becomes an incision when the button is released. The **mode**
# buttons above the figure switch the two (so does the key **c**, once a click into the figure has given it
# the keyboard). A timer runs one frame every 33 ms, but only on an interactive canvas: in Jupyter that needs
# ipympl (`pip install "tissuefem[interactive]"`, then this cell switches to `%matplotlib widget`). On any
# other backend (the inline one, or a headless run) nothing runs by itself and code calls `view.step()`.
#
# The 33 ms of a frame must pay for the picture too, so the readout above the axes shows both: the **step**
# (the simulation's frame) **+ the draw** against the budget, and the frames drawn per second. A redraw costs
# a few milliseconds because the view draws what does not move (axes, ticks, labels) once and per frame only
# the moving layer over it: the triangles as two paths whose vertex arrays are overwritten in place, the drag
# target, the stroke. Messages (a failed cut) appear in a fixed place under the axes and never move them.
#
# This section comes last because it may switch the notebook's plotting backend. Running the next cell again
# replaces the view (the old one stops: no hidden timer keeps stepping a simulation you no longer see).

# %%
try:
    import ipympl  # noqa: F401  (pip install "tissuefem[interactive]")
    get_ipython().run_line_magic("matplotlib", "widget")
    INTERACTIVE = True
except ImportError:
    get_ipython().run_line_magic("matplotlib", "inline")
    INTERACTIVE = False
from tissuefem.surgery.interactive import SurgeryView, synthetic_key, synthetic_mouse

sim = Simulation(demo_scene(n_triangles=2000))
view = SurgeryView(sim, autostart=False)
print("interactive canvas:", view.interactive, "| mode:", view.mode)

# %% [markdown]
# What the mouse would do, sent as made-up events through the same canvas callbacks (so this runs headless
# too): grab the right edge, drag it down and out over 15 frames and let go; press **c** and, while the sheet
# swings back, draw a stroke from above it down to below its middle; press **c** again, grab the right edge
# and pull the wound open. Each frame is also drawn (`view.draw()`), as the timer would, to time the picture.
# The cell ends with `view`, which shows the view: on ipympl the live figure with its buttons, once; elsewhere
# a picture.

# %%
def stroke(view, points):
    synthetic_mouse(view, "press", points[0])
    for point in points[1:-1]:
        synthetic_mouse(view, "move", point)
    synthetic_mouse(view, "release", points[-1])


def frame(view):
    view.step()
    view.draw()


events = {}
synthetic_mouse(view, "press", (1.97, 0.5))                       # drag mode: grab ...
for k in range(1, 16):
    synthetic_mouse(view, "move", (1.97 + 0.02 * k, 0.5 - 0.02 * k))   # ... drag ...
    frame(view)
synthetic_mouse(view, "release", (2.27, 0.2))                     # ... let go
synthetic_key(view, "c")                                          # cut mode
stroke(view, [(1.0, 1.35), (1.0, 1.1), (1.0, 0.85), (1.0, 0.6), (1.0, 0.4)])
events["cut"] = len(view.frame_times)
print(f"after the stroke: {view.sim.mesh.nvertices} nodes, {sim.pieces()} piece(s), message {view.message!r}")
for _ in range(5):
    frame(view)
synthetic_key(view, "c")                                          # back to drag mode
synthetic_mouse(view, "press", (1.97, 0.5))
events["grab"] = len(view.frame_times)
for k in range(1, 21):
    synthetic_mouse(view, "move", (1.97 + 0.015 * k, 0.5 - 0.01 * k))
    frame(view)
print(f"mode {view.mode}; handles {list(sim.handles)}; frames {sim.frames}")
view

# %% [markdown]
# The wound gapes where the sheet is pulled. (Run your own drags and you may see the two lips of a wound slide
# *over* each other: nothing in this simulator stops the tissue from passing through itself. Self-collision
# is a chapter of its own.) The time of each frame, the step and the draw stacked, against the 33 ms of a frame:

# %%
steps = np.array(view.frame_times)
draws = np.array(view.draw_times[:len(steps)])  # one draw per frame above (the page may have asked for more since)
fig, ax = plt.subplots(figsize=(6.5, 2.8), layout="constrained")
frames = np.arange(len(steps))
ax.bar(frames, steps, width=0.8, color="C0", label="step (sim.frame)")
if len(draws) == len(steps):
    ax.bar(frames, draws, width=0.8, bottom=steps, color="C1", label="draw")
ax.axhline(1e3 * FRAME_BUDGET, color="C3", lw=1, label="33 ms (1/30 s)")
for name, at in events.items():
    ax.axvline(at - 0.5, color="0.5", ls=":", lw=1)
    ax.text(at - 0.5, 0.95, f" {name}", transform=ax.get_xaxis_transform(), va="top", fontsize=8)
ax.set(xlabel="frame", ylabel="ms", title=f"{sim.mesh.nelements} triangles, dynamic, stable neo-Hookean",
       ylim=(0, None))
ax.legend(fontsize=8, loc="upper right")
ax.grid(alpha=0.3, axis="y")
timing = view.timings()
print(f"medians: step {timing['step_ms']:.1f} ms + draw {timing['draw_ms']:.1f} ms "
      f"= {timing['total_ms']:.1f} ms of {timing['budget_ms']:.0f} ms")

# %% [markdown]
# The first draw costs more: it draws the axes and ticks once, for all the frames after it. In the browser a
# draw also encodes the picture as PNG for the page, which costs a few milliseconds more than here.
#
# With ipympl, the next cell starts the timer: the view above comes alive. Drag the tissue with the mouse,
# click **cut** and cut it, and watch the readout. (`view.stop()` or the **run** button stops it.)

# %%
if INTERACTIVE:
    view.start()

# %% [markdown]
# ## What to try
# - Write a scene of your own in TOML: the example with `[effects.fibers]` (`stiffness = 500.0`,
#   `direction = [0.0, 1.0]`) and a probe. Save it, run `python -m tissuefem scene your_scene.toml -v`.
# - Cut the pulled sheet of section 5 with strokes of different lengths. How does the opening at the top
#   edge grow with the depth of the cut? What happens to the largest tension when you use 4800 triangles
#   instead of 1200?
# - Cut a crack that starts and ends inside the body (`sim.cut([[0.6, 0.5], [1.4, 0.5]])`) in a sheet pulled
#   *up* by its top edge. Which nodes were copied? Does it open?
# - Press the probe with `stiffness=1e5` into a *dynamic* block. Does the tissue bounce off the tool?
# - Close the incision of section 7 in one frame (`tightness=1.0` at once) in a *dynamic* scene and compare
#   with tightening over ten frames: watch `sim.positions()` of the lips after each frame.
# - Compare flap lengths 0.6 to 2.0 with `advancement_flap`, and the same flap at 1000, 2000 and 4000
#   triangles: which of `max_tension`, `p95_tension` and `flap_tension` depend on the mesh?
# - A rotation flap: with `flaps.pair_by_motion` and a rotation about a pivot, plan stitches for a flap cut
#   along an arc.
# - Run `python -m tissuefem bench scenes` and read which effect costs most at 8000 triangles.
#
# ## Exercises (graded by pytest)
# In `exercises/ch08.py`:
# - **8.1** `duplicate_cut_nodes(t, n_nodes, cut_edges)` — duplicate the nodes along a cut, fan by fan, so
#   that the cut edges open (section 5); graded by invariants (how many copies, `parent[new_t] == t`, which
#   edges are still shared, how many pieces), not by one particular numbering;
# - **8.2** `scene_file_text()` — write a scene as TOML text, as described in the stub; it is checked by
#   loading it with `Scene.from_toml` and building it.
#
# Grade: `python -m tissuefem grade ch08`.
