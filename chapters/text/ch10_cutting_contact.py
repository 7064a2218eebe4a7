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
# # Chapter 10 — Cutting through elements, and wound edges that touch
#
# **Goals.** By the end of this chapter you can
# 1. say why a cut snapped to mesh edges gives an answer that depends on the mesh, and measure it;
# 2. describe the *virtual node algorithm*: how a triangle the scalpel crosses becomes copies that each
#    carry part of its material, which nodes they share and where the crack ends;
# 3. check a cut against a closed form (Griffith's crack) and against conservation of mass and momentum;
# 4. stitch points of a wound that lies inside elements, and redo chapter 8b's flap and a rotation flap;
# 5. keep the lips of a wound from passing through each other with a contact energy.
#
# *Time: about 50 min to read and run, and four exercises.*
#
# *Reading:* the notes' introduction (reconstructive surgery, their Figure 1 and reference [3]); N. Molino,
# Z. Bao and R. Fedkiw, *A virtual node algorithm for changing mesh topology during simulation*, SIGGRAPH
# 2004 (Teran's group's standard remedy for cutting); for contact, M. Li et al., *Incremental Potential
# Contact*, SIGGRAPH 2020.
#
# **Index convention.** As in every chapter, $F_{ij} = \partial\phi_i/\partial X_j$; node $a$ sits at
# $\mathbf X_a$ in the reference configuration and at $\mathbf x_a$ now; element $e$ has reference area
# $A_e$.

# %%
# %matplotlib inline
import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

from tissuefem import Scene, Simulation, rectangle
from tissuefem.surgery.element_cuts import cut_through, lumped_mass
from tissuefem.surgery.flaps import advancement_flap, rotation_flap
from tissuefem.workbook.cracks import griffith_closed_form, griffith_opening
from tissuefem.workbook.figures.cutting import (fig_ch10_contact, fig_ch10_cut_through, fig_ch10_flaps,
                                                fig_ch10_virtual_nodes)
from tissuefem.workbook.procedures import crack_opening, crack_runs
from tissuefem.workbook.tables import markdown_table

# %% [markdown]
# ## 1. A cut that follows the mesh is a property of the mesh
#
# Chapter 8a cut the tissue the simplest way: the stroke is replaced by the nearest path of mesh edges and
# the nodes on that path are duplicated. No triangle is ever split, so nothing new has to be integrated.
# The price shows when the mesh changes. Below, the same slanted crack is drawn on a pulled sheet meshed
# with 1 200 and with 2 600 triangles. Snapped to edges (top row), the wound is a staircase whose steps,
# length and direction belong to each mesh, and so does the crack's opening at its mouth. Cut through
# the elements (bottom row), the wound is the drawn line on both meshes. The sentence under the table
# is written by the run: how much each way's opening moves from one mesh to the other.

# %%
crack = crack_runs()
display(fig_ch10_cut_through(runs=crack))
rows = [{"cut": method, "triangles": n, "elements": sim.mesh.nelements, "opening": crack_opening(sim, edit)}
        for (method, n), (sim, edit) in crack.items()]
display(Markdown(markdown_table(rows, [("cut", "cut", "{}"), ("triangles", "triangles", "{}"),
                                       ("elements", "elements after the cut", "{}"),
                                       ("opening", "opening at the mouth", "{:.4f}")], text_columns=1)))
opening = {(method, n): row["opening"] for (method, n), row in zip(crack, rows)}
small, large = sorted({n for _, n in crack})
change = {method: abs(opening[(method, large)] / opening[(method, small)] - 1) for method in ("edges", "elements")}
display(Markdown(f"From {small} to {large} triangles the opening at the mouth changes by {100 * change['edges']:.1f} % "
                 f"when the cut is snapped to edges, by {100 * change['elements']:.2f} % when it is cut through "
                 "the elements."))

# %% [markdown]
# A surgeon plans an incision by its length and direction; a simulator whose answer moves when the mesh
# is refined cannot be trusted to compare two plans. (Refining far enough shrinks the staircase, but
# real-time meshes are coarse.)
#
# ## 2. The virtual node algorithm
#
# Molino, Bao and Fedkiw cut *through* elements without building a new mesh. In 2D it goes like this.
#
# 1. **Where the stroke lies.** Inside one triangle the map $\phi$ is affine (P1), so a straight piece of
#    the stroke drawn on the deformed tissue is straight in the reference triangle too, with the same
#    barycentric coordinates $\lambda_k$. Each piece is found by keeping the part of the segment where all
#    three $\lambda_k \ge 0$ (Exercise 10.1).
# 2. **Split, don't remesh.** A triangle that the stroke separates into $k$ pieces becomes $k$ *copies*.
#    Every copy keeps the whole reference triangle, hence the same shape functions $N_a$ and the same
#    constant $\nabla_{\mathbf X} N_a$, but carries only the material of its piece: its *weight* $w$ is
#    the piece's share of the triangle's area (Exercise 10.2). Its energy and mass are the triangle's
#    times $w$:
#    $$E_{\text{copy}} = w\,A_e\,\Psi(\mathbf F_{\text{copy}}), \qquad m_{\text{copy}} = w\,\rho A_e,$$
#    with $\mathbf F_{\text{copy}} = \sum_a \mathbf x_a \otimes \nabla_{\mathbf X} N_a$ taken over the
#    copy's own three nodes.
# 3. **Virtual nodes.** A copy needs all three corners, but its material lies near only some of them. At
#    a vertex its material does not touch, the copy gets a *virtual node*: a new node that it shares with
#    the other copies on the same side of the cut (those joined to it across an edge where both hold
#    material). Two copies on opposite sides share no node, so the two sides move independently.
# 4. **The crack tip.** The triangle holding the end of the stroke is *not* split: its material is still
#    one piece. The two copies of the triangle through which the crack enters it both share its edge's
#    nodes, so the opening grows linearly from zero at that edge: the crack closes within one element of
#    the drawn tip.
#
# Slivers (a piece holding less than 0.1 % of its triangle) are merged into their neighbour and the cut
# is snapped onto the triangle's edges there; the drawn wound stays where it was drawn.
#
# A thin piece that is kept holds its virtual nodes with as little stiffness as it has material, and a
# pull on its lip (a grab, a stitch, contact) reaches them through the point's weights: they would fly
# out as spikes. The model therefore adds a *ghost penalty* (E. Burman, *Ghost penalty*, C. R. Acad. Sci.
# Paris 2010) between each copy that holds part of a triangle and each element beside it across an edge,
# $$E_{\text{ghost}} = \tfrac{\gamma\,\mu}{2}\,(A_e + A_f)\,\lvert\nabla\mathbf u_e - \nabla\mathbf u_f\rvert^2,$$
# with $\mu$ the shear modulus and $\gamma$ a small constant. It is zero for any linear displacement (a
# patch test still passes) and any rigid motion, shrinks with the mesh, and an uncut mesh has none.

# %%
display(fig_ch10_virtual_nodes())

mesh = rectangle(2.0, 1.0, 4, 2)
cut = cut_through(mesh, [[0.62, 1.1], [0.9, 0.6], [1.05, 0.35]])
print(f"{mesh.nelements} triangles -> {cut.mesh.nelements} elements; {mesh.nvertices} nodes -> "
      f"{cut.mesh.nvertices} ({cut.mesh.nvertices - mesh.nvertices} virtual)")
touched = np.array(sorted(cut.regions))  # the elements the stroke crosses or ends in
print(f"the stroke touches {touched.size} elements: {int((cut.weights[touched] < 1).sum())} copies that hold part "
      f"of a triangle, weights {np.round(np.sort(cut.weights[cut.weights < 1]), 3)}, and "
      f"{int((cut.weights[touched] == 1).sum())} whole triangle, the crack tip's")
print("the copies of each cut triangle add up to it:",
      np.allclose(np.bincount(cut.elements, weights=cut.weights), 1.0))

# %% [markdown]
# In the library the weights go straight into the assembler: `Model(mesh, material, weights=cut.weights)`
# integrates each element over its share, and everything else (the model's terms, Newton, the linear
# solvers, the real-time loop) is unchanged. A copy is an element like any other.
#
# ### Nothing lost: mass and momentum
#
# Each copy's lumped mass is a third of its material's mass at each of its nodes. A vertex's copies
# therefore hold together exactly what the vertex held, and giving every copy its parent's velocity keeps
# the momentum $\sum_a m_a \mathbf v_a$ to round-off:

# %%
before = lumped_mass(mesh)
after = lumped_mass(cut.mesh, cut.weights)
print("total mass before / after:", before.sum(), after.sum())
print("mass of each original node == mass of its copies:",
      np.allclose(np.bincount(cut.parent, weights=after), before))
velocity = np.random.default_rng(0).normal(size=(2, mesh.nvertices))
print("momentum before / after:", (velocity * before).sum(axis=1), (velocity[:, cut.parent] * after).sum(axis=1))

# %% [markdown]
# ### A closed form: Griffith's crack
#
# A straight crack of length $2a$ in a large plate pulled by the stress $\sigma$ across it opens, in plane
# strain and small strains, by
# $$\delta = \frac{4\sigma a\,(1-\nu^2)}{E}$$
# at its centre (Griffith 1921; Tada, Paris and Irwin's handbook gives the factor
# $\sqrt{\sec(\pi a/W)}$ for a plate of width $W$). Below, `griffith_opening` cuts the crack through the
# elements of three meshes of a $10\times 10$ plate (`cut_through`, then `Model(..., weights=cut.weights)`
# and `solve`) and reads the jump between the two lips of the wound; the test suite runs the same check
# (`tests/workbook/test_cutting.py::test_a_crack_cut_through_elements_opens_as_griffiths_crack`).

# %%
E, nu = 1000.0, 0.3
exact = griffith_closed_form(a=1.0, width=10.0, stress=1.0, E=E, nu=nu)
print(f"closed form: delta = {exact:.5f}")
rows = []
for n in (40, 80, 160):
    elements, delta = griffith_opening(n, a=1.0, width=10.0, stress=1.0, E=E, nu=nu)
    rows.append({"elements": elements, "delta": delta, "ratio": delta / exact})
display(Markdown(markdown_table(rows, [("elements", "elements", "{}"), ("delta", "opening δ", "{:.5f}"),
                                       ("ratio", "δ / closed form", "{:.3f}")])))
errors = [1 - row["ratio"] for row in rows]
extrapolated = 2 * rows[-1]["ratio"] - rows[-2]["ratio"]  # first order: the next error would be half the last
display(Markdown(f"Each refinement divides the error by {errors[0] / errors[1]:.2f} and then "
                 f"{errors[1] / errors[2]:.2f}: first order, because the crack tip is resolved to one element. "
                 f"Extrapolated, the openings meet the closed form within {100 * abs(1 - extrapolated):.1f} %."))

# %% [markdown]
# ## 3. Cutting a running simulation
#
# `Simulation.cut(stroke)` now cuts through the elements (`method="elements"`, the default); chapter 8a's
# cut is `method="edges"`. The stroke is drawn on the tissue as it is now, the state (displacement,
# velocity, time) carries over, and the weights and regions are kept for the next cut, so cuts can cross.
# In a scene file an incision or an excision names its method the same way. The interactive view of
# chapter 8b cuts through the elements along the mouse stroke, and draws each copy as the material it
# carries (`Simulation.picture`).

# %%
scene = Scene(domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 900},
              material={"model": "stable-neo-hookean", "youngs_modulus": E, "poisson_ratio": nu},
              effects={"handles": [{"name": "fixed", "region": "left"}], "inertia": {},
                       "gravity": {"acceleration": [0.0, -9.81]}},
              solver={"budget": 1e9})
sim = Simulation(scene)
sim.run(5)
mass, momentum = sim.total_mass(), sim.momentum()
sim.cut([[0.8, 1.2], [1.3, -0.2]])  # through the whole sheet
sim.cut([[0.5, 0.2], [1.7, 0.7]])  # crossing the first
print(f"pieces {sim.pieces()}; mass kept: {np.isclose(sim.total_mass(), mass, rtol=1e-12)}; "
      f"momentum kept: {np.allclose(sim.momentum(), momentum, rtol=1e-11, atol=1e-13)}")
sim.run(15)
fig, ax = plt.subplots(figsize=(6, 3.2))
picture = sim.picture
ax.triplot(*picture.points(sim.positions()), picture.triangles.T, lw=0.3, color="0.3")
ax.set_aspect("equal")
ax.set_title("two crossing cuts through the elements; the free piece falls")
plt.show()

# %% [markdown]
# ## 4. Stitches on a wound inside elements, and the flaps redone
#
# Chapter 8b tied wound *nodes* together. A wound cut through elements has no nodes on it: its lips are
# edges of the copies' material. A stitch end is therefore a *point of the material*: an element and the
# barycentric coordinates $\lambda$ of the point in it, so that $\mathbf x_{\text{end}} = \sum_k \lambda_k
# \mathbf x_{a_k}$ and the spring's force is spread over the three nodes with the weights $\lambda_k$. The
# suture term stays quadratic: $E = \tfrac{k}{2}\,|\mathbf D\mathbf x - \mathbf g|^2$ with $\mathbf D$ the
# (constant) map from the nodes to the gap.
#
# One care: a copy that holds a thin sliver of its triangle has as little stiffness as material, so a
# stitch pulling on it would stretch the sliver instead of the skin. Such an end is carried by the firm
# element next to it on the same side (its P1 map extended to the point).
#
# The flaps of chapter 8b and a *rotation flap* (a wedge-shaped defect closed by turning the flap beside
# it about its pivot) are redone below, each beside the edge-snapped version, on two meshes.

# %%
flaps = {}
for name, procedure in (("advancement", advancement_flap), ("rotation", rotation_flap)):
    for method in ("edges", "elements"):
        for n in (1500, 3000):
            flaps[(name, method, n)] = procedure(n_triangles=n, tighten_frames=8, method=method)
display(fig_ch10_flaps(runs=flaps))
rows = [{"flap": name, "cut": method, "triangles": n, "stitches": r.stitches, "flap_tension": r.flap_tension,
         "mean": r.mean_tension, "p95": r.p95_tension, "gap": r.max_gap} for (name, method, n), r in flaps.items()]
display(Markdown(markdown_table(rows, [("flap", "flap", "{}"), ("cut", "cut", "{}"), ("triangles", "triangles", "{}"),
                                       ("stitches", "stitches", "{}"),
                                       ("flap_tension", "mean tension in the flap", "{:.0f}"),
                                       ("mean", "mean over the whole skin", "{:.0f}"),
                                       ("p95", "95th percentile over the whole skin", "{:.0f}"),
                                       ("gap", "gap left", "{:.1e}")],
                                 text_columns=2)))

# %% [markdown]
# The first tension is a mean over the flap alone; the other two are over the whole skin, where most of
# the area is barely stretched and the tension gathers at the ends of the wound, so a 95th percentile over
# the skin can lie below the flap's mean (tensions in the model's units, with $E = 1000$).
#
# Read the table by pairs of rows. Cut through the elements, a flap's report barely moves when the mesh
# is refined: the flap is the drawn one. Snapped to edges, the defect is the set of triangles whose
# centroids fall inside it, and the incisions are staircases: the flap's size and shape, and its tension,
# change with the mesh (the rotation flap's arc is the worst case: a curve made of edges).

# %% [markdown]
# ## 5. Wound edges that touch but never pass through
#
# Nothing so far keeps two parts of the boundary apart: a closed incision's lips, a flap folded onto its
# bed or a sheet pressed onto itself pass through each other as if the other were not there. Self-contact
# is one more term of the incremental potential (`effects.contact` in a scene; `Model(..., contact=...)`).
#
# **The surface.** Its points are fixed combinations of node positions, $\mathbf y_i = \sum_k W_{ik}
# \mathbf x_{a_k}$: a boundary node, or a point on a lip cut through an element (the barycentric
# combination of the copy's three nodes). Its segments have the material on their left, so the outward
# normal of a segment $\mathbf y_a \to \mathbf y_b$ is its tangent turned clockwise.
#
# **The energy.** IPC (Li et al. 2020) puts a barrier $b(d) = -(d-\hat d)^2 \ln(d/\hat d)$ on the distance
# $d$ between a point and a segment: infinite at $d = 0$, so surfaces never touch. A freshly cut wound has
# its lips *at* $d = 0$ everywhere, and a closed wound must be allowed to stay closed. So the gap here is
# *signed*, $\sigma = \mathbf n \cdot (\mathbf y_p - \mathbf y_a)$ (Exercise 10.3), and the barrier acts
# *behind* the surface, in a skin of depth $\hat d$:
# $$E_p = \kappa\, l_p\, \hat d\, \beta\!\left(1 + \frac{\sigma}{\hat d}\right), \qquad
#   \beta(\zeta) = -(\zeta - 1)^2 \ln \zeta \;\;(0<\zeta<1), \quad \beta = 0 \;\;(\zeta \ge 1),$$
# with $\kappa$ a pressure and $l_p$ the length of surface the point stands for (Exercise 10.4). Lips that
# touch feel nothing; pressed together they push back, twice differentiably from the first touch, and
# infinitely hard before a point is $\hat d$ deep.
#
# **Never through.** An energy alone cannot stop a large Newton step from jumping a point across a
# segment (both ends of the step outside). The minimiser therefore asks the term for the largest
# fraction of every step that is free of crossings (continuous collision detection: the time a moving
# point meets a moving segment solves a polynomial in $t$) and takes at most 0.8 of it, as IPC does; the
# stepper cuts its warm start the same way.
#
# **Pay for nothing else.** Only pairs closer than a few skins are examined (a neighbour list refreshed
# when points move relative to each other), and the Hessian's sparsity pattern is widened only when a new
# pair needs it. A scene without `contact` builds no such term.

# %%
fig_ch10_contact()

# %% [markdown]
# The flaps with contact on: the flap's edges slide along the wound's lips as the stitches pull it in.

# %%
for name, procedure in (("advancement", advancement_flap), ("rotation", rotation_flap)):
    r = procedure(tighten_frames=10, contact=True)  # 3 000 triangles
    contact = r.simulation.model.contact
    print(f"{name} flap with contact: {r.summary()}")
    print(f"   frames converged {sum(x.converged for x in r.reports)} of {len(r.reports)}; "
          f"deepest press {contact.overlap(r.simulation.u) / contact.distance:.2f} of the skin")

# %% [markdown]
# Both close with every frame converged, and the flaps' tension is what it was without contact (the lips
# only touch). Contact is not free of trouble yet: on a coarser mesh, or tightened in 20 smaller steps,
# a frame of the advancement flap can stall in the line search. The lips cut through elements are chains of
# short pieces whose corners crumple as they slide, and where a point passes a folded corner the sign of
# its gap can flip within the skin: the energy jumps there (`tissuefem.engine.contact`, "Where the energy
# jumps"). The state stays valid (nothing crosses); the frame reports that it did not converge.
#
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Cut the Griffith plate's crack at an angle and compare the opening across the crack with
#   $\delta\cos\theta$ for the stress component normal to it.
#
# ```python
# import math
# import numpy as np
# from tissuefem import Handle, LinearElastic, Model, lame_parameters, rectangle, solve
# from tissuefem.surgery.element_cuts import cut_through
# from tissuefem.workbook.cracks import griffith_closed_form, lip_opening
#
# E, nu, width, n = 1000.0, 0.3, 10.0, 40
# mesh = rectangle(width, width, n, n)
# cut = cut_through(mesh, [[4.2, 4.6], [5.8, 5.4]])       # a crack at about 27 degrees through the middle
# p = cut.mesh.p
# held = [np.array([int(np.argmin(np.hypot(p[0] - x, p[1] - 5.0)))]) for x in (0.0, width)]
# model = Model(cut.mesh, LinearElastic(*lame_parameters(E, nu)), weights=cut.weights,
#               handles=[Handle(q) for q in held], tractions={"top": (0.0, 1.0), "bottom": (0.0, -1.0)})
# u = solve(model).u
# theta, a = math.atan2(0.8, 1.6), 0.5 * math.hypot(1.6, 0.8)
# print(f"opening at the centre {lip_opening(cut.wound, p + u.reshape(-1, 2).T, 5.0):.5f}; "
#       f"delta cos(theta) = {griffith_closed_form(a=a, width=width, E=E, nu=nu) * math.cos(theta):.5f}")
# ```
#
# - Make the rotation flap wider: does its tension fall, as the rule of thumb says?
#
# ```python
# from tissuefem.surgery.flaps import rotation_flap
#
# for angle in (120.0, 150.0):
#     r = rotation_flap(n_triangles=1500, flap_angle=angle, tighten_frames=8)
#     print(f"flap angle {angle:.0f}: mean tension in the flap {r.flap_tension:.0f}, 95th percentile {r.p95_tension:.0f}")
# ```
#
# - Cut the running sheet of section 3 with `method="edges"` instead, and compare the pictures after the
#   same frames.
#
# ```python
# import matplotlib.pyplot as plt
# from tissuefem import Scene, Simulation
#
# fig, axes = plt.subplots(1, 2, figsize=(11, 3))
# for ax, method in zip(axes, ("elements", "edges")):
#     sim = Simulation(Scene(domain={"shape": "rectangle", "width": 2.0, "height": 1.0, "triangles": 900},
#                            material={"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
#                            effects={"handles": [{"name": "fixed", "region": "left"}], "inertia": {},
#                                     "gravity": {"acceleration": [0.0, -9.81]}},
#                            solver={"budget": 1e9}))
#     sim.run(5)
#     sim.cut([[0.8, 1.2], [1.3, -0.2]], method=method)
#     sim.cut([[0.5, 0.2], [1.7, 0.7]], method=method)
#     sim.run(15)
#     picture = sim.picture
#     ax.triplot(*picture.points(sim.positions()), picture.triangles.T, lw=0.3, color="0.3")
#     ax.set(aspect="equal", title=f'method="{method}"')
# ```
#
# - Switch contact on in a scene of your own, fold it with a handle, and watch `report.crossed` (a handle
#   that drags tissue through tissue is obeyed and reported).
#
# ```python
# from tissuefem import Scene, Simulation
#
# sim = Simulation(Scene(domain={"shape": "rectangle", "width": 2.0, "height": 0.4, "triangles": 400},
#                        material={"model": "stable-neo-hookean", "youngs_modulus": 1000.0, "poisson_ratio": 0.3},
#                        effects={"contact": {}, "handles": [{"name": "fixed", "region": "left"},
#                                                            {"name": "tip", "region": "right"}]},
#                        solver={"budget": 1e9}))
# for k in range(1, 21):
#     report = sim.frame({"tip": (-1.6 * k / 20, 0.7 * k / 20)})     # fold the strip back over itself
# print(f"terms {sim.terms}; last frame {report.status}; crossed: {report.crossed}")
# ```
#
# ## Exercises
#
# In `exercises/ch10.py`, graded by `python -m tissuefem grade ch10`:
#
# - **10.1** Clip a straight stroke to a triangle with barycentric coordinates (step 1 of the algorithm).
# - **10.2** The area shares of the two pieces of a triangle cut by a line: the copies' weights.
# - **10.3** The signed gap of a point to a segment, and why a cut's lips need a sign.
# - **10.4** The skin's barrier energy and its derivative in the gap.
