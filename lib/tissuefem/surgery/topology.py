"""Mesh topology operations for virtual surgery: cutting along mesh edges (:func:`incise`, built from
:func:`cut_path` and :func:`duplicate_along_edges`) and removing tissue (:func:`excise`).

A cut duplicates every node on it as often as it separates the node's neighbourhood; an excision deletes whole
triangles. Both return a :class:`MeshEdit` (``parent``: new node -> old node, ``elements``: new element -> old), so
that a per-node field ``u`` carries over as ``u[..., parent]``; the new meshes keep every element's vertex order
(scikit-fem's re-sorting would reorder the triangles along the wound) and their named boundaries.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..engine.contact.surface import cross, segment_distance
from ..engine.meshes import MeshMap
from ..engine.parameters import ParameterError, call_user, check_count, check_indices, show
from .geometry import carry_names, mesh_arrays, mesh_at, new_mesh, pair_keys, polygon_contains, stroke_in_body

__all__ = ["MeshEdit", "duplicate_along_edges", "split_nodes", "cut_path", "incise", "excise", "connected_components"]

#: The 10 in an edge's cost in :func:`cut_path`: a detour of one edge length away costs more than several edges along it
_HUG = 10.0
#: An end of the polyline this close to the boundary (in lengths of the nearest boundary facet) is on it.
_NEAR_BOUNDARY = 0.5


@dataclass(frozen=True, eq=False, kw_only=True)
class MeshEdit(MeshMap):
    """A :class:`~tissuefem.engine.meshes.MeshMap` made by a cut along mesh edges or an excision."""

    #: (2, k) int: old-node pairs of the edges opened, in the order the cut passed them (empty for :func:`excise`)
    cut_edges: np.ndarray


def _node_indices(name: str, value, rows: int, n_nodes: int) -> np.ndarray:
    """``value`` as an int64 array shaped ``(rows, k)`` of node indices in ``[0, n_nodes)`` (integral floats, e.g.
    read from a text file, are accepted): the shape is checked here, the indices by ``check_indices``."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):  # ragged lists
        a = np.asarray(None)
    if a.ndim != 2 or a.shape[0] != rows:
        raise ParameterError(name, f"{name} must be an integer array shaped ({rows}, k), got {show(value)}")
    if a.dtype.kind == "f" and np.all(np.isfinite(a)) and np.all(a == np.round(a)):
        a = a.astype(np.int64)
    return check_indices(name, a.ravel(), n_nodes, "node indices").reshape(a.shape).astype(np.int64)


def duplicate_along_edges(t, n_nodes, edges):
    """Duplicate nodes so that the ``edges`` (2, k) (node pairs of triangle edges, either order, repeats allowed) of
    the triangles ``t`` (3, m, not modified) on ``n_nodes`` nodes open: the core of a cut. Returns ``(new_t, parent)``:
    the triangles in their vertex order with the copies' indices, and the old node of every node (copies appended).

    The triangles round a node on a cut fall into *fans*, the connected components of its corners (triangle, vertex)
    linked across uncut edges, one per side of the wound: where ``j`` cut edges meet, an interior node's ring breaks
    into ``j`` fans, a boundary node's into ``j + 1`` (a crack's tip stays closed; a single interior edge opens
    nothing); :func:`split_nodes` numbers them (the fan with the lowest triangle keeps the node).
    """
    n_nodes = check_count("n_nodes", n_nodes, 0)
    t, edges = _node_indices("t", t, 3, n_nodes), _node_indices("edges", edges, 2, n_nodes)
    m = t.shape[1]
    parent = np.arange(n_nodes, dtype=np.int64)
    if edges.shape[1] == 0:
        return t.copy(), parent

    flat = t.ravel()  # corner -> node: corner i m + e is vertex i of triangle e
    ci = np.arange(3 * m, dtype=np.int64)
    cj = np.roll(ci, -m)  # ci -> cj: the edges (0, 1), (1, 2), (2, 0) of every triangle
    a, b = flat[ci], flat[cj]
    key = pair_keys(np.stack([a, b]), n_nodes)
    cut_key = pair_keys(edges, n_nodes)
    known = np.isin(cut_key, key)
    if not np.all(known):
        bad = int(np.flatnonzero(~known)[0])
        raise ValueError(f"edges: ({edges[0, bad]}, {edges[1, bad]}) (column {bad}) is not an edge of the mesh "
                         f"(no triangle has both nodes)")

    is_cut_node = np.isin(np.arange(n_nodes), edges)

    # each occurrence of an edge paired with the next of the same key (on a manifold mesh: the two triangles of an
    # interior edge); uncut pairs glue the corners of their two shared nodes
    order = np.argsort(key, kind="stable")
    ks = key[order]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    keep = ~np.isin(ks[same], cut_key)
    o1, o2 = order[same][keep], order[same + 1][keep]
    links = []
    for end in (a, b):
        node = end[o1]
        # the corner of `node` in each of the two triangles
        c1 = np.where(a[o1] == node, ci[o1], cj[o1])
        c2 = np.where(a[o2] == node, ci[o2], cj[o2])
        on_cut = is_cut_node[node]
        links.append(np.stack([c1[on_cut], c2[on_cut]]))
    links = np.concatenate(links, axis=1)

    # the corners of cut nodes only (a few per cut node), each fan of them a node
    corners = np.flatnonzero(is_cut_node[flat])
    local = np.full(flat.size, -1, dtype=np.int64)
    local[corners] = np.arange(corners.size)
    new_flat = flat.copy()
    new_flat[corners], extra = split_nodes(flat[corners], corners % m, local[links], n_nodes)
    return new_flat.reshape(3, m), np.concatenate([parent, extra])


def split_nodes(node, owner, links, n_nodes):
    """The nodes of corners (element, vertex) at the old nodes ``node`` (c,), joined by ``links`` (2, k) (pairs of
    indices into the corners, each of one node) into classes: ``(new node of every corner (c,), old node of every
    new node)``. Of the classes at a node, the one with the lowest ``owner`` (c,) (the element or piece of a corner)
    keeps it; the others get nodes ``n_nodes, n_nodes + 1, ...`` in the order (node, lowest owner)."""
    graph = sp.coo_matrix((np.ones(links.shape[1]), (links[0], links[1])), shape=(node.size, node.size))
    n_classes, label = csgraph.connected_components(graph, directed=False)
    class_node = np.empty(n_classes, dtype=np.int64)  # links only join corners of one node
    class_node[label] = node
    first = np.full(n_classes, np.iinfo(np.int64).max)
    np.minimum.at(first, label, owner)
    by_node = np.lexsort((first, class_node))
    sorted_node = class_node[by_node]
    extra = np.r_[False, sorted_node[1:] == sorted_node[:-1]]  # the first class of each node keeps it
    new_index = np.empty(n_classes, dtype=np.int64)
    new_index[by_node] = np.where(extra, n_nodes + np.cumsum(extra) - 1, sorted_node)
    return new_index[label], sorted_node[extra]


# --- pieces, picking nodes ---
def connected_components(t, n_nodes, links=None):
    """The pieces of a mesh ``t (3, m)`` (tetrahedra: ``(4, m)``) with ``n_nodes`` nodes, joined also by the node
    pairs ``links (2, k)``: ``(n_pieces, labels (n_nodes,))``, numbered in the order of their lowest node (an unused
    node is a piece)."""
    n_nodes = check_count("n_nodes", n_nodes, 0)
    t = _node_indices("t", t, 4 if isinstance(t, np.ndarray) and t.ndim == 2 and t.shape[0] == 4 else 3, n_nodes)
    rows, cols = t[:-1].ravel(), t[1:].ravel()  # a chain through the corners of each element suffices
    if links is not None:
        rows, cols = np.concatenate([rows, links[0]]), np.concatenate([cols, links[1]])
    graph = sp.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n_nodes, n_nodes))
    n, labels = csgraph.connected_components(graph, directed=False)
    return int(n), labels.astype(np.int64)


# --- the path of a cut ---
def _boundary_snap(x, t, bfacets, end, towards):
    """If ``end`` lies outside or within half a facet of the boundary ``bfacets`` (2, nb), the boundary node where a
    polyline from it towards ``towards`` enters the body (the nearer end of the first facet crossed, or the boundary
    node nearest to ``end``); else ``None``."""
    A, B = x[:, bfacets[0]], x[:, bfacets[1]]
    dist = segment_distance(end[:, None], A, B)
    nearest = int(np.argmin(dist))
    length = np.hypot(*(B[:, nearest] - A[:, nearest]))
    # inside (or on) a triangle where its three sub-areas at ``end`` have the sign of the whole (either orientation)
    a, b, c, q = x[:, t[0]], x[:, t[1]], x[:, t[2]], end[:, None]
    area = cross(b - a, c - a)
    tol, sign = 1e-12 * np.abs(area), np.sign(area)
    outside = not np.any((sign * cross(b - q, c - q) >= -tol) & (sign * cross(q - a, c - a) >= -tol)
                         & (sign * cross(b - a, q - a) >= -tol) & (area != 0.0))
    if not outside and dist[nearest] >= _NEAR_BOUNDARY * length:
        return None
    if outside:  # where does end -> towards cross the boundary first?
        d, e = towards - end, B - A
        denom = cross(d, e)
        w = A - end[:, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            s = cross(w, e) / denom  # along the polyline
            r = cross(w, d) / denom  # along the facet
        hit = (denom != 0.0) & (s >= 0.0) & (s <= 1.0) & (r >= 0.0) & (r <= 1.0)
        if np.any(hit):
            f = np.flatnonzero(hit)[np.argmin(s[hit])]
            q = end + s[f] * d
            na, nb = bfacets[0, f], bfacets[1, f]
            return int(na if np.hypot(*(x[:, na] - q)) <= np.hypot(*(x[:, nb] - q)) else nb)
    bnodes = np.unique(bfacets)
    return int(bnodes[np.argmin(np.hypot(x[0, bnodes] - end[0], x[1, bnodes] - end[1]))])


def cut_path(mesh, polyline, positions=None) -> np.ndarray:
    """The path of mesh nodes (int64) that follows a ``polyline`` (k, 2), k >= 2, drawn at ``positions``: consecutive
    nodes are the ends of a mesh edge, or two copies of one point (crossing an old wound).

    Each vertex of the polyline (first clipped to the body, :func:`~.geometry.clip_to_body`) snaps to the nearest
    node; an *end* outside the body (or within half an edge of its boundary) to the boundary node where it enters, so
    a stroke across the body cuts it through. Between them runs a shortest path (Dijkstra) over the mesh edges, each
    costing ``length * (1 + 10 d / h)`` (``d``: the mean distance of its nodes from the drawn segment, ``h``: the
    median edge length): it hugs the line within about one element. ``ValueError`` for a bad polyline, one that misses
    the body, collapses to a single node, or joins two unconnected pieces.
    """
    p, t, x = mesh_at(mesh, positions)
    pts = stroke_in_body("polyline", polyline, x, t)[0]
    n = p.shape[1]
    facets = np.asarray(mesh.facets, dtype=np.int64)
    bfacets = facets[:, np.asarray(mesh.boundary_facets(), dtype=np.int64)]
    # the graph the path runs on: the mesh edges (facets first) plus links from every copy of a material point to
    # its lowest node (the nodes sorted by place, then index)
    used = np.unique(t)
    _, first, group = np.unique(p[:, used].T, axis=0, return_index=True, return_inverse=True)
    order = np.lexsort((used, group.ravel()))
    head, copy = used[first][group.ravel()][order], used[order]
    ends = np.concatenate([facets, np.stack([head[head != copy], copy[head != copy]])], axis=1)
    length = np.hypot(*(x[:, ends[0]] - x[:, ends[1]]))
    h = float(np.median(length[: facets.shape[1]])) or 1.0
    # every polyline vertex snaps to the nearest node, an end possibly to the boundary (and then the path ends there)
    snapped = [int(used[np.argmin(np.hypot(x[0, used] - q[0], x[1, used] - q[1]))]) for q in pts]
    at_boundary = [_boundary_snap(x, t, bfacets, pts[0], pts[1]), _boundary_snap(x, t, bfacets, pts[-1], pts[-2])]
    for i, node in zip((0, -1), at_boundary):
        if node is not None:
            snapped[i] = node

    path = [snapped[0]]
    for k in range(len(pts) - 1):
        src, dst = path[-1], snapped[k + 1]
        if src == dst:
            continue
        (ax, ay), (bx, by) = pts[k], pts[k + 1]
        d = segment_distance(x, pts[k][:, None], pts[k + 1][:, None])
        cost = length * (1.0 + _HUG * 0.5 * (d[ends[0]] + d[ends[1]]) / h)
        # a floor keeps zero-length links (copies at the same place) in the graph
        cost = np.maximum(cost, 1e-12 * h)
        graph = sp.csr_matrix((np.concatenate([cost, cost]), (np.r_[ends[0], ends[1]], np.r_[ends[1], ends[0]])),
                              shape=(n, n))
        dist, pred = csgraph.dijkstra(graph, directed=True, indices=src, return_predecessors=True)
        if not np.isfinite(dist[dst]):
            raise ValueError(f"polyline segment {k} ({ax:g}, {ay:g}) -> ({bx:g}, {by:g}) joins nodes {src} and {dst}, "
                             f"which lie on pieces of the mesh that are not connected")
        leg = [dst]
        while leg[-1] != src:
            leg.append(int(pred[leg[-1]]))
        path.extend(leg[-2::-1])

    # an end snapped to the boundary may reach it at a neighbouring boundary node and walk along the boundary to the
    # snapped one: such steps open nothing, the cut ends where it first meets the boundary
    on_boundary = set(pair_keys(bfacets, n).tolist())
    while at_boundary[0] is not None and len(path) > 2 and min(path[:2]) * n + max(path[:2]) in on_boundary:
        path.pop(0)
    while at_boundary[1] is not None and len(path) > 2 and min(path[-2:]) * n + max(path[-2:]) in on_boundary:
        path.pop()
    if len(path) < 2:
        raise ValueError(f"polyline collapses to the single node {path[0]}: draw a longer stroke "
                         f"(the mesh edges are about {h:.3g} long)")
    return np.asarray(path, dtype=np.int64)


def incise(mesh, polyline, positions=None) -> MeshEdit:
    """Cut ``mesh`` (not modified) along the path of mesh edges (:func:`cut_path`) of a drawn polyline, opened by
    :func:`duplicate_along_edges` (a crack's tip stays closed). Returns a :class:`MeshEdit` (reference coordinates,
    ``elements`` is ``arange(m)``) whose wound's faces are named ``"cut"``. ``ValueError`` for a bad polyline, or one
    that opens no edge (along the boundary, or a single edge inside the body)."""
    p, t = mesh_arrays(mesh)
    n = p.shape[1]
    path = cut_path(mesh, polyline, positions)
    pairs = np.stack([path[:-1], path[1:]])
    interior_keys = pair_keys(np.asarray(mesh.facets, dtype=np.int64), n)[np.asarray(mesh.f2t)[1] >= 0]
    # steps between copies of one point (crossing an old wound) are not edges; edges on the boundary are already open
    pairs = pairs[:, np.isin(pair_keys(pairs, n), interior_keys)]
    new_t, parent = duplicate_along_edges(t, n, pairs)
    elements = np.arange(t.shape[1], dtype=np.int64)
    plain = new_mesh(p[:, parent], new_t)
    cut = carry_names(mesh, plain, parent, elements, name="cut")
    # the path's edges that actually opened, once each, in the order of the path (plain and cut share their facets)
    opened_keys = pair_keys(parent[np.asarray(plain.facets, dtype=np.int64)[:, cut.boundaries["cut"]]], n)
    keys = pair_keys(pairs, n)
    first = np.sort(np.unique(keys, return_index=True)[1])
    cut_edges = pairs[:, first[np.isin(keys[first], opened_keys)]]
    if cut_edges.shape[1] == 0:
        raise ValueError(f"polyline opens no edge: its path {path.tolist()} runs along the boundary or is a single "
                         f"interior edge (a crack needs at least one node strictly inside it)")
    return MeshEdit(mesh=cut, parent=parent, elements=elements, cut_edges=cut_edges, n_old_nodes=n,
                    n_old_elements=t.shape[1])


def excise(mesh, region, positions=None) -> MeshEdit:
    """Remove the triangles of ``mesh`` (not modified) whose centroid (at ``positions``) lies in ``region``: a polygon
    (k, 2), k >= 3 (even-odd rule; first clipped to the body, :func:`~.geometry.clip_to_body`), or a function
    ``centroids (2, m) -> bool (m,)``. Returns a :class:`MeshEdit`: unused nodes dropped, the rest and the triangles
    kept in order, the rim named ``"defect"``. ``ValueError`` for a bad polygon or mask, or one that selects no element
    or every element."""
    p, t, x = mesh_at(mesh, positions)
    m = t.shape[1]
    centroids = x[:, t].mean(axis=1)
    if callable(region):
        remove = np.asarray(call_user("region", "function of the centroids", region, centroids.copy()))
        if remove.shape != (m,) or remove.dtype != bool:
            raise ValueError(f"region, as a function of the centroids (2, m), must return a bool array shaped "
                             f"({m},), got dtype {remove.dtype} shape {remove.shape}")
    else:
        remove = polygon_contains(stroke_in_body("region", region, x, t, closed=True)[0], centroids.T)
    if not remove.any():
        raise ValueError("region selects no element (no triangle centroid lies inside it)")
    if remove.all():
        raise ValueError(f"region selects every element (all {m}): nothing would be left")
    elements = np.flatnonzero(~remove).astype(np.int64)
    parent, new_t = np.unique(t[:, elements], return_inverse=True)  # increasing: the old order, compacted
    new_t = new_t.reshape(3, -1).astype(np.int64)
    defect = carry_names(mesh, new_mesh(p[:, parent], new_t), parent, elements, name="defect")
    return MeshEdit(mesh=defect, parent=parent, elements=elements, cut_edges=np.zeros((2, 0), dtype=np.int64),
                    n_old_nodes=p.shape[1], n_old_elements=m)
