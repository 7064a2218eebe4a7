"""The page's side of the live view: a canvas that draws the tissue from node positions the kernel sends.

:class:`TissueWidget` is a Jupyter widget (anywidget) whose JavaScript ships with the package
(``static/tissue_widget.js``, nothing fetched at run time): a canvas that draws triangles (fill and edges) from
binary arrays, the drag target and the cut stroke over them, the mode and run/pause buttons and a readout line.
The positions (float32) are sent each frame the tissue moved, the triangles (int32) only when the topology changes
(a cut); the page paints with ``requestAnimationFrame`` only when something arrived. The pointer comes back as
messages in world coordinates. Positions carry their dimension (``dim``): with ``dim = 3`` the page draws the
triangles (a surface) with WebGL, lit, from a camera the mouse turns, and a press picks the surface point under the
pointer. :class:`~tissuefem.surgery.interactive.SurgeryView` runs a simulation through it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..engine.parameters import ParameterError

try:
    import anywidget
    import traitlets
except ImportError as exc:  # an optional extra
    raise ImportError("tissuefem.surgery.widget needs anywidget (pip install anywidget)") from exc

__all__ = ["TissueWidget", "outline", "STATIC"]

#: the folder of the widget's JavaScript
STATIC = Path(__file__).with_name("static")


class TissueWidget(anywidget.AnyWidget):
    """A triangle mesh drawn on a canvas in the page, from binary arrays (see ``static/tissue_widget.js``).

    ``positions``: float32 bytes ``(n_points, dim)``; ``triangles``: int32 bytes ``(n_triangles, 3)``; ``edges``:
    int32 bytes ``(n_edges, 2)``; ``colors``: float32 bytes, one value per triangle mapped over ``color_range``, or
    empty (one fill colour); ``bounds``: the world box shown (``[xmin, xmax, ymin, ymax]``, 3D: and ``zmin, zmax``);
    ``target``: ``[x, y]`` (3D: ``[x, y, z]``) or ``[]``; ``stroke``: float32 bytes ``(k, dim)``; ``outline``: int32
    bytes, boundary loops of point indices each ended by ``-1`` (2D); ``mode`` and ``running``: set by the page's
    buttons (and the key ``c``) as well; ``disabled``: the buttons and the pointer off (a view that stopped). The page
    sends ``{"event": "pointer", "kind": "down" | "move" | "up", "x", "y", "inside"}`` (3D: and ``"z"``).
    """

    _esm = STATIC / "tissue_widget.js"
    dim = traitlets.Int(2).tag(sync=True)
    positions = traitlets.Bytes(b"").tag(sync=True)
    triangles = traitlets.Bytes(b"").tag(sync=True)
    edges = traitlets.Bytes(b"").tag(sync=True)
    outline = traitlets.Bytes(b"").tag(sync=True)
    colors = traitlets.Bytes(b"").tag(sync=True)
    color_range = traitlets.List(traitlets.Float(), [0.5, 1.5]).tag(sync=True)
    bounds = traitlets.List(traitlets.Float(), [0.0, 1.0, 0.0, 1.0]).tag(sync=True)
    target = traitlets.List(traitlets.Float(), []).tag(sync=True)
    stroke = traitlets.Bytes(b"").tag(sync=True)
    readout = traitlets.Unicode("").tag(sync=True)
    message = traitlets.Unicode("").tag(sync=True)
    mode = traitlets.Unicode("drag").tag(sync=True)
    running = traitlets.Bool(False).tag(sync=True)
    disabled = traitlets.Bool(False).tag(sync=True)
    width = traitlets.Int(700).tag(sync=True)
    height = traitlets.Int(450).tag(sync=True)

    def show_mesh(self, positions, triangles, edges=None, colors=None, outline=None) -> None:
        """Send a new topology with its positions, in one message: ``positions`` ``(n, dim)``, ``triangles``
        ``(q, 3)``, ``edges`` ``(r, 2)``, ``colors`` ``(q,)``, ``outline``: the boundary loops (:func:`outline`),
        filled instead of the triangles when there are no colours."""
        x = np.ascontiguousarray(positions, dtype=np.float32)
        t = np.ascontiguousarray(triangles, dtype=np.int32)
        if x.ndim != 2 or x.shape[1] not in (2, 3):
            raise ParameterError("positions", f"positions must be (n, 2) or (n, 3), got shape {x.shape}")
        if t.ndim != 2 or t.shape[1] != 3 or (t.size and (t.min() < 0 or t.max() >= len(x))):
            raise ParameterError("triangles", f"triangles must be (q, 3) indices into the {len(x)} positions")
        with self.hold_sync():
            self.dim = int(x.shape[1])
            self.triangles = t.tobytes()
            self.edges = b"" if edges is None else np.ascontiguousarray(edges, dtype=np.int32).tobytes()
            self.colors = b"" if colors is None else np.ascontiguousarray(colors, dtype=np.float32).tobytes()
            self.outline = b"" if outline is None else np.ascontiguousarray(outline, dtype=np.int32).tobytes()
            self.positions = x.tobytes()

    def arrays(self) -> dict:
        """What the widget holds, as arrays: ``positions`` ``(n, dim)``, ``triangles``, ``edges``, ``colors``,
        ``stroke``."""
        return {"positions": np.frombuffer(self.positions, np.float32).reshape(-1, self.dim),
                "triangles": np.frombuffer(self.triangles, np.int32).reshape(-1, 3),
                "edges": np.frombuffer(self.edges, np.int32).reshape(-1, 2),
                "colors": np.frombuffer(self.colors, np.float32),
                "outline": np.frombuffer(self.outline, np.int32),
                "stroke": np.frombuffer(self.stroke, np.float32).reshape(-1, self.dim)}


def outline(triangles, reference) -> np.ndarray:
    """The boundary of the triangles ``(3, q)`` (indices into the points ``reference`` ``(2, n)``) as closed loops
    of point indices, each ended by ``-1``: the outer ones counter-clockwise, holes and cuts clockwise, so that
    filling them (nonzero rule) paints what the triangles cover. One fill of a few hundred edges replaces one of
    every triangle, which a browser without a GPU rasterises ten times slower."""
    t = np.asarray(triangles, dtype=np.int64)
    if t.size == 0:
        return np.zeros(0, np.int32)
    a, b, c = (reference[:, t[k]] for k in range(3))
    flip = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) < 0
    t = np.where(flip, t[[0, 2, 1]], t)  # every triangle counter-clockwise
    tails, heads = t.ravel(), np.roll(t, -1, axis=0).ravel()
    directed = set(zip(tails.tolist(), heads.tolist()))
    nxt: dict[int, list[int]] = {}
    for u, v in directed:
        if (v, u) not in directed:  # an edge of one triangle only: on the boundary
            nxt.setdefault(u, []).append(v)
    loops = []
    while nxt:
        start = next(iter(nxt))
        loop, u = [start], start
        while True:
            heads_u = nxt[u]
            v = heads_u.pop()
            if not heads_u:
                del nxt[u]
            if v == start or v not in nxt:
                break
            loop.append(v)
            u = v
        loops += loop + [-1]
    return np.asarray(loops, dtype=np.int32)
