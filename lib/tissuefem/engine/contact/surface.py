"""The contact surface: points that are fixed linear combinations of nodes, and the segments between them.

A boundary node is a point of one node with weight 1; a point on the lip of a cut through an element the barycentric
combination of the element copy's nodes (:mod:`tissuefem.surgery.element_cuts`). A segment ``(a, b)`` has the material
on its *left*, so its outward normal is ``n = (e_y, -e_x) / |e|``, ``e = y_b - y_a``. The vector helpers (on (2, ...)
coordinate arrays) serve the other contact modules.
"""

import numpy as np
from skfem import MeshTri

from ..parameters import ParameterError, check_count, check_real_array, show


def cross(u, v):
    """``u_x v_y - u_y v_x``."""
    return u[0] * v[1] - u[1] * v[0]


def dot(u, v):
    """``u . v``."""
    return u[0] * v[0] + u[1] * v[1]


def segment_distance(y, ya, yb):
    """Distance from points ``y`` to the closed segments ``ya -> yb`` (all (2, m))."""
    e, w = yb - ya, y - ya
    t = np.clip(dot(w, e) / np.maximum(dot(e, e), 1e-300), 0.0, 1.0)
    return np.hypot(*(w - t * e))


def _array(field, value) -> np.ndarray:
    try:
        return np.asarray(value)
    except (TypeError, ValueError):  # ragged lists
        raise _refused(field, f" must be a rectangular array, got {show(value)}") from None


def _refused(field, message) -> ParameterError:
    name = f"contact.surface.{field}"
    return ParameterError(name, name + message)


class ContactSurface:
    """Points and the segments between them, material on each segment's left. Point ``i`` is
    ``sum_j weights[i, j] * x[:, nodes[i, j]]`` (``nodes``, ``weights`` (n_points, k), unused slots weighing 0);
    ``segments`` (2, n_segments): the points ``(a, b)`` of each; ``wound`` flags those on a wound's lips. ``next`` /
    ``previous``: the segment starting where this one ends (ending where it starts), -1 if none or several;
    ``neighbourhood`` (n_segments, 4): its ends and its neighbours' far ends; ``hinge_points``, ``hinge_segments``,
    ``hinge_corner``: at each corner (``hinge_corner`` the segment ending there), each segment's far end against the
    other segment."""

    def __init__(self, nodes, weights, segments, n_nodes, wound=None):
        self.n_nodes = check_count("contact.surface.n_nodes", n_nodes)
        nodes = _array("nodes", nodes)
        nodes = nodes[:, None] if nodes.ndim == 1 else nodes
        if nodes.ndim != 2 or nodes.shape[1] < 1 or nodes.size and (not np.issubdtype(nodes.dtype, np.integer)
                                                                    or nodes.min() < 0 or nodes.max() >= self.n_nodes):
            raise _refused("nodes", f" must be node indices in 0..{self.n_nodes - 1} shaped (n_points, k), got "
                                    f"{nodes!r}")
        weights = check_real_array("contact.surface.weights", weights)
        weights = weights[:, None] if weights.ndim == 1 else weights
        if weights.shape != nodes.shape or not np.all(np.isfinite(weights)):
            raise _refused("weights", f" must be finite and shaped like the nodes {nodes.shape}, got {weights!r}")
        segments, n_points = _array("segments", segments), nodes.shape[0]
        if segments.ndim != 2 or segments.shape[0] != 2 or segments.size and (
                not np.issubdtype(segments.dtype, np.integer) or segments.min() < 0 or segments.max() >= n_points):
            raise _refused("segments", f" must be point indices in 0..{n_points - 1} shaped (2, n_segments), got "
                                       f"{segments!r}")
        if np.any(segments[0] == segments[1]):
            raise _refused("segments", ": a segment joins a point to itself")
        self.nodes, self.weights, self.segments = nodes.astype(np.intp), weights, segments.astype(np.intp)
        self._plain = nodes.shape[1] == 1 and bool(np.all(weights == 1.0))  # every point a node
        self.n_points, self.n_segments = n_points, n_seg = nodes.shape[0], self.segments.shape[1]
        self.wound = np.zeros(n_seg, dtype=bool) if wound is None else _array("wound", wound)
        if self.wound.shape != (n_seg,) or (n_seg and self.wound.dtype.kind not in "biu"):
            raise _refused("wound", f" must be one bool per segment ({n_seg}), got {show(wound)}")
        self.wound = self.wound.astype(bool)
        # the loops: the segment leaving each segment's end (unique, or none)
        a, b = self.segments
        leaving, arriving = np.full(n_points, -1, dtype=np.intp), np.full(n_points, -1, dtype=np.intp)
        leaving[a], arriving[b] = np.arange(n_seg), np.arange(n_seg)
        self.next = np.where(np.bincount(a, minlength=n_points)[b] == 1, leaving[b], -1)
        self.previous = np.where(np.bincount(b, minlength=n_points)[a] == 1, arriving[a], -1)
        self.neighbourhood = np.stack([a, b, np.where(self.previous >= 0, a[np.maximum(self.previous, 0)], -1),
                                       np.where(self.next >= 0, b[np.maximum(self.next, 0)], -1)], axis=1)
        # hinges: at the corner between a segment and the next, each one's far end against the other segment
        into = np.flatnonzero(self.next >= 0)
        out = self.next[into]
        hinge_p, hinge_s, corner = np.concatenate([a[into], b[out]]), np.concatenate([out, into]), np.tile(into, 2)
        keep = (hinge_p != a[hinge_s]) & (hinge_p != b[hinge_s])  # not in a loop of two segments
        self.hinge_points, self.hinge_segments, self.hinge_corner = hinge_p[keep], hinge_s[keep], corner[keep]

    @classmethod
    def from_mesh(cls, mesh) -> "ContactSurface":
        """The boundary of a triangle mesh: a point per boundary node, a segment per boundary facet (with the lips of
        a :func:`~tissuefem.surgery.topology.incise` cut), flagged as wound on the facets named ``"cut"``."""
        if not isinstance(mesh, MeshTri):
            raise ParameterError("mesh", f"mesh must be a triangle mesh (skfem.MeshTri), got {type(mesh).__name__}")
        p, facets = np.asarray(mesh.p, dtype=float), np.asarray(mesh.boundary_facets(), dtype=np.intp)
        pairs = np.asarray(mesh.facets, dtype=np.intp)[:, facets]
        t = np.asarray(mesh.t, dtype=np.intp)[:, np.asarray(mesh.f2t, dtype=np.intp)[0, facets]]
        third = t.sum(axis=0) - pairs.sum(axis=0)  # the element's vertex off the facet
        left = cross(p[:, pairs[1]] - p[:, pairs[0]], p[:, third] - p[:, pairs[0]]) > 0
        nodes, segments = np.unique(np.where(left, pairs, pairs[::-1]), return_inverse=True)  # material on the left
        cut = (mesh.boundaries or {}).get("cut")
        wound = None if cut is None else np.isin(facets, np.asarray(cut))
        return cls(nodes[:, None], np.ones((nodes.size, 1)), segments.reshape(2, -1), p.shape[1], wound=wound)

    def positions(self, x) -> np.ndarray:
        """The points at node positions ``x`` (2, n_nodes): shape (2, n_points)."""
        x = check_real_array("x", x)
        if x.ndim != 2 or x.shape[0] != 2 or x.shape[1] != self.n_nodes:
            raise ParameterError("x", f"x must be node positions shaped (2, {self.n_nodes}), got shape {x.shape}")
        if self._plain:
            return x[:, self.nodes[:, 0]]
        return np.sum(self.weights.T * x[:, self.nodes.T], axis=1)  # (2, k, n_points) summed over the slots

    def segment_positions(self, x) -> np.ndarray:
        """The segments' ends at node positions ``x``: shape (n_segments, 2, 2) (segment, end, xy)."""
        y = self.positions(x)
        return np.stack([y[:, self.segments[0]].T, y[:, self.segments[1]].T], axis=1)

    def __repr__(self):
        return f"ContactSurface({self.n_points} points, {self.n_segments} segments, {int(self.wound.sum())} on wounds)"
