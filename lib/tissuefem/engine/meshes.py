"""The 2D domains the chapters use, as scikit-fem triangle meshes.

Every function here returns a :class:`skfem.MeshTri` that is

* **deterministic**: the same arguments give the same nodes, in the same
  order, and the same triangles;
* **counter-clockwise**: every triangle ``t[:, e] = (a, b, c)`` has positive
  signed area. scikit-fem sorts the vertex indices of each triangle by default
  (``sort_t=True``), which makes the orientation arbitrary; these meshes are
  built with ``sort_t=False`` so the orientation we chose survives;
* **named on the boundary**: ``mesh.boundaries[name]`` gives facet indices,
  ready for ``basis.get_dofs(name)``.

Node numbering of the structured meshes is row by row: node ``j (nx + 1) + i``
sits at column ``i`` (``0..nx``) and row ``j`` (``0..ny``).

Domains
-------
* :func:`rectangle`: ``[0, width] x [0, height]``, structured, ``2 nx ny``
  triangles, boundaries ``"left"``, ``"right"``, ``"bottom"``, ``"top"``.
* :func:`mesh_with_about`: a rectangle with about a given number of triangles
  (what benchmarks use to sweep sizes).
* :func:`fusiform_muscle` and :func:`fusiform_fiber_field`: a spindle-shaped
  muscle belly between two tendons, and its fiber directions per element
  (:func:`fusiform_fiber_direction` at any point).
* :func:`flap`: the rectangle of the tissue-flap scene (left edge fixed, a
  handle pulls the right edge).
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from skfem import MeshTri

__all__ = [
    "edge_lengths",
    "mesh_size",
    "mean_edge_length",
    "rectangle",
    "mesh_with_about",
    "fusiform_muscle",
    "fusiform_width",
    "fusiform_fiber_direction",
    "fusiform_fiber_field",
    "flap",
    "signed_areas",
]

_DIAGONALS = ("alternate", "right", "left")


# --------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------
def _positive_size(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a positive real number, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v <= 0.0:
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def _positive_count(name: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    v = int(value)
    if v <= 0:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return v


def edge_lengths(mesh) -> np.ndarray:
    """The length of every edge (facet) of the mesh, in reference coordinates."""
    p = np.asarray(mesh.p, dtype=float)
    d = p[:, mesh.facets[1]] - p[:, mesh.facets[0]]
    return np.hypot(d[0], d[1])


def mesh_size(mesh) -> float:
    """The element size ``h`` of stability limits and convergence rates: the shortest edge (the side of
    a square cell of :func:`rectangle`)."""
    return float(edge_lengths(mesh).min())


def mean_edge_length(mesh) -> float:
    """The mean edge length: the scale of a grab radius or a snapping tolerance."""
    return float(edge_lengths(mesh).mean())


def signed_areas(mesh) -> np.ndarray:
    """Signed area of every triangle of ``mesh`` (positive = counter-clockwise)."""
    p = np.asarray(mesh.p, dtype=float)
    t = np.asarray(mesh.t)
    a, b, c = p[:, t[0]], p[:, t[1]], p[:, t[2]]
    return 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))


def folded_triangles(p, t) -> np.ndarray:
    """Pairs of triangles that overlap across their shared edge, shape ``(2, n_pairs)``.

    In a valid (non-inverted) triangulation the two triangles on an interior
    edge lie on opposite sides of it. If one of them is inverted (folded over
    its neighbour), both third vertices lie on the same side. This test does
    not depend on the order in which a triangle lists its vertices (scikit-fem
    sorts them, so a good mesh has triangles of both orientations).
    """
    p = np.asarray(p, dtype=float)
    t = np.asarray(t, dtype=np.int64)
    nel = t.shape[1]
    # every edge of every triangle, with the vertex opposite to it
    edges = np.concatenate([t[[0, 1]], t[[1, 2]], t[[2, 0]]], axis=1)
    opposite = np.concatenate([t[2], t[0], t[1]])
    owner = np.tile(np.arange(nel), 3)
    key = np.sort(edges, axis=0)
    order = np.lexsort((key[1], key[0]))
    key, edges, opposite, owner = key[:, order], edges[:, order], opposite[order], owner[order]
    same = np.flatnonzero((key[0, 1:] == key[0, :-1]) & (key[1, 1:] == key[1, :-1]))
    if same.size == 0:
        return np.zeros((2, 0), dtype=np.int64)
    a, b = p[:, key[0, same]], p[:, key[1, same]]

    def side(o):
        c = p[:, o]
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    s1, s2 = side(opposite[same]), side(opposite[same + 1])
    bad = same[s1 * s2 > 0]
    return np.stack([owner[bad], owner[bad + 1]])


# --------------------------------------------------------------------------
# structured rectangle
# --------------------------------------------------------------------------
def _structured_triangles(nx: int, ny: int, diagonal: str) -> np.ndarray:
    """Connectivity (3, 2 nx ny) of a structured grid of (nx + 1) x (ny + 1) nodes.

    Each cell (i, j) has corners sw, se, ne, nw and is cut along one diagonal:
    ``"right"`` cuts sw-ne, ``"left"`` cuts se-nw, ``"alternate"`` uses sw-ne
    on cells with ``i + j`` even and se-nw otherwise (a pattern without a
    preferred direction, the usual choice for elasticity). Both triangles of a
    cell are listed counter-clockwise; cell (i, j) gives triangles
    ``2 (j nx + i)`` and ``2 (j nx + i) + 1``.
    """
    if diagonal not in _DIAGONALS:
        raise ValueError(f"diagonal must be one of {_DIAGONALS}, got {diagonal!r}")
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
    i, j = i.ravel(), j.ravel()  # cell order: row by row
    sw = j * (nx + 1) + i
    se = sw + 1
    nw = sw + (nx + 1)
    ne = nw + 1
    if diagonal == "right":
        cut_sw_ne = np.ones(i.shape, dtype=bool)
    elif diagonal == "left":
        cut_sw_ne = np.zeros(i.shape, dtype=bool)
    else:
        cut_sw_ne = (i + j) % 2 == 0
    # sw-ne diagonal: (sw, se, ne) and (sw, ne, nw); se-nw: (sw, se, nw) and (se, ne, nw)
    first = np.where(cut_sw_ne, np.stack([sw, se, ne]), np.stack([sw, se, nw]))
    second = np.where(cut_sw_ne, np.stack([sw, ne, nw]), np.stack([se, ne, nw]))
    t = np.empty((3, 2 * i.size), dtype=np.int64)
    t[:, 0::2] = first
    t[:, 1::2] = second
    return t


def _structured_mesh(x: np.ndarray, y: np.ndarray, nx: int, ny: int, diagonal: str) -> MeshTri:
    p = np.vstack([x.ravel(), y.ravel()])
    t = _structured_triangles(nx, ny, diagonal)
    return MeshTri(p, t, sort_t=False)


def rectangle(width=1.0, height=1.0, nx=10, ny=10, diagonal="alternate") -> MeshTri:
    """Structured triangulation of ``[0, width] x [0, height]``.

    ``nx`` x ``ny`` cells, each cut into two counter-clockwise triangles
    (``2 nx ny`` triangles, ``(nx + 1)(ny + 1)`` nodes). ``diagonal`` is
    ``"alternate"`` (default; cells alternate like a checkerboard), ``"right"``
    (every cell cut from lower left to upper right) or ``"left"``.

    Named boundaries: ``"left"`` (x = 0), ``"right"`` (x = width),
    ``"bottom"`` (y = 0), ``"top"`` (y = height).
    """
    width = _positive_size("width", width)
    height = _positive_size("height", height)
    nx = _positive_count("nx", nx)
    ny = _positive_count("ny", ny)
    if diagonal not in _DIAGONALS:
        raise ValueError(f"diagonal must be one of {_DIAGONALS}, got {diagonal!r}")
    xs = np.linspace(0.0, width, nx + 1)
    ys = np.linspace(0.0, height, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="xy")
    mesh = _structured_mesh(X, Y, nx, ny, diagonal)
    tx = 1e-9 * width
    ty = 1e-9 * height
    return mesh.with_boundaries(
        {
            "left": lambda m: np.abs(m[0]) < tx,
            "right": lambda m: np.abs(m[0] - width) < tx,
            "bottom": lambda m: np.abs(m[1]) < ty,
            "top": lambda m: np.abs(m[1] - height) < ty,
        }
    )


def _grid_for(n_triangles: int, width: float, height: float) -> tuple[int, int]:
    """(nx, ny) with 2 nx ny closest to n_triangles and cells as square as possible."""
    aspect = width / height
    nx0 = max(1, round(math.sqrt(n_triangles / 2.0 * aspect)))
    best = None
    for nx in range(max(1, nx0 - 2), nx0 + 3):
        ny = max(1, round(n_triangles / (2.0 * nx)))
        # closeness of the count first, then how square the cells are
        key = (abs(2 * nx * ny - n_triangles), abs(math.log((width / nx) / (height / ny))))
        if best is None or key < best[0]:
            best = (key, nx, ny)
    return best[1], best[2]


def mesh_with_about(n_triangles, width=1.0, height=1.0, diagonal="alternate") -> MeshTri:
    """A :func:`rectangle` of ``width x height`` with about ``n_triangles`` triangles.

    Picks ``nx, ny`` with ``nx / ny`` close to ``width / height`` (cells close
    to square) and ``2 nx ny`` as close to ``n_triangles`` as such grids allow.
    """
    n_triangles = _positive_count("n_triangles", n_triangles)
    width = _positive_size("width", width)
    height = _positive_size("height", height)
    nx, ny = _grid_for(n_triangles, width, height)
    return rectangle(width, height, nx, ny, diagonal=diagonal)


def flap(width=2.0, height=1.0, n_triangles=2000, diagonal="alternate") -> MeshTri:
    """The rectangle of the tissue-flap scene: ``[0, width] x [0, height]``.

    A :func:`mesh_with_about` rectangle with the usual boundaries ``"left"``,
    ``"right"``, ``"bottom"``, ``"top"`` plus two aliases naming the scene's
    roles: ``"fixed"`` (= ``"left"``, where the flap stays attached) and
    ``"handle"`` (= ``"right"``, the edge a handle pulls).
    """
    mesh = mesh_with_about(n_triangles, width, height, diagonal=diagonal)
    return mesh.with_boundaries({"fixed": mesh.boundaries["left"], "handle": mesh.boundaries["right"]})


# --------------------------------------------------------------------------
# fusiform (spindle-shaped) muscle
# --------------------------------------------------------------------------
def fusiform_width(x, length=4.0, max_width=1.0, tendon_width=0.25):
    """Width profile ``w(x)`` of the fusiform muscle and its slope ``w'(x)``.

    ``w(x) = tendon_width + (max_width - tendon_width) sin^2(pi x / length)``
    for ``0 <= x <= length``: ``tendon_width`` at both tendons, ``max_width``
    in the middle of the belly, smooth, with ``w' = 0`` at the tendons (the
    belly meets each tendon without a kink) and in the middle.

    Returns ``(w, dw_dx)`` with the shape of ``x``.
    """
    x = np.asarray(x, dtype=float)
    k = math.pi / length
    s = np.sin(k * x)
    c = np.cos(k * x)
    w = tendon_width + (max_width - tendon_width) * s * s
    dw = (max_width - tendon_width) * 2.0 * s * c * k
    return w, dw


def _check_fusiform(length, max_width, tendon_width):
    length = _positive_size("length", length)
    max_width = _positive_size("max_width", max_width)
    tendon_width = _positive_size("tendon_width", tendon_width)
    if tendon_width > max_width:
        raise ValueError(
            f"tendon_width must not exceed max_width (a fusiform belly is widest in the middle), "
            f"got tendon_width={tendon_width!r} > max_width={max_width!r}"
        )
    return length, max_width, tendon_width


def fusiform_muscle(length=4.0, max_width=1.0, tendon_width=0.25, nx=40, ny=8, diagonal="alternate") -> MeshTri:
    """A spindle-shaped (fusiform) muscle belly between two tendons.

    The domain is ``0 <= x <= length``, ``|y| <= w(x) / 2`` with the width
    profile :func:`fusiform_width`: symmetric about the x-axis (and about
    ``x = length / 2``), ``tendon_width`` wide at both ends and ``max_width``
    in the middle.

    It is the image of the structured :func:`rectangle`-style grid on
    ``(xi, eta) in [0, length] x [-1/2, 1/2]`` under the map
    ``(xi, eta) -> (xi, eta w(xi))``, whose Jacobian determinant ``w(xi)`` is
    positive, so the triangles stay counter-clockwise. The grid lines
    ``eta = const`` become the curves ``y = eta w(x)`` running tendon to
    tendon: the natural fiber directions (:func:`fusiform_fiber_field`).
    With ``ny`` even, the mid-line ``y = 0`` is a grid line and the mesh is a
    mirror image of itself about the x-axis.

    Named boundaries: ``"left_tendon"`` (x = 0), ``"right_tendon"``
    (x = length), ``"top"`` and ``"bottom"`` (the curved sides).
    """
    length, max_width, tendon_width = _check_fusiform(length, max_width, tendon_width)
    nx = _positive_count("nx", nx)
    ny = _positive_count("ny", ny)
    if diagonal not in _DIAGONALS:
        raise ValueError(f"diagonal must be one of {_DIAGONALS}, got {diagonal!r}")
    xi = np.linspace(0.0, length, nx + 1)
    eta = np.linspace(-0.5, 0.5, ny + 1)
    XI, ETA = np.meshgrid(xi, eta, indexing="xy")
    w, _ = fusiform_width(XI, length, max_width, tendon_width)
    mesh = _structured_mesh(XI, ETA * w, nx, ny, diagonal)
    tx = 1e-9 * length

    def at_end(m):
        return (np.abs(m[0]) < tx) | (np.abs(m[0] - length) < tx)

    return mesh.with_boundaries(
        {
            "left_tendon": lambda m: np.abs(m[0]) < tx,
            "right_tendon": lambda m: np.abs(m[0] - length) < tx,
            "top": lambda m: (m[1] > 0.0) & ~at_end(m),
            "bottom": lambda m: (m[1] < 0.0) & ~at_end(m),
        }
    )


def fusiform_fiber_direction(points, length=4.0, max_width=1.0, tendon_width=0.25) -> np.ndarray:
    """Unit fiber direction of the fusiform muscle at ``points`` (shape ``(2, ...)``).

    The fibers are the curves ``y = eta w(x)`` (``eta`` constant, ``w`` from
    :func:`fusiform_width`) of the muscle's parametrisation: the curve through
    ``(x, y)`` has ``eta = y / w(x)`` and tangent ``(1, eta w'(x))``, returned
    normalised. Horizontal on the mid-line ``y = 0``, at the tendons and at the
    widest section (where ``w' = 0``); elsewhere the fibers spread out of the
    left tendon and converge into the right one. ``x`` is measured from the
    left tendon (as in :func:`fusiform_muscle`).
    """
    length, max_width, tendon_width = _check_fusiform(length, max_width, tendon_width)
    pts = np.asarray(points, dtype=float)
    if pts.ndim < 1 or pts.shape[0] != 2:
        raise ValueError(f"points must be shaped (2, ...), got shape {pts.shape}")
    w, dw = fusiform_width(pts[0], length, max_width, tendon_width)
    eta = pts[1] / w
    a = np.stack([np.ones_like(eta), eta * dw])
    return a / np.hypot(a[0], a[1])


def fusiform_fiber_field(mesh, length=None, max_width=None, tendon_width=None) -> np.ndarray:
    """Unit fiber directions (2, n_elements) of a :func:`fusiform_muscle` mesh.

    The fibers follow the curves ``y = eta w(x)`` (``eta`` constant) of the
    muscle's parametrisation: they run from tendon to tendon, bulge with the
    belly and converge towards the narrow ends. Each triangle gets the
    direction :func:`fusiform_fiber_direction` at its centroid. On the
    mid-line ``y = 0`` the fibers are horizontal, and the field is the mirror
    image of itself about the x-axis.

    ``length``, ``max_width`` and ``tendon_width`` are the values the mesh was
    made with; left as ``None`` they are read off the mesh (its x-extent, its
    y-extent, and the y-extent of the nodes on the left tendon), which is exact
    for meshes from :func:`fusiform_muscle`.
    """
    p = np.asarray(mesh.p, dtype=float)
    t = np.asarray(mesh.t)
    if p.ndim != 2 or p.shape[0] != 2 or t.ndim != 2 or t.shape[0] != 3:
        raise ValueError("mesh must be a 2D triangle mesh (p shaped (2, n), t shaped (3, n))")
    if not np.all(np.isfinite(p)):
        raise ValueError("mesh has non-finite node coordinates")
    x0 = p[0].min()
    if length is None:
        length = p[0].max() - x0
    if max_width is None:
        max_width = 2.0 * np.abs(p[1]).max()
    if tendon_width is None:
        at_left = np.abs(p[0] - x0) <= 1e-9 * max(abs(float(length)), 1e-300)
        tendon_width = 2.0 * np.abs(p[1, at_left]).max()
    centroid = p[:, t].mean(axis=1)
    centroid[0] -= x0
    return fusiform_fiber_direction(centroid, length, max_width, tendon_width)
