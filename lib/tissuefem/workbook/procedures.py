"""The surgical procedures of chapters 8 and 10, run for their figures and claims on a clock that never
advances (:func:`still_clock`): every frame converges whatever the machine, and the figures are
byte-identical."""

from __future__ import annotations

from itertools import product

import numpy as np

from ..engine.constants import FRAME_BUDGET as FRAME_DT  # one frame, 1/30 s
from ..engine.materials import StableNeoHookean, rotation
from ..engine.meshes import mean_edge_length, rectangle
from ..engine.model import Handle, Model
from ..engine.stepping import Stepper
from ..surgery.element_cuts import cut_through
from ..surgery.flaps import advancement_flap, rotation_flap
from ..surgery.scene import Scene, demo_scene
from ..surgery.simulation import Simulation
from ..surgery.surfaces import contact_surface
from ..surgery.topology import connected_components

__all__ = ["still_clock", "sheet_scene", "still_simulation", "check_frame", "pulled_sheet", "incision_run",
           "two_pieces_run", "probe_run", "probe_indentation", "flap_runs", "crack_runs", "virtual_nodes_run",
           "crack_opening", "flap_comparison", "overlap_area", "fold_run", "pressed_cut_run"]

#: the incision: how far the right edge is pulled, and the cut (from above the top edge to mid-height)
INCISION_PULL, INCISION_PATH = 0.4, ((1.0, 1.2), (1.0, 0.5))
#: the two pieces: frames of sagging before the cut and of falling after it
SAG_FRAMES, FALL_FRAMES = 12, 14
#: the probe: disc radius and the depths swept (below the top edge)
PROBE_RADIUS, PROBE_DEPTHS = 0.25, (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3)
#: chapter 8's advancement flap: the lengths compared, the mesh (triangles), the frames that tighten it
FLAP_LENGTHS, FLAP_TRIANGLES, FLAP_TIGHTEN_FRAMES = (0.8, 1.2, 1.8), 2000, 6
#: chapter 10's slanted crack from above the top edge to mid-height (reference coordinates of the 2 x 1 sheet),
#: the two meshes it is cut on (triangles) and how far the right edge is pulled
CRACK, CRACK_MESHES, CRACK_PULL = [[0.93, 1.05], [1.17, 0.45]], (1200, 2600), 0.1
#: chapter 10's flaps: the coarse and the fine mesh (triangles)
FLAP_MESHES = (1500, 3000)
#: the virtual nodes close up: a stroke from the top edge, bending, ending inside the sheet
VIRTUAL_NODES_STROKE = ((0.62, 1.1), (0.9, 0.6), (1.05, 0.35))


def still_clock():
    """A clock that never advances: no frame ever runs out of budget, whatever the machine."""
    return 0.0


def sheet_scene(n_triangles=1200, *, handles, dynamic=False, gravity=False, width=2.0, height=1.0):
    """:func:`~tissuefem.surgery.scene.demo_scene`'s sheet of stable neo-Hookean tissue (E = 1000, nu = 0.3),
    ``width x height``, with the given handles, under gravity if asked; every frame solved to 1e-8, no budget."""
    data = demo_scene(int(n_triangles), dynamic).to_dict()
    data["domain"].update(width=width, height=height)
    data["effects"]["handles"] = handles
    if gravity:
        data["effects"]["gravity"] = {"acceleration": [0.0, -9.81]}
    data["solver"] = {"budget": 1e9, "rtol": 1e-8, "max_iterations": 100}
    return Scene.from_dict(data)


def still_simulation(n_triangles, handles, **options) -> Simulation:
    """:func:`sheet_scene` simulated on the :func:`still_clock`."""
    return Simulation(sheet_scene(n_triangles, handles=handles, **options), clock=still_clock)


def check_frame(report, what):
    """The frame's report, or a ``RuntimeError`` saying which frame did not converge."""
    if not report.converged:
        raise RuntimeError(f"{what}: the frame did not converge ({report.status})")
    return report


def pulled_sheet(n_triangles, pull) -> Simulation:
    """The sheet held on its left edge, its right edge pulled by ``pull`` to the right, at equilibrium."""
    sim = still_simulation(n_triangles, [{"name": "fixed", "region": "left"},
                                         {"name": "pull", "region": "right", "target": [pull, 0.0]}])
    check_frame(sim.frame(), "the pulled sheet")
    return sim


def incision_run(n_triangles=1200, pull=INCISION_PULL, path=INCISION_PATH) -> dict:
    """The pulled sheet before and after an incision along edges (positions, tension, opening, pieces)."""
    sim = pulled_sheet(n_triangles, pull)
    before = dict(x=sim.positions().copy(), t=sim.mesh.t.copy(), tension=sim.tension(), mesh=sim.mesh,
                  nodes=sim.mesh.nvertices)
    edit = sim.cut(np.asarray(path, dtype=float), method="edges")
    check_frame(sim.frame(), "the cut sheet")
    x = sim.positions()
    copies = np.arange(before["nodes"], sim.mesh.nvertices)
    opening = np.hypot(*(x[:, copies] - x[:, edit.parent[copies]]))
    after = dict(x=x.copy(), t=sim.mesh.t.copy(), tension=sim.tension(), mesh=sim.mesh, nodes=sim.mesh.nvertices,
                 opening=float(opening.max(initial=0.0)), pieces=sim.pieces())
    return {"before": before, "after": after, "edit": edit, "simulation": sim}


def two_pieces_run(n_triangles=800, sag_frames=SAG_FRAMES, fall_frames=FALL_FRAMES, cut_x=1.0) -> dict:
    """The hanging sheet cut at ``x = cut_x`` after ``sag_frames`` frames, then ``fall_frames`` more: the
    frames (positions, triangles, free elements), times, heights of the centres of mass and the discrete free
    fall."""
    sim = still_simulation(n_triangles, [{"name": "fixed", "region": "left"}], dynamic=True, gravity=True)
    X0 = sim.mesh.p
    frames, com = [], []
    right = X0[0] > cut_x  # before the cut: the nodes right of it; after: the free piece's nodes

    def record(free_elements):
        x = sim.positions()
        m = sim.model.inertia.M.diagonal()[0::2]  # lumped nodal masses
        frames.append((x.copy(), sim.mesh.t.copy(), free_elements))
        com.append(tuple(float(np.dot(m[s], x[1, s]) / m[s].sum()) for s in (~right, right)))

    record(np.zeros(sim.mesh.nelements, dtype=bool))
    for _ in range(sag_frames):
        check_frame(sim.frame(), "the hanging sheet")
        record(np.zeros(sim.mesh.nelements, dtype=bool))
    edit = sim.cut([[cut_x, 1.3], [cut_x, -0.3]])
    n_pieces, labels = connected_components(sim.mesh.t, sim.mesh.nvertices)
    if n_pieces != 2:
        raise RuntimeError(f"the cut should leave two pieces, left {n_pieces}")
    right = labels != labels[sim.handles["fixed"].nodes[0]]
    free_elements = right[sim.mesh.t[0]]
    del frames[-1], com[-1]
    record(free_elements)  # the last frame again, drawn cut (the cut moves nothing)
    # the free piece's centre of mass and velocity at the moment of the cut
    m = sim.model.inertia.M.diagonal()[0::2]
    y_cut = com[-1][1]
    vy_cut = float(np.dot(m[right], sim.v.reshape(-1, 2)[right, 1]) / m[right].sum())
    for _ in range(fall_frames):
        check_frame(sim.frame(), "the falling piece")
        record(free_elements)
    k = np.arange(fall_frames + 1)
    free_fall = y_cut + k * FRAME_DT * vy_cut - 0.5 * 9.81 * FRAME_DT**2 * k * (k + 1)
    return {"frames": frames, "times": FRAME_DT * np.arange(len(frames)), "com": np.array(com),
            "cut_frame": sag_frames, "edit": edit, "free_fall": free_fall, "simulation": sim, "X0": X0}


def probe_run(n_triangles=1200, radius=PROBE_RADIUS, depths=PROBE_DEPTHS, x_probe=1.0, stiffness=None) -> dict:
    """A disc pressed ever deeper into a block held on its bottom edge, one frame per depth: positions,
    tension, nodal contact forces ``k l_a h'(R - d_a) n_a``, their total, the penetration left and the Newton
    steps. ``stiffness``: the penalty (default ``100 E / radius``)."""
    sim = still_simulation(n_triangles, [{"name": "base", "region": "bottom"}])
    label = sim.add_probe([x_probe, 1.0 + radius - depths[0]], radius, stiffness=stiffness)
    states = []
    for depth in depths:
        sim.move_probe(label, [x_probe, 1.0 + radius - depth])
        report = check_frame(sim.frame(), f"the probe at depth {depth}")
        probe = sim.model.probes[0]
        contact = -probe.gradient(sim.u).reshape(-1, 2).T  # force on each node
        states.append(dict(depth=depth, center=probe.center.copy(), x=sim.positions().copy(), t=sim.mesh.t.copy(),
                           tension=sim.tension(), contact=contact, force=contact.sum(axis=1),
                           penetration=probe.penetration(sim.u), stiffness=probe.stiffness,
                           newton=report.newton_iterations))
    return {"states": states, "radius": radius, "simulation": sim}


def probe_indentation(n_triangles=1200, stiffness=None, depths=(0.05, 0.1, 0.15, 0.2), radius=0.25) -> dict:
    """:func:`probe_run` summed up: the penetration left at the last depth, the Newton steps per frame, the
    triangles and the penalty stiffness."""
    run = probe_run(n_triangles, radius, depths, stiffness=stiffness)
    last = run["states"][-1]
    return {"penetration": last["penetration"], "newton": [s["newton"] for s in run["states"]],
            "triangles": int(run["simulation"].mesh.nelements), "stiffness": float(last["stiffness"])}


def flap_runs(lengths=FLAP_LENGTHS, n_triangles=FLAP_TRIANGLES, tighten_frames=FLAP_TIGHTEN_FRAMES) -> dict:
    """:func:`~tissuefem.surgery.flaps.advancement_flap` cut along mesh edges for each flap length,
    ``{length: FlapResult}``."""
    return {float(L): advancement_flap(flap_length=float(L), n_triangles=n_triangles, tighten_frames=tighten_frames,
                                       clock=still_clock, method="edges") for L in lengths}


def crack_runs(meshes=CRACK_MESHES, crack=CRACK, pull=CRACK_PULL) -> dict:
    """``{(method, triangles): (simulation, edit)}``: the pulled sheet, then the crack, then the new equilibrium."""
    out = {}
    for method, n in product(("edges", "elements"), meshes):
        sim = pulled_sheet(n, pull)
        edit = sim.cut(np.asarray(crack, dtype=float), method=method)
        check_frame(sim.frame(), "the cracked sheet")
        out[(method, n)] = (sim, edit)
    return out


def virtual_nodes_run():
    """A 16-triangle sheet cut through its elements along :data:`VIRTUAL_NODES_STROKE`, then pulled open by 0.12
    over three frames: ``(simulation, edit, nodes before the cut)``."""
    sim = still_simulation(16, [{"name": "fixed", "region": "left"},
                                {"name": "pull", "region": "right", "target": [0.0, 0.0]}])
    n_old = sim.mesh.nvertices
    edit = sim.cut(np.array(VIRTUAL_NODES_STROKE))
    for k in range(1, 4):
        check_frame(sim.frame({"pull": [0.12 * k / 3, 0.0]}), "the cut sheet, pulled")
    return sim, edit, n_old


def crack_opening(sim, edit) -> float:
    """Opening of the crack at its mouth (the sheet's top edge), in the current configuration."""
    x = sim.positions()
    if getattr(edit, "wound", None) is not None:
        wound = edit.wound
        ends = wound.positions(x)
        first = np.flatnonzero(wound.stroke[:, 0] == wound.stroke[:, 0].min())
        a, b = first[wound.side[first] > 0][0], first[wound.side[first] < 0][0]
        return float(np.hypot(*(ends[a, 0] - ends[b, 0])))
    top = np.flatnonzero(np.isclose(sim.model.X[1], 1.0))
    copies = top[top >= edit.n_old_nodes]
    return float(np.max(np.hypot(*(x[:, copies] - x[:, edit.parent[copies]]))))


def flap_comparison(meshes=FLAP_MESHES, tighten_frames=8) -> dict:
    """``{(flap, method, triangles): FlapResult}`` for the advancement and the rotation flap."""
    procedures = (("advancement", advancement_flap), ("rotation", rotation_flap))
    return {(name, method, n): procedure(n_triangles=n, tighten_frames=tighten_frames, method=method,
                                         clock=still_clock)
            for (name, procedure), method, n in product(procedures, ("edges", "elements"), meshes)}


def overlap_area(picture, x, cells=400) -> float:
    """The area the drawn material at ``x`` covers twice or more (on a ``cells x cells`` grid)."""
    y = picture.points(x)
    lo, hi = y.min(axis=1), y.max(axis=1)
    step = float((hi - lo).max()) / cells
    nx, ny = (np.ceil((hi - lo) / step).astype(int) + 1).tolist()
    count = np.zeros((ny, nx), dtype=np.int32)
    gx, gy = lo[0] + (np.arange(nx) + 0.5) * step, lo[1] + (np.arange(ny) + 0.5) * step
    for tri in picture.triangles.T:
        a, b, c = y[:, tri[0]], y[:, tri[1]], y[:, tri[2]]
        i0, i1 = np.searchsorted(gx, min(a[0], b[0], c[0])), np.searchsorted(gx, max(a[0], b[0], c[0]))
        j0, j1 = np.searchsorted(gy, min(a[1], b[1], c[1])), np.searchsorted(gy, max(a[1], b[1], c[1]))
        if i1 <= i0 or j1 <= j0:
            continue
        X, Y = np.meshgrid(gx[i0:i1], gy[j0:j1])
        det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
        if det == 0:
            continue
        xi = ((c[1] - a[1]) * (X - a[0]) - (c[0] - a[0]) * (Y - a[1])) / det
        eta = (-(b[1] - a[1]) * (X - a[0]) + (b[0] - a[0]) * (Y - a[1])) / det
        count[j0:j1, i0:i1] += ((xi >= 0) & (eta >= 0) & (xi + eta < 1)).astype(np.int32)
    return float(np.count_nonzero(count >= 2)) * step * step


def fold_run(contact: bool):
    """A thin strip: its left part lies on a table, its right end is turned over onto it and pressed down."""
    mesh = rectangle(3.0, 0.1, 40, 2)
    h = mean_edge_length(mesh)
    options = dict(contact=dict(distance=0.1 * h, stiffness=5770.0)) if contact else {}
    model = Model(mesh, StableNeoHookean(577.0, 385.0), handles=[Handle({"box": [-1.0, -0.01, 1.2, 0.01]},
                  name="table"), Handle("right", name="end")], **options)
    stepper = Stepper(model, linear_solver="reuse")
    centre = np.array([[1.8], [0.25]])

    def fold(theta, drop):
        return lambda P: centre + rotation(theta) @ (P - centre) - np.array([[0.0], [drop]])

    path = ([(th, 0.0) for th in np.linspace(0, np.pi, 13)[1:]] + [(np.pi, d) for d in np.linspace(0, 0.29, 5)[1:]]
            + [(np.pi, d) for d in np.linspace(0.29, 0.33, 9)[1:]])
    for theta, drop in path:
        check_frame(stepper.step({"end": fold(theta, drop)}), "the fold")
    return mesh, None, model, stepper.u


def pressed_cut_run(contact: bool):
    """A sheet with a crack cut through its elements, its right edge pushed left and up: the lips press and slide."""
    mesh = rectangle(2.0, 1.0, 16, 8)
    h = mean_edge_length(mesh)
    cut = cut_through(mesh, [[0.93, 1.2], [1.07, 0.25]])
    options = dict(contact=dict(surface=contact_surface(cut.mesh, cut.weights, cut.regions), distance=0.1 * h,
                                stiffness=100.0)) if contact else {}
    model = Model(cut.mesh, StableNeoHookean(577.0, 385.0), weights=cut.weights,
                  handles=[Handle("left"), Handle("right", name="push")], **options)
    stepper = Stepper(model, linear_solver="reuse")
    for k in range(1, 9):
        check_frame(stepper.step({"push": (-0.03 * k, 0.012 * k)}), "the pressed cut")
    return cut.mesh, cut.regions, model, stepper.u
