"""Which (point, segment) pairs may touch: their signed gaps, the neighbourhoods left out, owners, the Verlet list.

With ``e = y_b - y_a``, ``w = y_p - y_a``, ``t = w . e / |e|^2``, the gap of a point ``p`` to a segment ``(a, b)`` is
``sigma = cross(w, e) / |e|`` for ``0 < t < 1``; else the distance to that end ``v``, negative when
``(y_p - y_v) . n_v < 0`` with ``n_v`` the corner's *pseudonormal* (the mean of its segments' normals): the signed
distance to a polygon [3]. Of each run of segments within ``d^`` of a point only the nearest, its *owner*, counts, so
the gap stays continuous where the nearest feature changes. That sign holds where the corner is the nearest feature of
the surface; a point nearer to a segment next to ``s`` that lies in its own neighbourhood (below: never paired with
it, one of its own segments aside) has that stretch as its nearest feature, and ``s`` does not press it (the gap is
taken as ``+distance``). Without this rule a lip crumpled or folded through 180 degrees flips a corner's sign next to
the point's own stretch, where the gap is small: the energy jumps there and Newton's line search stops (the gap can
still jump where the point lies equally near both, rarely).

A point is not paired with segments less than ``2 d^`` from it along the rest surface, else a cut's lip would touch
itself once it bends; the walk stops at a crack tip (a corner turned back into the material), where each lip's first
point is paired with the other's first segment (a *hinge*) while the corner turns by over 90 degrees. Coinciding lips
are at ``sigma = 0``: in contact, without force. Where the surface lies closer than ``d^`` to itself at rest, a
point's wall is moved by its *rest offset* ``o_p``. A pair whose point is behind its wall when a step *starts* is
ignored until the step ends (the far side of a thin body, tissue dragged through tissue).

The broad phase is a Verlet list [4] of the pairs closer than ``reach + skin`` (a k-d tree of the points and the
segments' midpoints), valid while the points move less than ``skin / 2`` relative to each other. A pair's *key* is
``p * n_segments + s``; lists are sorted by it.
"""

import numpy as np

from .surface import cross, dot, segment_distance


def _corner_normal(e_in, e_out, fold):
    """The pseudonormal of a corner: the mean of its segments' normals (folded right back: ``fold`` along ``e_in``)."""
    m = np.stack([e_in[1], -e_in[0]]) / np.sqrt(dot(e_in, e_in)) + \
        np.stack([e_out[1], -e_out[0]]) / np.sqrt(dot(e_out, e_out))
    size = np.sqrt(dot(m, m))
    folded = size < 1e-9
    return np.where(folded, fold * e_in / np.sqrt(dot(e_in, e_in)), m / np.where(folded, 1.0, size))


def find_keys(sorted_keys, keys) -> np.ndarray:
    """Where each of ``keys`` is in ``sorted_keys`` (-1: not there)."""
    if sorted_keys.size == 0:
        return np.full(np.shape(keys), -1, dtype=np.intp)
    at = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return np.where(sorted_keys[at] == keys, at, -1)


def spread(dY) -> float:
    """``max_i |dY_i - c|``, ``c`` the centre of the moves' bounding box: no distance changes by over twice this."""
    if dY.shape[1] == 0:
        return 0.0
    c = 0.5 * (dY.max(axis=1) + dY.min(axis=1))
    return float(np.max(np.hypot(*(dY - c[:, None]))))


def _arc_neighbourhood(surface, length, reach, stops) -> np.ndarray:
    """The points each segment is not paired with, (n_segments, k) padded with -1: its ends, its neighbours' far ends,
    and every point less than ``reach`` from it along the surface at rest (not round the corners ending ``stops``)."""
    seg = surface.segments
    n_seg = seg.shape[1]
    stop_after = np.zeros(n_seg, dtype=bool)  # no walking from this segment to its next
    stop_after[np.asarray(stops, dtype=np.intp)] = True
    stop_before = stop_after[np.maximum(surface.previous, 0)] & (surface.previous >= 0)  # ... to its previous
    columns = [surface.neighbourhood]
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


class CandidatePairs:
    """The pairs of a surface that may touch (rest points ``Y``, segment lengths, ``d^``, the list's margin ``skin``).
    ``offset``, ``skins``, ``reach``: rest offsets, walls ``d^ + o_p``, the deepest; ``excluded``: the points each
    segment is never paired with; ``fold``: where a corner folded right back opens; ``hinge``: the hinges that count;
    the list ``p``, ``s``, ``keys`` (built at ``points``); ``ignored``, ``hinge_ignored``: deep at ``step_start``;
    ``positions``: each pair's Hessian entries in the model's pattern (list, then hinges; -1 until looked up)."""

    def __init__(self, surface, Y, rest_length, distance, skin):
        self.surface, self.rest_length, self.skin = surface, rest_length, skin
        n_seg, (a, b) = surface.n_segments, surface.segments
        self.n_local = (6 * surface.nodes.shape[1]) ** 2  # Hessian entries of a pair: 3 points of k nodes, 2 dofs
        e_s = Y[:, b] - Y[:, a]
        e_n = e_s[:, np.maximum(surface.next, 0)]  # the next segment's
        turn, size = cross(e_s, e_n), np.hypot(*e_s) * np.hypot(*e_n)
        # a folded corner opens backwards if it turned into the material
        self.fold = np.where((surface.next >= 0) & (turn <= 1e-9 * size), -1.0, 1.0)
        # closing a corner that turns back into the material at rest (a crack tip, a notch) is contact; closing a
        # convex corner crushes the material between
        turn, size, inner = turn[surface.hinge_corner], size[surface.hinge_corner], dot(e_s, e_n)[surface.hinge_corner]
        self.hinge = np.flatnonzero((turn < -1e-9 * size) | ((np.abs(turn) <= 1e-9 * size) & (inner < 0)))
        self.excluded = _arc_neighbourhood(surface, rest_length, 2.0 * distance, surface.hinge_corner[self.hinge])
        hp, hs = self.hinge_pairs(slice(None))
        self.hinge_keys = hp.astype(np.int64) * max(n_seg, 1) + hs
        self.hinge_ignored = np.zeros(self.hinge_keys.size, dtype=bool)
        self.step_start, self.refreshes, self.keys, self.positions = None, 0, None, None
        self.offset = np.zeros(surface.n_points)  # the rest offsets: the reference configuration touches nothing
        for _ in range(8):
            p, s = self.query(Y, distance + float(self.offset.max(initial=0.0)))
            p, s = np.concatenate([p, hp]), np.concatenate([s, hs])
            _, gap, sigma = self.classify(lambda i: Y[:, i], p, s)
            # (two lips that coincide are at sigma = 0 up to round-off: they touch, they are not inside)
            inside = (gap < distance + self.offset[p]) & (sigma < -self.offset[p] - 1e-9 * rest_length[s])
            if not np.any(inside):
                break
            np.maximum.at(self.offset, p[inside], -sigma[inside])
        self.skins = distance + self.offset
        self.reach = float(self.skins.max(initial=distance))  # no pair is in contact farther apart
        self.refresh(Y)

    def query(self, Y, reach):
        """``(p, s)``: the pairs not excluded with the point within ``half length + reach`` of the segment's midpoint
        at the points ``Y``, sorted by key."""
        seg = self.surface.segments
        n_seg = seg.shape[1]
        if n_seg == 0 or self.surface.n_points == 0:
            return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
        ya, yb = Y[:, seg[0]], Y[:, seg[1]]
        radius = 0.5 * np.hypot(*(yb - ya)) + reach
        from scipy.spatial import cKDTree  # deferred: only contact needs it, and it is slow to import

        # every (midpoint, point) pair within the largest radius, then each segment's own radius
        near = cKDTree((0.5 * (ya + yb)).T).sparse_distance_matrix(cKDTree(Y.T), float(radius.max()),
                                                                   output_type="ndarray")
        s, p = near["i"].astype(np.intp), near["j"].astype(np.intp)
        keep = (near["v"] <= radius[s]) & np.all(self.excluded[s] != p[:, None], axis=1)
        p, s = p[keep], s[keep]
        order = np.argsort(p.astype(np.int64) * n_seg + s)
        return p[order], s[order]

    def classify(self, at, p, s):
        """``(kind, distance, sigma)`` of the pairs ``(p, s)``, ``at(i)`` giving the coordinates (2, m) of the points
        ``i`` of each pair: the feature nearest the point (1 the interior, 2 the start ``a``, 3 the end ``b``), how far,
        and the signed gap. A segment collapsed to a point (an element crushed flat) gives NaN: no contact."""
        seg, prev, nxt = self.surface.segments, self.surface.previous[s], self.surface.next[s]
        yp, ya, yb = at(p), at(seg[0, s]), at(seg[1, s])
        y_before, y_after = at(seg[0, np.maximum(prev, 0)]), at(seg[1, np.maximum(nxt, 0)])
        with np.errstate(invalid="ignore", divide="ignore"):
            e, w, wb = yb - ya, yp - ya, yp - yb
            L = np.sqrt(dot(e, e))
            t = dot(w, e) / (L * L)
            g = cross(w, e) / L
            r_a, r_b = np.sqrt(dot(w, w)), np.sqrt(dot(wb, wb))
            side_a = dot(w, _corner_normal(np.where(prev >= 0, ya - y_before, e), e, self.fold[np.maximum(prev, 0)]))
            side_b = dot(wb, _corner_normal(e, np.where(nxt >= 0, y_after - yb, e), self.fold[s]))
            kind = np.where(t <= 0, 2, np.where(t >= 1, 3, 1))
            distance = np.where(kind == 1, np.abs(g), np.where(kind == 2, r_a, r_b))
            sigma = np.where(kind == 1, g, np.where(kind == 2, np.where(side_a < 0, -r_a, r_a),
                                                    np.where(side_b < 0, -r_b, r_b)))
            sigma = np.where((sigma < 0) & self.neighbour_nearer(at, p, s, distance, own=True), distance, sigma)
        return kind, distance, sigma

    def owners(self, p, s, keys, distance):
        """Which of the pairs own their point: the nearest segment of each run of consecutive segments that are all
        within ``d^`` of the point (ties to the lower key). ``keys`` must be unique."""
        n_seg = max(self.surface.n_segments, 1)
        order = np.argsort(keys)
        k, pp, ss = keys[order], p[order], s[order]
        prev, nxt = self.surface.previous[ss], self.surface.next[ss]
        links = [np.where(prev >= 0, find_keys(k, pp.astype(np.int64) * n_seg + prev), -1),
                 np.where(nxt >= 0, find_keys(k, pp.astype(np.int64) * n_seg + nxt), -1)]
        best_d, best_k = distance[order].copy(), k.copy()
        for _ in range(k.size):  # spread the run's nearest along it, one segment per sweep
            changed = False
            for link in links:
                d_n, k_n = best_d[np.maximum(link, 0)], best_k[np.maximum(link, 0)]  # (masked below where -1)
                better = (link >= 0) & ((d_n < best_d) | ((d_n == best_d) & (k_n < best_k)))
                if np.any(better):
                    best_d[better], best_k[better] = d_n[better], k_n[better]
                    changed = True
            if not changed:
                break
        owner = np.empty(k.size, dtype=bool)
        owner[order] = best_k == k
        return owner

    def neighbour_nearer(self, at, p, s, depth, check=True, own=False):
        """Which points ``p`` (where ``check``) lie nearer than ``depth`` to a neighbour of their segment ``s``: one
        they may meet (not excluded for ``p``), or with ``own`` one in their own neighbourhood that is not one of
        their own segments (that stretch is then their nearest feature, so ``s`` does not press them). ``at(i)``:
        the coordinates (2, m) of the points ``i`` of each pair."""
        seg, near = self.surface.segments, np.zeros(p.size, dtype=bool)
        for neighbour in (self.surface.previous[s], self.surface.next[s]):
            nb = np.maximum(neighbour, 0)
            excluded = np.any(self.excluded[nb] == p[:, None], axis=1)
            fits = excluded & (seg[0, nb] != p) & (seg[1, nb] != p) if own else ~excluded
            fits &= check & (neighbour >= 0)
            if np.any(fits):
                near |= fits & (segment_distance(at(p), at(seg[0, nb]), at(seg[1, nb])) < depth)
        return near

    def deep_at_start(self, p, s) -> np.ndarray:
        """Which pairs had their point deeper than its wall behind the segment (and its neighbours) at the start."""
        if self.step_start is None or p.size == 0:
            return np.zeros(p.size, dtype=bool)
        Y = self.step_start
        _, _, sigma = self.classify(lambda i: Y[:, i], p, s)
        deep = sigma <= -self.skins[p]
        return deep & ~self.neighbour_nearer(lambda i: Y[:, i], p, s, self.skins[p], deep)

    def refresh(self, Y) -> None:
        """Rebuild the list at the points ``Y``, keeping the positions found for pairs that stay in it."""
        old_keys, old_positions = self.keys, self.positions
        self.p, self.s = self.query(Y, self.reach + self.skin)
        self.keys = self.p.astype(np.int64) * max(self.surface.n_segments, 1) + self.s
        self.points, self.refreshes = Y.copy(), self.refreshes + 1
        self.ignored = self.deep_at_start(self.p, self.s)
        self.positions = np.full((self.keys.size + self.hinge_keys.size, self.n_local), -1, dtype=np.intp)
        if old_keys is not None:
            self.positions[self.keys.size:] = old_positions[old_keys.size:]  # the hinges'
            at = find_keys(old_keys, self.keys)
            same = np.flatnonzero(at >= 0)
            self.positions[same] = old_positions[at[same]]

    def ensure(self, Y) -> None:
        """Refresh the list if the points moved by over ``skin / 2`` relative to each other (else no pair out of it,
        farther than ``reach + skin`` apart, came closer than ``reach``)."""
        if spread(Y - self.points) > 0.5 * self.skin:
            self.refresh(Y)

    def sharp_hinges(self, Y) -> np.ndarray:
        """Indices (into ``hinge``) of the hinges at corners turning by over 90 degrees at ``Y`` (the others cannot
        touch: the point projects before the segment)."""
        seg, into = self.surface.segments, self.surface.hinge_corner[self.hinge]
        out = self.surface.next[into]
        return np.flatnonzero(dot(Y[:, seg[1, into]] - Y[:, seg[0, into]], Y[:, seg[1, out]] - Y[:, seg[0, out]]) < 0)

    def hinge_pairs(self, hinges):
        """``(p, s)`` of the hinges ``hinges`` (indices into ``hinge``)."""
        return self.surface.hinge_points[self.hinge[hinges]], self.surface.hinge_segments[self.hinge[hinges]]

    def current(self, Y):
        """``(p, s, keys, ignored, rows)`` of the list and the sharp hinges at ``Y`` (``rows``: in ``positions``)."""
        hinges = self.sharp_hinges(Y)
        rows = np.arange(self.keys.size)
        if hinges.size == 0:
            return self.p, self.s, self.keys, self.ignored, rows
        hinge = (*self.hinge_pairs(hinges), self.hinge_keys[hinges], self.hinge_ignored[hinges], rows.size + hinges)
        return tuple(np.concatenate([a, b]) for a, b in zip((self.p, self.s, self.keys, self.ignored, rows), hinge))

    def start_step(self, Y) -> None:
        """A step starts at ``Y``: a fresh list, the pairs deep there ignored."""
        self.step_start = Y.copy()
        self.refresh(Y)
        self.hinge_ignored = self.deep_at_start(*self.hinge_pairs(slice(None)))

    def end_step(self) -> None:
        self.step_start = None
        self.ignored = np.zeros(self.keys.size, dtype=bool)
        self.hinge_ignored[:] = False
