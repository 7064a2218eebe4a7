"""The 2D domains the chapters use, as scikit-fem triangle meshes, a box of tetrahedra (:func:`box`) for 3D, and the
one mesh validator (:func:`check_mesh`, triangles and tetrahedra).

Every generator returns a deterministic, counter-clockwise :class:`skfem.MeshTri` (``sort_t=False``: scikit-fem's
sorting makes the orientation arbitrary) with named boundaries (``mesh.boundaries[name]``). Structured meshes number
nodes row by row: node ``j (nx + 1) + i`` at column ``i``, row ``j``. The limits below are checked before allocating.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from skfem import MeshTet, MeshTri

from .parameters import ParameterError, check_count, check_real, check_real_array, string

__all__ = [
    "edge_lengths", "mesh_size", "mean_edge_length", "rectangle", "mesh_with_about", "fusiform_muscle",
    "fusiform_width", "fusiform_fiber_direction", "fusiform_fiber_field", "flap", "signed_areas", "check_mesh",
    "box", "signed_volumes", "index_list", "MeshMap",
]

#: The most triangles a generated domain (and a mesh passed to :func:`check_mesh`) may have.
MAX_TRIANGLES = 200_000
#: Lengths accepted by the domain generators (closed interval, in the scene's length unit).
SIZE_RANGE = (1e-6, 1e6)
#: The largest aspect ratio of a domain (either way round).
MAX_ASPECT = 1e4
#: Node coordinates must lie within [-COORDINATE_MAX, COORDINATE_MAX].
COORDINATE_MAX = 1e6
#: Triangles with ``|2 area| <= DEGENERATE_TOL * (longest edge)^2`` count as degenerate (as in the assembler).
DEGENERATE_TOL = 1e-12

_DIAGONALS = ("alternate", "right", "left")


def _size(name: str, value) -> float:
    return check_real(name, value, *SIZE_RANGE)


def _check_aspect(name: str, ratio: float) -> None:
    if not (1.0 / MAX_ASPECT <= ratio <= MAX_ASPECT):
        raise ParameterError(name, f"{name} = {ratio:g}: the aspect ratio must lie within [1/{MAX_ASPECT:g}, "
                                   f"{MAX_ASPECT:g}]")


def _check_grid(counts: dict, per_cell: int = 2, diagonal="alternate") -> tuple[int, ...]:
    """The cell counts ``{"nx": nx, ...}`` checked as counts whose ``per_cell nx ny (nz)`` elements (triangles: 2 a
    cell, tetrahedra: 6) are allowed, and a known ``diagonal``."""
    n = tuple(check_count(key, value, 1, MAX_TRIANGLES // per_cell) for key, value in counts.items())
    if per_cell * math.prod(n) > MAX_TRIANGLES:
        raise ParameterError("nx", f"{', '.join(counts)}: {' x '.join(map(str, n))} cells give "
                                   f"{per_cell * math.prod(n)} {'triangles' if per_cell == 2 else 'tetrahedra'}, "
                                   f"more than the {MAX_TRIANGLES} a generated domain may have")
    string("diagonal", diagonal, _DIAGONALS)
    return n


def _sides(sizes, names) -> dict:
    """The boundaries of the box ``[0, sizes[0]] x [0, sizes[1]] (x [0, sizes[2]])``: ``names[2 a]`` where coordinate
    ``a`` is 0, ``names[2 a + 1]`` where it is ``sizes[a]`` (within ``1e-9 sizes[a]``)."""
    def side(axis, value, tol):
        return lambda m: np.abs(m[axis] - value) < tol
    return {names[2 * a + end]: side(a, end * size, 1e-9 * size) for a, size in enumerate(sizes) for end in (0, 1)}


def index_list(idx, limit=10) -> str:
    """Indices for an error message: the first ``limit`` of them and how many in all."""
    idx = np.asarray(idx).ravel()
    shown = ", ".join(str(int(i)) for i in idx[:limit])
    return f"[{shown}{', ...' if idx.size > limit else ''}] ({idx.size} in all)"


def edge_lengths(mesh) -> np.ndarray:
    """The length of every edge of the mesh (a facet in 2D), in reference coordinates."""
    p = np.asarray(mesh.p, dtype=float)
    if p.shape[0] == 3:
        d = p[:, mesh.edges[1]] - p[:, mesh.edges[0]]
        return np.sqrt(np.sum(d * d, axis=0))
    d = p[:, mesh.facets[1]] - p[:, mesh.facets[0]]
    return np.hypot(d[0], d[1])


def mesh_size(mesh) -> float:
    """The element size ``h`` of stability limits and convergence rates: the shortest edge."""
    return float(edge_lengths(mesh).min())


def mean_edge_length(mesh) -> float:
    """The mean edge length: the scale of a grab radius or a snapping tolerance."""
    return float(edge_lengths(mesh).mean())


def _signed_measures(p, t) -> np.ndarray:
    """Signed area (triangles, positive = counter-clockwise) or volume (tetrahedra, positive = vertices 1, 2, 3
    right-handed about vertex 0) of every element: the determinant of its edge vectors from vertex 0, over ``d!``."""
    x = p[:, t]
    d1, d2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    if p.shape[0] == 2:
        return 0.5 * (d1[0] * d2[1] - d2[0] * d1[1])
    d3 = x[:, 3] - x[:, 0]
    return (d1[0] * (d2[1] * d3[2] - d2[2] * d3[1]) - d1[1] * (d2[0] * d3[2] - d2[2] * d3[0])
            + d1[2] * (d2[0] * d3[1] - d2[1] * d3[0])) / 6.0


def signed_areas(mesh) -> np.ndarray:
    """Signed area of every triangle of ``mesh`` (positive = counter-clockwise), or volume of every tetrahedron
    (positive = vertices 1, 2, 3 right-handed about vertex 0): :func:`signed_volumes` is this function."""
    return _signed_measures(np.asarray(mesh.p, dtype=float), np.asarray(mesh.t))


signed_volumes = signed_areas


#: The facets of an element by local vertex: a triangle's edges, a tetrahedron's faces (face k opposite vertex k).
_FACETS = {3: ([0, 1], [1, 2], [2, 0]), 4: ([1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2])}
#: The words of the messages by dimension: an element, elements, a facet, a zero measure.
_WORDS = {2: ("triangle", "triangles", "edge", "zero-area"), 3: ("tetrahedron", "tetrahedra", "face", "zero-volume")}


def _facets(t: np.ndarray):
    """Every facet of every element, sorted: the keys ``(d, (d + 1) m)`` (nodes ascending), the element owning each
    and the vertex opposite it."""
    facets, nv = _FACETS[t.shape[0]], t.shape[0]
    key = np.sort(np.concatenate([t[f] for f in facets], axis=1), axis=0)
    opposite = np.concatenate([t[nv * (nv - 1) // 2 - sum(f)] for f in facets])
    order = np.lexsort(key[::-1])
    return key[:, order], np.tile(np.arange(t.shape[1]), nv)[order], opposite[order]


def _folded(p, t, copies: bool) -> np.ndarray:
    """Pairs of elements ``(2, n_pairs)`` overlapping across their shared facet (both opposite vertices on one side
    of it, by the sign of the facet's normal times the vertex); ``copies``: except copies of one element (opposite
    vertices at one point: a cut through triangles makes them)."""
    key, owner, opposite = _facets(t)
    same = np.flatnonzero((key[:, 1:] == key[:, :-1]).all(axis=0))
    a = p[:, key[0, same]]
    edges = [p[:, key[j, same]] - a for j in range(1, key.shape[0])]
    normal = np.stack([-edges[0][1], edges[0][0]]) if len(edges) == 1 else np.cross(*edges, axis=0)

    def side(o):
        return np.sum(normal * (p[:, o] - a), axis=0)
    bad = side(opposite[same]) * side(opposite[same + 1]) > 0
    if copies:
        bad &= ~(p[:, opposite[same]] == p[:, opposite[same + 1]]).all(axis=0)
    return np.stack([owner[same[bad]], owner[same[bad] + 1]])


def check_mesh(p, t, name: str = "mesh", *, unused_nodes: str = "refuse", cut: bool = False):
    """Check that ``(p, t)`` is a valid triangle mesh (or tetrahedron mesh: ``p`` ``(3, n)``, ``t`` ``(4, m)``); return
    ``(p, t)`` as float64 ``(d, n)`` and int64 ``(d + 1, m)``.

    Refused, with a :class:`ParameterError` naming ``name`` and the offending items: ``p`` not a real ``(2, n)``
    array, ``t`` not an integer ``(3, m)`` array; no element or more than :data:`MAX_TRIANGLES`; node indices out of
    range; coordinates not finite or beyond ``+-COORDINATE_MAX``; a mesh smaller than ``SIZE_RANGE[0]``; **unused
    nodes** (every linear system would be singular; ``unused_nodes="ignore"`` lets a file reader report in its own
    numbers first); a facet (edge, face) in three elements; duplicated, degenerate, folded (overlapping a neighbour
    across a facet) and, for tetrahedra, inverted (negative-volume) elements. ``cut=True`` (the assemblers) accepts
    what a cut through elements makes (fins, copies of a triangle; folded and inverted tetrahedra) and any number of
    elements.
    """
    def refuse(message):
        raise ParameterError(name, f"{name}: {message}")
    try:
        p_arr, t_arr = np.asarray(p), np.asarray(t)
    except (TypeError, ValueError):
        refuse("p and t must be rectangular arrays (p shaped (2, n), t shaped (3, m))")
    if p_arr.dtype.kind not in "iuf" or p_arr.ndim != 2 or p_arr.shape[0] not in (2, 3):
        refuse(f"p must be a real array shaped (2, n_nodes) or (3, n_nodes), got dtype {p_arr.dtype} and shape "
               f"{p_arr.shape}")
    dim = p_arr.shape[0]
    if t_arr.dtype.kind not in "iu" or t_arr.ndim != 2 or t_arr.shape[0] != dim + 1:
        what = "(3, n_triangles)" if dim == 2 else "(4, n_tetrahedra) for 3D nodes"
        refuse(f"t must be an integer array shaped {what}, got dtype {t_arr.dtype} and shape {t_arr.shape}")
    noun, nouns, facet, zero = _WORDS[dim]
    n, m = p_arr.shape[1], t_arr.shape[1]
    if m == 0:
        refuse(f"has no {nouns}")
    if m > MAX_TRIANGLES and not cut:
        refuse(f"has {m} {nouns}, more than the {MAX_TRIANGLES} allowed")
    if t_arr.min() < 0 or t_arr.max() >= n:
        refuse(f"{nouns} {index_list(np.flatnonzero(((t_arr < 0) | (t_arr >= n)).any(axis=0)))} refer to nodes "
               f"outside 0..{n - 1}")
    p_arr, t_arr = np.array(p_arr, dtype=np.float64), np.array(t_arr, dtype=np.int64)
    bad = np.flatnonzero(~np.isfinite(p_arr).all(axis=0))
    if bad.size:
        refuse(f"non-finite coordinates at nodes {index_list(bad)}")
    bad = np.flatnonzero((np.abs(p_arr) > COORDINATE_MAX).any(axis=0))
    if bad.size:
        refuse(f"nodes {index_list(bad)} lie beyond the coordinate limit +-{COORDINATE_MAX:g}")
    string("unused_nodes", unused_nodes, ("refuse", "ignore"))
    used = np.zeros(n, dtype=bool)
    used[t_arr.ravel()] = True
    if unused_nodes == "refuse" and not used.all():
        refuse(f"nodes {index_list(np.flatnonzero(~used))} belong to no {noun} (an unused node has no stiffness "
               "and no mass); remove them and renumber")
    extent = float(np.ptp(p_arr[:, used], axis=1).max())
    if extent < SIZE_RANGE[0]:
        refuse(f"spans only {extent:g} (the largest side of its bounding box must be at least {SIZE_RANGE[0]:g})")
    tri = np.sort(t_arr, axis=0)
    repeated = np.flatnonzero((tri[1:] == tri[:-1]).any(axis=0))
    if repeated.size:
        refuse(f"{nouns} {index_list(repeated)} use the same node twice")
    if not cut:  # a facet in three or more elements, an element listed twice
        key, owner, _ = _facets(t_arr)
        same = (key[:, 1:] == key[:, :-1]).all(axis=0)
        fins = np.flatnonzero(same[1:] & same[:-1])  # three equal keys in a row: start index fins + 0
        if fins.size:
            nodes = key[:, fins[0]]
            sharing = owner[(key == nodes[:, None]).all(axis=0)]
            count = np.unique(key[:, fins], axis=1).shape[1]
            refuse(f"{facet} {tuple(int(v) for v in nodes)} is shared by {sharing.size} {nouns} "
                   f"{sorted(sharing.tolist())} (three or more: a {dim}D mesh allows at most 2; a duplicated "
                   f"{noun}?); {count} such {facet}(s) in all")
        order = np.lexsort(tri[::-1])
        tri_sorted = tri[:, order]
        dup = np.flatnonzero((tri_sorted[:, 1:] == tri_sorted[:, :-1]).all(axis=0))
        if dup.size and dim == 2:  # (a tetrahedron listed twice is folded over its copy)
            i = int(dup[0])
            refuse(f"triangles {int(order[i])} and {int(order[i + 1])} are the same triangle "
                   f"{tuple(int(v) for v in tri_sorted[:, i])}; {dup.size} duplicate(s) in all")
    x = p_arr[:, t_arr]
    h2 = np.max([((x[:, j] - x[:, i]) ** 2).sum(0) for i in range(dim + 1) for j in range(i + 1, dim + 1)], axis=0)
    measure = _signed_measures(p_arr, t_arr)
    degenerate = np.flatnonzero(~(np.abs(math.factorial(dim) * measure) > DEGENERATE_TOL * h2 ** (dim / 2)))
    if degenerate.size:
        refuse(f"{zero} (degenerate) {nouns} {index_list(degenerate)}")
    inverted = np.flatnonzero(measure < 0) if dim == 3 and not cut else []
    if len(inverted):
        refuse(f"inverted tetrahedra {index_list(inverted)} (negative volume: vertices 1, 2, 3 must be right-handed "
               "about vertex 0)")
    folded = _folded(p_arr, t_arr, copies=dim == 2) if dim == 2 or not cut else np.zeros((2, 0))
    if folded.size:
        what = ("inverted triangles (folded over a neighbour across a shared edge)" if dim == 2 else
                "folded tetrahedra (overlapping a neighbour across a shared face)")
        pairs = ", ".join(f"({i}, {j})" for i, j in folded.T[:10]) + (" ..." if folded.shape[1] > 10 else "")
        refuse(f"{what}: pairs {pairs}; a rest mesh must not overlap itself")
    return p_arr, t_arr


# --- box of tetrahedra ------------------------------------------------------

#: The six tetrahedra of a cube ``(x, y, z) in {0, 1}^3`` (corner ``c = x + 2 y + 4 z``) around its diagonal 0-7,
#: each positively oriented: neighbouring cubes share their faces' diagonals without mirroring.
_CUBE_TETS = np.array([[0, 1, 3, 7], [0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7], [0, 4, 5, 7], [0, 5, 1, 7]]).T


def box(lx=1.0, ly=1.0, lz=1.0, nx=4, ny=4, nz=4) -> MeshTet:
    """Structured tetrahedral mesh of ``[0, lx] x [0, ly] x [0, lz]``: ``nx ny nz`` cells of six positively oriented
    tetrahedra each. Node ``i + (nx + 1) (j + (ny + 1) k)`` at column ``i``, row ``j``, layer ``k``. Named boundaries:
    ``"left"`` (x = 0), ``"right"`` (x = lx), ``"bottom"`` (y = 0), ``"top"`` (y = ly), ``"back"`` (z = 0),
    ``"front"`` (z = lz)."""
    lx, ly, lz = _size("lx", lx), _size("ly", ly), _size("lz", lz)
    for label, ratio in (("lx / ly", lx / ly), ("ly / lz", ly / lz), ("lx / lz", lx / lz)):
        _check_aspect(label, ratio)
    nx, ny, nz = _check_grid({"nx": nx, "ny": ny, "nz": nz}, per_cell=6)
    X, Y, Z = np.meshgrid(np.linspace(0.0, lx, nx + 1), np.linspace(0.0, ly, ny + 1), np.linspace(0.0, lz, nz + 1),
                          indexing="ij")
    p = np.vstack([X.ravel(order="F"), Y.ravel(order="F"), Z.ravel(order="F")])
    i, j, k = (a.ravel(order="F") for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
    corner = np.array([i + (nx + 1) * (j + (ny + 1) * k) + dx + (nx + 1) * (dy + (ny + 1) * dz)
                       for dz in (0, 1) for dy in (0, 1) for dx in (0, 1)])  # (8, cells), c = dx + 2 dy + 4 dz
    t = np.ascontiguousarray(corner[_CUBE_TETS].reshape(4, -1, order="F"))  # cell by cell, six tetrahedra each
    return MeshTet(p, t, sort_t=False).with_boundaries(
        _sides((lx, ly, lz), ("left", "right", "bottom", "top", "back", "front")))


# --- structured rectangle --------------------------------------------------

def _structured_mesh(x: np.ndarray, y: np.ndarray, nx: int, ny: int, diagonal: str) -> MeshTri:
    """The grid of (nx + 1) x (ny + 1) nodes at ``(x, y)``: cell (i, j) gives the counter-clockwise triangles
    ``2 (j nx + i)`` and ``2 (j nx + i) + 1``, cut sw-ne (``"right"``), se-nw (``"left"``), or sw-ne where ``i + j``
    is even, se-nw elsewhere (``"alternate"``)."""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy"))  # cells row by row
    sw = j * (nx + 1) + i
    corner = np.stack([sw, sw + 1, sw + nx + 1, sw + nx + 2])  # sw, se, nw, ne
    cut_sw_ne = (i + j) % 2 == 0 if diagonal == "alternate" else np.full(i.shape, diagonal == "right")
    # sw-ne diagonal: (sw, se, ne) and (sw, ne, nw); se-nw: (sw, se, nw) and (se, ne, nw)
    t = np.where(cut_sw_ne, corner[np.array([[0, 1, 3], [0, 3, 2]]).T], corner[np.array([[0, 1, 2], [1, 3, 2]]).T])
    t = np.ascontiguousarray(t.reshape(3, -1, order="F"))  # (3, 2, cells) to cell by cell, two triangles each
    return MeshTri(np.vstack([x.ravel(), y.ravel()]), t, sort_t=False)


def rectangle(width=1.0, height=1.0, nx=10, ny=10, diagonal="alternate") -> MeshTri:
    """Structured triangulation of ``[0, width] x [0, height]``: ``nx`` x ``ny`` cells, each cut into two triangles
    along ``diagonal`` (``"alternate"``, ``"right"`` or ``"left"``, as above). Named boundaries: ``"left"`` (x = 0),
    ``"right"`` (x = width), ``"bottom"`` (y = 0), ``"top"`` (y = height).
    """
    width, height = _size("width", width), _size("height", height)
    _check_aspect("width / height", width / height)
    nx, ny = _check_grid({"nx": nx, "ny": ny}, diagonal=diagonal)
    X, Y = np.meshgrid(np.linspace(0.0, width, nx + 1), np.linspace(0.0, height, ny + 1), indexing="xy")
    return _structured_mesh(X, Y, nx, ny, diagonal).with_boundaries(
        _sides((width, height), ("left", "right", "bottom", "top")))


def _grid_for(n_triangles: int, width: float, height: float) -> tuple[int, int]:
    """(nx, ny) with 2 nx ny closest to n_triangles (at most :data:`MAX_TRIANGLES`) and cells as square as possible,
    ``nx ~ sqrt(n/2 * aspect)`` capped at ``n/2`` (a thinner strip gets elongated cells, not more triangles)."""
    aspect = width / height
    half = max(1, n_triangles // 2)
    nx0 = min(half, max(1, round(math.sqrt(n_triangles / 2.0 * aspect))))
    grids = [(nx, max(1, round(n_triangles / (2.0 * nx)))) for nx in range(max(1, nx0 - 2), min(half, nx0 + 2) + 1)]
    # within the cap first, then closeness of the count, then how square the cells are (then the fewest columns)
    _, _, _, nx, ny = min((2 * nx * ny > MAX_TRIANGLES, abs(2 * nx * ny - n_triangles),
                           abs(math.log((width / nx) / (height / ny))), nx, ny) for nx, ny in grids)
    if 2 * nx * ny > MAX_TRIANGLES:  # rounding up overshot the cap: round down instead
        ny = max(1, n_triangles // (2 * nx))
    return nx, ny


def mesh_with_about(n_triangles, width=1.0, height=1.0, diagonal="alternate") -> MeshTri:
    """A :func:`rectangle` with about ``n_triangles`` triangles (within a factor 1.5), cells close to square."""
    n_triangles = check_count("n_triangles", n_triangles, 1, MAX_TRIANGLES)
    width, height = _size("width", width), _size("height", height)
    _check_aspect("width / height", width / height)
    nx, ny = _grid_for(n_triangles, width, height)
    return rectangle(width, height, nx, ny, diagonal=diagonal)


def flap(width=2.0, height=1.0, n_triangles=2000, diagonal="alternate") -> MeshTri:
    """The :func:`mesh_with_about` rectangle of the tissue-flap scene, with the aliases ``"fixed"`` (= ``"left"``,
    where the flap stays attached) and ``"handle"`` (= ``"right"``, the edge a handle pulls)."""
    mesh = mesh_with_about(n_triangles, width, height, diagonal=diagonal)
    return mesh.with_boundaries({"fixed": mesh.boundaries["left"], "handle": mesh.boundaries["right"]})


# --- fusiform (spindle-shaped) muscle ---------------------------------------

def fusiform_width(x, length=4.0, max_width=1.0, tendon_width=0.25):
    """``(w, dw/dx)`` of the width ``w(x) = tendon_width + (max_width - tendon_width) sin^2(pi x / length)`` (smooth,
    ``w' = 0`` at the tendons and in the middle)."""
    x, k = np.asarray(x, dtype=float), math.pi / length
    s, c = np.sin(k * x), np.cos(k * x)
    return tendon_width + (max_width - tendon_width) * s * s, (max_width - tendon_width) * 2.0 * s * c * k


def _check_fusiform(length, max_width, tendon_width):
    length = _size("length", length)
    max_width = _size("max_width", max_width)
    tendon_width = _size("tendon_width", tendon_width)
    if tendon_width > max_width:
        raise ParameterError("tendon_width", "tendon_width must not exceed max_width (a fusiform belly is widest "
                                             f"in the middle), got tendon_width={tendon_width!r} > "
                                             f"max_width={max_width!r}")
    _check_aspect("length / max_width", length / max_width)
    _check_aspect("max_width / tendon_width", max_width / tendon_width)
    return length, max_width, tendon_width


def fusiform_muscle(length=4.0, max_width=1.0, tendon_width=0.25, nx=40, ny=8, diagonal="alternate") -> MeshTri:
    """A spindle-shaped (fusiform) muscle belly ``0 <= x <= length``, ``|y| <= w(x) / 2`` (:func:`fusiform_width`):
    the image of a grid on ``[0, length] x [-1/2, 1/2]`` under ``(xi, eta) -> (xi, eta w(xi))`` (Jacobian ``w > 0``),
    whose lines ``y = eta w(x)`` are the natural fibers (:func:`fusiform_fiber_field`). Boundaries ``"left_tendon"``,
    ``"right_tendon"``, ``"top"``, ``"bottom"``."""
    length, max_width, tendon_width = _check_fusiform(length, max_width, tendon_width)
    nx, ny = _check_grid({"nx": nx, "ny": ny}, diagonal=diagonal)
    XI, ETA = np.meshgrid(np.linspace(0.0, length, nx + 1), np.linspace(-0.5, 0.5, ny + 1), indexing="xy")
    w, _ = fusiform_width(XI, length, max_width, tendon_width)
    ends = _sides((length,), ("left_tendon", "right_tendon"))

    def at_end(m):
        return ends["left_tendon"](m) | ends["right_tendon"](m)
    return _structured_mesh(XI, ETA * w, nx, ny, diagonal).with_boundaries({
        **ends, "top": lambda m: (m[1] > 0.0) & ~at_end(m), "bottom": lambda m: (m[1] < 0.0) & ~at_end(m)})


def fusiform_fiber_direction(points, length=4.0, max_width=1.0, tendon_width=0.25) -> np.ndarray:
    """Unit fiber direction at ``points`` ``(2, ...)`` (``x`` from the left tendon): the curve ``y = eta w(x)`` through
    the point has ``eta = y / w(x)`` and tangent ``(1, eta w'(x))``."""
    length, max_width, tendon_width = _check_fusiform(length, max_width, tendon_width)
    pts = check_real_array("points", points)
    if pts.ndim < 1 or pts.shape[0] != 2 or not np.all(np.abs(pts) <= COORDINATE_MAX):
        raise ParameterError("points", f"points must be shaped (2, ...), finite and within the coordinate limit "
                                       f"+-{COORDINATE_MAX:g}, got shape {pts.shape}")
    w, dw = fusiform_width(pts[0], length, max_width, tendon_width)
    eta = pts[1] / w
    a = np.stack([np.ones_like(eta), eta * dw])
    return a / np.hypot(a[0], a[1])


def fusiform_fiber_field(mesh) -> np.ndarray:
    """Unit fiber directions (2, n_elements) of a :func:`fusiform_muscle` mesh at the centroids, its sizes read off
    the mesh (length: the x-extent, max_width: the y-extent, tendon_width: the y-extent of the left tendon's nodes)."""
    p, t = check_mesh(mesh.p, mesh.t, cut=True)  # what an assembler accepts
    if p.shape[0] != 2:
        raise ParameterError("mesh", "mesh must be a 2D triangle mesh (p shaped (2, n), t shaped (3, n))")
    x0 = p[0].min()
    length, max_width = p[0].max() - x0, 2.0 * np.abs(p[1]).max()
    tendon_width = 2.0 * np.abs(p[1, np.abs(p[0] - x0) <= 1e-9 * max(float(length), 1e-300)]).max()
    centroid = p[:, t].mean(axis=1)
    centroid[0] -= x0
    return fusiform_fiber_direction(centroid, length, max_width, tendon_width)


@dataclass(frozen=True, eq=False, kw_only=True)
class MeshMap:
    """A new ``mesh`` and the maps back to the old one after a cut or an excision: ``parent``, the old node of each
    new node; ``elements``, the old element of each new element; the old sizes; ``weights``, the share of its
    triangle's area each new element's material fills (a cut through elements), or None; ``material``, per new node
    whether the copy has material at its place (a virtual node of a cut through elements has none, so it holds
    nothing: :meth:`~tissuefem.engine.model.Handle.remap`), or None: every node has."""

    mesh: MeshTri
    parent: np.ndarray
    elements: np.ndarray
    n_old_nodes: int
    n_old_elements: int
    weights: np.ndarray | None = None
    material: np.ndarray | None = None

    def contact_surface(self):
        """The new contact surface where the operation knows it better than the boundary (a cut through elements),
        else ``None``."""
        return None

    def transfer(self, values) -> np.ndarray:
        """Per-node values ``(..., n_old_nodes)`` on the new mesh (a copy starts with its parent's)."""
        return _last_axis(values, self.n_old_nodes, "one entry per old node")[..., self.parent]

    def transfer_elements(self, values) -> np.ndarray:
        """Per-element values ``(..., n_old_elements)`` on the new mesh."""
        return _last_axis(values, self.n_old_elements, "one entry per old element")[..., self.elements]

    def transfer_dofs(self, values) -> np.ndarray:
        """A vector P1 field ``(..., 2 n_old_nodes)`` (node ``n``: dofs ``2 n, 2 n + 1``) on the new mesh."""
        v = _last_axis(values, 2 * self.n_old_nodes, "two dofs per old node")
        pairs = v.reshape(v.shape[:-1] + (self.n_old_nodes, 2))
        return pairs[..., self.parent, :].reshape(v.shape[:-1] + (2 * self.parent.size,))


def _last_axis(values, length, what) -> np.ndarray:
    v = np.asarray(values)
    if v.ndim < 1 or v.shape[-1] != length:
        raise ParameterError("values", f"values must have {what} on the last axis (length {length}), got shape "
                                       f"{v.shape}")
    return v
