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
# # Chapter 8a — Virtual surgery: scenes, pulling, probing and cutting
#
# **Goals.** By the end of this chapter you can
# 1. describe a simulation as a *scene* (a small TOML file: domain, material, effects) and check that the
#    simulator builds exactly the energy terms the scene calls for, and no others;
# 2. apply the operations of a surgical simulator to a running simulation, between two frames: pull and
#    drag the tissue, press a tool into it, cut it (node duplication along mesh edges) and cut a piece off;
# 3. say why a contact penalty must act on the surface, and what its stiffness buys and costs.
#
# *Time: about 50 min to read and run, and two exercises.* Chapter 8 comes in two sittings; chapter 8b
# stitches, runs a whole procedure (a local flap), measures what each effect costs and hands the tissue to
# the mouse.
#
# *Reading:* the notes' introduction ("Real-time computing": the simulator the whole course aims at) and the
# loop of the "Time stepping" section. Cutting along mesh edges is the simplest way to change a mesh's
# topology; Molino, Bao and Fedkiw, *A virtual node algorithm for changing mesh topology during simulation*
# (SIGGRAPH 2004), cut through elements instead.
#
# **Index convention.** As everywhere (chapter 3), $F_{ij} = \partial\phi_i/\partial X_j$, formulas count from 1
# and code from 0; node $a$ sits at $\mathbf X_a$ in the reference configuration and at
# $\mathbf x_a = \mathbf X_a + \mathbf u_a$ now.

# %%
# %matplotlib inline
import tempfile
from pathlib import Path

import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

from tissuefem.surgery import topology as surgery
from tissuefem.workbook.figures.surgery import draw_mesh, fig_ch08_incision, fig_ch08_probe, fig_ch08_two_pieces
from tissuefem.workbook.procedures import probe_indentation, sheet_scene
from tissuefem import FRAME_BUDGET, Scene, Simulation, rectangle
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
# | removes a lesion | the mesh: elements are deleted | chapter 8b |
# | stitches a wound | a new term of the energy (springs between pairs of nodes) | chapter 8b |
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
dragged = {}
for name, s in [("linear", linear), ("stable neo-Hookean", scene)]:
    sm = Simulation(s)
    fac, newton, ms = dragged[name] = drag(sm)
    print(f"{name:19s} {sm.solver.linear_solver_name:22s} factorizations in 60 frames: {fac:3d}, "
          f"Newton steps per frame {newton:.2f}, median {ms:.1f} ms")

# %%
fac, newton, _ = dragged["stable neo-Hookean"]
display(Markdown(
    "(The nonlinear scene reuses its factorization too, as the preconditioner of conjugate gradients, chapter 7: "
    f"it needs {newton:.2f} Newton steps per frame, and over the 60 frames it factorised "
    + ("only once" if fac == 1 else f"{fac} times") + ". The linear model is only trustworthy for small strains, "
    "chapter 3; it is in the workbook as a baseline.)"))

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
# a constraint, we add an energy that grows as the tissue's surface enters the disc. Contact acts on the
# surface, so the penalty is a pressure on the boundary: each **boundary** node $a$ carries its share $l_a$
# of the boundary's length (half the length of each boundary edge it ends; an area in 3D). With
# $d_a = |\mathbf x_a - \mathbf c|$, the penetration $g_a = R - d_a$ and the outward normal
# $\mathbf n_a = (\mathbf x_a - \mathbf c)/d_a$,
#
# $$E_{\text{probe}}(\mathbf u) = \sum_{a \text{ on the boundary},\ g_a > 0} k\,l_a\,h(g_a),
#   \qquad \mathbf f_a = -\frac{\partial E_{\text{probe}}}{\partial \mathbf x_a} = k\,l_a\,h'(g_a)\,\mathbf n_a ,$$
#
# with $h(g) \approx g^2/2$: the force pushes each node inside the disc straight out, in proportion to how deep
# it is. (Exactly, $h$ starts as a cubic over a small depth $\delta = R/50$ and continues as a quadratic, so
# the force and its derivative grow from zero smoothly as a node enters the disc.) $k$ is a pressure per unit
# penetration and $k\,h'(g)$ a force per unit length of surface, whatever the mesh: the weights $l_a$ make
# the penalty **mesh independent**. Weighting the nodes by the area around them instead (a third of each
# triangle) would make the force per unit surface grow like $1/h$ as the mesh is refined. The Hessian,
# $k\,l_a\big[h''\,\mathbf n_a\mathbf n_a^T - \tfrac{h'}{d_a}(\mathbf I - \mathbf n_a\mathbf n_a^T)\big]$, has a negative
# tangential part (the disc is curved); Newton uses it as it is, and falls back on the positive normal part
# alone where a step would not point downhill (chapter 6's safeguards).
#
# A penalty always leaves some **penetration**: the tissue pushes back until $k\,h'(g)$ balances its
# pressure. Why not take $k$ huge, then? The Hessian blocks of the penalty then dwarf the tissue's stiffness,
# the linear systems become badly conditioned and Newton needs more steps. The default is $k = 100\,E/R$
# (`probe_indentation` below is the indentation of the figure further down: depth 0.2 in four frames):

# %%
for k in (1e4, 1e5, 1e6, 1e7, 1e8):
    run = probe_indentation(1200, stiffness=k)
    print(f"k = {k:.0e}: penetration left {run['penetration']:.1e}, Newton steps in the 4 frames {run['newton']}")
for n in (600, 1200, 4800):
    run = probe_indentation(n)
    print(f"{run['triangles']:5d} triangles, default k = {run['stiffness']:.0f}: penetration left {run['penetration']:.2e}")

# %% [markdown]
# Ten times the stiffness leaves about a third of the penetration (for $k \ge 10^6$; the pressure does not
# grow with $k$, but the tissue's surface wraps around the disc), and costs Newton steps: from 4 or 5 per
# frame at $k = 10^4$ to 11 to 17 at $10^8$. And the same push leaves the same penetration on every mesh: the
# three meshes above agree to within a few per cent (the test suite checks 600 to 12 000 triangles).
#
# The figure presses a disc ever deeper into a block held on its bottom edge (default stiffness). Arrows: the
# nodal contact forces $\mathbf f_a$. Right: the force the tool feels, which a haptic device would play back
# to the surgeon's hand. The tissue is coloured by its **tension**, the largest principal value of the
# Cauchy stress $\boldsymbol\sigma = \mathbf P\mathbf F^T/J$ (chapter 3, Figure 2): the true force per unit
# deformed length across the line (the plane, in 3D) on which it is largest; positive where the tissue is
# pulled apart.

# %%
fig_ch08_probe()

# %% [markdown]
# ## 5. An incision: duplicating nodes
#
# A P1 triangle cannot hold a crack inside it, so the simplest scalpel follows mesh edges: the stroke the user
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
# (Chapter 10 cuts through the triangles instead, with the virtual node algorithm, and that is what
# `Simulation.cut` does by default; this chapter asks for the edge-snapping cut with `method="edges"`.)
# On a running simulation, `sim.cut(polyline, method="edges")` does all of this on the *deformed* tissue (the stroke is drawn
# where the user sees the tissue), builds the new mesh and model, and carries the state over: each copy
# starts with the displacement and the velocity of the node it was copied from (`MeshEdit.transfer`). No
# element is lost, so the **mass** is unchanged; no velocity changes, and the lumped masses of a node's
# copies add up to the node's mass, so the **momentum** is unchanged too:

# %%
sim = Simulation(sheet_scene(800, handles=[{"name": "fixed", "region": "left"}], dynamic=True, gravity=True))
sim.run(5)
mass, momentum, nodes, elements = sim.total_mass(), sim.momentum(), sim.mesh.nvertices, sim.mesh.nelements
edit = sim.cut([[1.2, 1.3], [1.2, 0.4]], method="edges")   # from above the top edge to inside the sheet
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
sim.cut([[1.0, 1.3], [1.0, -0.3]], method="edges")
count, labels = surgery.connected_components(sim.mesh.t, sim.mesh.nvertices)
held = labels[sim.handles["fixed"].nodes[0]]
print(f"{sim.pieces()} pieces: {np.sum(labels == held)} nodes held, {np.sum(labels != held)} nodes free")

# %% [markdown]
# The filmstrip (`python -m tissuefem figures` also writes it as the animation
# `figures/fig_ch08_two_pieces.gif`):

# %%
fig_ch08_two_pieces()

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Write a scene of your own in TOML: the example with fibers and a probe. Build it, run it, save it, and
#   check it from the command line (`python -m tissuefem scene your_scene.toml -v`).
#
# ```python
# import tempfile
# from pathlib import Path
# from tissuefem import Scene, Simulation
# from tissuefem.surgery.scene import EXAMPLE_TOML
#
# text = EXAMPLE_TOML + """
# [effects.fibers]
# stiffness = 500.0
# direction = [0.0, 1.0]
#
# [[effects.probes]]
# center = [1.0, 1.1]
# radius = 0.2
# """
# scene = Scene.from_toml(text)
# sim = Simulation(scene)
# reports = sim.run(5)
# print("terms:", sim.terms, "| last frame:", reports[-1].status)
# path = Path(tempfile.mkdtemp()) / "your_scene.toml"
# scene.save(path)
# print("saved as", path)
# ```
#
# - Cut the pulled sheet of section 5 with strokes of different lengths. How does the opening at the top
#   edge grow with the depth of the cut? What happens to the largest tension on a finer mesh?
#
# ```python
# import numpy as np
# from tissuefem import Simulation
# from tissuefem.workbook.procedures import sheet_scene
#
# for n, end in ((1200, 0.7), (1200, 0.4), (4800, 0.4)):
#     sim = Simulation(sheet_scene(n, handles=[{"name": "fixed", "region": "left"},
#                                              {"name": "pull", "region": "right", "target": [0.4, 0.0]}]))
#     sim.frame()
#     n_before = sim.mesh.nvertices
#     edit = sim.cut([[1.0, 1.2], [1.0, end]], method="edges")
#     sim.frame()
#     copies = np.arange(n_before, sim.mesh.nvertices)
#     top = copies[np.argmax(sim.mesh.p[1, copies])]              # the copy on the top edge ...
#     x = sim.positions()
#     opening = np.hypot(*(x[:, top] - x[:, edit.parent[top]]))  # ... and how far it is from its original
#     print(f"{sim.mesh.nelements} triangles, cut down to y = {end}: opening at the top {opening:.3f}, "
#           f"largest tension {sim.tension().max():.0f}")
# ```
#
# - Cut a crack that starts and ends inside the body, in a sheet pulled *up* by its top edge. Which nodes
#   were copied? Does it open?
#
# ```python
# import numpy as np
# from tissuefem import Simulation
# from tissuefem.workbook.procedures import sheet_scene
#
# sim = Simulation(sheet_scene(1200, handles=[{"name": "base", "region": "bottom"},
#                                             {"name": "pull", "region": "top", "target": [0.0, 0.3]}]))
# sim.frame()
# n_before = sim.mesh.nvertices
# edit = sim.cut([[0.6, 0.5], [1.4, 0.5]], method="edges")
# sim.frame()
# copies = np.arange(n_before, sim.mesh.nvertices)
# x = sim.positions()
# print(f"{copies.size} nodes copied, at X1 = {np.round(sim.mesh.p[0, copies], 2)}")
# print(f"widest opening {np.hypot(*(x[:, copies] - x[:, edit.parent[copies]])).max():.3f}")
# ```
#
# - Press a soft probe into a *dynamic* block and hold it there. Does the tissue bounce off the tool?
#
# ```python
# from tissuefem import Simulation
# from tissuefem.workbook.procedures import sheet_scene
#
# sim = Simulation(sheet_scene(800, handles=[{"name": "base", "region": "bottom"}], dynamic=True))
# tool = sim.add_probe([1.0, 1.25], radius=0.25, stiffness=1e5)
# for frame in range(16):
#     sim.move_probe(tool, [1.0, 1.25 - 0.05 * min(frame + 1, 4)])
#     sim.frame()
#     print(f"frame {frame + 1:2d}: penetration {sim.model.probes[0].penetration(sim.u):.4f}")
# ```
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
