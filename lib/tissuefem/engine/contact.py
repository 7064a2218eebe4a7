"""Self-contact of the boundary: surfaces that touch, press, slide, and never pass through each other.

Where contact lives
-------------------
A :class:`Contact` term is one more term of the incremental potential (:mod:`tissuefem.engine.terms`), with two
hooks that a model without contact never calls:

* its Hessian couples nodes that no element couples (two sides of a fold, two lips of a wound), and *which* nodes
  changes as the body moves. The model's sparsity pattern is widened with the couplings of the current candidate
  pairs and rebuilt (a merge of a few keys, ~4 ms at 8k triangles) only when a pair appears that the pattern does
  not hold (:meth:`Contact.covers`);
* a state on the far side of a surface must never be reached. The minimiser asks :meth:`Contact.max_step` for the
  largest fraction of a Newton step free of crossings (continuous collision detection) before its line search, and
  the stepper asks the same of its warm start (:func:`tissuefem.engine.minimize.newton`, ``step_limit``).

The surface
-----------
A :class:`ContactSurface` is a set of *points* and *segments* between them. A point is a fixed linear combination of
node positions, ``y_i = sum_k W_ik x_(N_ik)``: a boundary node is one node with weight 1, a point on the lip of a
cut through an element (:mod:`tissuefem.surgery.element_cuts`) the barycentric combination of the nodes of the
element copy that carries that lip. A segment ``(a, b)`` has the material on its *left* (counter-clockwise around
the material), so its outward normal is the tangent turned clockwise, ``n = (e_y, -e_x) / |e|`` with
``e = y_b - y_a``. Segments follow each other round closed loops (:attr:`ContactSurface.next`).

Why a one-sided band behind the surface (and not IPC's barrier as it is)
-------------------------------------------------------------------------
Incremental Potential Contact (IPC) [1]_ keeps surfaces apart by a barrier on the unsigned distance ``d`` between a
point and a segment, ``b(d) = -(d - d^)^2 ln(d / d^)`` for ``0 < d < d^``: zero and twice differentiable at the
activation distance ``d^``, infinite at ``d = 0``, so two surfaces never touch. That cannot work here: the moment a
wound is cut, its two lips *coincide* (``d = 0`` along it), and a closed wound must be allowed to stay closed
without force.

So the gap is *signed*, measured against the outward normal of the segment (positive in front, negative behind), and
the barrier acts on the inside: a point's energy is zero for ``sigma >= 0`` (two lips that touch feel nothing) and
grows to infinity as the overlap reaches ``d^``:

    E = kappa * sum_(points p) sum_(stretches of surface near p) l_p d^ beta(1 + (sigma + o_p) / d^),
    beta(zeta) = -(zeta - 1)^2 ln(zeta)   for 0 < zeta < 1,   beta = 0 for zeta >= 1,

with ``sigma`` the signed gap of ``p`` to the nearest feature of that stretch and ``o_p`` a rest offset (both
below). This is IPC's barrier measured from the surface moved *inward* by ``d^`` (the "thickness" offset of
codimensional IPC [2]_, with the opposite sign): ``d^`` is the thin skin in which contact pressure builds up.
``beta`` and its first two derivatives vanish at ``zeta = 1`` (contact starts smoothly) and ``beta -> infinity`` as
``zeta -> 0``: no accepted state has a point deeper than ``d^`` behind a surface it is near. ``l_p`` is the point's
share of the surface length at rest (half of each segment it ends), so ``kappa`` is a *pressure*: at an overlap
``delta`` the pressure is ``kappa |beta'(1 - delta / d^)|``, ``kappa`` itself at ``delta = 0.46 d^`` (a scene's
default ``kappa`` is Young's modulus: tissue pressed at a tenth of its modulus overlaps by a fifth of ``d^``).

Why a barrier and not a penalty with a no-crossing check: a finite penalty lets Newton push a point against the
collision detection's limit step after step (each step cut to 0.8 of the way, never converging); a barrier's energy
grows without bound before the wall, so the minimiser turns back on its own and the collision detection only catches
steps that would jump over the skin.

The gradient is ``dE/dy = kappa l_p beta'(zeta) dsigma/dy`` (the force ``-kappa l_p beta' n`` pushes the point out
along the normal and the segment back, equal and opposite), and the Hessian

    d2E/dy2 = kappa l_p [ beta''(zeta) / d^ (dsigma/dy)(dsigma/dy)^T  +  beta'(zeta) d2sigma/dy2 ].

``beta'' >= 0``, ``beta' <= 0`` and ``d2sigma/dy2`` (the turning of the normal) is indefinite: the *safe* Hessian
(``safe=True``, the minimiser's fallback when a direction is not downhill) keeps only the first, positive
semi-definite part. The weights ``W`` carry the points' Hessian to the nodes.

The signed gap: which feature of the surface a point is measured against
------------------------------------------------------------------------
For a point ``p`` and a segment ``s = (a, b)`` with ``e = y_b - y_a``, ``w = y_p - y_a``, ``t = w . e / |e|^2`` says
where ``p`` projects along it:

* **point-segment (interior)**, ``0 < t < 1``: the distance to the segment's line, signed by the outward normal,
  ``sigma = cross(w, e) / |e| = (y_p - y_a) . n``;
* **point-point (an end)**, ``t <= 0`` or ``t >= 1``: the distance ``|y_p - y_v|`` to that end ``v``, negative when
  ``(y_p - y_v) . n_v < 0`` with the corner's *pseudonormal* ``n_v`` (the mean of the normals of the two segments
  meeting at ``v``). Behind a reflex corner a point is inside; behind a convex corner no point projects outside both
  segments.

This is the signed distance to a polygon of [3]_, continuous where the nearest feature changes from a segment's
interior to its end *inside the run the point sees*: the segments within ``d^`` of a point form runs of consecutive
segments (one where it touches one stretch of surface, two where it is pinched between two), and in each run only
the nearest segment counts. So a point pressed into a convex corner belongs to the nearer side (the only kink is
across the corner's bisector), is never counted twice, and segments shorter than the skin (the sliver a cut through
elements leaves next to a node) are handled like any other. Where it is not continuous: "Where the energy jumps".

A point is not paired with the two segments it ends, nor (in the broad phase) with their neighbours, nor with any
segment less than ``2 d^`` away from it along the surface at rest: a point and its own neighbourhood are not "in
contact" (without this a cut's lip, a chain of pieces shorter than ``d^``, puts its own points within the skin of
its corners as soon as it bends). The walk along the loop stops at a corner that turned back into the material when
the surface was built, the tip of a crack: there the first point of each lip is checked against the first segment of
the other (a *hinge*) whenever the corner turns by more than 90 degrees, so that a crack pressed shut right up to
its tip does not overlap there. Two coinciding lips are at ``sigma = 0``: in contact, with no force.

The reference configuration touches nothing. Where parts of the surface lie closer than the skin there (a zigzag of
segments shorter than ``d^``), a point sits behind another part already at rest; its skin is then measured from
where it sits, an *offset* ``o_p`` (its depth at rest): its energy uses ``sigma + o_p`` and its wall lies at
``sigma = -(d^ + o_p)``. Being one number per point, the offset keeps the energy continuous where the nearest
feature changes.

A point found deeper than ``d^`` behind a segment when a step *starts* (and not within ``d^`` of the segment's
neighbours, along which it may slide into this segment's ownership later in the step) is ignored for that pair until
the step is over: the far side of a thin body is such a pair, and so is tissue a handle dragged through tissue (the
handles' motion is obeyed; their crossings are counted in ``StepReport.crossed`` while the point stays through).
Once the point is back out, contact acts again.

Where the energy jumps
----------------------
An owner's gap is continuous while the point stays in the cone of the corner it is measured from. Two cases are not:

* a corner primitive whose point is *outside* the corner's cone, because the segment on the corner's other side is
  in the point's own neighbourhood: the pseudonormal's sign flips on the line through the corner perpendicular to
  it, possibly closer than ``d^``;
* a corner whose segments fold right over (through 180 degrees, as a crumpled lip of a cut through elements can):
  the pseudonormal turns over, and so does the sign of every point in the corner's cone.

The energy then jumps by a finite amount (or from zero to the wall), and Newton's line search stops at the jump.
Both are rare and both are open.

Continuous collision detection
------------------------------
The barrier is infinite only in the skin; a large step could carry a point from in front of a segment to deeper than
``d^`` behind it, where the energy is zero again. So every step is first limited: with all points moving linearly,
``y(tau) = y0 + tau dy``, the first ``tau`` in ``[0, 1]`` at which a point reaches a *wall* of a segment that owns
it then (no neighbouring segment nearer than ``d^``) is its time of impact. The walls are the segment's line moved
inward by ``d^``, ``cross(w(tau), e(tau)) = -d^ |e(tau)|`` (squared, a quartic in ``tau``, solved only for the pairs
a conservative quadratic bound flags), and the circles of radius ``d^`` round its ends,
``|y_p(tau) - y_v(tau)|^2 = d^2`` (a quadratic), where ``p`` lies behind the corner. The step is cut to ``0.8`` of
the earliest time of impact, IPC's safety factor [1]_.

The broad phase keeps this cheap: a Verlet list [4]_ of the (point, segment) pairs closer than ``d^ + skin`` (the
nearest points of each segment's midpoint, from a k-d tree), valid while the points have moved less than
``skin / 2`` *relative to each other* since it was built (a rigid drag refreshes nothing); a surface nowhere near
itself has an empty list, no couplings in the pattern, and costs a few vector operations per evaluation.

References
----------
.. [1] M. Li, Z. Ferguson, T. Schneider, T. Langlois, D. Zorin, D. Panozzo,
   C. Jiang, D. M. Kaufman, *Incremental Potential Contact: intersection- and
   inversion-free, large-deformation dynamics*, ACM Transactions on Graphics
   39(4) (SIGGRAPH 2020), 49.
.. [2] M. Li, D. M. Kaufman, C. Jiang, *Codimensional Incremental Potential
   Contact*, ACM Transactions on Graphics 40(4) (SIGGRAPH 2021), 170.
.. [3] J. A. Baerentzen, H. Aanaes, *Signed distance computation using the
   angle weighted pseudonormal*, IEEE Transactions on Visualization and
   Computer Graphics 11(3) (2005), 243-253.
.. [4] L. Verlet, *Computer "experiments" on classical fluids. I.
   Thermodynamical properties of Lennard-Jones molecules*, Physical Review
   159(1) (1967), 98-103.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .terms import Term, check_positive

__all__ = ["ContactSurface", "Contact", "barrier", "SAFETY"]

#: the fraction of the time of impact a step may take (IPC's choice)
SAFETY = 0.8


def _cross(u, v):
    return u[0] * v[1] - u[1] * v[0]


def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1]


def _segment_distance(y, ya, yb):
    """Distance from points ``y`` to the closed segments ``ya -> yb`` (all (2, m))."""
    e, w = yb - ya, y - ya
    t = np.clip(_dot(w, e) / np.maximum(_dot(e, e), 1e-300), 0.0, 1.0)
    return np.hypot(*(w - t * e))


def barrier(zeta):
    """``beta(zeta) = -(zeta - 1)^2 ln(zeta)`` on ``0 < zeta < 1`` (0 from 1 on) and its first two derivatives.

    Returns ``(beta, beta', beta'')``, zero where ``zeta >= 1`` (``beta(1) = beta'(1) = beta''(1) = 0``: the barrier
    starts twice differentiably; ``beta -> infinity`` as ``zeta -> 0``; the caller never passes ``zeta <= 0``).
    """
    z = np.asarray(zeta, dtype=float)
    inside = (z > 0.0) & (z < 1.0)
    zz = np.where(inside, z, 1.0)
    log, m = np.log(zz), zz - 1.0
    b0 = np.where(inside, -m * m * log, 0.0)
    b1 = np.where(inside, -2.0 * m * log - m * m / zz, 0.0)
    b2 = np.where(inside, -2.0 * log - 4.0 * m / zz + m * m / (zz * zz), 0.0)
    return b0, b1, b2


# ------------------------------------------------------------------------------------------------ the surface

class ContactSurface:
    """Points (linear combinations of nodes) and the segments between them, material on each segment's left.

    Point ``i`` is ``sum_j weights[i, j] * x[:, nodes[i, j]]`` (``nodes``, ``weights`` shaped (n_points, k), unused
    slots padded with weight 0; a plain boundary node has ``k = 1``, weight 1) among ``n_nodes`` mesh nodes.
    ``segments`` (2, n_segments) are the point indices ``(a, b)`` of every segment, run counter-clockwise round the
    material; ``wound`` (one bool per segment, optional) flags those on a wound's lips (for drawing and reports).

    Attributes: ``next`` / ``previous`` (n_segments,), the segment that starts where this one ends (ends where it
    starts), -1 where there is none or more than one; ``neighbourhood`` (n_segments, 4), the points the broad phase does
    not pair a segment with (its ends and its neighbours' far ends, -1 where missing); ``hinge_points``,
    ``hinge_segments``, ``hinge_corner``, the pairs it leaves out but that can touch where the surface folds back on
    itself: at the corner between a segment and the next (``hinge_corner`` is the first), the far end of each against
    the other (at a crack tip, the first point of one lip against the first segment of the other).
    """

    def __init__(self, nodes, weights, segments, n_nodes, wound=None):
        if isinstance(n_nodes, bool) or not isinstance(n_nodes, (int, np.integer)) or n_nodes < 1:
            raise ValueError(f"contact.surface: n_nodes must be a positive integer, got {n_nodes!r}")
        self.n_nodes = int(n_nodes)
        nodes = np.asarray(nodes)
        nodes = nodes[:, None] if nodes.ndim == 1 else nodes
        if nodes.ndim != 2 or nodes.shape[1] < 1 or not (nodes.size == 0 or np.issubdtype(nodes.dtype, np.integer)):
            raise ValueError(f"contact.surface.nodes must be node indices shaped (n_points, k), got {nodes!r}")
        if nodes.size and (nodes.min() < 0 or nodes.max() >= self.n_nodes):
            raise ValueError(f"contact.surface.nodes: node indices must lie in 0..{self.n_nodes - 1}, got "
                             f"{int(nodes.min())}..{int(nodes.max())}")
        try:
            weights = np.asarray(weights, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"contact.surface.weights must be numbers shaped {nodes.shape}") from None
        weights = weights[:, None] if weights.ndim == 1 else weights
        if weights.shape != nodes.shape or not np.all(np.isfinite(weights)):
            raise ValueError(f"contact.surface.weights must be finite and shaped like the nodes {nodes.shape}, "
                             f"got shape {weights.shape}")
        segments = np.asarray(segments)
        if (segments.ndim != 2 or segments.shape[0] != 2
                or not (segments.size == 0 or np.issubdtype(segments.dtype, np.integer))):
            raise ValueError(f"contact.surface.segments must be point indices shaped (2, n_segments), got "
                             f"shape {segments.shape}")
        n_points = nodes.shape[0]
        if segments.size and (segments.min() < 0 or segments.max() >= n_points):
            raise ValueError(f"contact.surface.segments: point indices must lie in 0..{n_points - 1}")
        if np.any(segments[0] == segments[1]):
            raise ValueError("contact.surface.segments: a segment joins a point to itself")
        self.nodes = nodes.astype(np.intp)
        self.weights = weights
        self._plain = nodes.shape[1] == 1 and bool(np.all(weights == 1.0))  # every point a node
        self.segments = segments.astype(np.intp)
        n_seg = self.segments.shape[1]
        self.wound = np.zeros(n_seg, dtype=bool) if wound is None else np.asarray(wound, dtype=bool)
        if self.wound.shape != (n_seg,):
            raise ValueError(f"contact.surface.wound must be one bool per segment ({n_seg}), got {self.wound.shape}")
        # the loops: the segment leaving each segment's end (unique, or none)
        a, b = self.segments
        starts = np.bincount(a, minlength=n_points)
        ends = np.bincount(b, minlength=n_points)
        leaving = np.full(n_points, -1, dtype=np.intp)
        leaving[a] = np.arange(n_seg)
        arriving = np.full(n_points, -1, dtype=np.intp)
        arriving[b] = np.arange(n_seg)
        self.next = np.where(starts[b] == 1, leaving[b], -1)
        self.previous = np.where(ends[a] == 1, arriving[a], -1)
        self.neighbourhood = np.stack([a, b, np.where(self.previous >= 0, a[np.maximum(self.previous, 0)], -1),
                                       np.where(self.next >= 0, b[np.maximum(self.next, 0)], -1)], axis=1)
        # hinges: at the corner between a segment and the next, each one's far end against the other segment
        into = np.flatnonzero(self.next >= 0)
        out = self.next[into]
        hinge_p = np.concatenate([a[into], b[out]])
        hinge_s = np.concatenate([out, into])
        corner = np.concatenate([into, into])  # the segment that ends at the hinge's corner
        keep = (hinge_p != a[hinge_s]) & (hinge_p != b[hinge_s])  # not in a loop of two segments
        self.hinge_points, self.hinge_segments, self.hinge_corner = hinge_p[keep], hinge_s[keep], corner[keep]

    # -------------------------------------------------------------- builders
    @classmethod
    def from_mesh(cls, mesh, wound_boundary="cut") -> "ContactSurface":
        """The boundary of a plain mesh: one point per boundary node, one segment per boundary facet.

        After :func:`tissuefem.surgery.topology.incise` the two lips of a cut are boundary facets between duplicated
        nodes, so they are part of it; the facets named ``wound_boundary`` are flagged as wound.
        """
        p = np.asarray(mesh.p, dtype=float)
        facets = np.asarray(mesh.boundary_facets(), dtype=np.intp)
        pairs = np.asarray(mesh.facets, dtype=np.intp)[:, facets]
        element = np.asarray(mesh.f2t, dtype=np.intp)[0, facets]
        t = np.asarray(mesh.t, dtype=np.intp)[:, element]
        third = t.sum(axis=0) - pairs.sum(axis=0)  # the element's vertex off the facet
        e = p[:, pairs[1]] - p[:, pairs[0]]
        left = _cross(e, p[:, third] - p[:, pairs[0]]) > 0
        pairs = np.where(left, pairs, pairs[::-1])  # the material on the left
        nodes, segments = np.unique(pairs, return_inverse=True)
        segments = segments.reshape(2, -1)
        wound = None
        if mesh.boundaries and wound_boundary in mesh.boundaries:
            wound = np.isin(facets, np.asarray(mesh.boundaries[wound_boundary]))
        return cls(nodes[:, None], np.ones((nodes.size, 1)), segments, p.shape[1], wound=wound)

    # -------------------------------------------------------------- geometry
    @property
    def n_points(self) -> int:
        return self.nodes.shape[0]

    @property
    def n_segments(self) -> int:
        return self.segments.shape[1]

    def positions(self, x) -> np.ndarray:
        """The points at node positions ``x`` (2, n_nodes): shape (2, n_points)."""
        x = np.asarray(x)
        if self._plain:
            return x[:, self.nodes[:, 0]]
        y = self.weights[:, 0] * x[:, self.nodes[:, 0]]
        for k in range(1, self.nodes.shape[1]):
            y = y + self.weights[:, k] * x[:, self.nodes[:, k]]
        return y

    def matrix(self) -> sp.csr_matrix:
        """The map from node coordinates to point coordinates as a sparse matrix (n_points, n_nodes)."""
        rows = np.repeat(np.arange(self.n_points), self.nodes.shape[1])
        return sp.csr_matrix((self.weights.ravel(), (rows, self.nodes.ravel())), shape=(self.n_points, self.n_nodes))

    def segment_positions(self, x) -> np.ndarray:
        """The segments' ends at node positions ``x``: shape (n_segments, 2, 2) (segment, end, xy)."""
        y = self.positions(x)
        return np.stack([y[:, self.segments[0]].T, y[:, self.segments[1]].T], axis=1)

    def __repr__(self):
        return (f"ContactSurface({self.n_points} points, {self.n_segments} segments, "
                f"{int(self.wound.sum())} on wounds)")


# ------------------------------------------------------------------------------------------------ the term

class Contact(Term):
    """Self-contact of a :class:`ContactSurface`: a one-sided barrier in the skin behind it (module docstring).

    ``X`` (2, n_nodes) are the reference node positions; ``distance`` is ``d^``, the depth of the skin in which contact
    pressure builds up (the largest overlap ever allowed), at most half the surface's median segment length;
    ``stiffness`` is ``kappa``, a pressure (the contact pressure at an overlap of about ``0.46 d^``); ``skin`` the
    Verlet list's margin (default: the median segment length). The hooks for the minimiser and the stepper:
    :meth:`covers` (the pattern), :meth:`max_step` (collision detection), :meth:`begin_step` / :meth:`end_step` (where a
    step starts).
    """

    name = "contact"
    has_safe_hessian = True

    def __init__(self, X, surface, distance, stiffness, skin=None):
        if not isinstance(surface, ContactSurface):
            raise ValueError(f"contact.surface must be a ContactSurface, got {type(surface).__name__}")
        X = np.asarray(X, dtype=float)
        if X.ndim != 2 or X.shape[0] != 2 or X.shape[1] != surface.n_nodes:
            raise ValueError(f"contact.surface combines {surface.n_nodes} nodes but the mesh has "
                             f"{X.shape[-1] if X.ndim == 2 else '?'}")
        self.X = X
        self.n_nodes = X.shape[1]
        self.surface = surface
        self.distance = check_positive("contact.distance", distance)
        self.stiffness = check_positive("contact.stiffness", stiffness)
        Y = surface.positions(X)
        a, b = surface.segments
        self.rest_length = np.hypot(*(Y[:, b] - Y[:, a]))
        if np.any(self.rest_length <= 1e-12 * max(1.0, float(np.ptp(X)))):
            k = int(np.argmin(self.rest_length))
            raise ValueError(f"contact.surface: segment {k} has zero length")
        self.point_length = 0.5 * (np.bincount(a, self.rest_length, minlength=surface.n_points)
                                   + np.bincount(b, self.rest_length, minlength=surface.n_points))
        median = float(np.median(self.rest_length)) if self.rest_length.size else np.inf
        if self.distance > 0.5 * median:
            raise ValueError(f"contact.distance = {self.distance:g} must be at most half the surface's median "
                             f"segment length ({0.5 * median:g}): the skin is a thin layer of the surface")
        if skin is None:
            self.skin = median if np.isfinite(median) else 1.0
        else:
            self.skin = check_positive("contact.skin", skin)
        self._width = width = surface.nodes.shape[1]  # nodes per point
        # local dof layout of a (point, a, b) triple: (point j, node slot k, component c) -> 6-vector entry 2 j + c
        j, k, c = np.meshgrid(np.arange(3), np.arange(width), np.arange(2), indexing="ij")
        self._slot_point, self._slot_node, self._slot_comp = j.ravel(), k.ravel(), c.ravel()
        self._slot_local = (2 * j + c).ravel()
        n_local = (6 * width) ** 2
        n_seg = surface.n_segments
        # a corner folded right back on itself (a crack tip at rest) has no mean normal: it opens backwards along
        # the incoming segment if it turned into the material when built (a crack tip), forwards if it turned
        # out of it (a needle). _fold[s] is that sign for the corner at the end of segment s.
        self._fold = np.ones(max(n_seg, 1))
        e_s = Y[:, b] - Y[:, a]
        e_n = e_s[:, np.maximum(surface.next, 0)]
        turns_in = _cross(e_s, e_n) <= 1e-9 * np.hypot(*e_s) * np.hypot(*e_n)
        self._fold[:n_seg] = np.where((surface.next >= 0) & turns_in, -1.0, 1.0)
        # hinges count only at corners that turn back into the material in the reference configuration (a crack
        # tip, a notch): closing such a corner is contact; closing a convex corner crushes the material between
        e_in, e_out = e_s[:, surface.hinge_corner], e_s[:, surface.next[surface.hinge_corner]]
        size = np.hypot(*e_in) * np.hypot(*e_out)
        armed = (_cross(e_in, e_out) < -1e-9 * size) | ((np.abs(_cross(e_in, e_out)) <= 1e-9 * size)
                                                          & (_dot(e_in, e_out) < 0))
        self._hinge = np.flatnonzero(armed)
        self._excluded = self._arc_neighbourhood(self.rest_length, 2.0 * self.distance,
                                                 surface.hinge_corner[self._hinge])
        self._hinge_keys = surface.hinge_points[self._hinge].astype(np.int64) * max(n_seg, 1) \
            + surface.hinge_segments[self._hinge]
        self._hinge_positions = np.full((self._hinge_keys.size, n_local), -1, dtype=np.intp)
        self._hinge_ignored = np.zeros(self._hinge_keys.size, dtype=bool)
        self._step_start = None  # the surface at the start of the current step (pairs deep there are ignored)
        self._through = (np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp))  # pairs a handle dragged through
        self._cache = None
        self.refreshes = 0  # how many times the Verlet list was rebuilt
        self.pattern = None
        # the rest offsets o_p (module docstring): the reference configuration touches nothing
        self.offset = np.zeros(surface.n_points)
        for _ in range(8):
            reach = self.distance + float(self.offset.max(initial=0.0))
            p, s = self._query(Y, reach)
            p = np.concatenate([p, surface.hinge_points[self._hinge]])
            s = np.concatenate([s, surface.hinge_segments[self._hinge]])
            _, distance, sigma = self._classify(Y, p, s)
            # (two lips that coincide are at sigma = 0 up to round-off: they touch, they are not inside)
            inside = ((distance < self.distance + self.offset[p])
                      & (sigma < -self.offset[p] - 1e-9 * self.rest_length[s]))
            if not np.any(inside):
                break
            np.maximum.at(self.offset, p[inside], -sigma[inside])
        self._skins = self.distance + self.offset  # each point's wall: sigma = -(d^ + o_p)
        self._reach = float(self._skins.max(initial=self.distance))  # no pair is in contact farther apart
        self._refresh(Y)
        self._coupled = self._covered = np.zeros(0, dtype=np.int64)

    def _arc_neighbourhood(self, length, reach, stops) -> np.ndarray:
        """The points each segment is not paired with, (n_segments, k) padded with -1: its ends, the far ends of
        its neighbours, and every point less than ``reach`` away from it along the surface at rest (walking from its
        ends along the loop, but not round a corner in ``stops``, given by the segment ending there).

        Such a point is within the skin of the segment, or gets there only by folding the surface right over in less
        than a few skins, where the sign of a gap says nothing.
        """
        surface = self.surface
        seg = surface.segments
        n_seg = seg.shape[1]
        base = surface.neighbourhood
        if n_seg == 0:
            return base
        stop_after = np.zeros(n_seg, dtype=bool)  # no walking from this segment to its next
        stop_after[np.asarray(stops, dtype=np.intp)] = True
        stop_before = stop_after[np.maximum(surface.previous, 0)] & (surface.previous >= 0)  # ... to its previous
        columns = [base]
        for step, end, stop in ((surface.next, 1, stop_after), (surface.previous, 0, stop_before)):
            at = step.copy()  # the neighbour (its far end is in base already)
            arc = np.where(at >= 0, length[np.maximum(at, 0)], np.inf)
            alive = (at >= 0) & ~stop
            for _ in range(n_seg):
                alive &= ~stop[np.maximum(at, 0)]
                nxt = np.where(alive, step[np.maximum(at, 0)], -1)
                alive &= nxt >= 0
                arc = np.where(alive, arc + length[np.maximum(nxt, 0)], np.inf)
                alive &= arc < reach
                if not np.any(alive):
                    break
                columns.append(np.where(alive, seg[end, np.maximum(nxt, 0)], -1)[:, None])
                at = nxt
        return np.concatenate(columns, axis=1)

    def describe(self):
        return (f"contact: {self.surface.n_segments} segments, d^ = {self.distance:g}, "
                f"kappa = {self.stiffness:g}")

    # -------------------------------------------------------------- positions
    def _points(self, u) -> np.ndarray:
        x = self.X + np.asarray(u)[: 2 * self.n_nodes].reshape(-1, 2).T
        return self.surface.positions(x)

    # -------------------------------------------------------------- broad phase
    def _query(self, Y, reach):
        """``(p, s)``: the (point, segment) pairs with the point within ``half length + reach`` of the segment's
        midpoint, its neighbourhood left out, sorted by ``key = p * n_segments + s``."""
        seg = self.surface.segments
        n_seg = seg.shape[1]
        if n_seg == 0 or self.surface.n_points == 0:
            empty = np.zeros(0, dtype=np.intp)
            return empty, empty
        ya, yb = Y[:, seg[0]], Y[:, seg[1]]
        radius = 0.5 * np.hypot(*(yb - ya)) + reach
        tree = cKDTree(Y.T)
        mid = (0.5 * (ya + yb)).T
        rows, k = np.arange(n_seg), min(8, Y.shape[1])
        found_s, found_p = [], []
        while rows.size:  # the k nearest points of each midpoint; again with more where all k are within reach
            dist, idx = tree.query(mid[rows], k=k, distance_upper_bound=float(radius[rows].max()))
            dist, idx = dist.reshape(rows.size, k), idx.reshape(rows.size, k)
            within = dist <= radius[rows, None]
            more = within[:, -1] & (k < Y.shape[1])
            done = ~more
            found_s.append(np.broadcast_to(rows[done, None], within[done].shape)[within[done]])
            found_p.append(idx[done][within[done]])
            rows, k = rows[more], min(2 * k, Y.shape[1])
        s = np.concatenate(found_s).astype(np.intp)
        p = np.concatenate(found_p).astype(np.intp)
        keep = np.all(self._excluded[s] != p[:, None], axis=1)
        p, s = p[keep], s[keep]
        keys = p.astype(np.int64) * n_seg + s
        order = np.argsort(keys)
        return p[order], s[order]

    def _deep_at_start(self, p, s) -> np.ndarray:
        """Which pairs had their point deeper than ``d^`` behind the segment when the step started."""
        if self._step_start is None or p.size == 0:
            return np.zeros(p.size, dtype=bool)
        Y = self._step_start
        _, _, sigma = self._classify(Y, p, s)
        deep = sigma <= -self._skins[p]
        # a point within its skin of a neighbouring segment is not through the surface there: it lies on (or
        # slides along) the stretch the segment belongs to, and the segment may own it later in the step
        seg = self.surface.segments
        for neighbour in (self.surface.previous[s], self.surface.next[s]):
            nb = np.maximum(neighbour, 0)
            check = deep & (neighbour >= 0) & np.all(self._excluded[nb] != p[:, None], axis=1)
            if np.any(check):
                near = _segment_distance(Y[:, p[check]], Y[:, seg[0, nb[check]]], Y[:, seg[1, nb[check]]])
                deep[np.flatnonzero(check)[near < self._skins[p[check]]]] = False
        return deep

    def _refresh(self, Y) -> None:
        """Rebuild the Verlet list at the points ``Y``: every pair closer than ``d^ + skin`` (not neighbours)."""
        old_keys = getattr(self, "_keys", None)
        old_positions = getattr(self, "_positions", None)
        self._p, self._s = self._query(Y, self._reach + self.skin)
        self._keys = self._p.astype(np.int64) * max(self.surface.n_segments, 1) + self._s
        self._list_points = Y.copy()
        self.refreshes += 1
        self._ignored = self._deep_at_start(self._p, self._s)
        # Hessian positions already found for pairs that stay in the list
        self._positions = np.full((self._keys.size, (6 * self._width) ** 2), -1, dtype=np.intp)
        if old_keys is not None and old_positions is not None and old_keys.size and self._keys.size:
            at = np.minimum(np.searchsorted(old_keys, self._keys), old_keys.size - 1)
            same = old_keys[at] == self._keys
            self._positions[same] = old_positions[at[same]]
        self._cache = None

    @staticmethod
    def _spread(dY) -> float:
        """How far the points moved relative to each other: ``max_i |dY_i - c|`` with ``c`` the centre of the
        moves' bounding box. Two points' distance changes by at most twice this (a rigid shift moves nothing)."""
        if dY.shape[1] == 0:
            return 0.0
        c = 0.5 * (dY.max(axis=1) + dY.min(axis=1))
        return float(np.max(np.hypot(*(dY - c[:, None]))))

    def _ensure_list(self, Y) -> None:
        """Refresh the list when the points have moved more than ``skin / 2`` relative to each other since it
        was built (a pair not in it was farther than ``d^ + skin`` apart, and has come closer by less than ``skin``)."""
        if self._spread(Y - self._list_points) > 0.5 * self.skin:
            self._refresh(Y)

    def _sharp_hinges(self, Y) -> np.ndarray:
        """Indices (into the armed hinges) of the hinge pairs at corners that turn by more than 90 degrees at
        ``Y`` (the others cannot touch: the point projects before the segment)."""
        if self._hinge_keys.size == 0:
            return np.zeros(0, dtype=np.intp)
        seg = self.surface.segments
        into = self.surface.hinge_corner[self._hinge]
        out = self.surface.next[into]
        e_in = Y[:, seg[1, into]] - Y[:, seg[0, into]]
        e_out = Y[:, seg[1, out]] - Y[:, seg[0, out]]
        return np.flatnonzero(_dot(e_in, e_out) < 0)

    def _pairs(self, Y):
        """``(p, s, keys, ignored, rows)`` of every pair to look at: the list, and the sharp hinges (``rows``: the
        pair's row in the list's position cache, or ``list size + hinge index``)."""
        hinges = self._sharp_hinges(Y)
        if hinges.size == 0:
            return self._p, self._s, self._keys, self._ignored, np.arange(self._keys.size)
        return (np.concatenate([self._p, self.surface.hinge_points[self._hinge[hinges]]]),
                np.concatenate([self._s, self.surface.hinge_segments[self._hinge[hinges]]]),
                np.concatenate([self._keys, self._hinge_keys[hinges]]),
                np.concatenate([self._ignored, self._hinge_ignored[hinges]]),
                np.concatenate([np.arange(self._keys.size), self._keys.size + hinges]))

    # -------------------------------------------------------------- narrow phase
    def _classify(self, Y, p, s):
        """``(kind, distance, sigma)`` of the pairs ``(p, s)`` at points ``Y``: which feature of the segment is
        nearest the point (1 its interior, 2 its start ``a``, 3 its end ``b``), how far, and the signed gap."""
        seg = self.surface.segments
        prev, nxt = self.surface.previous[s], self.surface.next[s]
        return self._classify_at(Y[:, p], Y[:, seg[0, s]], Y[:, seg[1, s]],
                                 Y[:, seg[0, np.maximum(prev, 0)]], Y[:, seg[1, np.maximum(nxt, 0)]],
                                 prev >= 0, nxt >= 0, self._fold[np.maximum(prev, 0)], self._fold[s])

    @staticmethod
    def _classify_at(yp, ya, yb, y_before, y_after, has_previous, has_next, fold_start, fold_end):
        """The classification of :meth:`_classify` from coordinates (2, m): the point, the segment's ends, the
        previous segment's start and the next segment's end (``has_*``: whether there is one; ``fold_*``: the side a
        corner folded right back on itself opens to, see ``_fold``). A segment collapsed to a point (an element crushed
        flat) gives NaN gaps, which count as no contact."""

        def corner_normal(e_in, e_out, fold):
            """The pseudonormal of a corner: the mean of its segments' normals (of a corner folded right back,
            the direction it opens to)."""
            m = np.stack([e_in[1], -e_in[0]]) / np.sqrt(_dot(e_in, e_in)) + \
                np.stack([e_out[1], -e_out[0]]) / np.sqrt(_dot(e_out, e_out))
            size = np.sqrt(_dot(m, m))
            folded = size < 1e-9
            return np.where(folded, fold * e_in / np.sqrt(_dot(e_in, e_in)), m / np.where(folded, 1.0, size))

        with np.errstate(invalid="ignore", divide="ignore"):
            e, w, wb = yb - ya, yp - ya, yp - yb
            L = np.sqrt(_dot(e, e))
            t = _dot(w, e) / (L * L)
            g = _cross(w, e) / L
            r_a, r_b = np.sqrt(_dot(w, w)), np.sqrt(_dot(wb, wb))
            side_a = _dot(w, corner_normal(np.where(has_previous, ya - y_before, e), e, fold_start))
            side_b = _dot(wb, corner_normal(e, np.where(has_next, y_after - yb, e), fold_end))
            kind = np.where(t <= 0, 2, np.where(t >= 1, 3, 1))
            distance = np.where(kind == 1, np.abs(g), np.where(kind == 2, r_a, r_b))
            sigma = np.where(kind == 1, g, np.where(kind == 2, np.where(side_a < 0, -r_a, r_a),
                                                    np.where(side_b < 0, -r_b, r_b)))
        return kind, distance, sigma

    def _owners(self, p, s, keys, distance):
        """Which of the pairs own their point: the nearest segment of each run of consecutive segments that
        are all within ``d^`` of the point (ties to the lower key). ``keys`` must be unique."""
        n_seg = max(self.surface.n_segments, 1)
        order = np.argsort(keys)
        k = keys[order]

        def find(target):  # the position (in sorted order) of the pair with key ``target``, or -1
            at = np.minimum(np.searchsorted(k, target), k.size - 1)
            return np.where(k[at] == target, at, -1)

        pp, ss = p[order], s[order]
        prev, nxt = self.surface.previous[ss], self.surface.next[ss]
        links = [np.where(prev >= 0, find(pp.astype(np.int64) * n_seg + prev), -1),
                 np.where(nxt >= 0, find(pp.astype(np.int64) * n_seg + nxt), -1)]
        best_d, best_k = distance[order].copy(), k.copy()
        for _ in range(k.size):  # spread the run's nearest along it, one segment per sweep
            changed = False
            for link in links:
                has = link >= 0
                if not np.any(has):
                    continue
                d_n = np.where(has, best_d[np.maximum(link, 0)], np.inf)
                k_n = np.where(has, best_k[np.maximum(link, 0)], -1)
                better = has & ((d_n < best_d) | ((d_n == best_d) & (k_n < best_k)))
                if np.any(better):
                    best_d[better], best_k[better] = d_n[better], k_n[better]
                    changed = True
            if not changed:
                break
        owner = np.empty(k.size, dtype=bool)
        owner[order] = best_k == k
        return owner

    def _evaluate(self, u):
        """The active primitives at ``u``: their pair (point, segment), kind, gap and cache row (cached by the
        surface's positions)."""
        Y = self._points(u)
        if self._cache is not None and np.array_equal(self._cache["Y"], Y):
            return self._cache
        self._ensure_list(Y)
        p, s, keys, ignored, rows = self._pairs(Y)
        active = np.zeros(0, dtype=np.intp)
        kind = sigma = np.zeros(0)
        if p.size:
            seg = self.surface.segments
            # only the pairs within d^ take part (the runs, the owners): find them first, cheaply
            near = np.flatnonzero(_segment_distance(Y[:, p], Y[:, seg[0, s]], Y[:, seg[1, s]]) < self._skins[p])
            p, s, keys, ignored, rows = p[near], s[near], keys[near], ignored[near], rows[near]
            if p.size:
                kind, distance, sigma = self._classify(Y, p, s)
                near = np.flatnonzero(distance < self._skins[p])
                owner = self._owners(p[near], s[near], keys[near], distance[near])
                near = near[owner]
                active = near[(sigma[near] < -self.offset[p[near]]) & ~ignored[near]]
        self._cache = {"Y": Y, "p": p[active], "s": s[active], "keys": keys[active], "rows": rows[active],
                       "kind": kind[active].astype(int), "sigma": sigma[active].astype(float)}
        self._seen = Y
        return self._cache

    def _derivatives(self, c):
        """Local derivatives of the active primitives, computed once per cached state: ``sigma``'s gradient
        (m, 6) and Hessian (m, 6, 6) with respect to the three points ``(p, a, b)`` of each pair (a point-point
        primitive depends on the point and one end only)."""
        if "local" in c:
            return c["local"]
        Y = c["Y"]
        seg = self.surface.segments
        p, a, b = c["p"], seg[0, c["s"]], seg[1, c["s"]]
        m = p.size
        grad = np.zeros((m, 6))
        hess = np.zeros((m, 6, 6))
        pe = c["kind"] == 1
        if np.any(pe):
            # sigma = g(w, e) = cross(w, e) / |e| with w = y_p - y_a, e = y_b - y_a
            w = (Y[:, p] - Y[:, a])[:, pe].T  # (k, 2)
            e = (Y[:, b] - Y[:, a])[:, pe].T
            L2 = np.einsum("ki,ki->k", e, e)
            L = np.sqrt(L2)
            g = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / L
            n = np.stack([e[:, 1], -e[:, 0]], axis=1) / L[:, None]  # dg/dw: the outward normal
            Jw = np.stack([-w[:, 1], w[:, 0]], axis=1)  # w turned counter-clockwise
            dg_de = Jw / L[:, None] - (g / L2)[:, None] * e
            grad[pe, 0:2] = n  # (p, a, b) from (w, e) = (p - a, b - a)
            grad[pe, 2:4] = -n - dg_de
            grad[pe, 4:6] = dg_de
            R = np.array([[0.0, 1.0], [-1.0, 0.0]])  # e -> (e_y, -e_x)
            H_we = R[None] / L[:, None, None] - n[:, :, None] * e[:, None, :] / L2[:, None, None]
            H_ee = (-(Jw[:, :, None] * e[:, None, :] + e[:, :, None] * Jw[:, None, :]) / (L2 * L)[:, None, None]
                    - (g / L2)[:, None, None] * np.eye(2)[None]
                    + 3.0 * (g / (L2 * L2))[:, None, None] * e[:, :, None] * e[:, None, :])
            H4 = np.zeros((w.shape[0], 4, 4))  # (w, w) is zero: g is linear in w
            H4[:, 0:2, 2:4] = H_we
            H4[:, 2:4, 0:2] = H_we.transpose(0, 2, 1)
            H4[:, 2:4, 2:4] = H_ee
            T = np.zeros((4, 6))
            T[0:2, 0:2], T[0:2, 2:4] = np.eye(2), -np.eye(2)
            T[2:4, 2:4], T[2:4, 4:6] = -np.eye(2), np.eye(2)
            hess[pe] = np.einsum("ai,kab,bj->kij", T, H4, T)
        for kind, end, slot in ((2, a, 2), (3, b, 4)):
            pp = c["kind"] == kind
            if not np.any(pp):
                continue
            # sigma = -|d| with d = y_p - y_v (active point-point primitives lie behind the corner)
            d = (Y[:, p] - Y[:, end])[:, pp].T
            r = np.hypot(d[:, 0], d[:, 1])
            unit = d / r[:, None]
            grad[pp, 0:2] = -unit
            grad[pp, slot:slot + 2] = unit
            H2 = -(np.eye(2)[None] - unit[:, :, None] * unit[:, None, :]) / r[:, None, None]
            for r0, s0 in ((0, 1.0), (slot, -1.0)):
                for r1, s1 in ((0, 1.0), (slot, -1.0)):
                    hess[pp, r0:r0 + 2, r1:r1 + 2] = s0 * s1 * H2
        c["local"] = np.stack([p, a, b], axis=1), grad, hess
        return c["local"]

    def _barrier(self, c):
        """``(l kappa d^ beta, l kappa beta', l kappa beta'' / d^)`` of the active primitives: the energy and its
        first two derivatives with respect to ``sigma``."""
        d = self.distance
        b0, b1, b2 = barrier(1.0 + (c["sigma"] + self.offset[c["p"]]) / d)
        scale = self.stiffness * self.point_length[c["p"]]
        return scale * d * b0, scale * b1, scale * b2 / d

    # -------------------------------------------------------------- the term
    def energy(self, u) -> float:
        c = self._evaluate(u)
        return float(np.sum(self._barrier(c)[0])) if c["p"].size else 0.0

    def _dofs(self, points):
        """Node dofs (m, 6 width) and their weights of the point triples ``points`` (m, 3)."""
        nodes = self.surface.nodes[points]  # (m, 3, width)
        weights = self.surface.weights[points]
        j, k, comp = self._slot_point, self._slot_node, self._slot_comp
        return 2 * nodes[:, j, k] + comp, weights[:, j, k]

    def gradient(self, u) -> np.ndarray:
        out = np.zeros(np.asarray(u).size)
        c = self._evaluate(u)
        if c["p"].size == 0:
            return out
        points, grad, _ = self._derivatives(c)
        _, e1, _ = self._barrier(c)
        dofs, coef = self._dofs(points)
        values = coef * (e1[:, None] * grad)[:, self._slot_local]
        out[: 2 * self.n_nodes] += np.bincount(dofs.ravel(), weights=values.ravel(), minlength=2 * self.n_nodes)
        return out

    def add_hessian(self, u, data, safe=False) -> None:
        c = self._evaluate(u)
        if c["p"].size == 0:
            return
        points, grad, hess = self._derivatives(c)
        _, e1, e2 = self._barrier(c)
        H = e2[:, None, None] * grad[:, :, None] * grad[:, None, :]
        if not safe:
            H = H + e1[:, None, None] * hess
        dofs, coef = self._dofs(points)
        local = self._slot_local
        block = coef[:, :, None] * coef[:, None, :] * H[:, local[:, None], local[None, :]]
        np.add.at(data, self._hessian_positions(c["rows"], dofs).ravel(), block.ravel())

    def _hessian_positions(self, rows, dofs):
        """Positions in the pattern's data of the (6 width)^2 entries of each pair (found once per pattern)."""
        n_list = self._keys.size
        in_list = rows < n_list
        pos = np.where(in_list[:, None], self._positions[np.minimum(rows, max(n_list - 1, 0))] if n_list else -1,
                       self._hinge_positions[np.maximum(rows - n_list, 0)] if self._hinge_keys.size else -1)
        missing = pos[:, 0] < 0
        if np.any(missing):
            d = dofs[missing]
            found = self.pattern.positions(np.repeat(d, d.shape[1], axis=1).ravel(),
                                           np.tile(d, (1, d.shape[1])).ravel()).reshape(d.shape[0], -1)
            pos[missing] = found
            r = rows[missing]
            self._positions[r[r < n_list]] = found[r < n_list]
            self._hinge_positions[r[r >= n_list] - n_list] = found[r >= n_list]
        return pos

    # -------------------------------------------------------------- the pattern
    def couplings(self):
        """The dof couplings of every pair the contact may need now: the list and the hinges that are sharp
        where the surface was last seen (the model asks for them when :meth:`covers` says the pattern lacks one)."""
        p, s, keys, _, _ = self._pairs(getattr(self, "_seen", self._list_points))
        self._coupled = np.sort(keys)
        if p.size == 0:
            return None
        seg = self.surface.segments
        points = np.stack([p, seg[0, s], seg[1, s]], axis=1)
        nodes = np.unique(np.sort(self.surface.nodes[points].reshape(points.shape[0], -1), axis=1), axis=0)
        rows = np.repeat(nodes, nodes.shape[1], axis=1).ravel()
        cols = np.tile(nodes, (1, nodes.shape[1])).ravel()
        pairs = np.unique(rows.astype(np.int64) * self.n_nodes + cols)
        r, q = np.divmod(pairs, self.n_nodes)
        return (np.concatenate([2 * r, 2 * r, 2 * r + 1, 2 * r + 1]),
                np.concatenate([2 * q, 2 * q + 1, 2 * q, 2 * q + 1]))

    def bind(self, pattern) -> None:
        super().bind(pattern)
        self._covered = self._coupled
        self._positions[:] = -1
        self._hinge_positions[:] = -1

    def covers(self, u) -> bool:
        """Whether the bound pattern holds the couplings of every pair active at ``u`` (else the model rebuilds
        it: :meth:`couplings` then names the pairs of the current list)."""
        c = self._evaluate(u)
        keys = c["keys"]
        if keys.size == 0:
            return True
        if self._covered.size == 0:
            return False
        at = np.minimum(np.searchsorted(self._covered, keys), self._covered.size - 1)
        return bool(np.all(self._covered[at] == keys))

    # -------------------------------------------------------------- steps
    def begin_step(self, u, previous=None) -> int:
        """Start a step at ``u``: pairs whose point is deeper than ``d^`` behind the segment are ignored until the
        step ends (module docstring). Returns how many surface points are through the surface now.

        ``previous`` is the state before the handles moved to ``u``: pairs that the handles' own motion carries through
        a wall (the collision detection of a Newton step) are *crossings*, remembered step after step while their point
        stays deeper than ``d^`` behind the segment (and less than the segment's length: farther, the sign of a gap says
        nothing).
        """
        Y = self._points(u)
        self._step_start = Y.copy()
        self._refresh(Y)
        self._hinge_ignored = self._deep_at_start(self.surface.hinge_points[self._hinge],
                                                  self.surface.hinge_segments[self._hinge])
        through_p, through_s = self._through
        if previous is not None:
            Y0 = self._points(previous)
            dY = Y - Y0
            moved = self._spread(dY)
            if moved > 0.0:
                if moved < 0.5 * self.skin:  # the list at Y holds every pair that came within d^ on the way
                    p, s = self._p, self._s
                else:
                    p, s = self._query(Y0, self._reach + 2.0 * moved)
                hit = np.isfinite(self._times_of_impact(Y0, dY, p, s))
                through_p = np.concatenate([through_p, p[hit]])
                through_s = np.concatenate([through_s, s[hit]])
        if through_p.size:  # still through: deeper than d^ behind the segment, but not beyond its length
            _, _, sigma = self._classify(Y, through_p, through_s)
            deep = (sigma <= -self._skins[through_p]) & (sigma > -self.rest_length[through_s])
            keys = np.unique(through_p[deep].astype(np.int64) * max(self.surface.n_segments, 1) + through_s[deep])
            through_p, through_s = np.divmod(keys, max(self.surface.n_segments, 1))
        self._through = (through_p.astype(np.intp), through_s.astype(np.intp))
        return int(np.unique(self._through[0]).size)

    def end_step(self) -> None:
        """Forget the step's start (every pair counts again)."""
        self._step_start = None
        self._ignored = np.zeros(self._keys.size, dtype=bool)
        self._hinge_ignored[:] = False
        self._cache = None

    def max_step(self, u, du) -> float:
        """The largest fraction of the step ``u -> u + du`` that keeps every point out of the walls: ``SAFETY``
        times the earliest time of impact, or 1 when nothing is hit (continuous collision detection)."""
        Y0 = self._points(u)
        dY = self._points(np.asarray(u) + np.asarray(du)) - Y0
        moved = self._spread(dY)
        if moved == 0.0:
            return 1.0
        self._ensure_list(Y0)
        drift = self._spread(Y0 - self._list_points)
        if drift + moved < 0.5 * self.skin:
            p, s, ignored = self._p, self._s, self._ignored
        else:  # a long step: the pairs that could meet on the way, found afresh
            p, s = self._query(Y0, self._reach + 2.0 * moved)
            ignored = self._deep_at_start(p, s)
        hinges = np.union1d(self._sharp_hinges(Y0), self._sharp_hinges(Y0 + dY))
        if hinges.size:
            p = np.concatenate([p, self.surface.hinge_points[self._hinge[hinges]]])
            s = np.concatenate([s, self.surface.hinge_segments[self._hinge[hinges]]])
            ignored = np.concatenate([ignored, self._hinge_ignored[hinges]])
        if p.size == 0:
            return 1.0
        toi = float(np.min(self._times_of_impact(Y0, dY, p[~ignored], s[~ignored]), initial=np.inf))
        return 1.0 if toi > 1.0 else SAFETY * toi

    def _times_of_impact(self, Y0, dY, p, s) -> np.ndarray:
        """For every pair, the earliest ``tau`` in ``[0, 1]`` at which it reaches its wall (``inf`` if it does not).

        The walls: the segment's line moved inward by ``d^`` (where the point projects onto the segment), and circles of
        radius ``d^`` round its ends (behind a corner). A wall counts where the segment owns the point: no neighbouring
        segment is nearer than ``d^`` then.
        """
        out = np.full(p.size, np.inf)
        if p.size == 0:
            return out
        d = self._skins[p]  # each point's wall depth
        seg = self.surface.segments
        a, b = seg[0, s], seg[1, s]
        prev, nxt = self.surface.previous[s], self.surface.next[s]
        before, after = seg[0, np.maximum(prev, 0)], seg[1, np.maximum(nxt, 0)]
        w0, dw = Y0[:, p] - Y0[:, a], dY[:, p] - dY[:, a]
        e0, de = Y0[:, b] - Y0[:, a], dY[:, b] - dY[:, a]
        # c(tau) = cross(w, e) = c0 + c1 tau + c2 tau^2;  q(tau) = |e|^2 = q0 + q1 tau + q2 tau^2
        c0, c1, c2 = _cross(w0, e0), _cross(w0, de) + _cross(dw, e0), _cross(dw, de)
        q0, q1, q2 = _dot(e0, e0), 2.0 * _dot(e0, de), _dot(de, de)
        found = []  # (pair, tau, wall): 1 the line, 2 the circle round a, 3 the circle round b
        # the line: only pairs in front of it, which a conservative bound says may reach it (the wall needs
        # c(tau) <= -d |e(tau)| <= -d min|e|, so c's minimum over [0, 1] must get there)
        in_front = c0 + d * np.sqrt(q0) > 0
        vertex = -c1 / np.where(c2 != 0, 2.0 * c2, 1.0)
        c_min = np.minimum(c0, c0 + c1 + c2)
        inner = (c2 > 0) & (vertex > 0) & (vertex < 1)
        c_min = np.where(inner, c0 + c1 * vertex + c2 * vertex**2, c_min)
        q_vertex = np.clip(-q1 / np.where(q2 > 0, 2.0 * q2, 1.0), 0.0, 1.0)
        L_low = np.sqrt(np.maximum(q0 + q1 * q_vertex + q2 * q_vertex**2, 0.0))
        for k in np.flatnonzero(in_front & (c_min + d * L_low <= 0)).tolist():
            # cross(w, e) = -d |e|  =>  c^2 - d^2 q = 0 with c < 0: a quartic in tau
            dk = d[k]
            coeffs = np.array([c2[k] * c2[k], 2 * c1[k] * c2[k], c1[k] ** 2 + 2 * c0[k] * c2[k] - dk * dk * q2[k],
                               2 * c0[k] * c1[k] - dk * dk * q1[k], c0[k] ** 2 - dk * dk * q0[k]])
            coeffs = coeffs / np.max(np.abs(coeffs))
            lead = np.flatnonzero(np.abs(coeffs) > 1e-14)
            if lead.size == 0 or lead[0] == 4:
                continue
            roots = np.roots(coeffs[lead[0]:])
            # nearly real roots count as real: a graze of the wall is a touch (the safe side)
            real = roots[np.abs(roots.imag) <= 1e-7 * np.maximum(1.0, np.abs(roots.real))].real
            real = real[(real >= 0.0) & (real <= 1.0)]
            real = real[c0[k] + c1[k] * real + c2[k] * real**2 < 0]
            found += [(k, tau, 1) for tau in real.tolist()]
        # the circles: |y_p - y_v|^2 = d^2 on the way out of the disc of radius d round the end v
        for wall, end in ((2, a), (3, b)):
            r0, dr = Y0[:, p] - Y0[:, end], dY[:, p] - dY[:, end]
            A, B, C = _dot(dr, dr), 2.0 * _dot(r0, dr), _dot(r0, r0) - d * d
            tau_out = (-B + np.sqrt(np.maximum(B * B - 4 * A * C, 0.0))) / np.where(A > 0, 2 * A, 1.0)
            leaving = (C < 0) & (A > 0) & (tau_out <= 1.0)
            found += [(k, max(float(tau_out[k]), 0.0), wall) for k in np.flatnonzero(leaving).tolist()]
        if not found:
            return out
        k = np.array([f[0] for f in found], dtype=np.intp)
        tau = np.array([f[1] for f in found])
        wall = np.array([f[2] for f in found])

        def at(i):  # the points i of each candidate at its time
            return Y0[:, i[k]] + tau * dY[:, i[k]]

        yp = at(p)
        kind, _, sigma = self._classify_at(yp, at(a), at(b), at(before), at(after), prev[k] >= 0, nxt[k] >= 0,
                                           self._fold[np.maximum(prev[k], 0)], self._fold[s[k]])
        hit = (kind == wall) & (sigma < 0)
        # the segment owns the point there unless a neighbour (one the point may meet) is nearer than d; a
        # neighbour through the wall's own corner lies at distance d exactly, and does not count
        for neighbour in (prev[k], nxt[k]):
            nb = np.maximum(neighbour, 0)
            counts = hit & (neighbour >= 0) & np.all(self._excluded[nb] != p[k][:, None], axis=1)
            if np.any(counts):
                ya_n = Y0[:, seg[0, nb]] + tau * dY[:, seg[0, nb]]
                yb_n = Y0[:, seg[1, nb]] + tau * dY[:, seg[1, nb]]
                hit &= ~(counts & (_segment_distance(yp, ya_n, yb_n) < (1.0 - 1e-9) * d[k]))
        np.minimum.at(out, k[hit], tau[hit])
        return out

    # -------------------------------------------------------------- reports
    def active_pairs(self, u) -> np.ndarray:
        """The (point, segment) pairs in contact at ``u``: shape (2, m)."""
        c = self._evaluate(u)
        return np.stack([c["p"], c["s"]])

    def overlap(self, u) -> float:
        """The deepest any point is pressed into the skin at ``u`` (0 when nothing touches; beyond its rest
        offset, for a point that sits behind another part of the surface at rest)."""
        c = self._evaluate(u)
        return float(-(c["sigma"] + self.offset[c["p"]]).min()) if c["p"].size else 0.0

    def forces(self, u) -> np.ndarray:
        """The contact forces on the nodes ``(2, n_nodes)``."""
        return -self.gradient(u)[: 2 * self.n_nodes].reshape(-1, 2).T
