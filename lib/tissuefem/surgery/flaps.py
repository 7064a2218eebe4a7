"""Local flaps: close a defect with a flap of neighbouring skin, and see the tension it leaves.

After Sifakis, Hellrung, Teran, Oliker and Cutting, "Local flaps: a real-time
finite element based solution to the plastic surgery defect puzzle" (2009).
A surgeon removes a lesion (excision), which leaves a defect too wide to pull
shut; instead a *flap* of nearby skin is cut on three sides and moved (advanced
or rotated) into the defect, and its edges are sutured to the wound's. Which
design leaves the least tension in the skin is the question such a simulator
answers before the operation.

:func:`advancement_flap` runs the whole procedure on a patch of skin held on
its outer edges:

1. **excise** a rectangular defect;
2. **cut** the flap: two parallel incisions continuing the defect's top and
   bottom edges away from it (the flap stays attached at its far end, its
   *base*);
3. **suture**: each node on the flap's wound edges is paired with the wound
   node where the planned motion (a translation by the defect's width) would
   take it; the stitches start slack and are tightened over several frames
   (quasistatic frames of the budget solver, so the flap is pulled in
   gradually);
4. **report** the tension left: the largest principal Cauchy stress of every
   element, its maximum and area-weighted mean, the stitch forces and the
   gaps still open.

:func:`pair_by_motion` is the general rule used in step 3 (any rigid motion:
a rotation flap passes a rotation).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .scene import Scene
from .simulation import Simulation

__all__ = ["advancement_flap", "pair_by_motion", "FlapResult", "wound_nodes"]


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
    snapshots: dict = field(default_factory=dict)  # stage -> (positions (2, n), triangles (3, m))

    @property
    def converged(self) -> bool:
        return bool(self.reports) and self.reports[-1].converged

    def summary(self) -> str:
        return (f"{self.stitches} stitches; gap {self.initial_gap:.3g} -> {self.max_gap:.2g}; "
                f"tension max {self.max_tension:.4g}, 95th percentile {self.p95_tension:.4g}, "
                f"mean {self.mean_tension:.4g} (in the flap {self.flap_tension:.4g}); "
                f"largest stitch force {self.suture_forces.max(initial=0.0):.4g}")


def wound_nodes(mesh, names=("cut", "defect")) -> np.ndarray:
    """Nodes on the wound: the boundary facets a cut or an excision created."""
    facets = [mesh.boundaries[n] for n in names if mesh.boundaries is not None and n in mesh.boundaries]
    if not facets:
        return np.zeros(0, dtype=np.intp)
    return np.unique(mesh.facets[:, np.concatenate(facets)])


def pair_by_motion(mesh, positions, flap_elements, motion, tolerance) -> np.ndarray:
    """Stitches for moving a flap by ``motion``: node pairs ``(2, k)``, flap node first.

    A wound node belongs to the flap when all its triangles are flap
    triangles (``flap_elements``, a boolean mask); after a cut the two copies
    of a node on the cut fall on different sides. Each flap wound node is
    moved by ``motion`` (``(2, n) -> (2, n)``, e.g. a translation or a rotation
    about the flap's pivot) and paired with the nearest non-flap wound node,
    if that is within ``tolerance``.
    """
    wound = wound_nodes(mesh)
    t = mesh.t
    on_flap = np.ones(mesh.nvertices, dtype=bool)
    off = t[:, ~np.asarray(flap_elements, dtype=bool)].ravel()
    on_flap[off] = False
    touched = np.zeros(mesh.nvertices, dtype=bool)
    touched[t.ravel()] = True
    on_flap &= touched
    flap_nodes = wound[on_flap[wound]]
    others = wound[~on_flap[wound]]
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
    return sim.positions().copy(), sim.mesh.t.copy()


def advancement_flap(*, width=4.0, height=2.0, n_triangles=3000, defect=(1.2, 0.7, 0.6, 0.6), flap_length=1.5,
                     model="stable-neo-hookean", youngs_modulus=1000.0, poisson_ratio=0.3, tighten_frames=10,
                     settle_frames=0, suture_stiffness=None, clock=None) -> FlapResult:
    """Excise a rectangular defect, cut an advancement flap beside it, pull it in, and report the tension.

    Parameters
    ----------
    width, height, n_triangles
        The skin patch ``[0, width] x [0, height]``, held on all four outer edges.
    defect
        ``(x, y, w, h)``: the defect's lower-left corner and size.
    flap_length
        How far the two incisions run from the defect's right edge (the flap is
        ``flap_length`` long and ``h`` wide, attached at its far end). Longer flaps
        stretch less: the classic advancement-flap trade-off.
    tighten_frames, settle_frames
        Frames over which the stitches are tightened from slack to closed, and
        frames run after that (each tightening frame is solved to the solver's
        tolerance, so extra frames change nothing; they only report).
    """
    x0, y0, w, h = (float(v) for v in defect)
    if not (np.isfinite(flap_length) and flap_length > 0):
        raise ValueError(f"flap_length must be finite and > 0, got {flap_length!r}")
    for name, value, low in (("tighten_frames", tighten_frames, 1), ("settle_frames", settle_frames, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
    if not (w > 0 and h > 0 and 0 < x0 and x0 + w + flap_length < width and 0 < y0 and y0 + h < height):
        raise ValueError(f"defect {defect!r} and flap_length {flap_length!r} must fit inside the {width} x {height} "
                         "patch, with skin on every side")
    x1, y1 = x0 + w, y0 + h
    tip = x1 + flap_length
    scene = Scene(
        name="advancement flap",
        description="A rectangular defect closed by advancing a flap cut beside it (after Sifakis et al. 2009).",
        domain={"shape": "rectangle", "width": width, "height": height, "triangles": int(n_triangles)},
        material={"model": model, "youngs_modulus": youngs_modulus, "poisson_ratio": poisson_ratio},
        effects={
            "handles": [{"name": side, "region": side} for side in ("left", "right", "bottom", "top")],
            "excisions": [{"polygon": [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]}],
            "incisions": [{"path": [[x1, y0], [tip, y0]]}, {"path": [[x1, y1], [tip, y1]]}],
        },
        solver={"budget": 1e9, "rtol": 1e-6, "max_iterations": 100},
    )
    options = {} if clock is None else {"clock": clock}
    sim = Simulation(scene, **options)
    snapshots = {"cut": _snapshot(sim)}
    mesh = sim.mesh
    centroids = mesh.p[:, mesh.t].mean(axis=1)
    flap = (centroids[0] > x1) & (centroids[0] < tip) & (centroids[1] > y0) & (centroids[1] < y1)
    edge = float(np.mean(np.hypot(*(mesh.p[:, mesh.facets[0]] - mesh.p[:, mesh.facets[1]]))))
    if not np.any(flap):
        raise ValueError("the flap holds no triangle: make the mesh finer or the flap larger")
    pairs = pair_by_motion(mesh, sim.positions(), flap, lambda X: X - np.array([[w], [0.0]]), 0.5 * edge)
    sim.suture(pairs, stiffness=suture_stiffness, tightness=0.0)
    initial_gap = float(sim.suture_gaps().max())
    reports = []
    for k in range(1, int(tighten_frames) + 1):
        sim.tighten(k / int(tighten_frames))
        reports.append(sim.frame())
    reports += sim.run(int(settle_frames))
    snapshots["sutured"] = _snapshot(sim)
    tension = sim.tension()
    areas = sim.model.element_areas()
    return FlapResult(
        simulation=sim,
        stitches=pairs.shape[1],
        tension=tension,
        max_tension=float(tension.max()),
        p95_tension=_weighted_percentile(tension, areas, 0.95),
        mean_tension=float(np.dot(areas, np.maximum(tension, 0.0)) / areas.sum()),
        flap_tension=float(np.dot(areas[flap], tension[flap]) / areas[flap].sum()),
        max_gap=float(sim.suture_gaps().max()),
        initial_gap=initial_gap,
        suture_forces=sim.model.sutures.forces(sim.u),
        reports=reports,
        snapshots=snapshots,
    )
