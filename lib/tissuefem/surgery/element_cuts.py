"""Cutting through elements: the virtual node algorithm in 2D.

:func:`~tissuefem.surgery.topology.incise` snaps a stroke to mesh edges, so the wound is jagged and depends on the
mesh. Here the stroke is followed exactly, without remeshing, by the *virtual node algorithm* of Molino, Bao and
Fedkiw [1]_: every triangle the cut separates is duplicated, one copy per piece of its material; each copy keeps the
triangle's reference geometry (hence its P1 shape functions) and carries only its piece; vertices whose material a
copy does not hold become extra ("virtual") nodes.

1. **Where the stroke lies.** The P1 map of a triangle is affine, so each segment ``a -> b`` of the stroke (drawn on
   the deformed tissue) is clipped in barycentric coordinates, keeping ``lambda_i(a) + s (lambda_i(b) -
   lambda_i(a)) >= 0``. A stroke within 1e-6 edge lengths of a node is first moved onto it.
2. **The material of an element** is a :class:`Region` (polygons, *slits*, *severed* edge parts); its weight, the
   polygons' share of the triangle, is what :class:`~tissuefem.engine.assembly.P1Assembler` integrates.
3. **Splitting.** The region's boundary, its slits and the stroke's new pieces form a planar graph; dangling edges (a
   crack ending in the material) are kept as slits; its ``k`` faces are ``k`` copies of the element.
4. **Nodes.** Two elements across a mesh edge are *joined* where the parts of the edge their regions touch (less what
   is severed) overlap over a positive length; joined elements share the edge's nodes. The new nodes are the classes
   of corners (element, vertex) under these joins. A cut along a mesh edge needs no split: severing stops the join.
5. **The crack tip.** The triangle holding the end of a crack is one piece, so (as in [1]_) it is not duplicated: the
   crack closes within one element of the drawn tip (phantom-node methods [3]_ make the same choice).
6. **No slivers.** A piece lighter than ``min_weight`` is merged into its neighbour across the cut and the parts of
   the triangle's edges that bounded it are severed instead. A light piece that stays is tied to its neighbours by a
   ghost penalty [4]_ (:class:`~tissuefem.engine.terms.GhostPenalty`), so that neither spikes nor crumpling lips appear.
7. **One element per set of nodes.** Copies of one triangle with the same three nodes (e.g. the corners outside a
   V-shaped crack) are one element, whose region may have several polygons.

Cuts through vertices and along edges need no special case (Wang et al. [2]_). Uncut elements and old nodes keep
their index and vertex order; the other pieces and the virtual nodes are appended. Nodal masses from the material
areas (:func:`lumped_mass`) carry mass and momentum over exactly.

.. [1] N. Molino, Z. Bao, R. Fedkiw, *A virtual node algorithm for changing mesh topology during simulation*, ACM
   Transactions on Graphics 23(3) (SIGGRAPH 2004), 385-392.
.. [2] Y. Wang, C. Jiang, C. Schroeder, J. Teran, *An adaptive virtual node algorithm with robust mesh cutting*,
   Symposium on Computer Animation 2014.
.. [3] J.-H. Song, P. M. A. Areias, T. Belytschko, *A method for dynamic crack and shear band propagation with phantom
   nodes*, International Journal for Numerical Methods in Engineering 67 (2006), 868-893.
.. [4] E. Burman, *Ghost penalty*, Comptes Rendus Mathematique 348(21-22) (2010), 1217-1220.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from itertools import groupby

import numpy as np

from ..engine.meshes import signed_areas
from ..engine.parameters import check_real
from .geometry import (EPS, WHOLE, Region, carry_names, check_regions, cross, crossings, edge_intervals, edge_point,
                       edges_of, element_edges, element_weights, mesh_arrays, mesh_at, new_mesh, overlaps,
                       polygon_area, polygon_contains, reversed_intervals, snap, stroke_in_body, subtract_intervals,
                       winding)
from .surfaces import contact_surface
from .topology import MeshEdit, excise, split_nodes

__all__ = ["Region", "Wound", "ElementCut", "cut_through", "excise_through", "Picture", "picture", "locate",
           "firm_anchor", "carry_points", "lumped_mass", "material_areas", "node_material"]

#: A stroke closer than this (times the median edge length) to a node is moved onto it (step 1 above).
_NODE_SNAP = 1e-6
#: Default smallest share of its triangle a piece may carry (``min_weight``): a corner piece's share is the product of
#: the fractions of the edges it cuts off, so this snaps a cut within about 3 % of a vertex (still well-conditioned).
MIN_WEIGHT = 1e-3

_P, _S, _C = 0, 1, 2  # the kinds of edge of an element's planar graph: region boundary, old slit, new cut


# --- one element: its material, cut by the new pieces of the stroke ---
class _Arrangement:
    """The planar graph of one element's region, old slits and new cut pieces ``cuts`` (stroke0, stroke1, a, b) (stroke
    parameters and local ends); ``open_edge`` (3 bools): has each local edge an element across (else a cut along it is
    not recorded)."""

    def __init__(self, region: Region, cuts, open_edge, min_weight):
        self.verts, self.cells = [], {}  # the graph's points; the grid cells of 2 EPS holding them
        self.min_weight = min_weight
        polys = [[tuple(v) for v in poly] for poly in region.polygons]
        self.severed = list(region.severed)  # segments on the triangle's edges, cut off from the element across

        segs = [(poly[i], poly[(i + 1) % len(poly)], _P, None) for poly in polys for i in range(len(poly))]
        segs += [(tuple(a), tuple(b), _S, None) for a, b in region.slits]
        segs += [(a, b, _C, (s0, s1)) for s0, s1, a, b in cuts]
        splits = [[(0.0, self._vertex(a)), (1.0, self._vertex(b))] for a, b, _, _ in segs]
        # only segments whose boxes meet can cross (the pairs in the same order as a double loop): a long wavy stroke
        # makes many pieces in one triangle, and all pairs of them would cost their square
        ends = np.array([(a[0], a[1], b[0], b[1]) for a, b, _, _ in segs]).reshape(-1, 4)
        lo = np.minimum(ends[:, :2], ends[:, 2:]) - 2.0 * EPS
        hi = np.maximum(ends[:, :2], ends[:, 2:]) + 2.0 * EPS
        boundary = np.array([kind == _P for _, _, kind, _ in segs])
        meet = ((lo[:, None, :] <= hi[None, :, :]) & (lo[None, :, :] <= hi[:, None, :])).all(axis=2)
        meet &= ~(boundary[:, None] & boundary[None, :])  # the polygons are simple and apart: they meet at vertices
        for i, j in zip(*np.nonzero(np.triu(meet, 1))):
            (pi, qi, ki, _), (pj, qj, kj, _) = segs[i], segs[j]
            for s, u in crossings(pi, qi, pj, qj):
                # the point from the older segment, so region boundaries stay where they were
                a, b, f = (pj, qj, u) if kj < ki else (pi, qi, s)
                v = self._vertex(snap(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])))
                splits[i].append((s, v))
                splits[j].append((u, v))

        self.graph = {}  # (u, v) with u < v -> kind
        cut_edges = []  # (u, v, stroke_u, stroke_v) in the direction of the stroke
        for (a, b, kind, strokes), sp in zip(segs, splits):
            chain = [next(run) for _, run in groupby(sorted(sp), key=lambda sv: sv[1])]  # repeated vertices once
            for (s0, u), (s1, v) in zip(chain[:-1], chain[1:]):
                if kind == _C:
                    t0, t1 = strokes
                    cut_edges.append((u, v, t0 + s0 * (t1 - t0), t0 + s1 * (t1 - t0)))
                else:
                    key = _key(u, v)
                    if self.graph.get(key, _C) > kind:
                        self.graph[key] = kind
        self.slits = []  # (u, v) edges of cracks that do not separate
        self.wound = []  # ("inner", u, v, t0, t1) or ("edge", u, v, t0, t1, k)
        for u, v, t0, t1 in cut_edges:
            kind = self.graph.get(_key(u, v))
            if kind == _P:  # severs an edge of the triangle with an element across (else: an old wound, the boundary)
                k = self._edge_of(u, v)
                if k is not None and open_edge[k]:
                    self.severed.append((self.verts[u], self.verts[v]))
                    self.wound.append(("edge", u, v, t0, t1, k))
            elif kind == _S:
                self.wound.append(("inner", u, v, t0, t1))
            # a new cut, unless on the triangle's edge where this copy has no material or outside its material
            elif self._edge_of(u, v) is None and sum(winding(_mid(self.verts[u], self.verts[v]), poly)
                                                     for poly in polys) != 0:
                self.graph[_key(u, v)] = _C
                self.wound.append(("inner", u, v, t0, t1))
        self.changed = _C in self.graph.values() or any(rec[0] == "edge" for rec in self.wound)
        self._settle()

    def _vertex(self, pt) -> int:
        """The first vertex within EPS of ``pt`` (found among those in the neighbouring cells of a 2 EPS grid), or a new
        one."""
        x, y = pt
        cx, cy = math.floor(x / (2.0 * EPS)), math.floor(y / (2.0 * EPS))
        near = [i for dx in (-1, 0, 1) for dy in (-1, 0, 1) for i in self.cells.get((cx + dx, cy + dy), ())
                if abs(self.verts[i][0] - x) <= EPS and abs(self.verts[i][1] - y) <= EPS]
        if near:
            return min(near)
        self.verts.append((float(x), float(y)))
        self.cells.setdefault((cx, cy), []).append(len(self.verts) - 1)
        return len(self.verts) - 1

    def _edge_of(self, u, v):
        both = set(edges_of(self.verts[u])) & set(edges_of(self.verts[v]))
        return min(both) if both else None

    def _prune(self):
        """Move dangling cut edges (and cut loops that touch no boundary) to the slits."""
        adj = {}
        for u, v in self.graph:
            adj.setdefault(u, set()).add(v)
            adj.setdefault(v, set()).add(u)
        stack = [u for u, nb in adj.items() if len(nb) == 1]
        while stack:
            u = stack.pop()
            if len(adj[u]) != 1:
                continue
            (v,) = adj[u]
            self.slits.append(_key(u, v))
            del self.graph[_key(u, v)]
            adj[u].discard(v)
            adj[v].discard(u)
            if len(adj[v]) == 1:
                stack.append(v)
        # what the region's boundary does not reach: closed loops of cuts inside the material
        reached = {u for key, kind in self.graph.items() if kind == _P for u in key}
        todo = list(reached)
        while todo:
            for v in adj[todo.pop()] - reached:
                reached.add(v)
                todo.append(v)
        for key in [k for k in self.graph if k[0] not in reached]:
            self.slits.append(key)
            del self.graph[key]

    def _extract(self):
        """Faces of the graph: counter-clockwise cycles of half-edges, the outer face dropped."""
        nbrs = {}
        for u, v in self.graph:
            nbrs.setdefault(u, []).append(v)
            nbrs.setdefault(v, []).append(u)
        for u, lst in nbrs.items():
            ux, uy = self.verts[u]
            lst.sort(key=lambda w: math.atan2(self.verts[w][1] - uy, self.verts[w][0] - ux))
        self.face_of, faces = {}, []
        for u0, v0 in sorted(self.graph):
            for start in ((u0, v0), (v0, u0)):
                if start in self.face_of:
                    continue
                cycle, he = [], start
                while he not in self.face_of:
                    self.face_of[he] = len(faces)
                    cycle.append(he)
                    u, v = he
                    lst = nbrs[v]
                    he = (v, lst[lst.index(u) - 1])  # the next edge clockwise from v -> u
                pts = [self.verts[a] for a, _ in cycle]
                faces.append({"edges": cycle, "area": polygon_area(pts), "points": pts})
        keep = [i for i, f in enumerate(faces) if f["area"] > 0.0]
        renum = {old: new for new, old in enumerate(keep)}
        self.face_of = {he: renum.get(f, -1) for he, f in self.face_of.items()}  # -1: the outer face
        self.faces = [faces[i] for i in keep]

    def _settle(self):
        while True:
            self._prune()
            self._extract()
            # a face bounded by cuts alone (a loop inside the material, attached at one point): not cut out
            island = next((f for f in self.faces if all(self.graph[_key(u, v)] != _P
                                                         for u, v in f["edges"])), None)
            if island is not None:
                for key in dict.fromkeys(_key(u, v) for u, v in island["edges"]):  # each edge once
                    self.slits.append(key)
                    del self.graph[key]
                continue
            weights = [2.0 * f["area"] for f in self.faces]
            if len(self.faces) < 2 or min(weights) >= self.min_weight:
                return
            # a sliver: merge it into the neighbour it shares the most cut with, and sever its part of the triangle's
            # edges, so that the cut runs along them instead
            f = int(np.argmin(weights))
            shared = {}
            for u, v in self.faces[f]["edges"]:
                g = self.face_of[(v, u)]
                if self.graph[_key(u, v)] != _P and g >= 0 and g != f:
                    shared[g] = shared.get(g, 0.0) + math.dist(self.verts[u], self.verts[v])
            if not shared:
                return
            g = max(shared, key=lambda h: (shared[h], -h))
            for u, v in self.faces[f]["edges"]:
                key = _key(u, v)
                if self.graph[key] == _P:
                    self.severed.append((self.verts[u], self.verts[v]))  # (one inside the triangle severs nothing)
                elif self.face_of[(v, u)] == g:
                    del self.graph[key]  # dropped, not kept as a slit: the cut moved to the edges

    def merge(self, groups):
        """Merge each group of faces into one (the cuts between them become slits): the new index of every old face."""
        group_of = {f: gi for gi, members in enumerate(groups) for f in members}
        for key in list(self.graph):
            if self.graph[key] == _P:
                continue
            a, b = self.face_of[key], self.face_of[(key[1], key[0])]
            if a in group_of and b in group_of and group_of[a] == group_of[b]:
                self.slits.append(key)
                del self.graph[key]
        old_faces = self.faces
        self._extract()
        # every face has a boundary edge, and those stay
        return [self.face_of[next(he for he in f["edges"] if self.graph.get((min(he), max(he))) == _P)]
                for f in old_faces]

    def locate(self, pt) -> int:
        return next((i for i, f in enumerate(self.faces) if winding(pt, f["points"]) != 0), -1)

    def face_regions(self):
        """For every face: (Region, whole?)."""
        severed = edge_intervals(self.severed)
        slit_pts = [(self.verts[u], self.verts[v]) for u, v in self.slits]
        slit_face = [self.locate(_mid(a, b)) for a, b in slit_pts]
        out = []
        for i, f in enumerate(self.faces):
            pts = _simplify(f["points"])
            touched = edge_intervals([(self.verts[u], self.verts[v]) for u, v in f["edges"]
                                      if self.graph[_key(u, v)] == _P])
            cut_off = [(edge_point(k, a), edge_point(k, b)) for k in range(3)
                       for a, b in subtract_intervals(touched[k], subtract_intervals(touched[k], severed[k]))]
            slits = [s for s, g in zip(slit_pts, slit_face) if g == i]
            region = Region.unchecked((np.array(pts),), np.array(slits, dtype=float).reshape(-1, 2, 2),
                                     np.array(cut_off, dtype=float).reshape(-1, 2, 2), 2.0 * f["area"],
                                     tuple(subtract_intervals(touched[k], severed[k]) for k in range(3)))
            whole = len(pts) == 3 and not slits and not cut_off and abs(2.0 * f["area"] - 1.0) <= EPS
            out.append((region, whole))
        return out

    def wound_faces(self):
        """One record per side of each new wound piece: (face, side (+1: the face is left of the stroke), stroke0,
        stroke1, a, b, opened); a piece along the triangle's edge has one side here, the other in the element across."""
        out = []
        for kind, u, v, t0, t1, *_ in self.wound:
            a, b = self.verts[u], self.verts[v]
            if kind == "edge":  # the side that has material here
                left = self.face_of.get((u, v), -1)
                sides = [(left, 1)] if left >= 0 else [(self.face_of[(v, u)], -1)]
            elif _key(u, v) in self.graph:
                sides = [(self.face_of[(u, v)], 1), (self.face_of[(v, u)], -1)]
            else:  # a slit, or a cut snapped away from a sliver: material on both sides
                sides = [(self.locate(_mid(a, b)), 1), (self.locate(_mid(a, b)), -1)]
            opened = kind == "edge" or sides[0][0] != sides[1][0]
            out += [(f, side, t0, t1, a, b, opened) for f, side in sides]
        return out


def _key(u, v):
    return (u, v) if u < v else (v, u)


def _mid(a, b):
    return 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])


def _simplify(pts):
    """Drop polygon vertices where the boundary goes straight on."""
    out = list(pts)
    i = 0
    while len(out) > 3 and i < len(out):
        (ax, ay), (bx, by), (cx, cy) = out[i - 1], out[i], out[(i + 1) % len(out)]
        straight = abs(cross(bx - ax, by - ay, cx - bx, cy - by)) <= EPS * EPS
        if straight and (bx - ax) * (cx - bx) + (by - ay) * (cy - by) > 0:
            del out[i]
        else:
            i += 1
    return out


# --- the stroke in every triangle ---
def _through_nearby_nodes(x, t, pts):
    """The stroke moved onto the nodes it nearly meets: the points (k', 2), each with its parameter on the drawn stroke
    (segment + fraction). A vertex near a node becomes the node; a node near a segment becomes a new vertex."""
    used = np.unique(t)
    xs = x[:, used]
    edges = x[:, np.roll(t, -1, axis=0)] - x[:, t]
    delta = _NODE_SNAP * float(np.median(np.hypot(edges[0], edges[1])))
    pts = pts.copy()
    for i, q in enumerate(pts):  # vertices of the stroke onto nearby nodes
        d = np.hypot(xs[0] - q[0], xs[1] - q[1])
        k = int(np.argmin(d))
        if d[k] <= delta:
            pts[i] = xs[:, k]
    out, param = [pts[0]], [0.0]
    for j in range(len(pts) - 1):
        a, b = pts[j], pts[j + 1]
        d = b - a
        L2 = float(d @ d)
        if L2 > 0.0:
            s = np.clip(((xs[0] - a[0]) * d[0] + (xs[1] - a[1]) * d[1]) / L2, 0.0, 1.0)
            off = np.hypot(a[0] + s * d[0] - xs[0], a[1] + s * d[1] - xs[1])
            near = np.flatnonzero((off <= delta) & (s * math.sqrt(L2) > delta) & ((1.0 - s) * math.sqrt(L2) > delta))
            for k in near[np.argsort(s[near])]:
                out.append(xs[:, k])
                param.append(j + float(s[k]))
        out.append(b)
        param.append(float(j + 1))
    return np.array(out), np.array(param)


def _stroke_pieces(x, t, pts, drawn):
    """Pieces of the stroke ``pts`` in each triangle as drawn (collapsed triangles skipped): ``(pieces,
    orientation)``, with ``pieces`` {element: [(stroke0, stroke1, a, b)]} (ends in local coordinates, and on the drawn
    polyline, where ``drawn`` puts the points of ``pts``) and the sign of each drawn area."""
    X = x[:, t]  # (2, 3, m)
    x0, d1, d2 = X[:, 0], X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    det = d1[0] * d2[1] - d1[1] * d2[0]
    h2 = np.maximum.reduce([(d1**2).sum(0), (d2**2).sum(0), ((X[:, 2] - X[:, 1]) ** 2).sum(0)])
    usable = np.abs(det) > 1e-12 * h2
    lo, hi = X.min(axis=1), X.max(axis=1)
    pad = 1e-9 * max(float(np.ptp(x, axis=1).max()), 1e-300)
    pieces = {}
    for j in range(len(pts) - 1):
        a, b = pts[j], pts[j + 1]
        if np.hypot(*(b - a)) == 0.0:
            continue
        cand = np.flatnonzero(usable & (lo <= np.maximum(a, b)[:, None] + pad).all(axis=0)
                              & (hi >= np.minimum(a, b)[:, None] - pad).all(axis=0))
        if cand.size == 0:
            continue
        e1, e2, dt = d1[:, cand], d2[:, cand], det[cand]
        w = np.stack([a, b])[:, :, None] - x0[:, cand]  # (end, xy, candidate)
        xi, eta = (w[:, 0] * e2[1] - w[:, 1] * e2[0]) / dt, (e1[0] * w[:, 1] - e1[1] * w[:, 0]) / dt
        la, lb = np.stack([1.0 - xi - eta, xi, eta], axis=1)  # barycentric coordinates of a and b
        dl = lb - la
        s_lo, s_hi = np.zeros(cand.size), np.ones(cand.size)
        # a segment with lambda_i within EPS of 0 at both ends (scaled by its reach) lies on that edge: that constraint
        # is dropped; every other one cuts exactly at lambda_i = 0, so that the ends stay on the stroke
        along = (np.abs(la) <= EPS * np.maximum(1.0, np.abs(lb))) & (np.abs(lb) <= EPS * np.maximum(1.0, np.abs(la)))
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -la / dl
        for i in range(3):
            active = ~along[i]
            s_lo = np.where(active & (dl[i] > 0), np.maximum(s_lo, bound[i]), s_lo)
            s_hi = np.where(active & (dl[i] < 0), np.minimum(s_hi, bound[i]), s_hi)
            s_hi = np.where(active & (dl[i] == 0) & (la[i] < 0), -1.0, s_hi)
        pa, pb = la[1:] + s_lo * dl[1:], la[1:] + s_hi * dl[1:]
        keep = (s_hi > s_lo) & (np.hypot(*(pb - pa)) > EPS)
        for c in np.flatnonzero(keep):
            pa_c, pb_c = snap(float(pa[0, c]), float(pa[1, c])), snap(float(pb[0, c]), float(pb[1, c]))
            if math.dist(pa_c, pb_c) <= EPS:
                continue
            s0, s1 = np.interp([j + float(s_lo[c]), j + float(s_hi[c])], np.arange(drawn.size), drawn)
            pieces.setdefault(int(cand[c]), []).append((float(s0), float(s1), pa_c, pb_c))
    return pieces, np.sign(det)


# --- the result ---
@dataclass(frozen=True, eq=False)
class Wound:
    """The faces of a cut to draw: one record per side of each piece of the stroke (``k``), moving with its element."""

    element: np.ndarray  #: (k,) int: the new element that carries the material on this side
    side: np.ndarray  #: (k,) int: +1 if the material lies to the left of the stroke (as drawn), -1 to its right
    barycentric: np.ndarray  #: (k, 2, 3): the two ends of the piece in the element's barycentric coordinates
    nodes: np.ndarray  #: (k, 3) int: the element's nodes in the new mesh (so that :meth:`positions` needs no mesh)
    reference: np.ndarray  #: (k, 2, 2): the two ends (k, end, xy) in the reference configuration
    stroke: np.ndarray  #: (k, 2): where the ends lie on the drawn polyline, segment index plus fraction
    opened: np.ndarray  #: (k,) bool: False where both sides are still one piece (a crack's tip, a sliver snapped away)

    def positions(self, x) -> np.ndarray:
        """The ends of every record at node positions ``x`` (2, n_new_nodes): shape (k, 2, 2)."""
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[0] != 2 or (self.nodes.size and x.shape[1] <= self.nodes.max()):
            raise ValueError(f"x must be node positions of the new mesh shaped (2, n_nodes), got {x.shape}")
        return np.einsum("kea,ika->kei", self.barycentric, x[:, self.nodes])  # corners (2, k, 3)


@dataclass(frozen=True, eq=False, kw_only=True)
class ElementCut(MeshEdit):
    """A :class:`~tissuefem.surgery.topology.MeshEdit` that cut through elements (``cut_edges``: those it ran along)."""

    #: (n_new_elements,): share of its triangle each element's material fills, in (0, 1]; the copies of one old element
    #: add up to its old weight (for :class:`~tissuefem.engine.assembly.P1Assembler`)
    weights: np.ndarray
    regions: dict  #: element -> :class:`Region`: where the material of each element that is not whole lies
    wound: Wound  #: the new wound's faces, to draw its two edges smoothly

    def contact_surface(self):
        """The contact surface of the cut body: where its material ends (:func:`~.surfaces.contact_surface`)."""
        return contact_surface(self.mesh, self.weights, self.regions)


def node_material(mesh, regions) -> np.ndarray | None:
    """Whether each node of a mesh cut through its elements (material ``regions``) has material at its place: some
    element at it is whole or holds its material at that corner. A *virtual* node (every element at it has its
    material elsewhere) has none, and holds nothing (:attr:`~tissuefem.engine.meshes.MeshMap.material`). ``None``
    when no element is cut: every node has."""
    if not regions:
        return None
    p, t = mesh_arrays(mesh)
    at_corner = np.ones(t.shape, dtype=bool)  # (3, m): has the element material at each of its corners
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    for e, region in regions.items():
        vertices = np.concatenate(region.polygons)  # a corner in the material is a vertex of its polygon
        at_corner[:, e] = (np.abs(vertices[None, :, :] - corners[:, None, :]) <= EPS).all(axis=2).any(axis=1)
    material = np.zeros(p.shape[1], dtype=bool)
    material[t[at_corner]] = True
    return material


def material_areas(mesh, weights=None) -> np.ndarray:
    """Reference area of every element's material: triangle area times weight, shape (n_elements,)."""
    _, t = mesh_arrays(mesh)
    return np.abs(signed_areas(mesh)) * element_weights(weights, t.shape[1])


def lumped_mass(mesh, weights=None, density=1.0) -> np.ndarray:
    """Lumped P1 mass of every node (n_nodes,): ``density`` times a third of the material area of its elements. With a
    cut's weights the copies of a node hold the mass it held: carrying a state by ``parent`` keeps mass and momentum."""
    density = check_real("density", density, 0.0, lo_open=True)
    p, t = mesh_arrays(mesh)
    share = np.repeat(material_areas(mesh, weights)[None, :] * (float(density) / 3.0), 3, axis=0)
    return np.bincount(t.ravel(), weights=share.ravel(), minlength=p.shape[1])


# --- the cut ---
def _one_element_per_nodes(arr, ids, faces, triples):
    """Copies of one triangle with the same three nodes (``triples``) as one element (step 7): its elements
    ``[(provisional id, Region, whole, area)]`` (by provisional id) and ``{face: provisional id}``."""
    by_triple = {}
    for i, nodes in enumerate(triples):
        by_triple.setdefault(nodes, []).append(i)
    groups = list(by_triple.values())
    new_of = list(range(len(ids)))
    if len(groups) < len(ids):
        # faces that share a cut become one face (the cut between them a slit); faces joined only outside the
        # triangle stay apart, as polygons of one region
        new_of = arr.merge([g for g in groups if len(g) > 1])
        faces = arr.face_regions()
    out, pid_of_face = [], {}
    for g in groups:
        members = sorted({new_of[i] for i in g})
        area = sum(arr.faces[f]["area"] for f in members)
        if len(members) == 1:
            region, whole = faces[members[0]]
        else:
            region = Region.unchecked(tuple(faces[f][0].polygons[0] for f in members),
                                      np.concatenate([faces[f][0].slits for f in members]),
                                      np.concatenate([faces[f][0].severed for f in members]), 2.0 * area)
            whole = False
        out.append((ids[min(g)], region, whole, area))
        pid_of_face.update({f: ids[min(g)] for f in members})
    return out, pid_of_face


def cut_through(mesh, polyline, positions=None, weights=None, regions=None, min_weight=MIN_WEIGHT) -> ElementCut:
    """Cut ``mesh`` (not modified) through its elements along a ``polyline`` (k, 2), k >= 2 (the virtual node
    algorithm), drawn at ``positions`` (default ``mesh.p``; triangles collapsed there are not cut) and first clipped to
    the body (:func:`~.geometry.clip_to_body`); it may end inside the body (a crack). A mesh cut before passes its
    ``weights`` and ``regions``. No piece carries less than ``min_weight`` in [0, 0.5) of its triangle (step 6). Named
    boundaries go to the facets whose material touched them, subdomains to every copy. ``ValueError`` for bad
    arguments, or a stroke that changes nothing (it meets no material, or runs only along the boundary or a wound)."""
    p, t, x = mesh_at(mesh, positions)
    n, m = p.shape[1], t.shape[1]
    pts, clipped = stroke_in_body("polyline", polyline, x, t)
    min_weight = check_real("min_weight", min_weight, 0.0, 0.5, hi_open=True)
    regions, w = check_regions(regions, weights, m)
    # the stroke in each triangle (stroke parameters back on the drawn polyline) and what it does to the material
    snapped, drawn = _through_nearby_nodes(x, t, pts)
    drawn = np.interp(drawn, np.arange(clipped.size), clipped)
    pieces, orientation = _stroke_pieces(x, t, snapped, drawn)
    key, side = element_edges(p, t)
    # an element edge has an element across when some element has the same node pair on the other side
    has_across = np.isin(key * 2 + (side > 0), key * 2 + (side < 0))
    arrangements = {}
    for e in sorted(pieces):
        arr = _Arrangement(regions.get(e, WHOLE), pieces[e], has_across[:, e], min_weight)
        if arr.changed:
            arrangements[e] = arr
    if not arrangements:
        raise ValueError("polyline changes nothing: it meets no material, or runs only along the body's boundary "
                         "or along an existing wound")
    affected = np.array(sorted(arrangements), dtype=np.int64)

    # provisional pieces: face 0 of a cut element keeps its index, the others are numbered from m
    faces_of = {e: arrangements[e].face_regions() for e in arrangements}
    piece_ids = {}  # element -> provisional ids of its faces
    touched = {}  # provisional id -> the parts of each local edge its material touches
    first = m  # the next provisional id
    for e in affected.tolist():
        piece_ids[e] = [e] + list(range(first, first + len(faces_of[e]) - 1))
        first += len(faces_of[e]) - 1
        touched.update({pid: region.touch for pid, (region, _) in zip(piece_ids[e], faces_of[e])})
    for e in regions:  # elements cut before (their material touches only parts of their edges)
        touched.setdefault(e, regions[e].touch)
    node_of, new_parent, fan = _number_nodes(t, n, key, side, affected, piece_ids, touched)

    def triple(pid, e):
        return tuple(node_of.get((pid, lv), int(t[lv, e])) for lv in range(3))

    # the new elements: the first piece (lowest provisional id) keeps the old index, the others are appended
    final_faces, element_of_face = {}, {}  # element -> its new elements; element -> {face: new element}
    final_id, elements = {}, list(range(m))
    for e in affected.tolist():
        final_faces[e], pid_of_face = _one_element_per_nodes(arrangements[e], piece_ids[e], faces_of[e],
                                                             [triple(pid, e) for pid in piece_ids[e]])
        for i, (pid, *_) in enumerate(final_faces[e]):  # in the order of their provisional ids
            final_id[pid] = e if i == 0 else len(elements)
            if i:
                elements.append(e)
        element_of_face[e] = {f: final_id[pid] for f, pid in pid_of_face.items()}
    elements = np.asarray(elements, dtype=np.int64)
    new_t = np.concatenate([t, np.empty((3, elements.size - m), dtype=np.int64)], axis=1)
    new_w = np.concatenate([w, np.empty(elements.size - m)])
    new_regions = {e: r for e, r in regions.items() if e not in arrangements}
    for e in fan.tolist():
        if e not in arrangements:
            new_t[:, e] = triple(e, e)
    for e in affected.tolist():
        total = sum(r[3] for r in final_faces[e])
        for pid, region, whole, area in final_faces[e]:
            E = final_id[pid]
            new_t[:, E] = triple(pid, e)
            new_w[E] = w[e] * area / total
            if not whole:
                new_regions[E] = region
    parent = np.concatenate([np.arange(n, dtype=np.int64), new_parent])
    wound, cut_edges = _wound(p, t, arrangements, element_of_face, orientation, new_t)
    touches = np.ones((3, elements.size), dtype=bool)  # which local edges each element's material touches
    for e, region in new_regions.items():
        touches[:, e] = [bool(iv) for iv in region.touch]
    cut_mesh = carry_names(mesh, new_mesh(p[:, parent], new_t), parent, elements, touches)
    return ElementCut(mesh=cut_mesh, parent=parent, elements=elements, cut_edges=cut_edges, n_old_nodes=n,
                      n_old_elements=m, weights=new_w, regions=new_regions, wound=wound,
                      material=node_material(cut_mesh, new_regions))


def _number_nodes(t, n, key, side, affected, piece_ids, touched):
    """The node of every corner at the nodes of the cut elements (step 4): ``(node_of {(provisional id, local vertex):
    node}, new_parent (the old node of each appended node), fan (the elements with a corner there))``: the classes of
    joined corners at each old node, numbered by :func:`~.topology.split_nodes` (the lowest piece keeps the node)."""
    at_hub = np.isin(np.arange(n), t[:, affected])  # the hub: the nodes of the cut elements
    fan = np.flatnonzero(at_hub[t].any(axis=0))
    sel_k, sel_e = np.nonzero(at_hub[t[:, fan]] | at_hub[np.roll(t, -1, axis=0)[:, fan]])
    sel_e = fan[sel_e]
    sides = {}  # edge key -> (elements on its + side, on its - side), as (element, local edge, forward?, corners)
    for k, e, kk, s in zip(sel_k.tolist(), sel_e.tolist(), key[sel_k, sel_e].tolist(), side[sel_k, sel_e].tolist()):
        forward = t[k, e] == kk // n  # the local edge runs from the lower node to the higher
        corners = (k, (k + 1) % 3) if forward else ((k + 1) % 3, k)  # the local vertices at the lower, higher node
        sides.setdefault(kk, ([], []))[0 if s > 0 else 1].append((e, k, forward, corners))

    corner, node = {}, []  # (provisional id, local vertex) -> index among the corners at the hub; their nodes
    for e in fan.tolist():
        for lv in range(3):
            if at_hub[t[lv, e]]:
                for pid in piece_ids.get(e, (e,)):
                    corner[pid, lv] = len(node)
                    node.append(int(t[lv, e]))

    def along(pid, k, forward):  # touched intervals, run from the edge's lower node to its higher
        iv = touched.get(pid, WHOLE.touch)[k]
        return iv if forward else reversed_intervals(iv)

    links = []  # the joined corners
    for kk, (plus, minus) in sides.items():
        for e, k, e_fwd, e_corners in plus:
            for f, l, f_fwd, f_corners in minus:
                for pe in piece_ids.get(e, (e,)):
                    te = along(pe, k, e_fwd)
                    for pf in piece_ids.get(f, (f,)):
                        if overlaps(te, along(pf, l, f_fwd)):
                            links += [(corner[pe, ce], corner[pf, cf])
                                      for v, ce, cf in zip(divmod(kk, n), e_corners, f_corners) if at_hub[v]]
    new, new_parent = split_nodes(np.array(node, dtype=np.int64), np.array([pid for pid, _ in corner]),
                                  np.array(links, dtype=np.int64).reshape(-1, 2).T, n)
    return dict(zip(corner, new.tolist())), new_parent, fan


def _wound(p, t, arrangements, element_of_face, orientation, new_t):
    """The wound's records (one per side of each piece) and the mesh edges the stroke ran along."""
    records, along = [], []  # (new element, old element, side, barycentric ends, stroke, opened)
    for e, arr in arrangements.items():
        records += [(element_of_face[e][f], e, s * int(orientation[e]),  # the local map may mirror the drawing
                     [[1.0 - a[0] - a[1], a[0], a[1]], [1.0 - b[0] - b[1], b[0], b[1]]], (t0, t1), opened)
                    for f, s, t0, t1, a, b, opened in arr.wound_faces() if f >= 0]
        along += [(rec[3], *sorted((int(t[rec[5], e]), int(t[(rec[5] + 1) % 3, e])))) for rec in arr.wound
                  if rec[0] == "edge"]

    def column(i, dtype):
        return np.asarray([r[i] for r in records], dtype=dtype)

    element, bary = column(0, np.int64), column(3, float).reshape(-1, 2, 3)
    wound = Wound(element=element, side=column(2, np.int64), barycentric=bary, nodes=new_t[:, element].T.copy(),
                  reference=np.einsum("kea,iak->kei", bary, p[:, t[:, column(1, np.int64)]]),
                  stroke=column(4, float).reshape(-1, 2), opened=column(5, bool))
    passed = dict.fromkeys((a, b) for _, a, b in sorted(along))  # each edge once, in the order the stroke ran along it
    cut_edges = np.asarray(list(passed), dtype=np.int64).reshape(-1, 2).T
    return wound, cut_edges


# --- removing what a closed cut encloses ---
def excise_through(mesh, polygon, positions=None, weights=None, regions=None, min_weight=MIN_WEIGHT) -> ElementCut:
    """Cut along a closed ``polygon`` through the elements (:func:`cut_through`) and remove the material inside it, so
    that the rim follows the drawn outline (not the centroids, as :func:`~tissuefem.surgery.topology.excise` does); a
    far-reaching polygon is first clipped to the body (what it encloses there is kept).
    Returns an :class:`ElementCut` that maps to ``mesh`` as it was; its ``wound`` holds the rim's records."""
    # what it encloses in the body, outlined within reach of the body (a far corner costs the rim no precision)
    _, t, x = mesh_at(mesh, positions)
    closed = stroke_in_body("polygon", polygon, x, t, closed=True)[0]
    first = cut_through(mesh, closed, positions, weights=weights, regions=regions, min_weight=min_weight)
    m = first.mesh.t.shape[1]
    # where each element's material is now (the stroke was drawn there): a point inside its material, carried by the
    # P1 map of its triangle; for a cut element, the centroid of the largest triangle of its material's triangulation
    # (inside even when the polygon is not convex)
    centre = np.full((m, 3), 1.0 / 3.0)
    for e, region in first.regions.items():
        tris = [(poly[i], poly[j], poly[k]) for poly in region.polygons for i, j, k in _triangulate(poly)]
        a, b, c = max(tris, key=lambda abc: abs(cross(*(abc[1] - abc[0]), *(abc[2] - abc[0]))))
        g = (a + b + c) / 3.0
        centre[e] = [1.0 - g[0] - g[1], g[0], g[1]]
    x = mesh_at(first.mesh, None if positions is None else first.transfer(np.asarray(positions, float)))[2]
    remove = polygon_contains(closed, np.einsum("ea,iae->ie", centre, x[:, first.mesh.t]).T)
    if not remove.any():
        raise ValueError("polygon encloses no material")
    if remove.all():
        raise ValueError("polygon encloses all the material: nothing would be left")
    second = excise(first.mesh, lambda _centroids: remove)
    keep = second.elements
    new_of = np.full(m, -1, dtype=np.int64)  # the wound records of the surviving elements, renumbered
    new_of[keep] = np.arange(keep.size)
    stay = new_of[first.wound.element] >= 0
    wound = {f.name: getattr(first.wound, f.name)[stay] for f in fields(Wound)}
    wound["element"] = new_of[wound["element"]]
    wound["nodes"] = np.asarray(second.mesh.t)[:, wound["element"]].T.copy()
    regions = {new: first.regions[old] for new, old in enumerate(keep.tolist()) if old in first.regions}
    return replace(first, mesh=second.mesh, parent=first.parent[second.parent], elements=first.elements[keep],
                   weights=first.weights[keep], regions=regions, wound=Wound(**wound),
                   material=node_material(second.mesh, regions))


# --- what to draw ---
@dataclass(frozen=True, eq=False)
class Picture:
    """What to draw of a mesh whose elements may fill only part of their triangle: its material polygons, split into
    triangles (drawing both copies of a cut triangle whole would paint material across the cut). Drawn point ``j`` sits
    at ``sum_a coefficients[a, j] * x[:, nodes[a, j]]`` (``nodes``, ``coefficients``: (3, k)): it follows P1."""

    nodes: np.ndarray
    coefficients: np.ndarray
    triangles: np.ndarray  #: (3, q) int: the filled triangles, by drawn point
    element: np.ndarray  #: (q,) int: the element of each drawn triangle (to colour it by a per-element value)
    edges: np.ndarray  #: (2, r) int: lines to draw (element edges, material outlines, cracks), by drawn point
    plain: bool  #: no element is cut: the drawn points are the nodes themselves (``points(x) is x``)

    def points(self, x) -> np.ndarray:
        """The drawn points ``(2, k)`` at node positions ``x`` ``(2, n_nodes)``."""
        x = np.asarray(x, dtype=float)
        return x if self.plain else np.einsum("ak,iak->ik", self.coefficients, x[:, self.nodes])


def picture(mesh, regions=None) -> Picture:
    """The :class:`Picture` of ``mesh`` with the material ``regions`` of a cut through elements; of a tetrahedral
    mesh, its surface (:func:`surface`)."""
    if np.shape(mesh.t)[0] == 4:
        return surface(mesh)
    p, t = mesh_arrays(mesh)
    n, m = p.shape[1], t.shape[1]
    regions = {} if regions is None else regions
    whole = np.ones(m, dtype=bool)
    whole[[e for e in regions if 0 <= e < m]] = False
    # the edges of every whole element (each once)
    tw = t[:, whole]
    a, b = tw.ravel(), np.roll(tw, -1, axis=0).ravel()
    pairs = np.unique(np.vstack([np.minimum(a, b), np.maximum(a, b)]), axis=1)
    nodes = np.vstack([np.arange(n), np.zeros(n, np.int64), np.zeros(n, np.int64)])  # every node, as itself
    coefficients = np.vstack([np.ones(n), np.zeros(n), np.zeros(n)])
    if not regions:
        return Picture(nodes, coefficients, t.copy(), np.arange(m), pairs, True)
    pt_nodes, pt_coef = [nodes], [coefficients]
    tris, tri_el, edges = [tw], [np.flatnonzero(whole)], [pairs]
    count = n
    for e, region in sorted(regions.items()):
        for poly in region.polygons:
            tri = np.asarray(_triangulate(poly), dtype=np.int64).reshape(-1, 3).T + count
            tris.append(tri)
            tri_el.append(np.full(tri.shape[1], e, dtype=np.int64))
            ring = np.arange(len(poly)) + count
            edges.append(np.vstack([ring, np.roll(ring, -1)]))
            count += len(poly)
        for _ in region.slits:  # a crack that ends inside the element: drawn as a line
            edges.append(np.array([[count], [count + 1]]))
            count += 2
        local = np.concatenate(list(region.polygons) + list(region.slits))  # the element's drawn points, in order
        pt_nodes.append(np.repeat(t[:, e][:, None], len(local), axis=1))
        pt_coef.append(np.vstack([1.0 - local[:, 0] - local[:, 1], local[:, 0], local[:, 1]]))
    return Picture(np.hstack(pt_nodes), np.hstack(pt_coef), np.hstack(tris), np.concatenate(tri_el),
                   np.hstack(edges), False)


def surface(mesh) -> Picture:
    """The :class:`Picture` of a tetrahedral mesh: its boundary faces, each turned to face outwards (its corners
    counter-clockwise seen from outside) and drawn with the tetrahedron it bounds as its ``element``; the lines are
    the faces' edges. The drawn points are the nodes (``points(x) is x``, ``(3, n)``)."""
    p, t = np.asarray(mesh.p, dtype=float), np.asarray(mesh.t, dtype=np.int64)
    n = p.shape[1]
    boundary = np.asarray(mesh.boundary_facets(), dtype=np.int64)
    faces = np.asarray(mesh.facets, dtype=np.int64)[:, boundary]
    element = np.asarray(mesh.f2t, dtype=np.int64)[0, boundary]
    # the tetrahedron's fourth corner lies behind an outward face
    opposite = t[:, element].sum(axis=0) - faces.sum(axis=0)
    a, b, c, d = (p[:, k] for k in (faces[0], faces[1], faces[2], opposite))
    inward = np.einsum("ik,ik->k", np.cross(b - a, c - a, axis=0), d - a) > 0
    faces[1:, inward] = faces[2:0:-1, inward]
    edges = np.unique(np.sort([faces.ravel(), np.roll(faces, -1, axis=0).ravel()], axis=0), axis=1)
    nodes = np.vstack([np.arange(n), np.zeros(n, np.int64), np.zeros(n, np.int64)])
    coefficients = np.vstack([np.ones(n), np.zeros(n), np.zeros(n)])
    return Picture(nodes, coefficients, faces, element, edges, True)


def _triangulate(poly) -> list:
    """Triangles ``(i, j, k)`` of a simple counter-clockwise polygon ``(k, 2)``, by clipping ears."""
    pts = [tuple(map(float, q)) for q in poly]
    idx = list(range(len(pts)))
    tris = []
    while len(idx) > 3:
        for j in range(len(idx)):
            ia, ib, ic = idx[j - 1], idx[j], idx[(j + 1) % len(idx)]
            (ax, ay), (bx, by), (cx, cy) = pts[ia], pts[ib], pts[ic]
            if cross(bx - ax, by - ay, cx - ax, cy - ay) <= 0.0:
                continue  # a reflex or flat corner is no ear
            if any(cross(bx - ax, by - ay, qx - ax, qy - ay) >= 0.0 and cross(cx - bx, cy - by, qx - bx, qy - by) >= 0.0
                   and cross(ax - cx, ay - cy, qx - cx, qy - cy) >= 0.0
                   for qx, qy in (pts[q] for q in idx if q not in (ia, ib, ic))):
                continue  # another corner inside (or on) the candidate ear
            tris.append((ia, ib, ic))
            idx.pop(j)
            break
        else:  # only flat corners left (points on a line): fan what remains
            tris.extend((idx[0], idx[i], idx[i + 1]) for i in range(1, len(idx) - 1))
            return tris
    tris.append(tuple(idx))
    return tris


# --- points of the material: where a stitch or a probe attaches ---
def _region_distance(region, xi) -> float:
    """How far the local point ``xi`` lies outside the material of ``region`` (0 inside or on its boundary)."""
    best = math.inf
    for poly in region.polygons:
        if winding(xi, poly.tolist()) != 0:
            return 0.0
        for a, b in zip(poly, np.roll(poly, -1, axis=0)):
            d = b - a
            s = min(1.0, max(0.0, float(np.dot(xi - a, d) / max(np.dot(d, d), 1e-300))))
            best = min(best, float(np.hypot(*(a + s * d - xi))))
    return best


def locate(mesh, point, positions=None, regions=None, reach=1e-3):
    """``(element, barycentric (3,))`` of the material holding ``point`` (deformed coordinates) or nearest to it, or
    ``None`` if none is within ``reach`` (in local coordinates: a fraction of a triangle's size); a point just off the
    material (in an open wound) extends the element's P1 map."""
    _, t, x = mesh_at(mesh, positions)
    q = np.asarray(point, dtype=float)
    a, b, c = (x[:, t[k]] for k in range(3))
    d1, d2 = b - a, c - a
    det = d1[0] * d2[1] - d1[1] * d2[0]
    ok = np.abs(det) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        r = q[:, None] - a
        xi = np.where(ok, (r[0] * d2[1] - r[1] * d2[0]) / det, np.inf)
        eta = np.where(ok, (d1[0] * r[1] - d1[1] * r[0]) / det, np.inf)
    outside = np.maximum.reduce([-xi, -eta, xi + eta - 1.0, np.zeros_like(xi)])
    regions = {} if regions is None else regions
    order = np.argsort(outside, kind="stable")
    best, best_d = None, math.inf
    for e in order.tolist():
        if outside[e] > reach or outside[e] >= best_d:
            break
        local = np.array([xi[e], eta[e]])
        d = outside[e] + (_region_distance(regions[e], local) if e in regions else 0.0)
        if d < best_d:
            best, best_d = (e, np.array([1.0 - local.sum(), local[0], local[1]])), d
    return None if best is None or best_d > reach else best


#: A point of the material in a copy lighter than this share of its triangle is carried by a firmer neighbour
FIRM_WEIGHT = 0.25


def firm_anchor(mesh, element, barycentric, positions=None, weights=None, regions=None):
    """``(element, barycentric)`` of a point of the material, moved to a neighbour (sharing a node) carrying at least
    :data:`FIRM_WEIGHT` of its triangle whose material lies nearest, by its P1 map extended (barycentric coordinates
    may be slightly negative): a stitch pulling at a sliver would stretch it (its virtual nodes hold almost nothing)."""
    _, t, x = mesh_at(mesh, positions)
    w = element_weights(weights, t.shape[1])
    best, best_d = (element, np.asarray(barycentric, dtype=float)), math.inf
    if w[element] >= FIRM_WEIGHT:
        return best
    point = x[:, t[:, element]] @ best[1]
    regions = {} if regions is None else regions
    for e in np.flatnonzero(np.isin(t, t[:, element]).any(axis=0) & (w >= FIRM_WEIGHT)).tolist():  # the firm neighbours
        J = x[:, t[1:, e]] - x[:, t[:1, e]]  # the edge vectors from vertex 0, as columns
        if abs(np.linalg.det(J)) <= 0:
            continue
        xi = np.linalg.solve(J, point - x[:, t[0, e]])
        d = _region_distance(regions[e], xi) if e in regions else max(0.0, -xi[0], -xi[1], xi.sum() - 1.0)
        if d < best_d:
            best, best_d = (e, np.array([1.0 - xi.sum(), xi[0], xi[1]])), d
    return best


def carry_points(edit, elements, barycentric, regions=None):
    """The new element of each point of the material (``elements (k,)``, ``barycentric (k, 3)``) after ``edit``, -1
    where it was removed: of the copies of its element, the one whose material (``regions`` of the new mesh) holds it
    (a cut keeps local coordinates)."""
    elements = np.asarray(elements, dtype=np.int64)
    copies = {}
    for new, old in enumerate(np.asarray(edit.elements).tolist()):
        copies.setdefault(old, []).append(new)
    regions = {} if regions is None else regions
    out = np.full(elements.shape, -1, dtype=np.int64)
    for j, (e, w) in enumerate(zip(elements.tolist(), np.asarray(barycentric, dtype=float))):
        if e in copies:  # the first copy nearest to the point
            out[j] = min(copies[e], key=lambda c: _region_distance(regions[c], w[1:]) if c in regions else 0.0)
    return out
