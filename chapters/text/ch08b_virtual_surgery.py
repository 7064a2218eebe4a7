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
# # Chapter 8b — Virtual surgery: stitches, a local flap, the cost of each effect, and the mouse
#
# **Goals.** By the end of this chapter you can
# 1. stitch a wound closed with zero-length springs, tightened gradually;
# 2. run a whole procedure, a local advancement flap, and read its tension report;
# 3. say what each effect costs per frame, and why a linear scene costs almost nothing;
# 4. operate on the tissue with the mouse;
# 5. give a haptic device the tool's force at 1 kHz from a reduced model of the last frame.
#
# *Time: about 60 min to read and run.* The second sitting of chapter 8: it uses the scenes, the sheet and
# the cuts of chapter 8a.
#
# *Reading:* the loop of the notes' "Time stepping" section. The procedure of section 1 follows Sifakis,
# Hellrung, Teran, Oliker and Cutting, *Local flaps: a real-time finite element based solution to the plastic
# surgery defect puzzle* (2009), the notes' reference [3].
#
# **Index convention.** As everywhere (chapter 3), $F_{ij} = \partial\phi_i/\partial X_j$, formulas count from 1
# and code from 0.

# %%
# %matplotlib inline
import inspect

import numpy as np
import matplotlib.pyplot as plt
from IPython.display import Markdown, display

from tissuefem.workbook.bench.scenes import effects_benchmark
from tissuefem.workbook.tables import markdown_table
from tissuefem.workbook.figures.surgery import fig_ch08_flap
from tissuefem.workbook.procedures import sheet_scene
from tissuefem import FRAME_BUDGET, Simulation, advancement_flap, demo_scene

print(f"frame budget {1e3 * FRAME_BUDGET:.1f} ms")

# %% [markdown]
# ## 1. Sutures, and a local flap
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
# rebuilds it when stitches are added). Below: the gaping incision of chapter 8a's figure, each copy stitched to its
# original, tightened over five frames:

# %%
sim = Simulation(sheet_scene(1200, handles=[{"name": "fixed", "region": "left"},
                                            {"name": "pull", "region": "right", "target": [0.4, 0.0]}]))
sim.frame()
n_before = sim.mesh.nvertices
edit = sim.cut([[1.0, 1.2], [1.0, 0.5]], method="edges")
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
flap_length = 1.2
result = advancement_flap(n_triangles=2000, flap_length=flap_length, tighten_frames=6, method="edges")
print(result.summary())
print("Newton steps per tightening frame:", [r.newton_iterations for r in result.reports])
print("boundaries of the final mesh:", sorted(result.simulation.mesh.boundaries), "| terms:", result.simulation.terms)

# %%
# where the largest tensions sit: each triangle's centre (reference coordinates) against the procedure's corners
x0, y0, w, h = inspect.signature(advancement_flap).parameters["defect"].default
features = {"a corner of the defect": [(x0, y0), (x0 + w, y0), (x0 + w, y0 + h), (x0, y0 + h)],
            "an end of an incision": [(x0 + w + flap_length, y0), (x0 + w + flap_length, y0 + h)]}
mesh = result.simulation.mesh
centres = mesh.p[:, mesh.t].mean(axis=1).T


def nearest_feature(point):
    return min((np.hypot(*(np.array(corner) - point)), name) for name, corners in features.items() for corner in corners)


largest = np.argsort(result.tension)[::-1][:6]
for i in largest:
    distance, name = nearest_feature(centres[i])
    print(f"tension {result.tension[i]:7.1f} at ({centres[i][0]:.2f}, {centres[i][1]:.2f}): {distance:.2f} from {name}")

# %%
near = [nearest_feature(centres[i]) for i in largest]
display(Markdown(
    f"The maximum, {result.tension[largest[0]]:.0f}, sits at {near[0][1]} (the triangle's centre {near[0][0]:.2f} "
    f"from it), and the {len(largest)} largest tensions all lie within {max(d for d, _ in near):.2f} of "
    + " or ".join(sorted({name for _, name in near})) + ". The ends of cuts and the corners of a defect are singular "
    "like a crack tip; the percentile and the means are the numbers to compare between designs."))

# %% [markdown]
# The figure draws the
# procedure and compares three flap lengths: a longer flap spreads the same advance over more skin, so the
# flap is stretched less (at the price of longer incisions).

# %%
fig_ch08_flap()

# %% [markdown]
# ## 2. The cost of each effect
#
# `effects_benchmark` (`tissuefem.workbook.bench.scenes`) runs the standard drag of chapter 7 once per variant of one scene: a base
# (stable neo-Hookean, quasistatic), the linear model with and without its constant factorisation, and the
# base with one effect added at a time, then everything together. Every frame is solved to the tolerance (no
# budget), so the columns compare the same work. A small run here (1000 triangles, 8 frames each); the full
# one, at 8000 triangles and 30 frames with JSON and CSV output, is `python -m tissuefem bench scenes`.
# **Timings are noisy** (a shared machine, and 8 frames are few), so the cell runs the whole benchmark three
# times. Each variant's time is the median of its three runs, with their range; its difference from the base
# is taken within each run, and it is a *cost* (or a saving) only where every run's difference is larger,
# in the same direction, than the spread of the base's own three runs. Otherwise the table says "noise" and
# shows the range: a difference smaller than the spread of repeats is not a measurement. One slow run of the
# base widens that spread for every row, so a row whose runs all differ in the same direction, but by less,
# says so ("saves in every run" or "costs in every run", within the noise) instead of a plain "noise".

# %%
runs = [effects_benchmark(n_triangles=1000, frames=8, out=None, progress=None) for _ in range(3)]
record = runs[-1]


def cost_cell(differences, spread):
    low, mid, high = np.min(differences), np.median(differences), np.max(differences)
    if low > spread:
        return f"+{mid:.1f} (+{low:.1f} to +{high:.1f})"
    if high < -spread:
        return f"saves {-mid:.1f} ({-high:.1f} to {-low:.1f})"
    if high < 0 or low > 0:
        return f"noise, but {'saves' if high < 0 else 'costs'} in every run ({low:+.1f} to {high:+.1f})"
    return f"noise ({low:+.1f} to {high:+.1f})"


table = []
for i, row in enumerate(record["rows"]):
    ms = np.array([run["rows"][i]["median_ms"] for run in runs])
    base = np.array([run["rows"][0]["median_ms"] for run in runs])
    table.append({"variant": row["variant"], "terms": ", ".join(row["terms"]), "newton": row["newton"],
                  "ms": f"{np.median(ms):.1f} ({ms.min():.1f} to {ms.max():.1f})",
                  "cost": "—" if i == 0 else cost_cell(ms - base, np.ptp(base))})
display(Markdown(markdown_table(table, [("variant", "variant", "{}"), ("terms", "terms", "{}"),
                                        ("ms", "median ms/frame (range of 3 runs)", "{}"),
                                        ("newton", "Newton/frame", "{:.2f}"), ("cost", "against the base, ms", "{}")],
                                text_columns=2)))
print("one evaluation of each term of 'everything' (energy + force + Hessian), ms:",
      ", ".join(f"{name} {ms:.2f}" for name, ms in record["term_ms"].items()))

# %% [markdown]
# What to read in it (the Newton counts are the same on every machine; the milliseconds are not):
# - an effect that is **not** in the scene costs nothing: the rows differ only by the terms listed;
# - the two **linear** rows take exactly 1.00 Newton step per frame. That step is the quasistatic frame's
#   *linearised start* (chapter 4): for a quadratic energy it lands on the answer, and Newton then finds the
#   residual already converged and does nothing more. (The start counts as a Newton step; before it was
#   counted, these rows read 0.00.) With the constant factorisation that one step is a single
#   back-substitution; through the general Newton loop it costs a tangent assembly and more;
# - **inertia** adds the mass matrix and, here, slightly *more* Newton steps per frame (2.00 for the
#   quasistatic base, 2.38 with inertia): a quasistatic frame starts from the linearised step, which already
#   follows the handle, and one Newton step finishes it; a dynamic frame starts from a prediction of the
#   motion (chapter 7) and takes two Newton steps after it, and three in the first frames, before the
#   prediction has a motion to follow;
# - the **probe** costs little to evaluate (the last line) but adds Newton steps, as section 4 of chapter 8a
#   showed;
# - the **projected tangent** (inversion handling, chapter 6b) costs nothing on this gentle drag: it is
#   projected only when Newton needs a descent direction (an element near inversion), so here every frame
#   takes the exact tangent, as the base does;
# - the rows of chapter 10 (cuts through elements, self-contact) show that a cut costs little per frame, and
#   that contact costs Newton steps only where a wound's lips are pressed together.

# %% [markdown]
# ## 3. With the mouse
#
# `tissuefem.surgery.interactive.SurgeryView` runs a simulation and draws it in the browser: each frame the
# kernel sends the deformed node positions to the page as a binary array (the triangles only when a cut changes
# them), and the page draws them on a canvas; the kernel draws no pictures. The mouse goes the other way and
# becomes the operations above: in **drag** mode a press grabs the tissue under the pointer, moving drags it,
# releasing lets go; in **cut** mode a stroke becomes an incision when the button is released. The **drag** and
# **cut** buttons above the canvas switch the two (so does the key **c**, once a click into the canvas has given
# it the keyboard); the **run** / **pause** button starts and stops the frames.
#
# While it runs, the view steps one frame every 32 ms (just over 30 frames a second) as long as something
# changes (the mouse, or the tissue still swinging) and rests otherwise: a still sheet costs no frames and sends nothing. The readout above the
# canvas says whether the view is *running*, *at rest* or *paused*, and shows each frame's step time and its
# solver status, with the pictures the page painted in the last second; under it, the frame's accuracy.
# Messages (a failed cut, a drag while paused) appear under the canvas. Without a browser (a headless run)
# nothing runs by itself and code calls `view.step()`. The widget (anywidget, installed with tissuefem) draws
# in the browser; the same cells run headless.
#
# Running the next cell again replaces the view (the old one stops: no hidden loop keeps stepping a simulation
# you no longer see).

# %%
from tissuefem.surgery.interactive import SurgeryView, snapshot, synthetic_key, synthetic_mouse

sim = Simulation(demo_scene(n_triangles=2000))
view = SurgeryView(sim, autostart=False)
print(repr(view))

# %% [markdown]
# What the mouse would do, sent as made-up messages through the view's own message handler (so this runs
# headless too): grab the right edge, drag it down and out over 15 frames and let go; press **c** and, while
# the sheet swings back, draw a stroke from above it down to below its middle; press **c** again, grab the right
# edge, pull the wound open, and let go at the end, so that no scripted grab holds the sheet when you take over.
# The cell ends with `view`, which shows the live view (its picture is the last frame sent).

# %%
def stroke(view, points):
    synthetic_mouse(view, "press", points[0])
    for point in points[1:-1]:
        synthetic_mouse(view, "move", point)
    synthetic_mouse(view, "release", points[-1])


events = {}
synthetic_mouse(view, "press", (1.97, 0.5))                       # drag mode: grab ...
for k in range(1, 16):
    synthetic_mouse(view, "move", (1.97 + 0.02 * k, 0.5 - 0.02 * k))   # ... drag ...
    view.step()
synthetic_mouse(view, "release", (2.27, 0.2))                     # ... let go
synthetic_key(view, "c")                                          # cut mode
stroke(view, [(1.0, 1.35), (1.0, 1.1), (1.0, 0.85), (1.0, 0.6), (1.0, 0.4)])
events["cut"] = len(view.frame_times)
print(f"after the stroke: {view.sim.mesh.nvertices} nodes, {sim.pieces()} piece(s), message {view.message!r}")
for _ in range(5):
    view.step()
synthetic_key(view, "c")                                          # back to drag mode
synthetic_mouse(view, "press", (1.97, 0.5))
events["grab"] = len(view.frame_times)
for k in range(1, 21):
    synthetic_mouse(view, "move", (1.97 + 0.015 * k, 0.5 - 0.01 * k))
    view.step()
synthetic_mouse(view, "release", (2.27, 0.3))                     # let go: the sheet is yours
print(f"mode {view.mode}; handles {list(sim.handles)}; frames {sim.frames}")
view

# %% [markdown]
# The wound gapes where the sheet is pulled. (Run your own drags and you may see the two lips of a wound slide
# *over* each other: this scene has no self-contact term, so nothing stops the tissue from passing through
# itself. Chapter 10 adds one, `effects.contact` in a scene; its rows in the effects table above show what it
# costs.) The same state as a static figure (`snapshot(view)`, for a page without the live view), and the time
# of each frame's step against the 33 ms of a frame:

# %%
steps = np.array(view.frame_times)
fig, (ax_view, ax) = plt.subplots(1, 2, figsize=(11, 3.2), layout="constrained", width_ratios=[1, 1.3])
snapshot(view, ax_view)
frames = np.arange(len(steps))
ax.bar(frames, steps, width=0.8, color="C0", label="step (sim.frame)")
ax.axhline(1e3 * FRAME_BUDGET, color="C3", lw=1, label="33 ms (1/30 s)")
for name, at in events.items():
    ax.axvline(at - 0.5, color="0.5", ls=":", lw=1)
    ax.text(at - 0.5, 0.95, f" {name}", transform=ax.get_xaxis_transform(), va="top", fontsize=8)
ax.set(xlabel="frame", ylabel="ms", title=f"{sim.mesh.nelements} triangles, dynamic, stable neo-Hookean",
       ylim=(0, None))
ax.legend(fontsize=8, loc="upper right")
ax.grid(alpha=0.3, axis="y")
print(f"median step {np.median(steps):.1f} ms of {1e3 * FRAME_BUDGET:.0f} ms")

# %% [markdown]
# None of a frame's 33 ms goes to drawing in the kernel: the browser draws the picture, in its own process.
# How fast does the picture follow the mouse? `python tests/chapters/test_browser_widget.py` measures it with
# real pointer input in JupyterLab and Chromium: pictures painted per second while dragging, the time from a
# pointer move to the picture that shows it, and what the kernel does at rest. Installing tissuefem enables a
# Jupyter Server extension (`tissuefem.surgery.nodelay`) that sends kernel messages to the page without Nagle's
# delay. The package ships runs on the 2-core reference machine with nothing else running, with and without it:

# %%
from tissuefem.workbook.bench.common import recorded

browser = recorded("browser_view")
print(f"recorded {browser['date']}, 1-minute load average before the session's benchmarks {browser['load_before']:.2f}")
for run in browser["rounds"]:  # at rest: nothing painted or sent; the server's socket with or without Nagle
    print(run.get("kernel_websockets", "Jupyter Server's default (Nagle on)"))
    for r in run["results"]:
        d, lat = r["dragging"], r["latency"]
        print(f"  {r['mesh']['triangles']:5d} triangles: {d['painted_per_second']:4.1f} pictures/s while dragging, "
              f"step {d['kernel_step_median_ms']:4.1f} ms, paint {d['page_paint_median_ms']:.1f} ms; mouse to picture "
              f"{lat['median_ms']:.0f} ms median, {lat['p95_ms']:.0f} ms p95; at rest {r['at_rest']['painted']} pictures, "
              f"kernel {r['at_rest']['cpu_percent_of_a_core']:.1f} % of a core")

# %% [markdown]
# The next cell runs the view: the picture above comes alive. Drag the tissue with the mouse, click **cut** and
# cut it, and watch the readout. The **pause** button (or `view.stop()`) pauses it; a drag while paused moves
# the marker, not the tissue, and the view says so.

# %%
view.start()

# %% [markdown]
# ## 4. The tool's force at haptic rate
#
# A haptic device, a stylus on a motorised arm, plays the tool's force back to the hand by sampling: read the
# position, compute the force, drive the motors. Between two samples the force stays as it was, a staircase whose
# every step is energy the device adds or takes away: a stiff contact sampled slowly feels mushy, or buzzes.
# The faster the loop, the stiffer the contact it renders stably, and haptic force loops run near 1 kHz while the
# deformation runs at 30 to 100 frames a second: **multirate** haptics. Our scenes run 30 frames a second; held
# for a whole frame, each frame's force would reach the hand as a step every 33 ms.
#
# **Precomputed and reduced models.** Cotin, Delingette and Ayache (1999) rendered force feedback within 7 ms
# from a linear elastic model of 6,500 tetrahedra whose responses were precomputed: the force of a contact is a
# superposition of stored responses to unit displacements of the surface nodes. The price is the model: linear
# elasticity (small strains, no large rotations) and a mesh fixed in advance, which no cut may change without a
# new precomputation. Barbič and James (2005) reduced a nonlinear model to a few deformation modes, again on a
# fixed shape. Here the body changes every frame (cuts,
# stitches, a nonlinear material), so nothing is precomputed once and for all: after each frame the body is
# reduced to the tool alone, and that small model serves the force loop until the next frame.
#
# **The tool's reduced model.** A frame ends at equilibrium: the residual of its free dofs is zero,
# $\mathbf g_f(\mathbf u, \mathbf p_0) = \mathbf 0$, with the tool at $\mathbf p_0$ (a grabbed edge's translation,
# or a probe's centre). Move the tool by $\delta\mathbf p$ and the equilibrium moves by
# $\delta\mathbf u_f = -\mathbf H_{ff}^{-1}\,(\partial\mathbf g_f/\partial\mathbf p)\,\delta\mathbf p$, with
# $\mathbf H$ the frame's tangent (inertia's $\mathbf M/\Delta t^2$ included). The tool's force
# $\mathbf F(\mathbf u, \mathbf p)$ then changes by $\mathbf S\,\delta\mathbf p$,
#
# $$\mathbf S = \frac{\partial\mathbf F}{\partial\mathbf p}
#   - \frac{\partial\mathbf F}{\partial\mathbf u_f}\,\mathbf H_{ff}^{-1}\,\frac{\partial\mathbf g_f}{\partial\mathbf p},
#   \qquad \mathbf f(\mathbf p) = \mathbf f_0 + \mathbf S\,(\mathbf p - \mathbf p_0),$$
#
# the **Schur complement** of the tool's unknowns: the tool's stiffness seen through the body. For a grabbed edge
# whose dofs $t$ follow the translation ($\mathbf u_t = \mathbf B\mathbf p$), with $\mathbf K$ the Hessian of the
# stored energy, it is
# $\mathbf S = \mathbf B^T\mathbf K_{tt}\mathbf B - (\mathbf K_{ft}\mathbf B)^T\,\mathbf H_{ff}^{-1}\,\mathbf H_{ft}\mathbf B$;
# for a probe, whose force depends on the contact nodes'
# $\mathbf x_a - \mathbf c$ only, $\mathbf S = \sum_a \mathbf P_a - \mathbf P^T\mathbf H_{ff}^{-1}\mathbf P$ with
# $\mathbf P_a$ the probe's Hessian block at node $a$. Each column of $\mathbf H_{ff}^{-1}(\dots)$ is one solve
# with the real-time solver's own kept factorization (a few CG iterations preconditioned by it): two solves per
# frame in 2D. Between frames an update is a 2 × 2 product, `tool_model(sim.solver, "handle").force(p)`
# (`tissuefem.engine.haptics`). The reference it is measured against: the converged frame at the same tool
# position, i.e. the frame taken again from its start with the tool there.

# %%
import time

from tissuefem import flap_path
from tissuefem.engine.haptics import tool_model
from tissuefem.workbook.bench.haptic import haptic_path
from tissuefem.workbook.bench.realtime import flap_simulation
from tissuefem.workbook.figures.haptics import fig_ch08_haptic_force

flap_sim = flap_simulation(1000)  # the standard flap of chapter 7, smaller
for k in range(1, 7):
    flap_sim.frame({"handle": flap_path(k * FRAME_BUDGET)})
build = []
for _ in range(5):
    t0 = time.perf_counter()
    edge = tool_model(flap_sim.solver, "handle")
    build.append(time.perf_counter() - t0)
p = flap_path(6.5 * FRAME_BUDGET)  # half way to the next frame's position
update = []
for _ in range(2000):
    t0 = time.perf_counter()
    edge.force(p)
    update.append(time.perf_counter() - t0)
print(f"{flap_sim.mesh.nelements} triangles; after frame {edge.frame}: "
      f"f0 = {np.array2string(edge.force0, precision=2)}, S =\n{np.array2string(edge.stiffness, precision=1)}")
print(f"building the reduced model: {1e3 * np.median(build):.2f} ms per frame; one update: "
      f"{1e6 * np.median(update):.1f} µs (median of 2000)")

run = haptic_path(n_triangles=1000, frames=10, substeps=4, warmup=5)
display(Markdown(
    f"Along the drag, at {run['substeps']} tool positions between each of {run['frames']} frames, the reduced model's "
    f"force is within {np.median(run['haptic_error']):.1e} of the converged frame's (relative; at most "
    f"{np.max(run['haptic_error']):.1e}), where holding the frame's force until the next one is off by "
    f"{np.median(run['hold_error']):.1e} (at most {np.max(run['hold_error']):.1e}): "
    f"{np.median(run['hold_error']) / np.median(run['haptic_error']):.0f} times less error, for an update of "
    f"{1e6 * np.median(update):.0f} µs. At each frame the force still jumps, by {np.median(run['jump_relative']):.1e} "
    f"of its size (median), {np.median(run['jump_relative']) / np.median(run['hold_error']):.1f} times the held "
    "force's median error: the body moved on during the frame, which the model of the frame before cannot know."))

# %% [markdown]
# The figure draws that run: the force of the edge on the body, each frame's reduced model carried on to the next
# frame (solid), the frame's force held (dotted) and the converged frames at the same positions (black dots); below,
# the relative error of both.

# %%
fig_ch08_haptic_force(run=run)

# %% [markdown]
# **What the update misses between frames.** It is exact to first order in the tool's move, and no further:
# - **nonlinearity**: the error grows like the square of the distance moved since the frame (it rises within
#   each segment of the figure and drops at each frame), so a fast drag, which moves the tool farther in a frame,
#   gets a worse force;
# - **contact made or lost**: a probe's model knows only the nodes in contact at the frame; a node the disc
#   reaches between frames adds no stiffness until the next frame (the force is too soft while pressing in), and
#   one it leaves still pushes (too stiff while withdrawing);
# - **the body's own motion**: in a dynamic scene the tissue moves on between frames even when the tool stands
#   still; the reduced model keeps the body where its frame left it, and the next frame's force differs by the
#   jump printed above. In this dynamic scene that jump is what the hand would feel most. A better model adds the
#   drift of the next frame: the linearised next step with the tool held still, one more solve with the same
#   factorization;
# - **topology**: a cut or a stitch between frames changes the body; the model of the frame before is stale
#   until the next frame rebuilds it.
#
# `python -m tissuefem bench haptic` runs the standard flap of chapter 7 with a thread updating the force at
# 1 kHz beside the frames (`docs/benchmarks.md`).

# %% [markdown]
# ## What to try
# Each suggestion comes with a few lines that run on their own in a new cell; change the numbers
# and run them again.
#
# - Close the incision of section 1 in a *dynamic* scene: in one frame, and tightened over ten frames.
#   Watch the widest gap after each frame: does the wound snap shut and bounce?
#
# ```python
# import numpy as np
# from tissuefem import Simulation
# from tissuefem.workbook.procedures import sheet_scene
#
# for frames in (1, 10):
#     sim = Simulation(sheet_scene(800, dynamic=True, handles=[{"name": "fixed", "region": "left"},
#                                                               {"name": "pull", "region": "right", "target": [0.4, 0.0]}]))
#     sim.run(10)
#     n_before = sim.mesh.nvertices
#     edit = sim.cut([[1.0, 1.2], [1.0, 0.5]], method="edges")
#     sim.run(5)
#     copies = np.arange(n_before, sim.mesh.nvertices)
#     sim.suture(np.vstack([copies, edit.parent[copies]]), tightness=0.0)
#     gaps = []
#     for k in range(1, 16):
#         sim.tighten(min(k / frames, 1.0))
#         sim.frame()
#         gaps.append(sim.suture_gaps().max())
#     print(f"tightened over {frames:2d} frame(s): widest gap per frame {np.round(gaps, 3)}")
# ```
#
# - Compare flap lengths, and the same flap on two meshes: which of the reported tensions (the maximum,
#   the 95th percentile, the mean inside the flap) depend on the mesh?
#
# ```python
# from tissuefem import advancement_flap
#
# for n, length in ((1000, 0.8), (1000, 1.6), (2000, 1.6)):
#     r = advancement_flap(n_triangles=n, flap_length=length, tighten_frames=4, method="edges")
#     print(f"{n} triangles, flap length {length}: max {r.max_tension:.0f}, 95th percentile {r.p95_tension:.0f}, "
#           f"flap mean {r.flap_tension:.0f}")
# ```
#
# - Measure the cost of each effect yourself, on a mesh of your choice (the full benchmark, at 8000
#   triangles and 30 frames, is `python -m tissuefem bench scenes`). Which effect costs most, in milliseconds
#   and in Newton steps?
#
# ```python
# from IPython.display import Markdown, display
# from tissuefem.workbook.bench.scenes import effects_benchmark, format_effects_table
#
# record = effects_benchmark(n_triangles=2000, frames=6, out=None, progress=None)
# display(Markdown(format_effects_table(record["rows"])))
# ```
#
# - Feel a probe instead of the edge: press a probe into the sheet, build its reduced model once, then press
#   deeper without rebuilding it. How far does the linear model carry before new nodes come into contact and
#   the error grows?
#
# ```python
# import numpy as np
# from tissuefem import Simulation
# from tissuefem.engine.haptics import tool_model
# from tissuefem.workbook.procedures import sheet_scene
#
# sim = Simulation(sheet_scene(800, handles=[{"name": "fixed", "region": "left"}, {"name": "far", "region": "right"}]))
# label = sim.add_probe([1.0, 1.25], 0.3)
# sim.frame()
# probe = tool_model(sim.solver, label)
# for depth in (0.002, 0.01, 0.05, 0.1):
#     centre = probe.position - [0.0, depth]
#     sim.move_probe(label, centre)
#     sim.frame()
#     converged = sim.model.probes[0].forces(sim.u).sum(axis=1)
#     error = np.linalg.norm(probe.force(centre) - converged) / np.linalg.norm(converged)
#     print(f"{depth} deeper: reduced {np.round(probe.force(centre), 1)}, converged {np.round(converged, 1)}, "
#           f"relative error {error:.1e}")
# ```
#
# - A bigger project: a rotation flap, which turns about a pivot instead of sliding. The flaps module pairs
#   the stitches by any motion you give it; plan them for a flap cut along an arc.
#
# ## Exercises
# The exercises of chapter 8 (8.1 and 8.2: node duplication along a cut, a scene file) are listed in chapter
# 8a; `python -m tissuefem grade ch08` grades them.
