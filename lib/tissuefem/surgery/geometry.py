"""The geometry of cuts, shared by :mod:`.topology`, :mod:`.element_cuts` and :mod:`.surfaces`: checked mesh arrays
and inputs, edges keyed by node pair, a triangle's local coordinates, and the material of an element cut through.

Local coordinates are ``(xi, eta) = (lambda_1, lambda_2)``: vertex 0 at ``(0, 0)``, 1 at ``(1, 0)``, 2 at ``(0, 1)``;
local edge ``k`` runs from vertex ``k`` to ``k + 1``. Points closer than :data:`EPS` are one point; intervals are
sorted lists ``[(lo, hi), ...]`` of an edge's parameter. The local helpers work on plain floats (on one triangle's
tiny graphs numpy's per-call cost would dominate).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from skfem import MeshTri

from ..engine.parameters import ParameterError, check_real_array, check_weights, show

#: Tolerance in local coordinates: points closer than this are one point, a point this close to an edge is on it.
EPS = 1e-9


# --- meshes and inputs ---
def mesh_arrays(mesh):
    """``(p (2, n) float, t (3, m) int64)`` of a 2D triangle mesh, checked."""
    try:
        p, t = check_real_array("mesh.p", mesh.p), np.asarray(mesh.t)
    except AttributeError:
        raise ParameterError("mesh", f"mesh must be a triangle mesh (a MeshTri), got {type(mesh).__name__}") from None
    except ParameterError as err:
        raise ParameterError("mesh", f"mesh must be a triangle mesh of real coordinates: {err}") from None
    if t.dtype.kind not in "iu":
        raise ParameterError("mesh", f"mesh must be a triangle mesh whose t holds node indices, got dtype {t.dtype}")
    t = t.astype(np.int64)
    if p.ndim != 2 or p.shape[0] != 2 or t.ndim != 2 or t.shape[0] != 3:
        raise ParameterError("mesh", f"mesh must be a 2D triangle mesh (p shaped (2, n), t shaped (3, m)), "
                                     f"got p {p.shape} and t {t.shape}")
    return p, t


def mesh_at(mesh, positions):
    """``(p, t, x)``: the checked arrays of ``mesh`` (:func:`mesh_arrays`) and where its nodes are now, ``positions``
    checked as a finite ``(2, n_nodes)`` array, or ``p``."""
    p, t = mesh_arrays(mesh)
    if positions is None:
        return p, t, p
    x = check_real_array("positions", positions)
    if x.shape != p.shape or not np.all(np.isfinite(x)):
        raise ParameterError("positions", f"positions must be finite and shaped (2, n_nodes) = {p.shape}, "
                                          f"got shape {x.shape}")
    return p, t, x


def check_points(name: str, value, min_points: int) -> np.ndarray:
    """A finite float array (a copy) shaped (k, 2) with k >= min_points (complex points are refused, not cut)."""
    a = np.array(check_real_array(name, value))
    if a.ndim != 2 or a.shape[1] != 2 or a.shape[0] < min_points or not np.all(np.isfinite(a)):
        raise ParameterError(name, f"{name} must be at least {min_points} finite points shaped (k, 2), "
                                   f"got {show(value)} (shape {a.shape})")
    return a


def pair_keys(pairs, n: int) -> np.ndarray:
    """One int64 per undirected node pair ``(2, k)`` of a mesh with ``n`` nodes: ``min * n + max``."""
    pairs = np.asarray(pairs, dtype=np.int64)
    return np.minimum(pairs[0], pairs[1]) * n + np.maximum(pairs[0], pairs[1])


def element_edges(p, t):
    """``(key, side)`` (3, m) of edge ``k`` of element ``e`` (from ``t[k, e]`` to ``t[(k+1) % 3, e]``): its
    :func:`pair_keys` and +1 if the element lies left of the edge run from its lower to its higher node, else -1."""
    n = p.shape[1]
    b, c = np.roll(t, -1, axis=0), np.roll(t, -2, axis=0)
    lo, hi = np.minimum(t, b), np.maximum(t, b)
    s = (p[0, hi] - p[0, lo]) * (p[1, c] - p[1, lo]) - (p[1, hi] - p[1, lo]) * (p[0, c] - p[0, lo])
    return lo * n + hi, np.where(s > 0, 1, -1)


def new_mesh(p, t) -> MeshTri:
    """A MeshTri that keeps every triangle's vertex order, from C-ordered copies (scikit-fem would copy the Fortran
    order fancy indexing leaves, with a warning on large meshes)."""
    return MeshTri(np.ascontiguousarray(p), np.ascontiguousarray(t), sort_t=False)


def carry_names(old, new, parent, elements, touches=None, name=None) -> MeshTri:
    """``new`` with the named boundaries and subdomains of ``old`` carried across an edit: a facet keeps a name if its
    nodes' parents formed a facet of that name (and, with ``touches`` (bool (3, n_new_elements)), some element's
    material touches it); the facets the edit opened (inside ``old``, on the boundary now) join the set ``name``;
    subdomains go to every copy."""
    n_old = old.p.shape[1]
    parent_keys = pair_keys(parent[np.asarray(new.facets, dtype=np.int64)], n_old)
    old_facets = np.asarray(old.facets, dtype=np.int64)
    names = {}
    if old.boundaries:
        t2f = np.asarray(new.t2f)  # row k: the facet of local edge k (scikit-fem's edge order)
        hit = np.unique(t2f if touches is None else t2f[touches])
        for label, facets in old.boundaries.items():
            old_keys = pair_keys(old_facets[:, np.asarray(facets, dtype=np.int64)], n_old)
            names[label] = hit[np.isin(parent_keys[hit], old_keys)].astype(np.int32)
    if name is not None:
        inside = pair_keys(old_facets[:, np.asarray(old.f2t)[1] >= 0], n_old)
        opened = np.flatnonzero((np.asarray(new.f2t)[1] < 0) & np.isin(parent_keys, inside))
        names[name] = np.union1d(names.get(name, np.zeros(0, dtype=np.int32)), opened).astype(np.int32)
    out = new.with_boundaries(names) if names else new
    if old.subdomains:
        out = out.with_subdomains({label: np.flatnonzero(np.isin(elements, np.asarray(els))).astype(np.int32)
                                   for label, els in old.subdomains.items()})
    return out


def polygon_contains(polygon, points) -> np.ndarray:
    """Which ``points`` (k, 2) lie inside the closed ``polygon`` (q, 2): bool (k,), by the even-odd test with the
    arithmetic and ties of ``matplotlib.path.Path.contains_points`` (a point on the outline goes the same way)."""
    tx, ty = points[:, 0], points[:, 1]
    inside = np.zeros(tx.shape, dtype=bool)
    for (x0, y0), (x1, y1) in zip(polygon, np.roll(polygon, -1, axis=0)):
        above0, above1 = y0 >= ty, y1 >= ty
        inside ^= (above0 != above1) & (((y1 - ty) * (x0 - x1) >= (x1 - tx) * (y0 - y1)) == above1)
    return inside


#: A stroke is clipped to the body's bounding box grown by this many body sizes on every side (:func:`clip_to_body`)
CLIP_MARGIN = 1.0


def _side_crossing(a, b, axis, bound):
    """Where the segment ``a -> b`` (points ``(x, y, parameter)``, one on each side of ``axis = bound``) crosses it:
    exactly on the line, the other coordinate and the parameter interpolated from the nearer end (so that a far end
    costs the crossing no precision), with halved differences (no overflow near the largest floats)."""
    run = 0.5 * b[axis] - 0.5 * a[axis]
    f = (0.5 * bound - 0.5 * a[axis]) / run  # from a
    g = (0.5 * b[axis] - 0.5 * bound) / run  # from b
    out = [0.0, 0.0, 0.0]
    out[axis] = bound
    for i in (1 - axis, 2):
        out[i] = (a[i] + 2.0 * f * (0.5 * b[i] - 0.5 * a[i]) if f <= g
                  else b[i] - 2.0 * g * (0.5 * b[i] - 0.5 * a[i]))
    return tuple(out)


def clip_to_body(points, x, t, closed=False):
    """The polyline ``points`` (k, 2) (a polygon if ``closed``) clipped to the bounding box of the triangles ``t`` at
    node positions ``x``, grown by :data:`CLIP_MARGIN` body sizes: ``(points (k', 2), parameter (k',))``, each point's
    place on the drawn polyline (segment index plus fraction). A part outside the box meets no material: it is
    replaced by a path along the box's sides (an open polyline's outer ends are dropped), so that however far a
    stroke reaches, it is cut where it lies in the body as precisely as a short one (a polygon keeps what it encloses
    in the box). Nothing is left when the stroke misses the box."""
    corners = x[:, np.asarray(t).ravel()]
    if corners.size == 0:  # no triangle: nothing to meet
        return np.zeros((0, 2)), np.zeros(0)
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    grow = CLIP_MARGIN * float((hi - lo).max())
    pts = [(float(px), float(py), float(i)) for i, (px, py) in enumerate(np.asarray(points, dtype=float))]
    if closed and len(pts) > 1 and pts[0][:2] == pts[-1][:2]:
        pts.pop()  # the closing point: the ring wraps around
    for axis, bound, sign in ((0, lo[0] - grow, -1.0), (0, hi[0] + grow, 1.0), (1, lo[1] - grow, -1.0),
                              (1, hi[1] + grow, 1.0)):
        inside = [sign * (q[axis] - bound) <= 0.0 for q in pts]
        out = []
        for i, q in enumerate(pts):
            if (i > 0 or closed) and inside[i - 1] != inside[i]:
                out.append(_side_crossing(pts[i - 1], q, axis, bound))
            if inside[i]:
                out.append(q)
        pts = out
    if closed and pts:
        pts.append(pts[0])
    a = np.array(pts, dtype=float).reshape(-1, 3)
    return a[:, :2].copy(), a[:, 2].copy()


def _has_area(poly) -> bool:
    """Whether the polygon ``poly`` (k, 2) encloses an area beyond round-off of its size."""
    return abs(polygon_area(poly.tolist())) > 1e-12 * np.ptp(poly, axis=0).max() ** 2


def stroke_in_body(name: str, value, x, t, closed=False):
    """The drawn polyline ``value`` (a polygon if ``closed``), checked and clipped to the body (:func:`clip_to_body`):
    ``(points, parameter)``. Refused, naming ``name``: fewer than 2 finite points (a polygon: 3, enclosing an area),
    or nothing left in the body."""
    drawn = check_points(name, value, 3 if closed else 2)
    # clipped: in the body's units, far corners neither overflow nor make a thin polygon look flat
    pts, parameter = clip_to_body(drawn, x, t, closed)
    if closed and (pts.shape[0] < 4 or not _has_area(pts)):  # the ring closes on its first point
        if not _has_area(drawn / max(float(np.abs(drawn).max()), 1e-300)):  # scaled: no overflow
            raise ParameterError(name, f"{name} must be a polygon with non-zero area, got {show(drawn.tolist())}")
        raise ParameterError(name, f"{name} selects no element: it encloses no material (it lies outside the body)")
    if pts.shape[0] < 2:
        raise ParameterError(name, f"{name} changes nothing: it meets no material (it passes outside the body)")
    return pts, parameter


# --- a triangle's local coordinates ---
def cross(ax, ay, bx, by):
    """The cross product ``a x b`` of two plane vectors."""
    return ax * by - ay * bx


def snap(x, y):
    """A local point pulled onto the triangle's edges and vertices it is within :data:`EPS` of."""
    x = 0.0 if abs(x) <= EPS else x
    y = 0.0 if abs(y) <= EPS else y
    r = 1.0 - x - y
    if abs(r) <= EPS:
        if x == 0.0:
            y = 1.0
        elif y == 0.0:
            x = 1.0
        else:
            x += 0.5 * r
            y = 1.0 - x
    # a point a round-off outside: back onto the triangle
    x, y = max(x, 0.0), max(y, 0.0)
    if x + y > 1.0:
        s = x + y
        x, y = x / s, 1.0 - x / s
    return x, y


def edges_of(pt):
    """The local edges a point lies on."""
    x, y = pt
    return [k for k, d in enumerate((y, 1.0 - x - y, x)) if abs(d) <= EPS]


def edge_param(k, pt) -> float:
    """Position along local edge ``k``, 0 at its vertex ``k`` and 1 at vertex ``k + 1``."""
    return pt[0] if k == 0 else pt[1] if k == 1 else 1.0 - pt[1]


def edge_point(k, s):
    """The local point at parameter ``s`` along local edge ``k`` (the inverse of :func:`edge_param`)."""
    return (s, 0.0) if k == 0 else (1.0 - s, s) if k == 1 else (0.0, 1.0 - s)


def winding(pt, poly) -> int:
    """Winding number of a closed polygon (a list of points) around ``pt``."""
    px, py = pt
    w = 0
    for (ax, ay), (bx, by) in zip(poly, poly[1:] + poly[:1]):
        side = cross(bx - ax, by - ay, px - ax, py - ay)
        if ay <= py:
            if by > py and side > 0.0:
                w += 1
        elif by <= py and side < 0.0:
            w -= 1
    return w


def polygon_area(poly) -> float:
    """Signed area of a polygon (a list of points, not an array)."""
    return 0.5 * sum(ax * by - ay * bx for (ax, ay), (bx, by) in zip(poly, poly[1:] + poly[:1]))


def crossings(p, q, a, b):
    """Where segments ``p -> q`` and ``a -> b`` meet (ends within :data:`EPS` count): a list of (s, u) parameters, two
    for collinear overlapping segments (the ends of the overlap)."""
    rx, ry = q[0] - p[0], q[1] - p[1]
    vx, vy = b[0] - a[0], b[1] - a[1]
    lr, lv = math.hypot(rx, ry), math.hypot(vx, vy)
    if lr <= EPS or lv <= EPS:
        return []
    wx, wy = a[0] - p[0], a[1] - p[1]
    den = cross(rx, ry, vx, vy)
    tr, tv = EPS / lr, EPS / lv
    if abs(den) > 1e-12 * lr * lv:
        s, u = cross(wx, wy, vx, vy) / den, cross(wx, wy, rx, ry) / den
        if -tr <= s <= 1.0 + tr and -tv <= u <= 1.0 + tv:
            return [(min(max(s, 0.0), 1.0), min(max(u, 0.0), 1.0))]
        return []
    if abs(cross(rx, ry, wx, wy)) / lr > EPS:  # parallel, apart
        return []
    sa = (wx * rx + wy * ry) / (lr * lr)
    sb = ((b[0] - p[0]) * rx + (b[1] - p[1]) * ry) / (lr * lr)
    lo, hi = max(0.0, min(sa, sb)), min(1.0, max(sa, sb))
    if hi < lo - tr:
        return []
    out = []
    for s in (lo, hi) if hi > lo else (lo,):
        u = ((p[0] + s * rx - a[0]) * vx + (p[1] + s * ry - a[1]) * vy) / (lv * lv)
        out.append((s, min(max(u, 0.0), 1.0)))
    return out


def merge_intervals(iv):
    """Intervals sorted and merged where they overlap or meet within :data:`EPS`."""
    out = []
    for a, b in sorted(iv):
        if out and a <= out[-1][1] + EPS:
            out[-1] = (out[-1][0], max(out[-1][1], b))
        else:
            out.append((a, b))
    return out


def subtract_intervals(iv, cut):
    """Intervals ``iv`` less the intervals ``cut`` (both merged lists); pieces shorter than :data:`EPS` dropped."""
    out = []
    for a, b in iv:
        for c, d in cut:  # sorted and apart: what is left of [a, b] lies right of the cuts passed
            if d > a and c < b:
                out.append((a, c))
                a = d
        out.append((a, b))
    return [(x, y) for x, y in out if y - x > EPS]


def intersect_intervals(iv, jv):
    """The intersection of two interval lists, merged."""
    return merge_intervals([(max(a, c), min(b, d)) for a, b in iv for c, d in jv if min(b, d) > max(a, c)])


def overlaps(iv, jv) -> bool:
    """Do two interval lists overlap over more than :data:`EPS`?"""
    return any(min(b, d) - max(a, c) > EPS for a, b in iv for c, d in jv)


def reversed_intervals(iv):
    """Intervals of an edge seen from its other end."""
    return [(1.0 - hi, 1.0 - lo) for lo, hi in iv]


def edge_intervals(segments):
    """Segments (k, 2, 2) on the triangle's edges (severed or touched parts) -> three merged interval lists."""
    out = [[], [], []]
    for a, b in segments:
        for k in set(edges_of(a)) & set(edges_of(b)):
            s, u = edge_param(k, a), edge_param(k, b)
            if abs(u - s) > EPS:
                out[k].append((min(s, u), max(s, u)))
    return [merge_intervals(iv) for iv in out]


# --- the material of an element ---
def _segments(name, value) -> np.ndarray:
    a = np.zeros((0, 2, 2)) if value is None else check_real_array(name, value)
    if a.size and (a.ndim != 3 or a.shape[1:] != (2, 2) or not np.all(np.isfinite(a))):
        raise ParameterError(name, f"{name} must be finite segments shaped (k, 2, 2), got shape {a.shape}")
    return a if a.size else np.zeros((0, 2, 2))


@dataclass(frozen=True, eq=False)
class Region:
    """The part of its triangle an element's material fills, in the triangle's local coordinates."""

    #: (k, 2) arrays: the material, as counter-clockwise polygons that do not overlap; several when pieces a cut
    #: separates inside the triangle are joined outside it (around the end of the cut): they share all three nodes
    polygons: tuple
    #: (s, 2, 2): cracks inside the material that do not separate it (a crack tip)
    slits: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    #: (r, 2, 2): parts of the triangle's edges cut off from the element across
    severed: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    #: the share of the triangle's area the material fills (twice the polygons' area), worked out from them
    weight: float = field(init=False)

    def __post_init__(self):
        out, weight = [], 0.0
        for i, poly in enumerate(self.polygons):
            name = f"Region.polygons[{i}]"
            poly = check_points(name, poly, 3)
            if not ((poly >= -EPS).all() and (poly.sum(axis=1) <= 1.0 + EPS).all()):
                raise ParameterError(name, f"{name} must lie in the unit triangle (xi, eta >= 0, xi + eta <= 1)")
            area = 2.0 * polygon_area(poly.tolist())
            if not area > 0.0:
                raise ParameterError(name, f"{name} must be counter-clockwise with a positive area")
            out.append(poly)
            weight += area
        if not out:
            raise ParameterError("Region.polygons", "Region.polygons must hold at least one polygon")
        if weight > 1.0 + 1e-9:
            raise ParameterError("Region.polygons", f"Region.polygons cover {weight:.6g} times the triangle: they "
                                                    "must not overlap")
        self.__dict__.update(polygons=tuple(out), slits=_segments("Region.slits", self.slits),
                             severed=_segments("Region.severed", self.severed), weight=weight)

    @classmethod
    def unchecked(cls, polygons, slits, severed, weight, touch=None):
        """A region the cut built itself (valid by construction): no checks, no copies; its :attr:`touch` if known."""
        region = object.__new__(cls)
        region.__dict__.update(polygons=polygons, slits=slits, severed=severed, weight=weight)
        if touch is not None:
            region.__dict__["touch"] = touch  # where the cached property keeps it
        return region

    def sides(self) -> np.ndarray:
        """The polygons' sides (k, 2, 2), counter-clockwise (material on the left)."""
        return np.concatenate([np.stack([poly, np.roll(poly, -1, axis=0)], axis=1) for poly in self.polygons])

    @cached_property
    def touch(self) -> tuple:
        """The parts of each local edge the material touches, less what is severed (three interval lists, not to be
        modified). A region does not change: this is worked out once, so that a cut costs what it touches, not what
        was cut before."""
        touched, severed = edge_intervals(self.sides()), edge_intervals(self.severed)
        return tuple(subtract_intervals(touched[k], severed[k]) for k in range(3))


#: The material of a whole element.
WHOLE = Region((np.array([(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]),))


def element_weights(weights, m) -> np.ndarray:
    """The weights (each element's share of its triangle), all 1 when ``None``; checked as the assembler does."""
    return np.ones(m) if weights is None else check_weights(weights, m)


def check_regions(regions, weights, m):
    """Checked ``(regions, weights)`` of ``m`` elements: the weights follow from the regions, or must agree."""
    regions = {} if regions is None else regions
    if not isinstance(regions, dict):
        raise ParameterError("regions", f"regions must be a dict element -> Region, got {type(regions).__name__}")
    out = {}
    for e, r in regions.items():
        if isinstance(e, (bool, np.bool_)) or not isinstance(e, numbers.Integral) or not 0 <= int(e) < m:
            raise ParameterError("regions", f"regions: key {show(e)} is not an element index in [0, {m})")
        if not isinstance(r, Region):
            raise ParameterError(f"regions[{e}]", f"regions[{e}] must be a Region, got {type(r).__name__}")
        out[int(e)] = r
    implied = np.ones(m)
    implied[list(out)] = [r.weight for r in out.values()]
    if weights is None:
        return out, implied
    w = element_weights(weights, m)
    bad = np.flatnonzero(np.abs(w - implied) > 1e-9)
    if bad.size:
        e = int(bad[0])
        hint = "" if e in out else " (an element cut through before needs its region: pass regions=previous.regions)"
        raise ParameterError("weights", f"weights[{e}] = {w[e]!r} does not match the material of its region "
                                        f"({implied[e]!r}){hint}")
    return out, w
