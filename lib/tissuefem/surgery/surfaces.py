"""The contact surface of a cut body: where its material ends, outer boundary and wound lips alike.

For a plain mesh, and after :func:`~tissuefem.surgery.topology.incise`, that is the mesh's boundary. After
:func:`~tissuefem.surgery.element_cuts.cut_through` it follows the material's polygon sides (material on the left): a
side *inside* a triangle is a wound's lip; a side *on* a triangle's edge is surface except where material across that
edge is joined to it (same nodes, same part of the edge touched, not severed). The ends are barycentric combinations
of an element's nodes; the same combination seen from two elements is one point, so the pieces close into loops.
"""

from __future__ import annotations

import numpy as np
from skfem import MeshTri

from ..engine.contact import ContactSurface
from ..engine.meshes import signed_areas
from ..engine.parameters import ParameterError
from .geometry import (EPS, WHOLE, check_regions, edge_intervals, edge_point, edges_of, element_edges,
                       intersect_intervals, mesh_arrays, merge_intervals, pair_keys, reversed_intervals,
                       subtract_intervals)

__all__ = ["contact_surface"]


def contact_surface(mesh, weights=None, regions=None) -> ContactSurface:
    """The surface of the material of ``mesh`` with the ``weights`` and ``regions`` of a cut through elements (without
    them: the mesh's boundary), material on the left of each segment; the wound's lips are flagged (sides inside a
    triangle, severed parts of edges, facets named ``"cut"``)."""
    if not isinstance(mesh, MeshTri):  # its facets and boundaries are read below
        raise ParameterError("mesh", f"mesh must be a triangle mesh (a MeshTri), got {type(mesh).__name__}")
    p, t = mesh_arrays(mesh)
    n, m = p.shape[1], t.shape[1]
    regions, _ = check_regions(regions, weights, m)
    if not regions:
        return ContactSurface.from_mesh(mesh)
    key, side = element_edges(p, t)  # edge k of element e: nodes t[k], t[k+1]; side of the edge e lies on
    # the node pair and the side as one number; the edges there by flat index k m + e (plain numbers: few objects)
    here, there = (key * 2 + (side > 0)).ravel().tolist(), (key * 2 + (side < 0)).ravel().tolist()
    by_edge = {}
    for i, edge in enumerate(here):
        by_edge.setdefault(edge, []).append(i)
    key = key.tolist()
    cut = np.asarray((mesh.boundaries or {}).get("cut", []), dtype=np.intp)
    cut_facets = set(pair_keys(np.asarray(mesh.facets)[:, cut], n).tolist())

    def joinable(e):  # the parts of each local edge the material of e touches, less what is severed
        return regions[e].touch if e in regions else WHOLE.touch

    pieces = []  # (element, local point a, local point b, wound?) with the material on the left in local coordinates
    for e in range(m):
        touched = edge_intervals(regions[e].sides()) if e in regions else WHOLE.touch  # severed or not
        for k in range(3):
            kk = key[k][e]
            across = by_edge.get(there[k * m + e], ())  # the same node pair, the other side
            if across and e not in regions and all(i % m not in regions for i in across):
                continue  # two whole elements share this edge: inside the material
            reach = []
            for l, f in (divmod(i, m) for i in across):  # f may run the edge the other way
                reach += joinable(f)[l] if int(t[l, f]) == int(t[k, e]) else reversed_intervals(joinable(f)[l])
            joined = intersect_intervals(joinable(e)[k], merge_intervals(reach))
            for lo, hi in subtract_intervals(touched[k], joined):  # a lip where it is on a wound or severed
                severed = bool(subtract_intervals([(lo, hi)], joinable(e)[k]))
                pieces.append((e, edge_point(k, lo), edge_point(k, hi), kk in cut_facets or severed))
    for e, r in regions.items():
        for a, b in r.sides():
            if set(edges_of(a)) & set(edges_of(b)):
                continue  # on an edge of the triangle: done above
            pieces.append((e, (float(a[0]), float(a[1])), (float(b[0]), float(b[1])), True))
    return _assemble(pieces, t, signed_areas(mesh), n)


def _assemble(pieces, t, area, n) -> ContactSurface:
    """Points (merged where two elements see the same combination of nodes) and oriented segments."""
    element = np.array([e for e, _, _, _ in pieces])
    local = np.array([end for _, a, b, _ in pieces for end in (a, b)], dtype=float)  # per piece end
    lam = np.stack([1.0 - local[:, 0] - local[:, 1], local[:, 0], local[:, 1]], axis=1)
    lam[np.abs(lam) < 1e-12] = 0.0
    nodes = np.repeat(t[:, element].T, 2, axis=0).astype(np.int64)
    weights = lam / lam.sum(axis=1, keepdims=True)
    # canonical form: nodes with weight, sorted by node; unused slots point at the first node with weight 0
    weights = np.where(weights > 0, weights, 0.0)
    sort_key = np.where(weights > 0, nodes, n + np.arange(3))
    order = np.argsort(sort_key, axis=1)
    nodes, weights = np.take_along_axis(nodes, order, axis=1), np.take_along_axis(weights, order, axis=1)
    nodes = np.where(weights > 0, nodes, nodes[:, :1])
    used = weights > 0
    # merge the same combination seen from several elements (the weights agree within EPS, as local coordinates do)
    count = used.sum(axis=1)
    tag = np.where(used, nodes, -1)
    order = np.lexsort((weights[:, 2], weights[:, 1], weights[:, 0], tag[:, 2], tag[:, 1], tag[:, 0], count))
    new = np.ones(order.size, dtype=bool)
    new[1:] = (tag[order[1:]] != tag[order[:-1]]).any(axis=1)
    new[1:] |= np.abs(weights[order[1:]] - weights[order[:-1]]).max(axis=1) > EPS
    point = np.empty(order.size, dtype=np.intp)
    point[order] = np.cumsum(new) - 1
    first = np.full(int(new.sum()), -1, dtype=np.intp)  # the first row of every point
    first[point[::-1]] = np.arange(order.size)[::-1]
    width = int(count.max(initial=1))
    ends = point.reshape(-1, 2).T  # (2, pieces)
    segments = np.where(area[element] < 0, ends[::-1], ends)  # a clockwise triangle mirrors "left"
    keep = segments[0] != segments[1]
    wound = np.array([w for _, _, _, w in pieces], dtype=bool)
    return ContactSurface(nodes[first, :width], weights[first, :width], segments[:, keep], n, wound=wound[keep])
