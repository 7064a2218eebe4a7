"""Local flaps: close a defect with a flap of neighbouring skin, and see the tension it leaves.

After Sifakis, Hellrung, Teran, Oliker and Cutting, "Local flaps: a real-time finite element based solution to the
plastic surgery defect puzzle" (2009). A defect too wide to pull shut is closed by a *flap* of nearby skin, cut on three
sides, moved (advanced or rotated) into it and sutured; which design leaves the least tension is what such a simulator
answers before the operation. :func:`advancement_flap`, on a patch of skin held on its outer edges:

1. **excise** a rectangular defect;
2. **cut** two incisions continuing the defect's top and bottom edges (the flap stays attached at its far end);
3. **suture** each point of the flap's wound edges to where the planned motion takes it (:func:`pair_by_motion`,
   :func:`stitch_points`), tightening the slack stitches over several quasistatic frames;
4. **report** the tension left: the largest principal Cauchy stress per element, its maximum, 95th percentile and
   area-weighted mean, the stitch forces and the gaps.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..engine.meshes import mean_edge_length
from ..engine.parameters import check_count, check_positive, string
from .scene import Scene
from .simulation import Simulation

__all__ = ["advancement_flap", "rotation_flap", "pair_by_motion", "stitch_points", "FlapResult", "wound_nodes"]


@dataclass
class FlapResult:
    """The outcome of a flap procedure."""

    simulation: Simulation
    stitches: int
    tension: np.ndarray  # largest principal Cauchy stress per element (after closing)
    max_tension: float  # at the incision tips and corners this grows as the mesh is refined (a singularity)
    p95_tension: float  # 95th percentile over the area: a mesh-robust measure
    mean_tension: float  # area-weighted mean of the positive part
    flap_tension: float  # area-weighted mean tension inside the flap
    max_gap: float  # the widest sutured pair still open
    initial_gap: float  # the widest before tightening
    suture_forces: np.ndarray
    reports: list = field(default_factory=list)
    snapshots: dict = field(default_factory=dict)  # stage -> (drawn points (2, k), triangles (3, q), element (q,))

    @property
    def converged(self) -> bool:
        return bool(self.reports) and self.reports[-1].converged

    def summary(self) -> str:
        return (f"{self.stitches} stitches; gap {self.initial_gap:.3g} -> {self.max_gap:.2g}; "
                f"tension max {self.max_tension:.4g}, 95th percentile {self.p95_tension:.4g}, "
                f"mean {self.mean_tension:.4g} (in the flap {self.flap_tension:.4g}); "
                f"largest stitch force {self.suture_forces.max(initial=0.0):.4g}")


def wound_nodes(mesh) -> np.ndarray:
    """Nodes on the wound: the boundary facets a cut (``"cut"``) or an excision (``"defect"``) created."""
    named = mesh.boundaries or {}
    facets = [named[name] for name in ("cut", "defect") if name in named]
    return np.unique(mesh.facets[:, np.concatenate(facets)]) if facets else np.zeros(0, dtype=np.intp)


def pair_by_motion(mesh, positions, flap_elements, motion, tolerance) -> np.ndarray:
    """Stitches for moving a flap by ``motion`` (``(2, n) -> (2, n)``): node pairs ``(2, k)``, flap node first. A
    wound node is on the flap when all its triangles are (``flap_elements``, a mask); each is moved by ``motion`` and
    paired with the nearest other wound node within ``tolerance``."""
    wound = wound_nodes(mesh)
    on_flap = np.zeros(mesh.nvertices, dtype=bool)
    on_flap[mesh.t.ravel()] = True  # a node of some triangle, and of flap triangles only
    on_flap[mesh.t[:, ~np.asarray(flap_elements, dtype=bool)].ravel()] = False
    flap_nodes, others = wound[on_flap[wound]], wound[~on_flap[wound]]
    if flap_nodes.size == 0 or others.size == 0:
        raise ValueError("flap: no wound nodes on the flap or around it; cut the flap before suturing")
    moved = np.asarray(motion(positions[:, flap_nodes]), dtype=float)
    d = np.hypot(moved[0][:, None] - positions[0, others][None, :], moved[1][:, None] - positions[1, others][None, :])
    nearest = np.argmin(d, axis=1)
    ok = d[np.arange(flap_nodes.size), nearest] <= tolerance
    return np.vstack([flap_nodes[ok], others[nearest[ok]]])


def _weighted_percentile(values, weights, q) -> float:
    order = np.argsort(values)
    cumulative = np.cumsum(weights[order]) / np.sum(weights)
    return float(values[order][min(np.searchsorted(cumulative, q), values.size - 1)])


def _snapshot(sim):
    """The tissue as drawn (``Simulation.picture``): drawn points, triangles, and the element of each triangle."""
    return sim.picture.points(sim.positions()).copy(), sim.picture.triangles.copy(), sim.picture.element.copy()


def _material_points(sim) -> np.ndarray:
    """A point inside the material of every element (reference coordinates), shape (2, n_elements)."""
    picture = sim.picture
    x = picture.points(sim.model.X)
    out = np.empty((2, sim.mesh.nelements))
    # an element drawn as several triangles keeps the last one's centre
    out[:, picture.element] = x[:, picture.triangles].mean(axis=1)
    return out


def stitch_points(samples, normals, motion, offset) -> np.ndarray:
    """Stitches for a flap cut through elements: point pairs ``(k, 2, 2)``, flap point first. ``samples`` ``(k, 2)``
    on the flap's wound edges, with unit ``normals`` ``(k, 2)`` into the flap, are paired with where ``motion`` takes
    them; both ends are moved by ``offset`` into their own side (into the flap; into the bed, away from where the flap
    arrives), so that each is attached to the right lip where two lips touch."""
    samples = np.asarray(samples, dtype=float)
    normals = np.asarray(normals, dtype=float)
    target = np.asarray(motion(samples.T), dtype=float).T
    step = 1e-6 * max(1.0, float(np.abs(samples).max()))
    turned = (np.asarray(motion((samples + step * normals).T), dtype=float).T - target) / step  # its gradient on n
    turned /= np.hypot(turned[:, 0], turned[:, 1])[:, None]
    return np.stack([samples + offset * normals, target - offset * turned], axis=1)


def _along(a, b, spacing) -> np.ndarray:
    """Points along the segment ``a -> b`` at about ``spacing``, ends excluded (the corners are left open)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    n = max(1, int(round(np.hypot(*(b - a)) / spacing)))
    s = (np.arange(n) + 0.5) / n
    return a + s[:, None] * (b - a)


def _close_flap(scene, *, in_flap, motion, edges, method, tighten_frames, settle_frames, suture_stiffness,
                clock) -> FlapResult:
    """Build the cut scene, stitch the flap to the bed by ``motion``, tighten, and report the tension;
    ``edges(spacing)``: points on the flap's wound edges and their normals into the flap (:func:`stitch_points`)."""
    tighten_frames = check_count("tighten_frames", tighten_frames)
    settle_frames = check_count("settle_frames", settle_frames, 0)
    sim = Simulation(scene, **({} if clock is None else {"clock": clock}))
    snapshots = {"cut": _snapshot(sim)}
    flap = in_flap(_material_points(sim))
    edge = mean_edge_length(sim.mesh)
    if not np.any(flap):
        raise ValueError("the flap holds no triangle: make the mesh finer or the flap larger")
    if method == "edges":
        pairs = pair_by_motion(sim.mesh, sim.positions(), flap, motion, 0.5 * edge)
        stitches = pairs.shape[1]
    else:
        pairs = stitch_points(*edges(edge), motion, 1e-2 * edge)
        stitches = pairs.shape[0]
    sim.suture(pairs, stiffness=suture_stiffness, tightness=0.0)
    initial_gap = float(sim.suture_gaps().max())
    reports = []
    for k in range(1, tighten_frames + 1):
        sim.tighten(k / tighten_frames)
        reports.append(sim.frame())
    reports += sim.run(settle_frames)
    snapshots["sutured"] = _snapshot(sim)
    tension = sim.tension()
    areas = sim.model.element_areas()  # the mesh is the cut one still: ``flap`` marks the same elements
    return FlapResult(simulation=sim, stitches=stitches, tension=tension, max_tension=float(tension.max()),
                      p95_tension=_weighted_percentile(tension, areas, 0.95),
                      mean_tension=float(np.dot(areas, np.maximum(tension, 0.0)) / areas.sum()),
                      flap_tension=float(np.dot(areas[flap], tension[flap]) / areas[flap].sum()),
                      max_gap=float(sim.suture_gaps().max()), initial_gap=initial_gap,
                      suture_forces=sim.model.sutures.forces(sim.u), reports=reports, snapshots=snapshots)


def _patch_scene(name, description, patch, material, method, excisions, incisions, contact=False) -> Scene:
    """A ``width x height`` patch of skin held on its four outer edges, with the flap's excisions and incisions (and
    self-contact of its surface when ``contact``)."""
    width, height, n_triangles = patch
    model, youngs_modulus, poisson_ratio = material
    effects = {
        "handles": [{"name": side, "region": side} for side in ("left", "right", "bottom", "top")],
        "excisions": [{"polygon": polygon, "method": method} for polygon in excisions],
        "incisions": [{"path": path, "method": method} for path in incisions],
    }
    if contact:
        effects["contact"] = {}
    return Scene(name=name, description=description,
                 domain={"shape": "rectangle", "width": width, "height": height, "triangles": int(n_triangles)},
                 material={"model": model, "youngs_modulus": youngs_modulus, "poisson_ratio": poisson_ratio},
                 effects=effects, solver={"budget": 1e9, "rtol": 1e-6, "max_iterations": 100})


def advancement_flap(*, width=4.0, height=2.0, n_triangles=3000, defect=(1.2, 0.7, 0.6, 0.6), flap_length=1.5,
                     model="stable-neo-hookean", youngs_modulus=1000.0, poisson_ratio=0.3, tighten_frames=10,
                     settle_frames=0, suture_stiffness=None, clock=None, method="elements",
                     contact=False) -> FlapResult:
    """Excise a rectangular defect, cut an advancement flap beside it, pull it in, and report the tension.

    The skin patch ``[0, width] x [0, height]`` (``n_triangles``) is held on its four outer edges; ``defect`` ``(x, y,
    w, h)`` is the defect's lower-left corner and size; the two incisions run ``flap_length`` from its right edge (the
    flap is ``h`` wide, attached at its far end: longer flaps stretch less, the classic trade-off). The stitches are
    tightened from slack to closed over ``tighten_frames`` (each solved to tolerance), then ``settle_frames`` run.
    ``method="elements"`` cuts through the elements along the drawn lines, with stitches on the wound's edges about
    one per mesh edge length; ``"edges"`` removes the triangles whose centroids fall in the defect, snaps the incisions
    to mesh edges and ties wound nodes (the jagged, mesh-dependent version, to compare).
    """
    method = string("method", method, ("elements", "edges"))
    x0, y0, w, h = (float(v) for v in defect)
    flap_length = check_positive("flap_length", flap_length)
    if not (w > 0 and h > 0 and 0 < x0 and x0 + w + flap_length < width and 0 < y0 and y0 + h < height):
        raise ValueError(f"defect {defect!r} and flap_length {flap_length!r} must fit inside the {width} x {height} "
                         "patch, with skin on every side")
    x1, y1 = x0 + w, y0 + h
    tip = x1 + flap_length
    scene = _patch_scene("advancement flap",
                         "A rectangular defect closed by advancing a flap cut beside it (after Sifakis et al. 2009).",
                         (width, height, n_triangles), (model, youngs_modulus, poisson_ratio), method,
                         [[[x0, y0], [x1, y0], [x1, y1], [x0, y1]]], [[[x1, y0], [tip, y0]], [[x1, y1], [tip, y1]]],
                         contact)

    def in_flap(c):
        return (c[0] > x1) & (c[0] < tip) & (c[1] > y0) & (c[1] < y1)

    def edges(spacing):  # the flap's leading edge, then its top and bottom edges
        sides = (((x1, y0), (x1, y1), (1.0, 0.0)), ((x1, y1), (tip, y1), (0.0, -1.0)),
                 ((x1, y0), (tip, y0), (0.0, 1.0)))
        points = [_along(a, b, spacing) for a, b, _ in sides]
        return np.vstack(points), np.repeat([n for _, _, n in sides], [len(q) for q in points], axis=0)

    return _close_flap(scene, in_flap=in_flap, motion=lambda X: X - np.array([[w], [0.0]]), edges=edges,
                       method=method, tighten_frames=tighten_frames, settle_frames=settle_frames,
                       suture_stiffness=suture_stiffness, clock=clock)


def rotation_flap(*, width=4.0, height=3.0, n_triangles=3000, pivot=(1.5, 1.5), radius=1.0, defect_angle=30.0,
                  flap_angle=120.0, model="stable-neo-hookean", youngs_modulus=1000.0, poisson_ratio=0.3,
                  tighten_frames=10, settle_frames=0, suture_stiffness=None, clock=None,
                  method="elements", contact=False) -> FlapResult:
    """Close a wedge-shaped defect by rotating a flap about its pivot, and report the tension.

    The defect is the sector of the circle of ``radius`` about ``pivot`` between 60 and ``60 + defect_angle`` degrees;
    the flap is the sector between ``60 - flap_angle`` and 60 degrees, freed by an incision along the arc and attached
    along its straight base. Its leading edge turns by ``defect_angle`` onto the defect's far edge; its base cannot
    turn, so the flap fans out: the radius at angle ``theta`` turns by ``defect_angle (theta - theta_0) / flap_angle``
    and the arc slides along the circle, where its stitches meet the outer lip. A wider flap fans out less and leaves
    less tension: the rotation flap's rule of thumb (an arc several times the defect's width). ``method`` and
    ``contact`` as in :func:`advancement_flap`.
    """
    method = string("method", method, ("elements", "edges"))
    px, py = (float(v) for v in pivot)
    r = float(radius)
    a1 = np.deg2rad(60.0)
    alpha = np.deg2rad(float(defect_angle))
    a0 = a1 - np.deg2rad(float(flap_angle))
    if not (0 < alpha < np.pi / 2 and 0 < a1 - a0 < 1.5 * np.pi and r > 0):
        raise ValueError(f"defect_angle must be in (0, 90) and flap_angle in (0, 270) degrees, radius > 0; got "
                         f"{defect_angle!r}, {flap_angle!r}, {radius!r}")

    def arc(start, stop, n):  # n points (n, 2) on the circle, from angle start to stop
        a = np.linspace(start, stop, n)
        return np.stack([px + r * np.cos(a), py + r * np.sin(a)], axis=1)

    ring = arc(a0, a1 + alpha, 400)
    if not (np.all(ring > 0) and np.all(ring < [width, height]) and 0 < px < width and 0 < py < height):
        raise ValueError(f"the flap and the defect (radius {radius!r} about {pivot!r}) must fit inside the "
                         f"{width} x {height} patch, with skin on every side")
    edge_guess = np.sqrt(2.0 * width * height / max(int(n_triangles), 1))
    # the arcs as polylines with chords a quarter of an edge long: they stray from the circle by
    # (h/4)^2 / (8 r), far less than the offset by which a stitch's ends are put on their own side
    n_arc = max(8, int(np.ceil(4.0 * r * (a1 - a0) / edge_guess)))
    defect = np.vstack([[[px, py]], arc(a1, a1 + alpha, max(4, int(np.ceil(4.0 * r * alpha / edge_guess))))])
    scene = _patch_scene("rotation flap",
                         "A wedge-shaped defect closed by rotating the flap beside it about its pivot.",
                         (width, height, n_triangles), (model, youngs_modulus, poisson_ratio), method,
                         [defect.tolist()], [arc(a1, a0, n_arc).tolist()], contact)

    def polar(X, tol):  # distance from the pivot, and angle from a0 on (the flap and the defect lie there)
        d = np.asarray(X, float) - np.array([[px], [py]])
        ang = np.arctan2(d[1], d[0])
        return np.hypot(d[0], d[1]), np.where(ang < a0 - tol, ang + 2 * np.pi, ang)

    def motion(X):  # the flap fans out: each radius turns in proportion to its angle from the base
        rho, ang = polar(X, 1e-9)
        turned = ang + alpha * np.clip((ang - a0) / (a1 - a0), 0.0, 1.0)
        return np.array([[px], [py]]) + rho * np.stack([np.cos(turned), np.sin(turned)])

    def in_flap(X):
        rho, ang = polar(X, 1e-12)
        return (rho < r) & (ang > a0) & (ang < a1)

    def edges(spacing):  # the leading edge, then the rim
        lead = _along((px, py), (px + r * np.cos(a1), py + r * np.sin(a1)), spacing)
        n = max(1, int(round(r * (a1 - a0) / spacing)))
        ang = a1 - (np.arange(n) + 0.5) / n * (a1 - a0)
        rim = np.stack([px + r * np.cos(ang), py + r * np.sin(ang)], axis=1)
        return np.vstack([lead, rim]), np.vstack([np.repeat([[np.sin(a1), -np.cos(a1)]], len(lead), axis=0),
                                                  -np.stack([np.cos(ang), np.sin(ang)], axis=1)])

    return _close_flap(scene, in_flap=in_flap, motion=motion, edges=edges, method=method,
                       tighten_frames=tighten_frames, settle_frames=settle_frames,
                       suture_stiffness=suture_stiffness, clock=clock)
